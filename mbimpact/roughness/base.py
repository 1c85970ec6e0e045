"""Roughness measures (G, P): the distribution of facet normals, (2.2) and §3 of the paper.

What the law (2.8) needs from a microrelief is only the probability measure of
the unit normals ``m`` of the facets at the contact point, written in the local
frame of the base surface (last component along the base normal n⁰). Every
measure here provides a quadrature *rule* for that measure restricted to the
facets that can face a given contact velocity ``u``: nodes ``m_j`` and weights
``p_j``. The boundary of the facing set G* = {mᵀu < 0} depends on the direction
of ``u`` only, never on the mass matrix, so a rule can follow it exactly.

Measures are fractions of true physical surface area (a facet of slope angle α
over a base area dA weighs dA / cos α): see :mod:`mbimpact.theory`, §3.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.geometry import scaled_norm
from ..common.validation import as_array, as_scalar
from ..errors import ParameterError, RoughnessError

__all__ = ["Roughness", "FiniteRoughness", "Rule", "check_normals", "check_weights", "check_tilt"]

#: A quadrature rule, ``rule(U (B, d), nodes) -> (normals, weights)`` as :meth:`Roughness.rule_batch`.
Rule = Callable[[NDArray[np.float64], int], tuple[NDArray[np.float64], NDArray[np.float64]]]

# Tolerance on |m| = 1 for user-given facet normals.
_UNIT_TOL = 1e-9


class Roughness(ABC):
    """Base class of the roughness measures.

    Attributes
    ----------
    dim : int or None
        Contact-space dimension the measure lives in (2 planar, 3 spatial), or
        ``None`` when it fits both (:class:`Smooth`).
    exact : bool
        True when :meth:`rule` integrates the measure exactly (finite facet sets);
        False when it is a quadrature whose node count the law refines.
    initial_nodes : int
        First node count tried by an adaptive law (ignored when ``exact``).
    node_limit : int
        Default node count at which an adaptive law stops refining.
    methods : tuple of str
        The averaging methods of :data:`mbimpact.averaging.METHODS` that can average
        this measure (a method may still decline a particular W or batch at run time).
    graded_rows : int or None
        Rows per pass of the graded rule's refinement when it is large (a tilt × azimuth
        product puts ~10⁶ facets on a row); None: all rows at once.
    """

    dim: ClassVar[int | None] = None
    exact: ClassVar[bool] = True
    initial_nodes: ClassVar[int] = 1
    node_limit: ClassVar[int] = 4096
    methods: ClassVar[tuple[str, ...]] = ("exact", "monte-carlo")
    graded_rows: ClassVar[int | None] = None

    @abstractmethod
    def rule_batch(self, U: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Quadrature of the measure on (a superset of) the facets facing each row of ``U``.

        Parameters
        ----------
        U : ndarray, shape (B, d)
            Pre-impact contact velocities in the local frame, ``U[:, -1] < 0``.
        nodes : int
            Node count for measures that are not finite (ignored otherwise).

        Returns
        -------
        normals : ndarray, shape (K, d) or (B, K, d)
            Unit facet normals in the local frame; 2-D when shared by all rows.
        weights : ndarray, shape (K,) or (B, K)
            Their probabilities dP (non-negative).
        """

    def rule(self, u: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`rule_batch` for one velocity ``u`` (d,): normals (K, d), weights (K,)."""
        m, w = self.rule_batch(u[None, :], nodes)
        return (m if m.ndim == 2 else m[0]), (w if w.ndim == 1 else w[0])

    def graded_rule(self, W: NDArray[np.float64], peaked: float) -> Rule | None:
        """A rule graded towards the peaks of the kernels of (2.8), for a nearly singular W.

        Parameters
        ----------
        W : ndarray, shape (d, d)
            Delassus matrix in the local frame.
        peaked : float
            Peaks narrower than this (radians) call for grading.

        Returns
        -------
        callable or None
            ``rule(U, nodes)`` with the signature of :meth:`rule_batch`, or None
            when the measure's own rule serves (the default).
        """
        return None

    def rule_size(self, nodes: int, graded: bool = False) -> int:
        """Facets a rule with ``nodes`` nodes a piece puts on one velocity, at most: the work of one
        average, with which :class:`mbimpact.RoughLaw` bounds repeated micro-impacts.

        Parameters
        ----------
        nodes : int
            Nodes a piece (the ``nodes`` of :meth:`rule_batch`).
        graded : bool
            For the rule of :meth:`graded_rule` instead (more pieces).

        Returns
        -------
        int
            Default ``nodes``: a rule along one curve (finite measures ignore ``nodes``).
        """
        return nodes

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        """``count`` facet normals drawn from P (local frame), shape (count, d).

        Used by the Monte Carlo average (``RoughLaw(method="monte-carlo")``).
        """
        raise ParameterError(f"{type(self).__name__} cannot be sampled; use another averaging method")

    def supports(self, d: int) -> bool:
        """Whether the measure can be used in a contact space of dimension ``d``."""
        return self.dim is None or self.dim == d


class FiniteRoughness(Roughness):
    """A measure with finitely many facets, the same for every velocity."""

    @abstractmethod
    def facets(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Normals (K, d) and probabilities (K,) summing to 1."""

    def rule_batch(self, U: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self.facets()

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        m, w = self.facets()
        return m[rng.choice(len(w), size=count, p=w)]


def check_tilt(name: str, alpha: object) -> float:
    """A facet tilt in [0, π/2) rad: a facet at π/2 would be vertical, its normal in the base surface."""
    value = as_scalar(name, alpha, -math.inf, math.inf)
    if not 0.0 <= value < math.pi / 2:
        raise ParameterError(f"{name} must satisfy 0 ≤ {name} < π/2 rad ({math.pi / 2:.5g}); got {value:g} rad")
    return value


def check_normals(name: str, normals: ArrayLike) -> NDArray[np.float64]:
    """Validate facet normals (K, d): unit, d = 2 or 3, pointing out of the base surface."""
    m = as_array(name, normals, 2)
    if m.shape[1] not in (2, 3) or m.shape[0] == 0:
        raise RoughnessError(f"facet normals must have shape (K, d), K ≥ 1, d = 2 or 3; got {m.shape}")
    lengths = scaled_norm(m, axis=1)  # entries near the float range must not overflow the squares
    bad = np.flatnonzero(np.abs(lengths - 1.0) > _UNIT_TOL)
    if bad.size:
        raise RoughnessError(
            f"facet normal {bad[0]} has length {lengths[bad[0]]:.12g}; normals must be unit vectors"
        )
    if np.any(m[:, -1] <= 0.0):
        i = int(np.flatnonzero(m[:, -1] <= 0.0)[0])
        raise RoughnessError(
            f"facet normal {i} = {m[i].tolist()} does not point out of the base surface; "
            "its last component (along n0) must be > 0"
        )
    return m


def check_weights(name: str, weights: ArrayLike, count: int) -> NDArray[np.float64]:
    """Validate non-negative, not-all-zero weights of length ``count``; normalise to sum 1."""
    w = as_array(name, weights, 1, (count,))
    if np.any(w < 0):
        raise RoughnessError(f"{name} must be non-negative; {name}[{int(np.argmin(w))}] is {w.min():.6g}")
    big = float(w.max())
    if big <= 0.0:
        raise RoughnessError(f"{name} are all zero; at least one facet must have positive weight")
    w = w / big  # scaled first: a sum of weights near the largest float would overflow
    return w / float(w.sum())

"""Roughness measures (G, P): the distribution of facet normals, (2.2) and §3.

What the law (2.8) needs from a microrelief is only the probability measure of
the unit normals ``m`` of the facets at the contact point, written in the local
frame of the base surface (last component along the base normal n⁰). Every
measure here provides a quadrature *rule* for that measure restricted to the
facets that can face a given contact velocity ``u``: nodes ``m_j`` and weights
``p_j``. The boundary of the facing set G* = {mᵀu < 0} depends on the direction
of ``u`` only, never on the mass matrix, so a rule can follow it exactly.
"""

from __future__ import annotations

import functools
import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._validate import as_array, as_scalar
from .errors import ParameterError, RoughnessError
from .graded import graded_azimuth_rule, ring_minima, ring_width_bound
from .quadrature import azimuth_rule

__all__ = ["Roughness", "FiniteRoughness", "Smooth", "Sawtooth", "Cone", "Facets", "check_normals", "check_weights"]

# A quadrature rule (U (B, d), nodes) -> normals, weights, as Roughness.rule_batch.
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
    """

    dim: ClassVar[int | None] = None
    exact: ClassVar[bool] = True
    initial_nodes: ClassVar[int] = 1
    node_limit: ClassVar[int] = 4096

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

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        """``count`` facet normals drawn from P (local frame), shape (count, d).

        Used by the Monte Carlo average (``RoughLaw(method="mc")``).
        """
        raise ParameterError(f"{type(self).__name__} cannot be sampled; use method='quadrature'")

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


@dataclass(frozen=True)
class Smooth(FiniteRoughness):
    """No microrelief, g ≡ 0: every facet is the base surface (property 5°)."""

    def facets(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        raise AssertionError("Smooth has no fixed dimension; use rule_batch")  # pragma: no cover

    def rule_batch(self, U: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        normal = np.zeros((1, U.shape[1]))
        normal[0, -1] = 1.0
        return normal, np.ones(1)

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        raise ParameterError("Smooth has a single facet; Monte Carlo sampling is pointless, use the quadrature")


@dataclass(frozen=True)
class Sawtooth(FiniteRoughness):
    """Planar sawtooth of the paper's example (2.11)–(2.13).

    Facet normals (∓sin α, cos α) with probability ½ each.

    Parameters
    ----------
    alpha : float
        Slope angle of the teeth, 0 ≤ α < π/2.
    """

    alpha: float
    dim: ClassVar[int | None] = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "alpha", as_scalar("alpha", self.alpha, 0.0, math.pi / 2, hi_open=True))

    def facets(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        s, c = math.sin(self.alpha), math.cos(self.alpha)
        return np.array([[-s, c], [s, c]]), np.array([0.5, 0.5])


@dataclass(frozen=True)
class Cone(Roughness):
    """Spatial isotropic roughness with a single tilt: facets at angle α from n⁰.

    The facet normal is m = (sin α cos φ, sin α sin φ, cos α) with the azimuth φ
    uniform on [0, 2π). When the whole cone faces the velocity
    (|u_t| tan α < |u_n|) the rule is the periodic trapezoid rule, which
    converges geometrically; otherwise the facing arc
    cos(φ - ψ) < cot α |u_n| / |u_t| is found in closed form and integrated by
    Gauss–Legendre on that arc, so convergence stays geometric in the truncated
    regime too (:func:`mbimpact.quadrature.azimuth_rule`).

    Parameters
    ----------
    alpha : float
        Tilt of the facets, 0 ≤ α < π/2.
    """

    alpha: float
    dim: ClassVar[int | None] = 3
    exact: ClassVar[bool] = False
    initial_nodes: ClassVar[int] = 32  # 32 and 64 nodes agree to ~1e-15 for ordinary W: one pass

    def __post_init__(self) -> None:
        object.__setattr__(self, "alpha", as_scalar("alpha", self.alpha, 0.0, math.pi / 2, hi_open=True))

    def rule_batch(self, U: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if self.alpha == 0.0:
            return np.array([[0.0, 0.0, 1.0]]), np.ones(1)
        B = U.shape[0]
        return azimuth_rule(np.full((B, 1), self.alpha), np.ones((B, 1)), U, nodes)

    def graded_rule(self, W: NDArray[np.float64], peaked: float) -> Rule | None:
        if self.alpha == 0.0 or ring_width_bound(self.alpha, W) >= peaked:
            return None
        minima = ring_minima(self.alpha, W)
        # ε ≲ 1e-7 means q_min / q_max ≲ 1e-14: facets the mechanism cannot push (skipped as
        # degenerate), around which the flux weight is not integrable; grading cannot help
        if not minima[1].size or not 1e-7 < minima[1].min() < peaked:
            return None
        return functools.partial(graded_azimuth_rule, self.alpha, minima)

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        phi = rng.uniform(0.0, 2.0 * math.pi, count)
        s, c = math.sin(self.alpha), math.cos(self.alpha)
        return np.column_stack([s * np.cos(phi), s * np.sin(phi), np.full(count, c)])


def check_normals(name: str, normals: ArrayLike) -> NDArray[np.float64]:
    """Validate facet normals (K, d): unit, d = 2 or 3, pointing out of the base surface."""
    m = as_array(name, normals, 2)
    if m.shape[1] not in (2, 3) or m.shape[0] == 0:
        raise RoughnessError(f"facet normals must have shape (K, d), K ≥ 1, d = 2 or 3; got {m.shape}")
    lengths = np.linalg.norm(m, axis=1)
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
    total = float(w.sum())
    if total <= 0.0:
        raise RoughnessError(f"{name} are all zero; at least one facet must have positive weight")
    return w / total


@dataclass(frozen=True, eq=False)
class Facets(FiniteRoughness):
    """Any finite measure: facet normals with weights, planar or spatial.

    Parameters
    ----------
    normals : array_like, shape (K, d)
        Unit facet normals in the local frame (last component along n⁰, > 0:
        a facet tilts by less than π/2), d = 2 or 3.
    weights : array_like, shape (K,), optional
        Non-negative, not all zero; normalised to sum 1. Uniform by default.
    """

    normals: NDArray[np.float64]
    weights: NDArray[np.float64] | None = field(default=None)

    def __post_init__(self) -> None:
        m = check_normals("normals", self.normals).copy()
        if self.weights is None:
            w = np.full(m.shape[0], 1.0 / m.shape[0])
        else:
            w = check_weights("weights", self.weights, m.shape[0])
        m.flags.writeable = False
        w.flags.writeable = False
        object.__setattr__(self, "normals", m)
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "dim", m.shape[1])

    def __repr__(self) -> str:
        return f"Facets({self.normals.shape[0]} facets, d={self.normals.shape[1]})"

    def facets(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        assert self.weights is not None
        return self.normals, self.weights

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
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._validate import as_array, as_scalar
from .errors import RoughnessError

__all__ = ["Roughness", "Smooth", "Sawtooth", "Cone", "Facets"]

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
    """

    dim: ClassVar[int | None] = None
    exact: ClassVar[bool] = True
    #: First node count tried by an adaptive law (ignored when ``exact``).
    initial_nodes: ClassVar[int] = 1

    @abstractmethod
    def rule(self, u: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Quadrature of the measure on (a superset of) the facets facing ``u``.

        Parameters
        ----------
        u : ndarray, shape (d,)
            Pre-impact contact velocity in the local frame, ``u[-1] < 0``.
        nodes : int
            Node count for measures that are not finite (ignored otherwise).

        Returns
        -------
        normals : ndarray, shape (K, d)
            Unit facet normals in the local frame.
        weights : ndarray, shape (K,)
            Their probabilities dP (non-negative).
        """

    def supports(self, d: int) -> bool:
        """Whether the measure can be used in a contact space of dimension ``d``."""
        return self.dim is None or self.dim == d


@dataclass(frozen=True)
class Smooth(Roughness):
    """No microrelief, g ≡ 0: every facet is the base surface (property 5°)."""

    def rule(self, u: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        normal = np.zeros((1, u.shape[0]))
        normal[0, -1] = 1.0
        return normal, np.ones(1)


@dataclass(frozen=True)
class Sawtooth(Roughness):
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

    def rule(self, u: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        s, c = math.sin(self.alpha), math.cos(self.alpha)
        return np.array([[-s, c], [s, c]]), np.array([0.5, 0.5])


@functools.lru_cache(maxsize=32)
def _gauss_legendre(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    x, w = np.polynomial.legendre.leggauss(n)
    x.flags.writeable = False
    w.flags.writeable = False
    return x, w


@dataclass(frozen=True)
class Cone(Roughness):
    """Spatial isotropic roughness with a single tilt: facets at angle α from n⁰.

    The facet normal is m = (sin α cos φ, sin α sin φ, cos α) with the azimuth φ
    uniform on [0, 2π). When the whole cone faces the velocity
    (|u_t| tan α < |u_n|) the rule is the periodic trapezoid rule, which
    converges geometrically; otherwise the facing arc
    cos(φ - ψ) < cot α |u_n| / |u_t| is found in closed form and integrated by
    Gauss–Legendre on that arc, so convergence stays geometric in the truncated
    regime too.

    Parameters
    ----------
    alpha : float
        Tilt of the facets, 0 ≤ α < π/2.
    """

    alpha: float
    dim: ClassVar[int | None] = 3
    exact: ClassVar[bool] = False
    initial_nodes: ClassVar[int] = 16

    def __post_init__(self) -> None:
        object.__setattr__(self, "alpha", as_scalar("alpha", self.alpha, 0.0, math.pi / 2, hi_open=True))

    def facing_arc(self, u: NDArray[np.float64]) -> tuple[float, float]:
        """Centre ψ and half-width of the azimuth arc of facets facing ``u``.

        Returns ``(psi, half)``; ``half = π`` means the whole cone faces ``u``.
        """
        ut = math.hypot(u[0], u[1])
        psi = math.atan2(u[1], u[0])
        s, c = math.sin(self.alpha), math.cos(self.alpha)
        # mᵀu < 0  <=>  cos(φ - ψ) < c |u_n| / (s |u_t|)
        if s * ut <= c * abs(u[2]):
            return psi, math.pi
        return psi + math.pi, math.pi - math.acos(c * abs(u[2]) / (s * ut))

    def rule(self, u: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if self.alpha == 0.0:
            return np.array([[0.0, 0.0, 1.0]]), np.ones(1)
        centre, half = self.facing_arc(u)
        if half == math.pi:
            # nodes symmetric about ψ: the result lies exactly in the plane of u and n⁰ (2°)
            phi = centre + (2.0 * math.pi / nodes) * np.arange(nodes)
            w = np.full(nodes, 1.0 / nodes)
        else:
            x, gw = _gauss_legendre(nodes)
            phi = centre + half * x
            w = gw * (half / (2.0 * math.pi))
        s, c = math.sin(self.alpha), math.cos(self.alpha)
        normals = np.empty((phi.size, 3))
        normals[:, 0] = s * np.cos(phi)
        normals[:, 1] = s * np.sin(phi)
        normals[:, 2] = c
        return normals, w


@dataclass(frozen=True, eq=False)
class Facets(Roughness):
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
        m = as_array("normals", self.normals, 2)
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
        if self.weights is None:
            w = np.full(m.shape[0], 1.0 / m.shape[0])
        else:
            w = as_array("weights", self.weights, 1, (m.shape[0],))
            if np.any(w < 0):
                raise RoughnessError(f"weights must be non-negative; weight {int(np.argmin(w))} is {w.min():.6g}")
            total = float(w.sum())
            if total <= 0.0:
                raise RoughnessError("weights are all zero; at least one facet must have positive weight")
            w = w / total
        m = m.copy()
        m.flags.writeable = False
        w.flags.writeable = False
        object.__setattr__(self, "normals", m)
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "dim", m.shape[1])

    def supports(self, d: int) -> bool:
        return self.dim == d

    def rule(self, u: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        assert self.weights is not None
        return self.normals, self.weights

"""One velocity on a :class:`~mbimpact.Cone`: (2.8) at two node counts in a few array operations.

A single impact on a cone is what simulations call in their inner loop, and its
cost is the number of numpy calls, not the number of nodes. Measured from the
azimuth ψ of u_t, θ = φ − ψ, every quantity the quadrature needs is a
combination of the five harmonics T(θ) = (1, cos θ, sin θ, cos 2θ, sin 2θ):

    mᵀu = c u_n + s |u_t| cos θ,          mᵀWm = T(θ) · (q₀, a₁, b₁, a₂, b₂)ψ,
    m   = T(θ) M(ψ),

so both levels of the rule (n and 2n nodes, concatenated) are one product of a
(3n, 5) table of harmonics — cached for the full ring, three operations for an
arc — with small coefficient matrices. The nodes are exactly those of
:func:`mbimpact.quadrature.rules.azimuth_rule`: the periodic trapezoid rule on the full
ring, Gauss–Legendre on the facing arc θ ∈ π ± h, so the result is the one of the
adaptive rule's first pass up to rounding.
"""

from __future__ import annotations

import functools
import math

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import DEGENERATE, EPS, facing_half_width_scalar, ring_quadratic_form
from ..quadrature.rules import gauss_legendre
from ..results.impact import ContactImpulses
from .base import Averaging
from .kernels import AveragingSpec, Flux, kernel_powers

__all__ = ["ConePair", "cone_pair"]

# Harmonic orders and phases: column k of T is cos(order_k θ − phase_k).
_ORDER = np.array([0.0, 1.0, 1.0, 2.0, 2.0])
_PHASE = np.array([0.0, 0.0, math.pi / 2, 0.0, math.pi / 2])
# On the arc θ = π + θ', cos θ and sin θ change sign; cos 2θ and sin 2θ do not.
_ARC_SIGN = np.array([1.0, -1.0, -1.0, 1.0, 1.0])


@functools.lru_cache(maxsize=16)
def _full_ring(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Harmonics T (3n, 5) at θ = 2πj/n and 2πj/2n, and the level weights (2, 3n)."""
    theta = np.concatenate([2 * math.pi * np.arange(n) / n, 2 * math.pi * np.arange(2 * n) / (2 * n)])
    levels = np.zeros((2, 3 * n))
    levels[0, :n], levels[1, n:] = 1.0 / n, 1.0 / (2 * n)
    return np.cos(np.multiply.outer(theta, _ORDER) - _PHASE), levels


@functools.lru_cache(maxsize=16)
def _arc(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss–Legendre nodes × harmonic orders (3n, 5) on [-1, 1], and level weights (2, 3n) / 2π."""
    x1, w1 = gauss_legendre(n)
    x2, w2 = gauss_legendre(2 * n)
    levels = np.zeros((2, 3 * n))
    levels[0, :n], levels[1, n:] = w1 / (2 * math.pi), w2 / (2 * math.pi)
    return np.multiply.outer(np.concatenate([x1, x2]), _ORDER), levels


def cone_pair(
    alpha: float, W: NDArray[np.float64], u: NDArray[np.float64], n: int, flux: Flux
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """The two integrals of (2.8) on a cone, with n and with 2n azimuth nodes.

    Parameters
    ----------
    alpha : float
        Tilt of the cone, 0 < α < π/2.
    W : ndarray, shape (3, 3)
        Delassus matrix in the local frame.
    u : ndarray, shape (3,)
        Unit contact velocity in the local frame, u_n < 0.
    n : int
        Coarse node count.
    flux : {"physical", "configuration"}
        Facet weight of (2.7) (:mod:`mbimpact.averaging.kernels`).

    Returns
    -------
    (N, D) or None
        N (2, 3) = ∫ (mᵀu)² m / (mᵀWm)^γ and D (2,) = ∫ (−mᵀu) / (mᵀWm)^δ over the
        facing arc, coarse and fine rows, so that P = (1+e) N / D; None when a
        node sits on a degenerate facet (the general rule then masks it).
    """
    ux, uy, uz = u.tolist()
    ut = math.hypot(ux, uy)
    cp, sp = (ux / ut, uy / ut) if ut > 0.0 else (1.0, 0.0)
    s, c = math.sin(alpha), math.cos(alpha)
    h = facing_half_width_scalar(s, c, ut, -uz)
    w = W.tolist()
    q0, a1, b1, a2, b2 = ring_quadratic_form(s, c, w)
    c2, s2 = cp * cp - sp * sp, 2.0 * cp * sp
    # columns: mᵀu and mᵀWm in the harmonics of θ; M: the three components of m
    row1 = [s * ut, a1 * cp + b1 * sp, s * cp, s * sp, 0.0]
    row2 = [0.0, b1 * cp - a1 * sp, -s * sp, s * cp, 0.0]
    if h == math.pi:  # the whole ring faces u: periodic trapezoid rule from ψ
        T, levels = _full_ring(n)
    else:  # the facing arc θ ∈ π ± h: Gauss–Legendre; cos θ and sin θ change sign (_ARC_SIGN)
        X, unit = _arc(n)
        T = np.cos(h * X - _PHASE)
        levels = h * unit
        row1, row2 = [-x for x in row1], [-x for x in row2]
    coef = np.array([[c * uz, q0, 0.0, 0.0, c], row1, row2,
                     [0.0, a2 * c2 + b2 * s2, 0.0, 0.0, 0.0],
                     [0.0, b2 * c2 - a2 * s2, 0.0, 0.0, 0.0]])
    # (ndarray.dot rather than @ here: the same BLAS calls, without the generalised ufunc's overhead)
    values = T.dot(coef[:, :2])
    su, q = np.minimum(values[:, 0], 0.0), values[:, 1]
    if not np.minimum.reduce(q) > DEGENERATE * (w[0][0] + w[1][1] + w[2][2]):  # q.min() without its Python wrapper
        return None
    if kernel_powers(flux)[1]:  # configuration: w = −mᵀu / √q, kernel (mᵀu)² / q^{3/2}
        r = 1.0 / np.sqrt(q)
        weight = -su * r
        kernel = weight * weight * r
    else:  # physical: w = −mᵀu, kernel (mᵀu)² / q
        weight = -su
        kernel = su * su / q
    N = (levels * kernel).dot(T).dot(coef[:, 2:])
    return N, levels.dot(weight)


class ConePair(Averaging):
    """One velocity on a :class:`~mbimpact.Cone`: the first pass of the adaptive rule (n and 2n
    nodes) in a handful of array operations (:func:`cone_pair`). Declines when that pass is not
    conclusive (or meets a degenerate facet): the adaptive rule then goes on. Chosen by
    ``"auto"`` for single velocities without a fixed node count."""

    name: ClassVar[str] = "cone-pair"

    def supports(self, spec: AveragingSpec) -> bool:
        return super().supports(spec) and getattr(spec.roughness, "alpha", 0.0) > 0.0

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        return spec.nodes is None and len(U) == 1

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        n = spec.roughness.initial_nodes
        if 2 * n > spec.max_nodes or len(U) != 1:
            return None
        pair = cone_pair(spec.roughness.alpha, W, U[0], n, spec.flux)  # type: ignore[attr-defined]
        if pair is None:
            return None
        # the impulses of both levels, P = (1+e) N / D, in floats (2 × 3 numbers); W P by the product
        D0, D1 = pair[1].tolist()
        if not (D0 > 0.0 and D1 > 0.0):
            return None
        k = 1.0 + spec.e
        (n0, n1, n2), (m0, m1, m2) = pair[0].tolist()
        P = np.array([[k * n0 / D0, k * n1 / D0, k * n2 / D0], [k * m0 / D1, k * m1 / D1, k * m2 / D1]])
        (c0, c1, c2), (f0, f1, f2) = P.dot(W).tolist()
        err = math.sqrt(((f0 - c0) ** 2 + (f1 - c1) ** 2 + (f2 - c2) ** 2) / (f0 * f0 + f1 * f1 + f2 * f2))
        if not err <= max(spec.rtol, 100 * EPS * math.sqrt(2 * n)):  # the floor of the adaptive rule
            return None
        return ContactImpulses(P[1:], np.array([err]), 2 * n, self.name)

    def reason(self, spec: AveragingSpec) -> str:
        return "the two-level pass is not conclusive here (or there are several velocities); use 'adaptive'"

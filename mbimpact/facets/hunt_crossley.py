"""The Hunt–Crossley facet: a restitution that falls with the facet's normal impact speed.

Hunt & Crossley (1975) replace the Kelvin–Voigt force (2.3) by F = K δⁿ (1 + χ δ̇) (δ the
penetration, n = 3/2 for Hertz): the damping grows with the penetration, so the force
starts and ends at zero and the restitution depends on the approach speed v. Along
the facet normal, with W fixed as in (2.4), the motion is one-dimensional with
δ̈ = −W_nn F, and δ̇ (1 + χ δ̇)⁻¹ dδ̇ = −W_nn K δⁿ dδ integrates to the first integral

    G(δ̇) = δ̇/χ − ln(1 + χ δ̇)/χ² = −W_nn K δⁿ⁺¹/(n+1) + const,

the same at entry (δ̇ = v) and exit (δ̇ = −e v). The restitution therefore depends on
x = χ v alone — not on K, n or the mass:

    x − ln(1 + x) = −e x − ln(1 − e x),       e(v) = 1 − (2/3) χ v + O(χ v)²

(:func:`hunt_crossley_restitution`). With Hunt and Crossley's χ = 3α/2, e ≈ 1 − α v.

Consequence for the rough law: the facet impulse is no longer homogeneous of degree 1
in the velocity, so neither is the averaged law (property 1° of the paper fails, by
design: this is the speed dependence of the paper's remark 3°). :class:`mbimpact.RoughLaw`
hands such a facet law physical velocities (m/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_scalar
from .base import FacetLaw

__all__ = ["HuntCrossleyFacet", "hunt_crossley_restitution"]


@dataclass(frozen=True)
class HuntCrossleyFacet(FacetLaw):
    """Frictionless facet impact with the Hunt–Crossley restitution e(v), v = −mᵀu (m/s).

    P = −(1 + e(v)) (mᵀu / mᵀWm) m: Newton's facet law (2.6) with the restitution of the
    Hunt–Crossley force at that facet's own normal impact speed.

    Parameters
    ----------
    alpha : float
        Hunt–Crossley damping factor α ≥ 0 in s/m (χ = 3α/2); e(v) ≈ 1 − α v for α v ≪ 1.
        α = 0 is the elastic facet, e = 1.
    """

    alpha: float
    name: ClassVar[str] = "hunt-crossley"
    homogeneous: ClassVar[bool] = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "alpha", as_scalar("alpha", self.alpha, 0.0, math.inf))

    def __repr__(self) -> str:
        return f"HuntCrossleyFacet(alpha={self.alpha:g})"

    @property
    def e(self) -> float:  # type: ignore[override]
        """The restitution at 1 m/s (the law itself depends on the speed, :meth:`restitution`)."""
        return float(self.restitution(1.0))

    def restitution(self, speed: ArrayLike) -> NDArray[np.float64]:
        """e(v) at normal impact speeds v ≥ 0 (m/s), any shape."""
        with np.errstate(over="ignore"):  # α v beyond the float range: e = 0, the limit x → ∞
            x = 1.5 * self.alpha * np.asarray(speed, dtype=float)
        return hunt_crossley_restitution(x)

    def facet_impulse(self, W: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        P = np.zeros_like(u)
        un = u[:, -1]
        P[:, -1] = -(1.0 + self.restitution(-un)) * un / W[:, -1, -1]
        return P

    def impulse(self, m: NDArray[np.float64], W: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        s = np.einsum("nd,nd->n", m, u)
        q = np.einsum("nd,nd->n", m @ W, m)
        return (-(1.0 + self.restitution(-s)) * s / q)[:, None] * m


def _x_minus_log1p(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """x − ln(1 + x) for x > −1 without cancellation near 0 (series below |x| = 0.1)."""
    small = np.abs(x) < 0.1
    xs = np.where(small, x, 0.0)
    series = np.zeros_like(x)
    power = xs * xs
    for k in range(2, 24):
        series += (1.0 if k % 2 == 0 else -1.0) * power / k
        power = power * xs
    with np.errstate(divide="ignore", invalid="ignore"):
        direct = x - np.log1p(np.where(small, 0.0, x))
    return np.where(small, series, direct)


def hunt_crossley_restitution(x: ArrayLike) -> NDArray[np.float64]:
    """The Hunt–Crossley restitution e as a function of x = χ v ≥ 0 (any shape).

    The root e ∈ [0, min(1, 1/x)) of x − ln(1 + x) = −e x − ln(1 − e x), by bisection on the
    scaled form (x − ln(1+x))/x² = (−y − ln(1−y))/x² with y = e x (60 halvings: to rounding).
    e → 1 − 2x/3 as x → 0 and e → 0 as x → ∞.
    """
    x = np.asarray(x, dtype=float)
    infinite = np.isinf(np.atleast_1d(x).ravel())
    flat = np.minimum(np.atleast_1d(x).ravel(), 1e300)  # e(1e300) = 0 to rounding, as e(∞)
    lhs = _x_minus_log1p(flat)
    lo = np.zeros_like(flat)
    hi = np.where(flat > 1.0, 1.0 / np.where(flat > 1.0, flat, 1.0), 1.0)
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        # A(−e x) − A(x) grows with e: too big ⇒ e is smaller
        big = _x_minus_log1p(-mid * flat) > lhs
        hi = np.where(big, mid, hi)
        lo = np.where(big, lo, mid)
    e = 0.5 * (lo + hi)
    e = np.where(flat == 0.0, 1.0, np.where(infinite, 0.0, e))
    return e.reshape(x.shape)

"""Quadrature rules on the facets of an isotropic roughness, with G* exact.

For facets tilted by α from n⁰, with azimuth φ uniform, the set facing the contact
velocity is the whole ring (periodic trapezoid rule: geometric convergence) or an
arc whose end points are known in closed form
(:func:`mbimpact.common.geometry.facing_half_width`; Gauss–Legendre on the arc:
geometric convergence too). Everything is vectorised over rows of velocities and
tilts. Rules graded towards the peaks of a nearly singular W are in
:mod:`mbimpact.quadrature.graded`.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import facing_half_width, facing_half_width_scalar

__all__ = ["gauss_legendre", "azimuth_rule", "tilt_segments"]


@functools.lru_cache(maxsize=64)
def gauss_legendre(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss–Legendre nodes and weights on [-1, 1] (cached, read-only)."""
    if n <= 256:
        x, w = np.polynomial.legendre.leggauss(n)
    else:  # numpy's dense companion eigenproblem is O(n³); scipy's banded one is far cheaper
        import scipy.special  # deferred: 0.2 s to import, needed only past 256 nodes

        x, w = scipy.special.roots_legendre(n)
    x.flags.writeable = False
    w.flags.writeable = False
    return x, w


def azimuth_rule(
    tilt: NDArray[np.float64], tilt_weight: NDArray[np.float64], U: NDArray[np.float64], nodes: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Facet normals and weights over tilts × the facing part of the azimuth circle.

    Parameters
    ----------
    tilt, tilt_weight : ndarray, shape (B, L)
        Tilt nodes α (0 ≤ α < π/2) and their probabilities, per velocity row.
    U : ndarray, shape (B, 3)
        Contact velocities in the local frame, ``U[:, 2] < 0``.
    nodes : int
        Azimuth nodes per tilt.

    Returns
    -------
    normals : ndarray, shape (B, L * nodes, 3)
    weights : ndarray, shape (B, L * nodes)
        ``tilt_weight`` × the azimuth probability of each node; nodes on the
        excluded part of the circle never appear.
    """
    if tilt.size == 1:
        return _azimuth_rule_one(float(tilt[0, 0]), float(tilt_weight[0, 0]), U[0], nodes)
    ut = np.hypot(U[:, 0], U[:, 1])[:, None]  # (B, 1)
    un = np.abs(U[:, 2])[:, None]
    psi = np.arctan2(U[:, 1], U[:, 0])[:, None]
    s, c = np.sin(tilt), np.cos(tilt)  # (B, L)
    half = facing_half_width(s, c, ut, un)
    full = half == np.pi
    centre = np.where(full, psi, psi + np.pi)
    x, gw = gauss_legendre(nodes)
    j = np.arange(nodes)
    # full circle: ψ + 2πj/n (symmetric about ψ, so property 2° holds exactly); arc: Gauss–Legendre
    offset = np.where(full[..., None], 2.0 * np.pi * j / nodes, half[..., None] * x)  # (B, L, n)
    w_az = np.where(full[..., None], 1.0 / nodes, gw * half[..., None] / (2.0 * np.pi))
    phi = centre[..., None] + offset
    B = U.shape[0]
    normals = np.empty((B, tilt.shape[1], nodes, 3))
    normals[..., 0] = s[..., None] * np.cos(phi)
    normals[..., 1] = s[..., None] * np.sin(phi)
    normals[..., 2] = c[..., None]
    weights = tilt_weight[..., None] * w_az
    return normals.reshape(B, -1, 3), weights.reshape(B, -1)


def _azimuth_rule_one(
    tilt: float, tilt_weight: float, u: NDArray[np.float64], nodes: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`azimuth_rule` for one velocity and one tilt, in scalar arithmetic (single calls)."""
    ut, un = math.hypot(u[0], u[1]), abs(u[2])
    psi = math.atan2(u[1], u[0])
    s, c = math.sin(tilt), math.cos(tilt)
    half = facing_half_width_scalar(s, c, ut, un)
    if half == math.pi:
        phi = psi + (2.0 * math.pi / nodes) * np.arange(nodes)
        w = np.full(nodes, tilt_weight / nodes)
    else:
        x, gw = gauss_legendre(nodes)
        phi = psi + math.pi + half * x
        w = gw * (tilt_weight * half / (2.0 * math.pi))
    normals = np.empty((1, nodes, 3))
    normals[0, :, 0] = s * np.cos(phi)
    normals[0, :, 1] = s * np.sin(phi)
    normals[0, :, 2] = c
    return normals, w[None, :]


def tilt_segments(
    lo: float, hi: float, split: NDArray[np.float64], nodes: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Tilt nodes on [lo, split] ∪ [split, hi] per row, geometric also at the switch.

    Where the cone of tilt α starts to be cut by G* (α* = atan(|u_n| / |u_t|)),
    the averaged integrand behaves like (α − α*)^{3/2}; the substitution
    α = α* + t² on the upper segment makes it analytic in t (also when α* < lo).

    Parameters
    ----------
    split : ndarray, shape (B,)
        Split point per row, clipped into [lo, hi].

    Returns
    -------
    tilt, dtilt : ndarray, shape (B, 2 * nodes)
        Nodes and quadrature weights (dα) on [lo, hi].
    """
    x, w = gauss_legendre(nodes)
    a = np.clip(split, lo, hi)[:, None]
    # [lo, a]: plain Gauss–Legendre
    t1 = lo + (a - lo) * (x + 1.0) / 2.0
    w1 = (a - lo) / 2.0 * w
    # [a, hi]: α = o + t², from the onset o = min(α*, a): below lo (every ring cut) the
    # onset lies just outside the support and would otherwise slow the rule down
    origin = np.minimum(split[:, None], a)
    t0, tmax = np.sqrt(a - origin), np.sqrt(hi - origin)
    t = t0 + (tmax - t0) * (x + 1.0) / 2.0
    t2 = origin + t * t
    w2 = (tmax - t0) / 2.0 * w * 2.0 * t
    return np.concatenate([t1, t2], axis=1), np.concatenate([w1, w2], axis=1)

"""Quadrature nodes on the azimuth circle of an isotropic roughness, with G* exact.

For facets tilted by α from n⁰, with azimuth φ uniform, a facet faces the contact
velocity u iff sin α |u_t| cos(φ − ψ) < cos α |u_n| (ψ: azimuth of u_t). That set
is the whole circle (periodic trapezoid rule: geometric convergence) or an arc
whose end points are known in closed form (Gauss–Legendre on the arc: geometric
convergence too). Everything is vectorised over rows of velocities and tilts.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import scipy.special
from numpy.typing import NDArray

__all__ = ["gauss_legendre", "azimuth_rule", "tilt_segments", "ring_minima", "graded_azimuth_rule"]


@functools.lru_cache(maxsize=64)
def gauss_legendre(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss–Legendre nodes and weights on [-1, 1] (cached, read-only)."""
    if n <= 256:
        x, w = np.polynomial.legendre.leggauss(n)
    else:  # numpy's dense companion eigenproblem is O(n³); scipy's banded one is far cheaper
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
    full = s * ut <= c * un
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(full, 1.0, c * un / np.where(full, 1.0, s * ut))
    half = np.where(full, np.pi, np.pi - np.arccos(np.clip(ratio, -1.0, 1.0)))
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
    if s * ut <= c * un:
        phi = psi + (2.0 * math.pi / nodes) * np.arange(nodes)
        w = np.full(nodes, tilt_weight / nodes)
    else:
        half = math.pi - math.acos(min(1.0, c * un / (s * ut)))
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
    α = split + t² on the upper segment makes it analytic in t.

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
    # [a, hi]: α = a + t², t ∈ [0, sqrt(hi − a)]
    tmax = np.sqrt(hi - a)
    t = tmax * (x + 1.0) / 2.0
    t2 = a + t * t
    w2 = tmax / 2.0 * w * 2.0 * t
    return np.concatenate([t1, t2], axis=1), np.concatenate([w1, w2], axis=1)


def ring_minima(alpha: float, W: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Azimuths where q(φ) = m(φ)ᵀ W m(φ) has a local minimum on the cone of tilt α, and
    the width ε = sqrt(2 q / q'') of the peak that 1/q makes there.

    A nearly singular Delassus matrix W (an arm near a singular posture) makes the
    kernels of (2.8), (mᵀu)² m / q^{3/2} and 1/√q, peak at these azimuths with
    width ε ≪ 1: a rule that ignores them converges only once its spacing is below ε.

    Returns
    -------
    phi, eps : ndarray, shape (k,), k ≤ 2
    """
    s, c = math.sin(alpha), math.cos(alpha)
    w = W.tolist()
    # q = q0 + a1 cos φ + b1 sin φ + a2 cos 2φ + b2 sin 2φ
    q0 = 0.5 * s * s * (w[0][0] + w[1][1]) + c * c * w[2][2]
    a1, b1 = 2 * s * c * w[0][2], 2 * s * c * w[1][2]
    a2, b2 = 0.5 * s * s * (w[0][0] - w[1][1]), s * s * w[0][1]

    grid = 2 * math.pi * np.arange(64) / 64
    q = q0 + a1 * np.cos(grid) + b1 * np.sin(grid) + a2 * np.cos(2 * grid) + b2 * np.sin(2 * grid)
    found: list[float] = []
    widths: list[float] = []
    # a trigonometric polynomial of degree 2 has at most two local minima: Newton on q' = 0
    # from each grid minimum, in floats (this runs once per impact when W is ill-conditioned)
    for i in np.flatnonzero((q <= np.roll(q, 1)) & (q < np.roll(q, -1))).tolist():
        phi = float(grid[i])
        for _ in range(50):
            c1, s1, c2, s2 = math.cos(phi), math.sin(phi), math.cos(2 * phi), math.sin(2 * phi)
            dq = -a1 * s1 + b1 * c1 - 2 * a2 * s2 + 2 * b2 * c2
            d2q = -a1 * c1 - b1 * s1 - 4 * a2 * c2 - 4 * b2 * s2
            step = min(max(dq / d2q, -0.05), 0.05) if d2q > 0 else 0.0
            phi -= step
            if abs(step) < 1e-15:
                break
        c1, s1, c2, s2 = math.cos(phi), math.sin(phi), math.cos(2 * phi), math.sin(2 * phi)
        qmin = q0 + a1 * c1 + b1 * s1 + a2 * c2 + b2 * s2
        d2q = -a1 * c1 - b1 * s1 - 4 * a2 * c2 - 4 * b2 * s2
        found.append(phi % (2 * math.pi))
        widths.append(math.sqrt(2.0 * max(qmin, 0.0) / max(d2q, 1e-300)))
    phi_arr, eps = np.array(found), np.array(widths)
    return phi_arr, eps


def graded_azimuth_rule(
    alpha: float, minima: tuple[NDArray[np.float64], NDArray[np.float64]], U: NDArray[np.float64], nodes: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`azimuth_rule` for one tilt, graded towards the peaks of a nearly singular W.

    The facing interval (arc or whole circle) is cut at the minima of q that lie in
    it and every piece is halved; each half is mapped by φ = a ± ε sinh t onto the end
    a it shares with a peak, ε being the distance from a to the nearest peak's
    complex singularity (sqrt(ε_j² + |a − φ_j|²)), and integrated by Gauss–Legendre
    in t. The sinh map turns 1/(x² + ε²)^k into a smooth function of t, so the rule
    converges geometrically whatever ε (Johnston & Elliott's sinh transformation).

    Parameters
    ----------
    minima : (phi, eps)
        From :func:`ring_minima`.
    U : ndarray, shape (B, 3)
        Unit local-frame velocities, ``U[:, 2] < 0``.

    Returns
    -------
    normals : ndarray, shape (B, (2k + 2) * nodes, 3)
    weights : ndarray, shape (B, (2k + 2) * nodes)
        k peaks: the interval is cut into at most k + 1 pieces, 2 halves each.
    """
    phi_star, eps_star = minima
    s, c = math.sin(alpha), math.cos(alpha)
    ut, un = np.hypot(U[:, 0], U[:, 1]), np.abs(U[:, 2])
    psi = np.arctan2(U[:, 1], U[:, 0])
    full = s * ut <= c * un
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(full, 1.0, c * un / np.where(full, 1.0, s * ut))
    half = np.where(full, math.pi, math.pi - np.arccos(np.clip(ratio, -1.0, 1.0)))
    centre = np.where(full, psi, psi + math.pi)
    lo, hi = centre - half, centre + half  # (B,)
    B, k = len(U), len(phi_star)
    # minima inside (lo, hi), unwrapped; those outside are parked at hi (zero-length pieces)
    inside = np.mod(phi_star[None, :] - lo[:, None], 2 * math.pi) + lo[:, None]  # (B, k) in [lo, lo + 2π)
    inside = np.where(inside < hi[:, None], inside, hi[:, None])
    breaks = np.sort(np.concatenate([lo[:, None], inside, hi[:, None]], axis=1), axis=1)  # (B, k + 2)
    a, b = breaks[:, :-1], breaks[:, 1:]  # k + 1 pieces
    mid = 0.5 * (a + b)
    # each half-piece: graded end g, direction ±1, length ℓ
    g = np.concatenate([a, b], axis=1)  # (B, 2k + 2)
    sign = np.concatenate([np.ones_like(a), -np.ones_like(b)], axis=1)
    ell = np.concatenate([mid - a, b - mid], axis=1)
    # distance from each graded end to each peak's complex singularity φ_j ± iε_j (circular)
    dist = np.abs(np.mod(g[:, :, None] - phi_star[None, None, :] + math.pi, 2 * math.pi) - math.pi)
    eps = np.sqrt(eps_star**2 + dist**2).min(axis=2) if k else np.ones(g.shape)
    eps = np.maximum(eps, 1e-300)
    T = np.arcsinh(ell / eps)
    x, gw = gauss_legendre(nodes)
    t = T[..., None] * (x + 1.0) / 2.0  # (B, 2k + 2, n)
    phi = g[..., None] + sign[..., None] * eps[..., None] * np.sinh(t)
    w = eps[..., None] * np.cosh(t) * (T[..., None] / 2.0) * gw / (2.0 * math.pi)
    normals = np.empty((B, 2 * k + 2, nodes, 3))
    normals[..., 0] = s * np.cos(phi)
    normals[..., 1] = s * np.sin(phi)
    normals[..., 2] = c
    return normals.reshape(B, -1, 3), w.reshape(B, -1)

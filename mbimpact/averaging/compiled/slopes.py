"""The adaptive rule of (2.8) on an isotropic tilt density for one velocity, every level in one call:
the compiled backend of :class:`~mbimpact.averaging.Adaptive` on :class:`~mbimpact.IsotropicSlopes`.

This is :func:`mbimpact.averaging.refinement.refine` on one row of the measure's own rule
(:meth:`mbimpact.IsotropicSlopes.rule_batch`; its nodes and ring sums:
:mod:`~mbimpact.averaging.compiled.slope_nodes`), compiled by numba (``njit``, cached on disk), so that
a single impact costs its floating-point work rather than a few numpy calls for every array of every
level: the same levels, the same error estimate (the relative change of W P between the last two
levels) and the same stopping rule (``rtol`` or the rounding floor 100 ε √K). No array is passed to a
compiled function per ring (each would cost atomic reference counts). It is imported on first use only
(:data:`mbimpact.averaging.compiled.SLOPES`).
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .primitives import CAPPED, EPS, NEED_TABLE, NOT_FACING, SETTLED, STALLED, sin_cos_tilt
from .slope_nodes import (FAST, gaussian_density, split_tilt, level_count, level_table, prepare_rings, ring_sums,
                          segments, tilt, tilt_nodes)

__all__ = ["slope_adaptive", "level_table", "tilt_nodes", "jit_seconds", "TABULATED", "GAUSSIAN"]

#: Kinds of tilt density: values given at the nodes of :func:`~mbimpact.averaging.compiled.slope_nodes.tilt_nodes`,
#: or the density of :class:`mbimpact.roughness.slopes.GaussianTiltDensity` in closed form.
TABULATED, GAUSSIAN = 0, 1


@njit(cache=True, error_model="numpy", fastmath=FAST)
def _spatial_level(k: int, u: NDArray[np.float64], W: NDArray[np.float64], table: NDArray[np.float64], n0: int,
                   density: NDArray[np.float64], kind: int, lo: float, hi: float, sigma: float, radial: bool,
                   mass: float, configuration: bool, e: float, degenerate: float, rings: NDArray[np.float64]
                   ) -> tuple[bool, float, float, float]:
    """(2.8) by level k of the spatial rule: whether a facet faces u, and P (3 floats); ``rings`` is
    scratch space, (4, ≥ 2n)."""
    n, off = n0 << k, n0 * ((1 << k) - 1)
    ux, uy, uz = u[0], u[1], u[2]
    ut = math.hypot(ux, uy)
    un = abs(uz)
    cp, sp = (ux / ut, uy / ut) if ut > 0.0 else (1.0, 0.0)  # the azimuth ψ of u_t
    # W' = Rᵀ W R / tr W in the frame (e_ψ, e_ψ⊥, n⁰) of the ring's θ = φ − ψ: mᵀWm in units of
    # tr W is of order one (see _terms), and P = (1+e) N / D in those units is tr W times P
    trace = W[0, 0] + W[1, 1] + W[2, 2]
    w11 = (cp * (cp * W[0, 0] + sp * W[1, 0]) + sp * (cp * W[0, 1] + sp * W[1, 1])) / trace
    w12 = (cp * (-sp * W[0, 0] + cp * W[1, 0]) + sp * (-sp * W[0, 1] + cp * W[1, 1])) / trace
    w22 = (-sp * (-sp * W[0, 0] + cp * W[1, 0]) + cp * (-sp * W[0, 1] + cp * W[1, 1])) / trace
    w13 = (cp * W[0, 2] + sp * W[1, 2]) / trace
    w23 = (-sp * W[0, 2] + cp * W[1, 2]) / trace
    w33 = W[2, 2] / trace
    # the level's columns as views indexed from 0, made once (a view costs two atomic reference
    # counts): an index from 0 is one the compiler proves non-negative, so that it loads a ring's
    # nodes as vectors instead of wrapping each index around
    xs, gs = table[0, off:off + n], table[1, off:off + n]
    cs, sn = table[2, off:off + n], table[3, off:off + n]
    prepare_rings(rings, xs, gs, density[2 * off:2 * off + 2 * n], lo, hi, split_tilt(u), kind == GAUSSIAN,
                  1.0 / sigma, radial, 1.0 / mass, ut, un)
    D = X = Y = Z = 0.0
    for i in range(2 * n):
        pr = rings[3, i]
        if not pr > 0.0:
            continue
        s, c = rings[0, i], rings[1, i]
        ss, sc = s * s, 2.0 * s * c
        rd, rx, ry, rz = ring_sums(xs, gs, cs, sn, rings[2, i], s * ut, c * uz, ss * w11, 2.0 * ss * w12, ss * w22,
                                   sc * w13, sc * w23, c * c * w33, degenerate, configuration)
        D += pr * rd
        X += pr * s * rx
        Y += pr * s * ry
        Z += pr * c * rz
    if not D > 0.0:
        return False, 0.0, 0.0, 0.0
    k1 = (1.0 + e) / (D * trace)
    return True, k1 * (cp * X - sp * Y), k1 * (sp * X + cp * Y), k1 * Z


@njit(cache=True, error_model="numpy")
def _planar_level(k: int, u: NDArray[np.float64], W: NDArray[np.float64], table: NDArray[np.float64], n0: int,
                  density: NDArray[np.float64], kind: int, lo: float, hi: float, sigma: float, radial: bool,
                  mass: float, configuration: bool, e: float, degenerate: float) -> tuple[bool, float, float, float]:
    """(2.8) by level k of the planar rule: whether a facet faces u, and P (2 floats and a 0); its
    2n facets in one loop."""
    n, off = n0 << k, n0 * ((1 << k) - 1)
    u0, u1 = u[0], u[1]
    side = 1.0 if u0 >= 0.0 else -1.0  # the sign of u_t: tilting "with" the motion
    thr = degenerate * (W[0, 0] + W[1, 1])
    a, origin, t0, tmax = segments(lo, hi, split_tilt(u))
    xs, gs = table[0, off:off + n], table[1, off:off + n]
    inv_sigma = 1.0 / sigma
    D = N0 = N1 = 0.0
    for i in range(2 * n):
        j = i if i < n else i - n
        alpha, dalpha = tilt(i, n, xs[j], gs[j], lo, hi, a, origin, t0, tmax, True)
        s, c = sin_cos_tilt(alpha)
        p = (density[2 * off + i] if kind == TABULATED else gaussian_density(s, c, inv_sigma, radial) / mass) * dalpha
        m0 = (-side if i < n else side) * s
        su = m0 * u0 + c * u1
        q = (m0 * W[0, 0] + c * W[1, 0]) * m0 + (m0 * W[0, 1] + c * W[1, 1]) * c
        if not (su < 0.0 and q > thr and p > 0.0):
            continue
        w = p * (-su / math.sqrt(q) if configuration else -su)
        wc = w * (-su / q)
        D += w
        N0 += wc * m0
        N1 += wc * c
    if not D > 0.0:
        return False, 0.0, 0.0, 0.0
    k1 = (1.0 + e) / D
    return True, k1 * N0, k1 * N1, 0.0


@njit(cache=True, error_model="numpy")
def _level(k: int, u: NDArray[np.float64], W: NDArray[np.float64], table: NDArray[np.float64], n0: int,
           density: NDArray[np.float64], kind: int, lo: float, hi: float, sigma: float, radial: bool, mass: float,
           configuration: bool, e: float, degenerate: float, rings: NDArray[np.float64]
           ) -> tuple[bool, float, float, float]:
    """(2.8) by level k of the rule (:func:`_spatial_level`, :func:`_planar_level`)."""
    if u.shape[0] == 2:
        return _planar_level(k, u, W, table, n0, density, kind, lo, hi, sigma, radial, mass, configuration, e,
                             degenerate)
    return _spatial_level(k, u, W, table, n0, density, kind, lo, hi, sigma, radial, mass, configuration, e,
                          degenerate, rings)


@njit(cache=True, error_model="numpy")
def _times_W(W: NDArray[np.float64], x0: float, x1: float, x2: float) -> tuple[float, float, float]:
    """x W for a row x of 2 or 3 entries (x2 = 0 when d = 2)."""
    if W.shape[0] == 2:
        return x0 * W[0, 0] + x1 * W[1, 0], x0 * W[0, 1] + x1 * W[1, 1], 0.0
    return (x0 * W[0, 0] + x1 * W[1, 0] + x2 * W[2, 0], x0 * W[0, 1] + x1 * W[1, 1] + x2 * W[2, 1],
            x0 * W[0, 2] + x1 * W[1, 2] + x2 * W[2, 2])


# ---------------------------------------------------------------------- the refinement
@njit(cache=True, error_model="numpy")
def slope_adaptive(U: NDArray[np.float64], W: NDArray[np.float64], table: NDArray[np.float64], n0: int,
               density: NDArray[np.float64], kind: int, lo: float, hi: float, sigma: float, radial: bool,
               mass: float, e: float, configuration: bool, rtol: float, max_nodes: int, degenerate: float,
               P: NDArray[np.float64], state: NDArray[np.float64], start: int) -> int:
    """The adaptive rule of :func:`mbimpact.averaging.refinement.refine` for one velocity.

    Levels n0, 2 n0, … of the measure's rule until two successive ones agree to
    max(rtol, 100 ε √K) (K facets of the finer) in the relative change of W P
    (:func:`mbimpact.averaging.integrand.relative_change`).

    Parameters
    ----------
    U : ndarray, shape (1, d)
        Unit contact velocity u, local frame, u_n < 0 (d = 2 or 3).
    W : ndarray, shape (d, d)
        Delassus matrix, local frame.
    table : ndarray, shape (4, K)
        :func:`level_table` from level n0 on.
    n0 : int
        Nodes a piece of the first level.
    density : ndarray, shape (2 K,)
        ``kind`` TABULATED: the normalised tilt density at :func:`tilt_nodes`; else read but unused
        (any values: the closed form is selected after both are computed).
    kind : int
        TABULATED or GAUSSIAN.
    lo, hi : float
        The density's support.
    sigma, radial, mass : float, bool, float
        GAUSSIAN: the RMS slope, whether the slope density is the spatial one (x e^{−x²/2}), and
        the integral of the unnormalised density.
    e : float
        Facet restitution.
    configuration : bool
        The "configuration" flux of (2.7) (else "physical").
    rtol : float
        Relative accuracy.
    max_nodes : int
        Nodes a piece at which refinement stops.
    degenerate : float
        A facet with mᵀWm ≤ degenerate · tr W cannot be pushed by the mechanism: left out
        (:data:`mbimpact.common.geometry.DEGENERATE`).
    P : ndarray, shape (1, d)
        Out: the impulse of the last level, (2.8), local frame. In, when ``start`` ≥ 0: the impulse
        of level ``start`` (a call resumed after NEED_TABLE).
    state : ndarray, shape (2,)
        Out: the last level compared with the one before (its index, as a float) and that error
        estimate. In, when ``start`` ≥ 0: level ``start``'s, as left by the call that returned
        NEED_TABLE.
    start : int
        −1 for a new velocity; else the level the call that returned NEED_TABLE ended with.

    Returns
    -------
    int
        SETTLED, STALLED, CAPPED (``P`` and ``state`` hold the last level), NOT_FACING or NEED_TABLE
        (extend ``table``, and ``density`` for TABULATED, and call again).
    """
    u = U[0]
    d = u.shape[0]
    count = level_count(table, n0)
    trace = W[0, 0] + W[1, 1] + (W[2, 2] if d == 3 else 0.0)
    rings = np.empty((4, 2 * (n0 << (count - 1)) if d == 3 and count > 0 else 0))  # _spatial_level's scratch
    k = start
    # the coarse level's impulse c, and the error estimate before this one
    c0, c1, c2 = (P[0, 0], P[0, 1], (P[0, 2] if d == 3 else 0.0)) if k >= 0 else (0.0, 0.0, 0.0)
    previous = state[1] if k >= 0 else math.inf
    while True:
        k += 1
        if k >= count:  # (after level 0 alone a resumed call starts again from −1)
            state[0] = k - 1 if k > 1 else -1.0
            return NEED_TABLE
        # (one call site of the level: the compiler inlines it once at most)
        ok, f0, f1, f2 = _level(k, u, W, table, n0, density, kind, lo, hi, sigma, radial, mass, configuration, e,
                                degenerate, rings)
        if not ok:
            return NOT_FACING
        if k == 0:  # the first level: no comparison yet
            c0, c1, c2 = f0, f1, f2
            continue
        # relative_change: |(fine − coarse) W| / |fine W|
        g0, g1, g2 = _times_W(W, f0 - c0, f1 - c1, f2 - c2)
        r0, r1, r2 = _times_W(W, f0, f1, f2)
        err = math.sqrt((g0 * g0 + g1 * g1 + g2 * g2) / (r0 * r0 + r1 * r1 + r2 * r2))
        P[0, 0], P[0, 1] = f0, f1
        if d == 3:
            P[0, 2] = f2
        state[0], state[1] = k, err
        nodes = n0 << k
        floor = 100.0 * EPS * math.sqrt(2.0 * nodes * (nodes if d == 3 else 1))  # the level's facets
        if not err > max(rtol, floor):
            return SETTLED
        # the adaptive rule's test for results stalled at rounding amplified by |W| |P| / |W P|
        amplification = trace * math.sqrt((f0 * f0 + f1 * f1 + f2 * f2) / (r0 * r0 + r1 * r1 + r2 * r2))
        if err <= floor * amplification and err > 0.1 * previous:
            return STALLED
        if nodes * 2 > max_nodes:
            return CAPPED
        c0, c1, c2, previous = f0, f1, f2, err


def jit_seconds() -> float:
    """Wall time to make the kernels callable in this process (numba's import excluded: importing
    this module does it): their machine code loaded from numba's on-disk cache (``__pycache__`` next
    to this file), or compiled when that cache is missing or stale. The first call pays it; later
    calls return near 0."""
    start = time.perf_counter()
    table = level_table(2, 2)
    for d in (3, 2):
        U = np.full((1, d), -1.0 / math.sqrt(d))
        U[0, 0] = -U[0, 0]
        density = np.ones(2 * table.shape[1])
        tilt_nodes(U, 0.0, 1.0, table, 2)
        for kind in (TABULATED, GAUSSIAN):
            slope_adaptive(U, np.eye(d), table, 2, density, kind, 0.0, 1.0, 0.5, True, 1.0, 0.5, False, 1e-12, 8, 1e-14,
                       np.empty((1, d)), np.empty(2), -1)
    return time.perf_counter() - start

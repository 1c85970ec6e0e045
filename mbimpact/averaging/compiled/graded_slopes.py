"""An isotropic tilt density's graded rule of (2.8) for one velocity (spatial, d = 3), every level in one
call: the compiled backend of :class:`~mbimpact.averaging.Graded` on tilt densities.

A nearly singular Delassus matrix W makes q = mᵀWm small near a few directions, and the kernels of
(2.8) with the flux weights of (2.7) peak there with widths ε ≪ 1. :class:`~mbimpact.averaging.Graded`
then integrates with :meth:`mbimpact.IsotropicSlopes.graded_rule`: tilts graded towards
:func:`~mbimpact.quadrature.graded.peak_tilts` (:func:`~mbimpact.quadrature.graded.graded_tilt_rule`),
and on every ring of tilt α its azimuths graded towards that ring's own minima of q
(:func:`~mbimpact.quadrature.graded.ring_minima_many`,
:func:`~mbimpact.quadrature.graded.graded_azimuth_rule`), refined as
:func:`mbimpact.averaging.refinement.refine` refines. In numpy each level costs arrays of 10⁵–10⁶
facets. Here it runs on floats, level after level (n, 2n, 4n, … nodes a piece): :func:`tilt_nodes`
forms the graded tilt nodes of every level (graded_tilt_rule's arithmetic; the caller weighs them with
the measure's density p(α) dα in one numpy call, so any tilt density works), and
:func:`graded_slopes`, ring after ring, finds the minima of q (256-point grid, Newton on q' = 0,
widths capped by the quartic one), cuts the facing interval at them, halves every piece and maps each
half by φ = a ± ε sinh t, Gauss–Legendre in t; sums the facet weights (2.7) and Newton impulses (2.8)
(node loops in SIMD lanes, :mod:`~mbimpact.averaging.compiled.half_pieces`; half-pieces added with compensation);
and stops by the adaptive rule's error estimate and stopping rule. Its result is the numpy rule's to
rounding.

Imported on first use only (numba costs ~0.3 s to import:
:data:`mbimpact.averaging.compiled.GRADED_SLOPES`).
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

from ...common.compiled import kernel
from .graded_cone import rule_table
from .half_pieces import NODE_PLUS_ONE, WEIGHT, half_piece_nodes, half_piece_sums
from .primitives import (CAPPED, DEGENERATE_FACET, EPS, NEED_TABLE, NOT_FACING, NOT_SETTLED, compensated_add,
                         level_decision)

__all__ = ["rule_table", "tilt_nodes", "graded_slopes", "jit_seconds"]

# ring_minima_many's Newton tolerance (_NEWTON_ROUNDING ε of the rounding of q') and iteration cap
_NEWTON_ROUNDING = 16.0
_NEWTON_STEPS = 60

# ring_minima_many's 256-point grid, the numpy floats (rows cos φ, sin φ, cos 2φ, sin 2φ), frozen as constants
_GRID_N = 256
_GRID_ANGLES = 2 * math.pi * np.arange(_GRID_N) / _GRID_N
_GRID = np.ascontiguousarray(np.vstack([np.cos(_GRID_ANGLES), np.sin(_GRID_ANGLES), np.cos(2 * _GRID_ANGLES),
                                        np.sin(2 * _GRID_ANGLES)]))
_GRID.flags.writeable = False

# Explicit signatures, compiled (or loaded from the cache) on first use: W and U of any layout, read-only; the
# tilts and the table C-contiguous (strided indexing would keep the node loops out of SIMD lanes)
_IN1 = types.Array(types.float64, 1, "C", readonly=True)
_IN2 = types.Array(types.float64, 2, "A", readonly=True)
_TABLE = types.Array(types.float64, 2, "C", readonly=True)
_INT1 = types.Array(types.int64, 1, "C", readonly=True)
_TILTS = types.int64(types.float64, types.float64, types.float64, _IN1, _IN1, _TABLE, types.int64, types.int64,
                      types.float64[::1], types.float64[::1], types.int64[::1])
_PASS = types.UniTuple(types.int64, 2)(_IN2, _IN2, _IN1, _IN1, _INT1, _TABLE, types.int64, types.int64,
                                       types.boolean, types.float64, types.float64, types.float64,
                                       types.float64[:, ::1], types.float64[::1])
# _level's, so that its calls from every level share one compilation (not one more for a constant start)
_LEVEL = types.UniTuple(types.int64, 2)(types.int64, types.int64, _TABLE, _IN1, _IN1, types.int64, types.int64, _IN2,
                                        _IN2, types.float64, types.boolean, types.float64, types.float64[::1])


@kernel(_TILTS, error_model="numpy")
def tilt_nodes(lo: float, hi: float, split: float, at: NDArray[np.float64], et: NDArray[np.float64],
               table: NDArray[np.float64], n: int, count: int, tilt: NDArray[np.float64], dtilt: NDArray[np.float64],
               start: NDArray[np.int64]) -> int:  # pragma: no cover — compiled
    """:func:`~mbimpact.quadrature.graded.graded_tilt_rule` for one velocity at ``count`` levels (n, 2n, …
    nodes a piece), its arithmetic on floats; the nodes of positive dα only, as
    :meth:`mbimpact.IsotropicSlopes._graded_spatial` keeps them.

    Parameters
    ----------
    lo, hi, split : float
        The support and α*.
    at, et : ndarray, shape (3,)
        :func:`~mbimpact.quadrature.graded.peak_tilts`' tilts and widths, NaN for none.
    table : ndarray, shape (2, n (2^levels − 1)), levels ≥ count
        :func:`~mbimpact.averaging.compiled.graded_cone.rule_table`.
    tilt, dtilt : ndarray, shape (≥ 10 n (2^count − 1),)
        Output: the nodes and their dα, level after level.
    start : ndarray of int, shape (count + 1,)
        Output: where each level starts.

    Returns
    -------
    int
        The number of nodes written.
    """
    star = min(max(split, lo), hi)
    breaks = np.empty(6)
    breaks[0], breaks[1], breaks[5] = lo, star, hi
    for j in range(3):
        ok = math.isfinite(at[j]) and math.isfinite(et[j])
        breaks[2 + j] = at[j] if ok and at[j] > lo and at[j] < hi else hi  # outside, none: parked at hi
    breaks.sort()
    g, sign, width, T, square = np.empty(10), np.empty(10), np.empty(10), np.empty(10), np.empty(10, np.bool_)
    for i in range(5):  # five pieces, each halved; a half graded towards its own end
        a, b = breaks[i], breaks[i + 1]
        mid = 0.5 * (a + b)
        g[i], sign[i], T[i], square[i] = a, 1.0, mid - a, a == star
        g[5 + i], sign[5 + i], T[5 + i], square[5 + i] = b, -1.0, b - mid, False
    for h in range(10):
        eps = math.inf  # distance from the end to the nearest peak's complex singularity α_j ± iε_j
        for j in range(3):
            if math.isfinite(at[j]) and math.isfinite(et[j]):
                eps = min(eps, math.sqrt(et[j] ** 2 + abs(g[h] - at[j]) ** 2))
        eps = max(eps, 1e-300) if math.isfinite(eps) else 1.0
        if square[h]:  # α = a + (ε_τ sinh t)² just above α*: a width in τ = sqrt(α − α*)
            eps = math.sqrt(eps)
        width[h], T[h] = eps, math.asinh((math.sqrt(T[h]) if square[h] else T[h]) / eps)
    k, col, m = 0, 0, n
    start[0] = 0
    for level in range(count):
        for h in range(10):
            for i in range(col, col + m):
                t = T[h] * table[NODE_PLUS_ONE, i] / 2.0
                y = width[h] * math.sinh(t)
                dy = width[h] * math.cosh(t) * (T[h] / 2.0) * table[WEIGHT, i]
                da = 2.0 * y * dy if square[h] else dy
                if da > 0.0:
                    tilt[k], dtilt[k] = g[h] + (y * y if square[h] else sign[h] * y), da
                    k += 1
        start[level + 1] = k
        col += m
        m *= 2
    return k


@njit(cache=True, error_model="numpy")
def _minima(q0: float, a1: float, b1: float, a2: float, b2: float, grid: NDArray[np.float64],
            phi_out: NDArray[np.float64], eps_out: NDArray[np.float64]) -> int:  # pragma: no cover — compiled
    """:func:`~mbimpact.quadrature.graded.ring_minima_many` on one ring: the (at most two) minima of
    q(φ) = q₀ + a₁ cos φ + b₁ sin φ + a₂ cos 2φ + b₂ sin 2φ in grid order and their widths into
    ``phi_out``, ``eps_out`` (2,); their number. ``grid`` (256,) is scratch. Newton runs per minimum
    until its own step is at rounding (numpy steps all rings until all are: the extra steps move φ by
    rounding only)."""
    for i in range(_GRID_N):  # no calls, no branches: SIMD lanes
        grid[i] = q0 + a1 * _GRID[0, i] + b1 * _GRID[1, i] + a2 * _GRID[2, i] + b2 * _GRID[3, i]
    noise = _NEWTON_ROUNDING * EPS * (abs(a1) + abs(b1) + 2 * abs(a2) + 2 * abs(b2))
    k = 0
    for i in range(_GRID_N):
        q = grid[i]
        if not (q <= grid[(i + _GRID_N - 1) % _GRID_N] and q < grid[(i + 1) % _GRID_N]):
            continue
        phi = _GRID_ANGLES[i]
        for _ in range(_NEWTON_STEPS):
            # the double angle from the single one (half the libm calls; q' moves by rounding only)
            c1, s1 = math.cos(phi), math.sin(phi)
            c2, s2 = (c1 - s1) * (c1 + s1), 2.0 * s1 * c1
            dq = -a1 * s1 + b1 * c1 - 2 * a2 * s2 + 2 * b2 * c2
            d2q = -a1 * c1 - b1 * s1 - 4 * a2 * c2 - 4 * b2 * s2
            step = min(max(dq / d2q, -0.05), 0.05) if d2q > 0 else 0.0
            tol = max(noise / d2q, 1e-15) if d2q > 0 else 1e-15
            phi = phi - step
            if not abs(step) > tol:
                break
        c1, s1 = math.cos(phi), math.sin(phi)
        c2, s2 = (c1 - s1) * (c1 + s1), 2.0 * s1 * c1
        qmin = max(q0 + a1 * c1 + b1 * s1 + a2 * c2 + b2 * s2, 0.0)
        d2q = -a1 * c1 - b1 * s1 - 4 * a2 * c2 - 4 * b2 * s2
        d4q = a1 * c1 + b1 * s1 + 16 * a2 * c2 + 16 * b2 * s2
        eps = math.sqrt(2.0 * qmin / max(d2q, 1e-300))
        if d4q > 0:  # two minima merging with the maximum between them: the quartic width
            eps = min(eps, (24.0 * qmin / max(d4q, 1e-300)) ** 0.25)
        phi_out[k], eps_out[k] = phi % (2 * math.pi), eps
        k += 1
        if k == 2:
            break
    return k


@kernel(_LEVEL, error_model="numpy")
def _level(start: int, m: int, table: NDArray[np.float64], tilt: NDArray[np.float64], pd: NDArray[np.float64],
           lo_tilt: int, hi_tilt: int, W: NDArray[np.float64], U: NDArray[np.float64], floor: float,
           configuration: bool, e: float, out: NDArray[np.float64]) -> tuple[int, int]:  # pragma: no cover
    """The impulse P = (1+e) N / D of (2.8) by the graded rule with ``m`` nodes a half-piece in tilt and
    in azimuth (columns ``start`` … ``start + m`` of the table) into ``out`` (3,).

    The rings are ``tilt[lo_tilt:hi_tilt]`` with weights p(α) dα ``pd``; on each, the minima of q
    (:func:`_minima`), the facing interval cut at them, six half-pieces graded towards their ends
    (:func:`~mbimpact.quadrature.graded.graded_azimuth_rule`'s arithmetic). Returns (status, K): 0 or the
    status that declines, and the facet count K of the numpy rule (nodes of positive weight)."""
    ux, uy, uz = U[0, 0], U[0, 1], U[0, 2]
    ut, un = math.hypot(ux, uy), abs(uz)
    psi = math.atan2(uy, ux)
    cp, sp = math.cos(psi), math.sin(psi)
    # W in the frame turned by ψ (x along u_t); a ring cut to an arc is centred on ψ + π, the frame turned
    # by π more (x, y → −x, −y): there W's xz, yz entries and u_x change sign
    r00 = cp * (cp * W[0, 0] + sp * W[1, 0]) + sp * (cp * W[0, 1] + sp * W[1, 1])
    r01 = -sp * (cp * W[0, 0] + sp * W[1, 0]) + cp * (cp * W[0, 1] + sp * W[1, 1])
    r11 = -sp * (-sp * W[0, 0] + cp * W[1, 0]) + cp * (-sp * W[0, 1] + cp * W[1, 1])
    r02 = cp * W[0, 2] + sp * W[1, 2]
    r12 = -sp * W[0, 2] + cp * W[1, 2]
    d, n0, n1, n2 = 0.0, 0.0, 0.0, 0.0  # in the ψ frame
    ed, e0, e1, e2 = 0.0, 0.0, 0.0, 0.0  # their compensations
    facets = 0
    phi_star, eps_star = np.empty(2), np.empty(2)
    g, sign, width, T = np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    breaks, grid = np.empty(4), np.empty(_GRID_N)
    cs, sn, pw = np.empty(m), np.empty(m), np.empty(m)
    for r in range(lo_tilt, hi_tilt):
        weight_tilt = pd[r]
        if not weight_tilt > 0.0:
            continue  # no weight in the numpy rule either (dropped)
        s, c = math.sin(tilt[r]), math.cos(tilt[r])
        q0 = 0.5 * s * s * (W[0, 0] + W[1, 1]) + c * c * W[2, 2]  # ring_quadratic_form
        k = _minima(q0, 2 * s * c * W[0, 2], 2 * s * c * W[1, 2], 0.5 * s * s * (W[0, 0] - W[1, 1]), s * s * W[0, 1],
                    grid, phi_star, eps_star)
        # the facing interval [lo, hi]: the whole ring from ψ, or the arc ψ + π ± h (facing_half_width)
        arc = not s * ut <= c * un
        if arc:
            half, centre = math.pi - math.acos(min(1.0, max(-1.0, c * un / (s * ut)))), psi + math.pi
        else:
            half, centre = math.pi, psi
        lo, hi = centre - half, centre + half
        breaks[0], breaks[1], breaks[2], breaks[3] = lo, hi, hi, hi  # missing minima parked at hi
        for j in range(k):
            inside = (phi_star[j] - lo) % (2 * math.pi) + lo
            breaks[j + 1] = inside if inside < hi else hi
        if breaks[2] < breaks[1]:
            breaks[1], breaks[2] = breaks[2], breaks[1]
        for i in range(3):  # three pieces, each halved and graded towards its own end
            a, b = breaks[i], breaks[i + 1]
            mid = 0.5 * (a + b)
            g[i], sign[i], T[i] = a, 1.0, mid - a
            g[3 + i], sign[3 + i], T[3 + i] = b, -1.0, b - mid
        for h in range(6):
            eps = math.inf  # distance from the end to the nearest peak's complex singularity φ_j ± iε_j
            for j in range(k):
                dist = abs((g[h] - phi_star[j] + math.pi) % (2 * math.pi) - math.pi)
                eps = min(eps, math.sqrt(eps_star[j] ** 2 + dist**2))
            eps = max(eps, 1e-300) if math.isfinite(eps) else 1.0  # no peak: a mild map
            width[h], T[h] = eps, math.asinh(T[h] / eps)
        flip = -1.0 if arc else 1.0
        for h in range(6):
            if not T[h] > 0.0:
                continue  # a zero-length half-piece: weight 0, not one of the numpy rule's facets
            half_piece_nodes(start, m, table, g[h] - centre, sign[h], width[h], T[h], weight_tilt, cs, sn, pw)
            hd, h0, h1, h2, count, bad = half_piece_sums(m, cs, sn, pw, s, c, flip * ut, 0.0, uz, r00, r01, r11,
                                                         flip * r02, flip * r12, W[2, 2], floor, configuration)
            if bad:
                return DEGENERATE_FACET, facets  # the numpy rule drops such a facet; leave it to it
            facets += count
            d, ed = compensated_add(d, ed, hd)
            n0, e0 = compensated_add(n0, e0, flip * h0)
            n1, e1 = compensated_add(n1, e1, flip * h1)
            n2, e2 = compensated_add(n2, e2, h2)
    d = d + ed
    if not d > 0.0:
        return NOT_FACING, facets
    x, y = n0 + e0, n1 + e1
    out[0] = (1.0 + e) * (cp * x - sp * y) / d  # back from the ψ frame
    out[1] = (1.0 + e) * (sp * x + cp * y) / d
    out[2] = (1.0 + e) * (n2 + e2) / d
    return 0, facets


@kernel(_PASS, error_model="numpy")
def graded_slopes(W: NDArray[np.float64], U: NDArray[np.float64], tilt: NDArray[np.float64],
                      pd: NDArray[np.float64], tilt_start: NDArray[np.int64], table: NDArray[np.float64], n: int,
                      levels: int, configuration: bool, e: float, rtol: float, degenerate: float,
                      P: NDArray[np.float64], error: NDArray[np.float64]) -> tuple[int, int]:  # pragma: no cover
    """(2.8) for one unit velocity on an isotropic tilt density by the graded rule, refined as the adaptive
    rule refines it: n, 2n, 4n, … nodes a half-piece until two successive levels agree.

    Parameters
    ----------
    W : ndarray, shape (3, 3)
        Delassus matrix in the local frame.
    U : ndarray, shape (1, 3)
        Unit contact velocity u in the local frame, u_n < 0.
    tilt, pd : ndarray, shape (L,)
        The graded tilt nodes of every given level in turn (:func:`~mbimpact.quadrature.graded.graded_tilt_rule`,
        those of positive dα) and their weights p(α) dα, p the normalised density.
    tilt_start : ndarray of int, shape (given + 1,)
        Level k's tilts are ``tilt[tilt_start[k]:tilt_start[k + 1]]``.
    table : ndarray, shape (2, n (2^levels − 1))
        The Gauss–Legendre nodes of every level (:func:`~mbimpact.averaging.compiled.graded_cone.rule_table`).
    n : int
        Nodes a half-piece of the first level.
    levels : int
        The levels ``max_nodes`` allows (the table has them all; the tilts may end sooner).
    configuration : bool
        The facet weight of (2.7): w = p (−mᵀu) / √(mᵀWm) if True, else w = p (−mᵀu).
    e : float
        Facet restitution.
    rtol : float
        Two levels agree within this or the rounding floor 100 ε √K of a K-facet level.
    degenerate : float
        A facet with mᵀWm ≤ degenerate · tr W cannot be pushed by the mechanism.
    P : ndarray, shape (1, 3)
        Output: the last level's P = (1+e) N / D, N = ∫ w (−mᵀu / mᵀWm) m, D = ∫ w over G*.
    error : ndarray, shape (1,)
        Output: the error estimate |W (P_m − P_{m/2})| / |W P_m|.

    Returns
    -------
    status : int
        ``SETTLED`` (``P``, ``error`` written), ``STALLED`` / ``CAPPED`` (the numpy rule would warn),
        ``DEGENERATE_FACET``, ``NOT_FACING``, or ``NEED_TABLE`` (the tilts given end before the next
        level): :mod:`~mbimpact.averaging.compiled.primitives`.
    nodes : int
        Nodes a piece of the last level computed.
    """
    given = tilt_start.shape[0] - 1
    trace = W[0, 0] + W[1, 1] + W[2, 2]
    floor = degenerate * trace
    coarse, fine = np.empty(3), np.empty(3)
    previous, start, m = math.inf, 0, n
    for level in range(levels):
        if level >= given:
            return NEED_TABLE, m // 2
        status, facets = _level(start, m, table, tilt, pd, tilt_start[level], tilt_start[level + 1], W, U, floor,
                                configuration, e, fine)
        if status:
            return status, m
        if level > 0:
            decision, err = level_decision(coarse, fine, W, rtol, facets, previous, P, error)
            if decision != NOT_SETTLED:  # settled (P and error written), or stalled at rounding
                return decision, m
            previous = err
        coarse[0], coarse[1], coarse[2] = fine[0], fine[1], fine[2]
        start += m
        m *= 2
    return CAPPED, m // 2


def jit_seconds() -> float:
    """Wall time to make :func:`graded_slopes` callable in this process (loaded from numba's on-disk
    cache, or compiled); later calls return near 0."""
    start = time.perf_counter()
    tilt, dtilt, begin = np.empty(60), np.empty(60), np.empty(3, np.int64)
    tilt_nodes(0.0, 1.0, 0.5, np.array([0.3, np.nan, 0.7]), np.array([1e-3, np.nan, 1e-2]), rule_table(2, 2), 2, 2,
               tilt, dtilt, begin)
    W = np.diag([1e-6, 1.0, 1.0])
    tilt = np.array([0.1, 0.2, 0.3, 0.1, 0.15, 0.2, 0.25, 0.3])
    graded_slopes(W, np.array([[0.6, 0.0, -0.8]]), tilt, np.full(8, 0.1), np.array([0, 3, 8]), rule_table(2, 2),
                      2, 2, True, 0.5, 1e-12, 1e-14, np.empty((1, 3)), np.empty(1))
    return time.perf_counter() - start

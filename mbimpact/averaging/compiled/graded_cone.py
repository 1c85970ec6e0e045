"""A cone's graded rule of (2.8) for one velocity: the compiled backend of :class:`~mbimpact.averaging.Graded`.

A nearly singular Delassus matrix W makes q(φ) = m(φ)ᵀ W m(φ) small near its minima on the ring
of facets, and the kernels of (2.8) with the flux weights of (2.7) peak there with widths ε ≪ 1.
:class:`~mbimpact.averaging.Graded` then integrates with the graded rule of
:func:`mbimpact.quadrature.graded.graded_azimuth_rule` and refines it as
:func:`mbimpact.averaging.refinement.refine` does; in numpy each level costs its array operations.
:func:`graded_cone` does all of it on floats: the minima of q and their widths
(:func:`mbimpact.quadrature.graded.ring_minima`, with :meth:`mbimpact.Cone.graded_rule`'s test that
the ring has a narrow peak), the facing interval cut at the minima inside it, every piece halved
and each half mapped by φ = a ± ε sinh t onto its graded end a, Gauss–Legendre in t, and the
levels n, 2n, 4n, … nodes a piece with the adaptive rule's error estimate and stopping rule. The
nodes of a half-piece are computed and summed in SIMD lanes (:mod:`~mbimpact.averaging.compiled.half_pieces`),
the half-pieces added with compensation. Its result is :class:`~mbimpact.averaging.Graded`'s to
rounding.

The module is imported on first use only (numba costs ~0.3 s to import:
:data:`mbimpact.averaging.compiled.GRADED_CONE`). Run with ``NUMBA_DISABLE_JIT=1``, the same source
runs interpreted.
"""

from __future__ import annotations

import functools
import math
import time

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

from ...common.compiled import kernel
from ...common.geometry import ring_coefficients
from ...quadrature import graded
from ...quadrature.rules import gauss_legendre
from .half_pieces import NODE_PLUS_ONE, WEIGHT, half_piece_nodes, half_piece_sums
from .primitives import (CAPPED, DEGENERATE_FACET, NOT_FACING, NOT_PEAKED, NOT_SETTLED, SETTLED, compensated_add,
                         level_decision, rounding_floor)

__all__ = ["rule_table", "ring_form", "ring_minima_into", "minima_sensitivity", "ring_peaks", "graded_cone",
           "jit_seconds"]

# the widths below which :meth:`mbimpact.Cone.graded_rule` gives up: q_min / q_max ≲ 1e-14, facets the
# mechanism cannot push, around which the flux weight is not integrable (grading cannot help)
_NARROWEST = 1e-7

# The 64-point grid of ring_minima and ring_width_bound, computed by numpy as they compute it (frozen into
# the compiled code as constants): rows cos φ, sin φ, cos 2φ, sin 2φ (ring_minima), and the sines as
# ring_width_bound's table has them, cos(φ − π/2) and cos(2φ − π/2).
_GRID_ANGLES = 2 * np.pi * np.arange(64) / 64
_GRID = np.ascontiguousarray(np.vstack([
    np.cos(_GRID_ANGLES), np.sin(_GRID_ANGLES), np.cos(2 * _GRID_ANGLES), np.sin(2 * _GRID_ANGLES),
    np.cos(_GRID_ANGLES - np.pi / 2), np.cos(2 * _GRID_ANGLES - np.pi / 2),
]))
_GRID.flags.writeable = False


@functools.lru_cache(maxsize=32)
def rule_table(n: int, levels: int) -> NDArray[np.float64]:
    """Gauss–Legendre nodes of the levels n, 2n, …, 2^(levels−1) n nodes a piece (cached, read-only).

    Parameters
    ----------
    n : int
        Node count a piece of the first level.
    levels : int
        Number of levels.

    Returns
    -------
    ndarray, shape (2, n (2^levels − 1))
        Columns: the n nodes of the first level, then the 2n of the second, and so on. Rows: x + 1
        for the Gauss–Legendre nodes x on [−1, 1] (the map t = T (x + 1) / 2 of every half-piece,
        as :func:`~mbimpact.quadrature.graded.graded_azimuth_rule` forms it), and their weights.
    """
    counts = [n << k for k in range(levels)]
    table = np.empty((2, sum(counts)))
    start = 0
    for m in counts:
        x, w = gauss_legendre(m)
        table[NODE_PLUS_ONE, start:start + m], table[WEIGHT, start:start + m] = x + 1.0, w
        start += m
    table.flags.writeable = False
    return table


# Explicit signatures, compiled (or loaded from the cache) on first use (mbimpact.common.compiled.kernel):
# read-only inputs of any layout, so that a caller's read-only or strided W or U does not make numba compile
# another specialisation
_IN2 = types.Array(types.float64, 2, "A", readonly=True)
# the table C-contiguous: strided indexing would keep the node loops out of SIMD lanes
_TABLE = types.Array(types.float64, 2, "C", readonly=True)
_PEAKS = types.int64(types.float64, _IN2, types.float64)
_PASS = types.UniTuple(types.int64, 2)(types.float64, _IN2, _IN2, _TABLE, types.int64, types.float64, types.boolean,
                                       types.float64, types.float64, types.float64, types.float64[:, ::1],
                                       types.float64[::1])
# _level's, so that its calls from every level share one compilation (not one more for a constant start)
_LEVEL = types.int64(types.int64, types.int64, _TABLE, types.int64, types.float64[:, ::1], types.float64,
                     types.float64, _IN2, _IN2, types.float64, types.boolean, types.float64, types.float64[::1])


#: :func:`mbimpact.common.geometry.ring_coefficients`, :func:`mbimpact.quadrature.graded.polish_minimum` and
#: :func:`~mbimpact.quadrature.graded.minimum_sensitivity` compiled: the same functions as the numpy rules'.
ring_form = njit(cache=True, error_model="numpy", inline="always")(ring_coefficients)
polish_minimum = njit(cache=True, error_model="numpy", inline="always")(graded.polish_minimum)
minimum_sensitivity = njit(cache=True, error_model="numpy", inline="always")(graded.minimum_sensitivity)


@njit(cache=True, error_model="numpy")
def ring_minima_into(form: tuple[float, float, float, float, float], peaked: float, phi_out: NDArray[np.float64],
           eps_out: NDArray[np.float64]) -> int:  # pragma: no cover — compiled
    """The minima of q on the ring and their widths into ``phi_out``, ``eps_out`` (2,): their number, or
    0 where :meth:`mbimpact.Cone.graded_rule` has no graded rule (no peak narrower than ``peaked``, or
    one too narrow to grade). :func:`~mbimpact.quadrature.graded.ring_width_bound` first, then
    :func:`~mbimpact.quadrature.graded.ring_minima` (Newton on q' = 0 from each grid minimum), as in numpy."""
    q0, a1, b1, a2, b2 = form
    # ring_width_bound: on the grid the smallest q is within q''_max h² / 8 of the true minimum
    curvature = math.hypot(a1, b1) + 4.0 * math.hypot(a2, b2)
    if not curvature > 0.0:
        return 0  # q is constant on the ring: no peak
    low = math.inf
    for i in range(64):
        low = min(low, q0 + a1 * _GRID[0, i] + b1 * _GRID[4, i] + a2 * _GRID[2, i] + b2 * _GRID[5, i])
    low -= curvature * (2 * math.pi / 64) ** 2 / 8
    if (math.sqrt(2.0 * low / curvature) if low > 0.0 else 0.0) >= peaked:
        return 0
    # ring_minima: a trigonometric polynomial of degree 2 has at most two local minima (and so has its
    # sampling: a grid minimum brackets one, and two grid minima are not adjacent)
    k = 0
    for i in range(64):
        q = q0 + a1 * _GRID[0, i] + b1 * _GRID[1, i] + a2 * _GRID[2, i] + b2 * _GRID[3, i]
        before, after = (i + 63) % 64, (i + 1) % 64
        if not (q <= q0 + a1 * _GRID[0, before] + b1 * _GRID[1, before] + a2 * _GRID[2, before]
                + b2 * _GRID[3, before]
                and q < q0 + a1 * _GRID[0, after] + b1 * _GRID[1, after] + a2 * _GRID[2, after]
                + b2 * _GRID[3, after]) or k == 2:
            continue
        phi_out[k], eps_out[k] = polish_minimum(_GRID_ANGLES[i], q0, a1, b1, a2, b2)
        k += 1
    # Cone.graded_rule: a peak narrower than `peaked`, none too narrow to grade
    narrowest = math.inf
    for j in range(k):
        narrowest = min(narrowest, eps_out[j])
    if k == 0 or not _NARROWEST < narrowest < peaked:
        return 0
    return k


@njit(cache=True, error_model="numpy")
def minima_sensitivity(s: float, c: float, W: NDArray[np.float64], phi: NDArray[np.float64], k: int,
                       power: float) -> float:  # pragma: no cover — compiled
    """How far the rounding of q = mᵀWm at the ring's minima can move the answer:
    power · ε · Σ |W_ik| |m_i| |m_k| / q_min, the largest over the ``k`` minima at azimuths ``phi``
    (:func:`mbimpact.quadrature.graded.minima_sensitivity`, in its arithmetic; inf where q_min ≤ 0).

    Float64 rounds q(m) by up to ε Σ |W_ik| |m_i| |m_k|, relative to q_min at the bottom of a peak, and it
    does so alike at every level's nodes there: two levels agree while both are off. A peak's integral
    goes as q_min^(−power) (½ for the physical flux, 1 for the configuration flux, whose kernels go as
    q^(−3/2)), and its relative change as power times q's. An ulp of W's own entries moves the exact
    answer by about as much.
    """
    worst = 0.0
    for j in range(k):
        worst = max(worst, minimum_sensitivity(s, c, W, phi[j], power))
    return worst


@kernel(_PEAKS, error_model="numpy")
def ring_peaks(alpha: float, W: NDArray[np.float64], peaked: float) -> int:  # pragma: no cover — compiled
    """How many minima of q = mᵀWm the graded rule of a cone of tilt α is cut at (1 or 2), or 0 where
    :meth:`mbimpact.Cone.graded_rule` gives none (its kernels have no peak narrower than ``peaked``,
    or one too narrow to grade).

    Parameters
    ----------
    alpha : float
        Tilt of the cone, 0 < α < π/2.
    W : ndarray, shape (3, 3)
        Delassus matrix in the local frame.
    peaked : float
        Peak width (radians) below which the rule is graded (:attr:`mbimpact.averaging.Graded.peaked`).

    Returns
    -------
    int
    """
    phi, eps = np.empty(2), np.empty(2)
    return ring_minima_into(ring_form(math.sin(alpha), math.cos(alpha), W), peaked, phi, eps)


@kernel(_LEVEL, error_model="numpy")
def _level(start: int, m: int, table: NDArray[np.float64], pieces: int, ends: NDArray[np.float64], s: float,
           c: float, W: NDArray[np.float64], U: NDArray[np.float64], floor: float, configuration: bool, e: float,
           out: NDArray[np.float64]) -> int:  # pragma: no cover — compiled
    """The impulse P = (1+e) N / D of (2.8) by the graded rule with ``m`` nodes a half-piece (columns
    ``start`` … ``start + m`` of the table) into ``out`` (3,); 0, or the status that declines.

    ``ends`` (4, pieces): every half-piece's graded end a, direction ±1, width ε of its map
    and T = asinh(ℓ / ε); its nodes are φ = a ± ε sinh t, t = T (x + 1) / 2, with weights
    ε cosh t (T / 2) w / 2π (:func:`~mbimpact.quadrature.graded.graded_azimuth_rule`'s arithmetic),
    summed half-piece by half-piece (:mod:`~mbimpact.averaging.compiled.half_pieces`) in W's own frame: a frame
    turned to u_t would perturb W's entries by their rounding, which moves q near a minimum by far more
    than the nodes' own rounding does, differently at every level."""
    d, n0, n1, n2 = 0.0, 0.0, 0.0, 0.0
    ed, e0, e1, e2 = 0.0, 0.0, 0.0, 0.0  # their compensations
    cs, sn, pw = np.empty(m), np.empty(m), np.empty(m)
    for h in range(pieces):
        if not ends[3, h] > 0.0:
            continue  # a zero-length half-piece (a minimum outside the facing interval): weight 0
        half_piece_nodes(start, m, table, ends[0, h], ends[1, h], ends[2, h], ends[3, h], 1.0, cs, sn, pw)
        hd, h0, h1, h2, _, bad = half_piece_sums(m, cs, sn, pw, s, c, U[0, 0], U[0, 1], U[0, 2], W[0, 0], W[0, 1],
                                                 W[1, 1], W[0, 2], W[1, 2], W[2, 2], floor, configuration)
        if bad:
            return DEGENERATE_FACET  # the numpy rule drops such a facet; this kernel leaves it to it
        d, ed = compensated_add(d, ed, hd)
        n0, e0 = compensated_add(n0, e0, h0)
        n1, e1 = compensated_add(n1, e1, h1)
        n2, e2 = compensated_add(n2, e2, h2)
    d = d + ed
    if not d > 0.0:
        return NOT_FACING
    out[0] = (1.0 + e) * (n0 + e0) / d
    out[1] = (1.0 + e) * (n1 + e1) / d
    out[2] = (1.0 + e) * (n2 + e2) / d
    return 0


@kernel(_PASS, error_model="numpy")
def graded_cone(alpha: float, W: NDArray[np.float64], U: NDArray[np.float64], table: NDArray[np.float64], levels: int,
                peaked: float, configuration: bool, e: float, rtol: float, degenerate: float, P: NDArray[np.float64],
                error: NDArray[np.float64]) -> tuple[int, int]:  # pragma: no cover — compiled
    """(2.8) for one unit velocity on a cone by the graded rule, refined as the adaptive rule refines it:
    n, 2n, 4n, … nodes a half-piece until two successive levels agree.

    Parameters
    ----------
    alpha : float
        Tilt of the cone, 0 < α < π/2.
    W : ndarray, shape (3, 3)
        Delassus matrix in the local frame.
    U : ndarray, shape (1, 3)
        Unit contact velocity u in the local frame, u_n < 0.
    table : ndarray, shape (2, n (2^levels − 1))
        The Gauss–Legendre nodes of every level (:func:`rule_table`).
    levels : int
        The number of levels, every one ``max_nodes`` allows.
    peaked : float
        The peak width below which the rule is graded (:attr:`mbimpact.averaging.Graded.peaked`).
    configuration : bool
        The facet weight of (2.7): ``"configuration"`` (w = −mᵀu / √(mᵀWm)) if True, else
        ``"physical"`` (w = −mᵀu).
    e : float
        Facet restitution.
    rtol : float
        Two levels agree when their relative difference is within this, or within the rounding
        floor 100 ε √K of a K-facet sum (K = (2k + 2) · nodes: the graded rule's facet count, k
        the minima of q).
    degenerate : float
        A facet with mᵀWm ≤ degenerate · tr W cannot be pushed by the mechanism.
    P : ndarray, shape (1, 3)
        Output: the last level's impulse P = (1+e) N / D, N = ∫ w (−mᵀu / mᵀWm) m and D = ∫ w over
        the facing set, w the flux weight of (2.7).
    error : ndarray, shape (1,)
        Output: the error estimate: the largest of |W (P_m − P_{m/2})| / |W P_m|, the rounding of q at its
        minima (:func:`minima_sensitivity`) and that of P itself
        (:func:`~mbimpact.averaging.compiled.primitives.rounding_floor`), which no level reduces and which
        may exceed rtol.

    Returns
    -------
    status : int
        ``SETTLED`` (``P`` and ``error`` are written); ``NOT_PEAKED`` where
        :meth:`mbimpact.Cone.graded_rule` gives no graded rule; ``STALLED`` or ``CAPPED`` where the
        numpy rule would stop short of rtol with an AccuracyWarning (rounding amplified by an
        ill-conditioned W; the last level of the table); ``DEGENERATE_FACET`` (a node on a facet the
        mechanism cannot push), ``NOT_FACING`` (no weight): :mod:`~mbimpact.averaging.compiled.primitives`.
    nodes : int
        The node count a piece of the last level computed.
    """
    s, c = math.sin(alpha), math.cos(alpha)
    phi_star, eps_star = np.empty(2), np.empty(2)
    k = ring_minima_into(ring_form(s, c, W), peaked, phi_star, eps_star)
    if k == 0:
        return NOT_PEAKED, 0
    # the facing interval [lo, hi] (facing_half_width): the whole ring from ψ, or the arc ψ + π ± h
    ux, uy, uz = U[0, 0], U[0, 1], U[0, 2]
    ut, un = math.hypot(ux, uy), abs(uz)
    psi = math.atan2(uy, ux)
    half = math.pi if s * ut <= c * un else math.pi - math.acos(min(1.0, max(-1.0, c * un / (s * ut))))
    centre = psi if half == math.pi else psi + math.pi
    lo, hi = centre - half, centre + half
    # cut at the minima inside it (unwrapped); those outside make zero-length pieces at hi
    breaks = np.empty(k + 2)
    breaks[0], breaks[k + 1] = lo, hi
    for j in range(k):
        inside = (phi_star[j] - lo) % (2 * math.pi) + lo
        breaks[j + 1] = inside if inside < hi else hi
    if k == 2 and breaks[2] < breaks[1]:
        breaks[1], breaks[2] = breaks[2], breaks[1]
    # every piece halved; each half graded towards its end a: φ = a ± ε sinh t, ε the distance from a to
    # the nearest peak's complex singularity φ_j ± iε_j, t ∈ [0, T], T = asinh(ℓ / ε)
    pieces = 2 * k + 2
    ends = np.empty((4, pieces))
    for i in range(k + 1):
        a, b = breaks[i], breaks[i + 1]
        mid = 0.5 * (a + b)
        ends[0, i], ends[1, i], ends[3, i] = a, 1.0, mid - a
        ends[0, k + 1 + i], ends[1, k + 1 + i], ends[3, k + 1 + i] = b, -1.0, b - mid
    for h in range(pieces):
        eps = math.inf
        for j in range(k):
            dist = abs((ends[0, h] - phi_star[j] + math.pi) % (2 * math.pi) - math.pi)
            eps = min(eps, math.sqrt(eps_star[j] ** 2 + dist**2))
        eps = max(eps, 1e-300)
        ends[2, h], ends[3, h] = eps, math.asinh(ends[3, h] / eps)
    trace = W[0, 0] + W[1, 1] + W[2, 2]
    floor = degenerate * trace
    n = table.shape[1] // ((1 << levels) - 1)
    coarse, fine = np.empty(3), np.empty(3)
    previous, start, m = math.inf, 0, n
    for level in range(levels):
        status = _level(start, m, table, pieces, ends, s, c, W, U, floor, configuration, e, fine)
        if status:
            return status, m
        if level > 0:
            decision, err = level_decision(coarse, fine, W, rtol, pieces * m, previous, P, error)
            if decision == SETTLED:  # P and error written: the estimate also holds what the levels cannot see
                error[0] = max(error[0], minima_sensitivity(s, c, W, phi_star, k, 1.0 if configuration else 0.5),
                               rounding_floor(P, W))
            if decision != NOT_SETTLED:  # settled, or stalled at rounding
                return decision, m
            previous = err
        coarse[0], coarse[1], coarse[2] = fine[0], fine[1], fine[2]
        start += m
        m *= 2
    return CAPPED, m // 2


def jit_seconds() -> float:
    """Wall time to make :func:`ring_peaks` and :func:`graded_cone` callable in this process (numba's
    import excluded): their machine code loaded from numba's on-disk cache (``__pycache__`` next to this
    file), or compiled when that cache is missing or stale. The first call pays it; later calls return
    near 0."""
    start = time.perf_counter()
    W = np.diag([1e-6, 1.0, 1.0])  # q has two sharp minima on a tilted ring
    ring_peaks(0.4, W, 0.15)
    graded_cone(0.4, W, np.array([[0.6, 0.0, -0.8]]), rule_table(4, 3), 3, 0.15, True, 0.5, 1e-12, 1e-14,
                np.empty((1, 3)), np.empty(1))
    return time.perf_counter() - start

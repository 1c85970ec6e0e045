"""The adaptive rule of (2.8) on a cone of facets for one velocity: the compiled backend of
:class:`~mbimpact.averaging.Adaptive`.

The two integrals of (2.8) with the flux weights of (2.7) over the facing arc of a cone of tilt α,
at n, 2n, 4n, … azimuth nodes, their impulses P = (1+e) N / D and the relative difference of two
successive levels by the velocity change W P they produce, until two levels agree: the nodes, error
estimate and stopping rule of :func:`mbimpact.averaging.refinement.refine`, compiled by numba
(``njit``, cached on disk; :func:`cone_adaptive`). The level sums are compensated
(:func:`~mbimpact.averaging.compiled.primitives.compensated_add`). Imported on first use only
(numba costs ~0.3 s to import): :data:`mbimpact.averaging.compiled.CONE`.

The nodes are those of :func:`mbimpact.quadrature.rules.azimuth_rule`, measured from the azimuth
ψ of u_t (θ = φ − ψ): the periodic trapezoid rule θ = 2πj/n on the full ring when the whole cone
faces u, Gauss–Legendre on the facing arc θ ∈ π ± h otherwise. Both come from a table built once
per n and level count (:func:`rule_table`). Per node, with m = (s cos φ, s sin φ, c), s = sin α, c = cos α:

    mᵀu  = c u_n + s |u_t| cos θ,
    mᵀWm = q₀ + a₁ cos θ + b₁ sin θ + a₂ cos 2θ + b₂ sin 2θ   (the ring's harmonics, rotated by ψ),

so a node costs its cos θ, sin θ and a few products. Both loops run in SIMD lanes: the arc's cos θ
and sin θ are polynomials (:func:`~mbimpact.averaging.compiled.primitives.cos_sin`), and a level is
summed in blocks of 32 nodes, reassociated, the blocks added with compensation. Run with
``NUMBA_DISABLE_JIT=1``, the same source runs interpreted.
"""

from __future__ import annotations

import functools
import math
import time

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

from ...common.compiled import kernel
from ...quadrature.rules import gauss_legendre
from .primitives import CAPPED, DEGENERATE_FACET, NOT_FACING, NOT_SETTLED, compensated_add, cos_sin, level_decision

__all__ = ["rule_table", "cone_adaptive", "jit_seconds"]

# fast-math flags of the node sums: reassociated into SIMD lanes, products fused (no finite-math
# assumptions: a NaN must stay one)
_FAST = {"reassoc", "contract"}

# nodes a block of a level's sums: summed in SIMD lanes, the blocks added with compensation
_BLOCK = 32

# rows of the table of :func:`rule_table` (columns: the nodes of each level in turn)
_GL_NODE, _GL_WEIGHT, _RING_COS, _RING_SIN, _RING_WEIGHT = range(5)


@functools.lru_cache(maxsize=32)
def rule_table(n: int, levels: int = 2) -> NDArray[np.float64]:
    """The nodes of the levels n, 2n, …, 2^(levels−1) n of :func:`cone_adaptive` (cached, read-only).

    Parameters
    ----------
    n : int
        Node count of the first level.
    levels : int
        Number of levels.

    Returns
    -------
    ndarray, shape (5, n (2^levels − 1))
        Columns: the n nodes of the first level, then the 2n of the second, and so on. Rows:
        Gauss–Legendre nodes x on [-1, 1] and weights / 2π (the arc θ = π + h x, weight h w / 2π);
        cos θ, sin θ and the weight 1/m of the periodic trapezoid rule θ = 2πj/m on the full ring
        (m nodes at that level).
    """
    counts = [n << k for k in range(levels)]
    table = np.empty((5, sum(counts)))
    start = 0
    for m in counts:
        x, w = gauss_legendre(m)
        theta = 2 * math.pi * np.arange(m) / m
        block = slice(start, start + m)
        table[_GL_NODE, block], table[_GL_WEIGHT, block] = x, w / (2 * math.pi)
        table[_RING_COS, block], table[_RING_SIN, block] = np.cos(theta), np.sin(theta)
        table[_RING_WEIGHT, block] = 1.0 / m
        start += m
    table.flags.writeable = False
    return table


# Explicit signatures, compiled (or loaded from the cache) on first use (mbimpact.common.compiled.kernel):
# read-only inputs of any layout, so that a caller's read-only or strided W or U does not make numba compile
# another specialisation; the table C-contiguous (strided loads would keep the node loops out of SIMD lanes)
_IN2 = types.Array(types.float64, 2, "A", readonly=True)
_TABLE = types.Array(types.float64, 2, "C", readonly=True)
_SIGNATURE = types.int64(types.float64, _IN2, _IN2, _TABLE, types.boolean, types.float64, types.float64,
                         types.float64, types.float64[:, ::1], types.float64[::1])
_PASS = types.UniTuple(types.int64, 2)(types.float64, _IN2, _IN2, _TABLE, types.int64, types.boolean, types.float64,
                                       types.float64, types.float64, types.float64[:, ::1], types.float64[::1])
# _level's, so that its calls from every level share one compilation (not one more for a constant start)
_F = types.float64
_LEVEL = types.int64(types.int64, types.int64, _TABLE, types.boolean, _F, _F, _F, _F, _F, _F, _F,
                     types.UniTuple(_F, 5), _F, types.boolean, _F, types.float64[::1])


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _block_sums(ct: NDArray[np.float64], st: NDArray[np.float64], wt: NDArray[np.float64], lo: int, hi: int,
                s: float, c: float, ut: float, uz: float, harmonics: tuple[float, float, float, float, float],
                floor: float, configuration: bool) -> tuple[float, float, float, float, int]:  # pragma: no cover
    """Sums over the nodes ``lo`` … ``hi`` of a level (cos θ, sin θ and quadrature weight in ``ct``,
    ``st``, ``wt``): D = Σ wt f and the kernels Σ wt f (−mᵀu / q) g for g = 1, cos θ, sin θ, with f the
    flux weight of (2.7) (−mᵀu, or −mᵀu / √q for the configuration flux), q = mᵀWm, and −mᵀu / q the
    facet's Newton impulse; and the count of nodes the mechanism cannot push (q ≤ ``floor``), left out. No calls, no early exit, reassociated: the loop
    runs in SIMD lanes; the blocks are added with compensation."""
    q0, a1, b1, a2, b2 = harmonics
    d, k0, k1, k2 = 0.0, 0.0, 0.0, 0.0
    bad = 0
    for i in range(lo, hi):
        cx, sx, w = ct[i], st[i], wt[i]
        q = q0 + a1 * cx + b1 * sx + a2 * (cx * cx - sx * sx) + b2 * (2.0 * cx * sx)
        bad += not q > floor
        q = max(q, floor)  # no division by 0 in a lane that is left out (the level is declined then)
        # −mᵀu on the facing set, 0 off it (the trapezoid rule runs over the whole ring)
        sweep = max(-(c * uz + s * ut * cx), 0.0)
        if configuration:  # w = −mᵀu / √q, kernel (mᵀu)² / q^{3/2}
            r = 1.0 / math.sqrt(q)
            weight = sweep * r
            kernel = weight * weight * r
        else:  # w = −mᵀu, kernel (mᵀu)² / q
            weight = sweep
            kernel = sweep * sweep / q
        d += w * weight
        k0 += w * kernel
        k1 += w * kernel * cx
        k2 += w * kernel * sx
    return d, k0, k1, k2, bad


@kernel(_LEVEL, error_model="numpy")
def _level(start: int, m: int, table: NDArray[np.float64], arc: bool, h: float, s: float, c: float, ut: float,
           uz: float, cp: float, sp: float, harmonics: tuple[float, float, float, float, float], floor: float,
           configuration: bool, e: float, out: NDArray[np.float64]) -> int:  # pragma: no cover — compiled
    """The impulse P = (1+e) N / D of one level (``m`` nodes from column ``start`` of the table) into
    ``out`` (3,); 0, or the status that declines (a degenerate facet, no weight).

    The nodes' cos θ and sin θ come from the table on the full ring, else from polynomials
    (:func:`~mbimpact.averaging.compiled.primitives.cos_sin`, in SIMD lanes); the sums run in blocks
    of :data:`_BLOCK` nodes (:func:`_block_sums`), added with compensation."""
    if arc:  # the facing arc θ = π + h x
        ct, st, wt = np.empty(m), np.empty(m), np.empty(m)
        for i in range(m):
            j = start + i
            cx, sx = cos_sin(h * table[_GL_NODE, j])
            ct[i], st[i], wt[i] = -cx, -sx, h * table[_GL_WEIGHT, j]
    else:  # the whole ring faces u: the periodic trapezoid rule from ψ
        ct, st, wt = table[_RING_COS, start:start + m], table[_RING_SIN, start:start + m], \
            table[_RING_WEIGHT, start:start + m]
    d, k0, k1, k2 = 0.0, 0.0, 0.0, 0.0
    ed, e0, e1, e2 = 0.0, 0.0, 0.0, 0.0  # their compensations
    for lo in range(0, m, _BLOCK):
        bd, b0, b1, b2, bad = _block_sums(ct, st, wt, lo, min(lo + _BLOCK, m), s, c, ut, uz, harmonics, floor,
                                          configuration)
        if bad:
            return DEGENERATE_FACET
        d, ed = compensated_add(d, ed, bd)
        k0, e0 = compensated_add(k0, e0, b0)
        k1, e1 = compensated_add(k1, e1, b1)
        k2, e2 = compensated_add(k2, e2, b2)
    d, k0, k1, k2 = d + ed, k0 + e0, k1 + e1, k2 + e2
    if not d > 0.0:
        return NOT_FACING
    # P = (1+e) N / D, m = (s (cos ψ cos θ − sin ψ sin θ), s (sin ψ cos θ + cos ψ sin θ), c)
    f = (1.0 + e) / d
    out[0] = f * s * (cp * k1 - sp * k2)
    out[1] = f * s * (sp * k1 + cp * k2)
    out[2] = f * c * k0
    return 0


@kernel(_PASS, error_model="numpy")
def cone_adaptive(alpha: float, W: NDArray[np.float64], U: NDArray[np.float64], table: NDArray[np.float64],
                  levels: int, configuration: bool, e: float, rtol: float, degenerate: float, P: NDArray[np.float64],
                  error: NDArray[np.float64]) -> tuple[int, int]:  # pragma: no cover — compiled
    """The adaptive rule of (2.8) for one unit velocity on a cone: levels n, 2n, 4n, … until two
    successive ones agree (:func:`mbimpact.averaging.refinement.refine`'s test and stopping rule).

    Parameters
    ----------
    alpha : float
        Tilt of the cone, 0 < α < π/2.
    W : ndarray, shape (3, 3)
        Delassus matrix in the local frame.
    U : ndarray, shape (1, 3)
        Unit contact velocity u in the local frame, u_n < 0.
    table : ndarray, shape (5, n (2^levels − 1))
        The nodes of every level (:func:`rule_table`), every one ``max_nodes`` allows.
    levels : int
        The number of levels of the table.
    configuration : bool
        The facet weight of (2.7): ``"configuration"`` (w = −mᵀu / √(mᵀWm), kernels
        (mᵀu)² / (mᵀWm)^{3/2} and −mᵀu / √(mᵀWm)) if True, else ``"physical"`` (w = −mᵀu,
        kernels (mᵀu)² / mᵀWm and −mᵀu).
    e : float
        Facet restitution.
    rtol : float
        Two levels agree when their relative difference is within this, or within the rounding floor
        100 ε √m of an m-node sum.
    degenerate : float
        A facet with mᵀWm ≤ degenerate · tr W cannot be pushed by the mechanism.
    P : ndarray, shape (1, 3)
        Output: the last level's impulse P = (1+e) N / D, N = ∫ (mᵀu)² m / (mᵀWm)^γ and
        D = ∫ (−mᵀu) / (mᵀWm)^δ over the facing arc.
    error : ndarray, shape (1,)
        Output: the error estimate |W (P_m − P_{m/2})| / |W P_m|.

    Returns
    -------
    status : int
        ``SETTLED`` (``P`` and ``error`` are written); ``STALLED`` or ``CAPPED`` where the numpy rule
        would stop short of rtol with an AccuracyWarning (rounding amplified by an ill-conditioned W;
        the last level of the table); ``DEGENERATE_FACET``, ``NOT_FACING``
        (:mod:`~mbimpact.averaging.compiled.primitives`).
    nodes : int
        The node count of the last level computed.
    """
    n = table.shape[1] // ((1 << levels) - 1)
    ux, uy, uz = U[0, 0], U[0, 1], U[0, 2]
    ut = math.hypot(ux, uy)
    cp, sp = (ux / ut, uy / ut) if ut > 0.0 else (1.0, 0.0)
    s, c = math.sin(alpha), math.cos(alpha)
    arc = not s * ut <= c * -uz
    h = math.pi - math.acos(min(1.0, c * -uz / (s * ut))) if arc else 0.0
    # mᵀWm in the harmonics of φ, then of θ = φ − ψ
    w00, w01, w02, w11, w12, w22 = W[0, 0], W[0, 1], W[0, 2], W[1, 1], W[1, 2], W[2, 2]
    q0 = 0.5 * s * s * (w00 + w11) + c * c * w22
    a1, b1 = 2.0 * s * c * w02, 2.0 * s * c * w12
    a2, b2 = 0.5 * s * s * (w00 - w11), s * s * w01
    c2, s2 = cp * cp - sp * sp, 2.0 * cp * sp
    a1, b1 = a1 * cp + b1 * sp, b1 * cp - a1 * sp
    a2, b2 = a2 * c2 + b2 * s2, b2 * c2 - a2 * s2
    harmonics = (q0, a1, b1, a2, b2)
    floor = degenerate * (w00 + w11 + w22)
    coarse, fine = np.empty(3), np.empty(3)
    previous, start, m = math.inf, 0, n
    for level in range(levels):
        status = _level(start, m, table, arc, h, s, c, ut, uz, cp, sp, harmonics, floor, configuration, e, fine)
        if status:
            return status, m
        if level > 0:
            decision, err = level_decision(coarse, fine, W, rtol, m, previous, P, error)
            if decision != NOT_SETTLED:
                return decision, m
            previous = err
        coarse[0], coarse[1], coarse[2] = fine[0], fine[1], fine[2]
        start += m
        m *= 2
    return CAPPED, m // 2


def jit_seconds() -> float:
    """Wall time to make :func:`cone_adaptive` callable in this process (numba's import excluded): its
    machine code loaded from numba's on-disk cache, or compiled when that cache is missing or stale."""
    start = time.perf_counter()
    cone_adaptive(0.4, np.eye(3) / 3.0, np.array([[0.6, 0.0, -0.8]]), rule_table(1, 4), 4, True, 0.5, 1e-12,
                  1e-14, np.empty((1, 3)), np.empty(1))
    return time.perf_counter() - start

"""The compiled core of :class:`~mbimpact.averaging.ConePair`: one velocity on a cone, in one call.

The two integrals of (2.8) with the flux weights of (2.7) over the facing arc of a cone of tilt α,
at n and at 2n azimuth nodes, their impulses P = (1+e) N / D and the relative difference of the
two by the velocity change W P they produce — the first pass of the adaptive rule — compiled by
numba (``njit``, cached on disk). It is imported on first use only: numba costs ~0.3 s to import,
more than ``import mbimpact`` may take (:data:`mbimpact.averaging.cone_pair.KERNELS`).

The nodes are those of :func:`mbimpact.quadrature.rules.azimuth_rule`, measured from the azimuth
ψ of u_t (θ = φ − ψ): the periodic trapezoid rule θ = 2πj/n on the full ring when the whole cone
faces u, Gauss–Legendre on the facing arc θ ∈ π ± h otherwise. Both come from a table built once
per n (:func:`rule_table`). Per node, with m = (s cos φ, s sin φ, c), s = sin α, c = cos α:

    mᵀu  = c u_n + s |u_t| cos θ,
    mᵀWm = q₀ + a₁ cos θ + b₁ sin θ + a₂ cos 2θ + b₂ sin 2θ   (the ring's harmonics, rotated by ψ),

so a node costs its cos θ, sin θ and a few products. Run with ``NUMBA_DISABLE_JIT=1``, the same
source runs interpreted.
"""

from __future__ import annotations

import functools
import math
import time

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

from ..quadrature.rules import gauss_legendre

__all__ = ["rule_table", "cone_pair", "jit_seconds", "SETTLED", "DEGENERATE_FACET", "NOT_FACING", "NOT_SETTLED"]

# status codes of :func:`cone_pair`: the pair settles the velocity, or why it does not
SETTLED, DEGENERATE_FACET, NOT_FACING, NOT_SETTLED = 0, 1, 2, 3

# machine epsilon (a constant of float64, safe to freeze into the compiled code)
_EPS = float(np.finfo(float).eps)

# rows of the table of :func:`rule_table` (columns: the n coarse nodes, then the 2n fine ones)
_GL_NODE, _GL_WEIGHT, _RING_COS, _RING_SIN, _RING_WEIGHT = range(5)


@functools.lru_cache(maxsize=16)
def rule_table(n: int) -> NDArray[np.float64]:
    """The nodes of both levels of :func:`cone_pair` for n coarse nodes (cached, read-only).

    Parameters
    ----------
    n : int
        Coarse node count.

    Returns
    -------
    ndarray, shape (5, 3n)
        Columns: the n coarse nodes, then the 2n fine ones. Rows: Gauss–Legendre nodes x on
        [-1, 1] and weights / 2π (the arc θ = π + h x, weight h w / 2π); cos θ, sin θ and the weight
        1/n or 1/2n of the periodic trapezoid rule θ = 2πj/n, 2πj/2n on the full ring.
    """
    (x1, w1), (x2, w2) = gauss_legendre(n), gauss_legendre(2 * n)
    theta = np.concatenate([2 * math.pi * np.arange(n) / n, 2 * math.pi * np.arange(2 * n) / (2 * n)])
    table = np.empty((5, 3 * n))
    table[_GL_NODE] = np.concatenate([x1, x2])
    table[_GL_WEIGHT] = np.concatenate([w1, w2]) / (2 * math.pi)
    table[_RING_COS], table[_RING_SIN] = np.cos(theta), np.sin(theta)
    table[_RING_WEIGHT, :n], table[_RING_WEIGHT, n:] = 1.0 / n, 1.0 / (2 * n)
    table.flags.writeable = False
    return table


# One explicit signature, compiled (or loaded from the cache) on import: read-only inputs of any layout, so
# that a caller's read-only or strided W or U does not make numba compile another specialisation
_IN2 = types.Array(types.float64, 2, "A", readonly=True)
_SIGNATURE = types.int64(types.float64, _IN2, _IN2, _IN2, types.boolean, types.float64, types.float64, types.float64,
                         types.float64[:, ::1], types.float64[::1])


@njit(_SIGNATURE, cache=True, error_model="numpy")
def cone_pair(alpha: float, W: NDArray[np.float64], U: NDArray[np.float64], table: NDArray[np.float64],
              configuration: bool, e: float, rtol: float, degenerate: float, P: NDArray[np.float64],
              error: NDArray[np.float64]) -> int:
    """(2.8) for one unit velocity on a cone at n and 2n nodes, and whether the pair settles it.

    Parameters
    ----------
    alpha : float
        Tilt of the cone, 0 < α < π/2.
    W : ndarray, shape (3, 3)
        Delassus matrix in the local frame.
    U : ndarray, shape (1, 3)
        Unit contact velocity u in the local frame, u_n < 0.
    table : ndarray, shape (5, 3n)
        The nodes of both levels (:func:`rule_table`).
    configuration : bool
        The facet weight of (2.7): ``"configuration"`` (w = −mᵀu / √(mᵀWm), kernels
        (mᵀu)² / (mᵀWm)^{3/2} and −mᵀu / √(mᵀWm)) if True, else ``"physical"`` (w = −mᵀu,
        kernels (mᵀu)² / mᵀWm and −mᵀu).
    e : float
        Facet restitution.
    rtol : float
        The pair settles the velocity when its relative difference is within this, or within the
        rounding floor 100 ε √(2n) of the adaptive rule (the same decision).
    degenerate : float
        A facet with mᵀWm ≤ degenerate · tr W cannot be pushed by the mechanism.
    P : ndarray, shape (1, 3)
        Output: the fine level's impulse P = (1+e) N / D, N = ∫ (mᵀu)² m / (mᵀWm)^γ and
        D = ∫ (−mᵀu) / (mᵀWm)^δ over the facing arc (the caller allocates it: cheaper than
        returning an array).
    error : ndarray, shape (1,)
        Output: the error estimate |W (P_2n − P_n)| / |W P_2n|.

    Returns
    -------
    int
        :data:`SETTLED` when the pair settles the velocity (``P`` and ``error`` are written);
        else the reason the general rule must take over, the outputs then meaningless:
        :data:`DEGENERATE_FACET` (a node on a facet the mechanism cannot push: the general rule
        masks it), :data:`NOT_FACING` (a level with no weight) or :data:`NOT_SETTLED` (the
        difference exceeds the tolerance).
    """
    n = table.shape[1] // 3
    ux, uy, uz = U[0, 0], U[0, 1], U[0, 2]
    ut = math.hypot(ux, uy)
    cp, sp = (ux / ut, uy / ut) if ut > 0.0 else (1.0, 0.0)
    s, c = math.sin(alpha), math.cos(alpha)
    # the nodes θ of both levels, their cos θ, sin θ and weights
    nodes = np.empty((3, 3 * n))
    if s * ut <= c * -uz:  # the whole ring faces u: the periodic trapezoid rule from ψ
        for j in range(3 * n):
            nodes[0, j], nodes[1, j], nodes[2, j] = table[_RING_COS, j], table[_RING_SIN, j], table[_RING_WEIGHT, j]
    else:  # the facing arc θ = π + h x: cos θ and sin θ change sign
        h = math.pi - math.acos(min(1.0, c * -uz / (s * ut)))
        for j in range(3 * n):
            # Gauss–Legendre nodes come in pairs x, −x (exactly): half the cosines and sines
            mirror = n - 1 - j if j < n else 4 * n - 1 - j
            if mirror < j:
                nodes[0, j], nodes[1, j] = nodes[0, mirror], -nodes[1, mirror]
            else:
                x = h * table[_GL_NODE, j]
                nodes[0, j], nodes[1, j] = -math.cos(x), -math.sin(x)
            nodes[2, j] = h * table[_GL_WEIGHT, j]
    # mᵀWm in the harmonics of φ, then of θ = φ − ψ
    w00, w01, w02, w11, w12, w22 = W[0, 0], W[0, 1], W[0, 2], W[1, 1], W[1, 2], W[2, 2]
    q0 = 0.5 * s * s * (w00 + w11) + c * c * w22
    a1, b1 = 2.0 * s * c * w02, 2.0 * s * c * w12
    a2, b2 = 0.5 * s * s * (w00 - w11), s * s * w01
    c2, s2 = cp * cp - sp * sp, 2.0 * cp * sp
    a1, b1 = a1 * cp + b1 * sp, b1 * cp - a1 * sp
    a2, b2 = a2 * c2 + b2 * s2, b2 * c2 - a2 * s2
    floor = degenerate * (w00 + w11 + w22)
    levels = np.empty((2, 3))
    for level in range(2):
        # D and the moments Σ w k (1, cos θ, sin θ) of the kernel k of N, from which N follows
        d, k0, k1, k2 = 0.0, 0.0, 0.0, 0.0
        for j in range(0, n) if level == 0 else range(n, 3 * n):
            ct, st, wt = nodes[0, j], nodes[1, j], nodes[2, j]
            q = q0 + a1 * ct + b1 * st + a2 * (ct * ct - st * st) + b2 * (2.0 * ct * st)
            if not q > floor:
                return DEGENERATE_FACET
            # −mᵀu on the facing set, 0 off it (the trapezoid rule runs over the whole ring)
            sweep = max(-(c * uz + s * ut * ct), 0.0)
            if configuration:  # w = −mᵀu / √q, kernel (mᵀu)² / q^{3/2}
                r = 1.0 / math.sqrt(q)
                weight = sweep * r
                kernel = weight * weight * r
            else:  # w = −mᵀu, kernel (mᵀu)² / q
                weight = sweep
                kernel = sweep * sweep / q
            d += wt * weight
            k0 += wt * kernel
            k1 += wt * kernel * ct
            k2 += wt * kernel * st
        if not d > 0.0:
            return NOT_FACING
        # P = (1+e) N / D, m = (s (cos ψ cos θ − sin ψ sin θ), s (sin ψ cos θ + cos ψ sin θ), c)
        f = (1.0 + e) / d
        levels[level, 0] = f * s * (cp * k1 - sp * k2)
        levels[level, 1] = f * s * (sp * k1 + cp * k2)
        levels[level, 2] = f * c * k0
    # the relative difference of the two levels by the velocity change W P they produce (defined
    # even when J is rank-deficient, where P is not); settled within rtol or the rounding floor
    # 100 ε √(2n) of the adaptive rule
    diff, ref = 0.0, 0.0
    for i in range(3):
        coarse = levels[0, 0] * W[0, i] + levels[0, 1] * W[1, i] + levels[0, 2] * W[2, i]
        fine = levels[1, 0] * W[0, i] + levels[1, 1] * W[1, i] + levels[1, 2] * W[2, i]
        diff += (fine - coarse) ** 2
        ref += fine * fine
    err = math.sqrt(diff / ref)
    if not err <= max(rtol, 100 * _EPS * math.sqrt(2 * n)):
        return NOT_SETTLED
    P[0, 0], P[0, 1], P[0, 2] = levels[1, 0], levels[1, 1], levels[1, 2]
    error[0] = err
    return SETTLED


def jit_seconds() -> float:
    """Wall time to make :func:`cone_pair` callable in this process (numba's import excluded:
    importing this module does it): its machine code loaded from numba's on-disk cache
    (``__pycache__`` next to this file), or compiled when that cache is missing or stale. The first
    call pays it; later calls return near 0."""
    start = time.perf_counter()
    cone_pair(0.4, np.eye(3) / 3.0, np.array([[0.6, 0.0, -0.8]]), rule_table(1), True, 0.5, 1e-12, 1e-14,
              np.empty((1, 3)), np.empty(1))
    return time.perf_counter() - start

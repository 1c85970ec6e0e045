"""The compiled core of :class:`~mbimpact.averaging.Laplace`: (2.8) on Gaussian slopes with the kernel
1/mᵀWm written as a Laplace integral, so that the average over the facets is a Gaussian integral in
closed form and one integral over τ is left.

Write a facet by its slope s = tan α (cos φ, sin φ) and s̃ = (s, 1), so that m = s̃ / |s̃|. A
:class:`~mbimpact.GaussianSlopes` measure weighs a facet by its true area: dP ∝ e^{−|s|²/2σ²} |s̃| d²s.
With the physical flux of (2.7) every power of |s̃| cancels from the two integrals of (2.8):

    D = ∫_H g(s) (−s̃ᵀu) d²s,      N = ∫_H g(s) (s̃ᵀu)² s̃ / q(s) d²s,      P = (1+e) N / D,

with g(s) = e^{−|s|²/2σ²}, q(s) = s̃ᵀW s̃ = (1 + |s|²) mᵀWm, and H = {s̃ᵀu < 0} (the set G*, a half-plane
of slopes). D is a Gaussian integral over a half-plane, in closed form. In N the only obstacle is 1/q,
which peaks, for a nearly singular W, over a region of slopes as narrow as sqrt(λ₁/λ₃). Written as

    1/q = ∫₀^∞ e^{−τq} dτ,

it turns N into ∫₀^∞ T(τ) dτ, where T(τ) = ∫_H g e^{−τq} (s̃ᵀu)² s̃ d²s is again a Gaussian integral over a
half-plane (the Gaussian of precision M = I/σ² + 2τW_tt, centred at μ(τ), which moves from 0 to the
slope s* where q is least as τ grows), in closed form with one erfc. Where the kernels peak, T merely
decays slowly, as e^{−τ q_min} with q_min = q(s*); the peak's width never enters. The τ-integral is the
trapezoid rule after the double-exponential map τ = c exp(x − e^{−x}): T is analytic in a strip about
the real x-axis, so the rule converges geometrically and halving the step squares the error. Levels
halve the step from 1/2 until two agree to rtol (:func:`mbimpact.averaging.compiled.primitives.level_decision`);
a velocity needs 60–300 nodes, growing as log(1/q_min) however narrow the peak.

The closed form of T. With ξ = sᵀν, ν = −u_t (so that −s̃ᵀu = ξ − u_n, H = {ξ > u_n}) and s Gaussian
with mean μ and covariance Σ = M⁻¹, ξ has mean ξ̄ = νᵀμ and variance v = νᵀΣν, and s − μ splits into
Σν (ξ − ξ̄)/v plus a part independent of ξ. With d = ξ̄ − u_n, t = d/√v and Φ, φ the normal distribution
and density,

    E[(ξ − u_n)² 1_H]     = (d² + v) Φ(t) + √v d φ(t),
    E[(ξ − u_n)² s 1_H]   = E[(ξ − u_n)² 1_H] μ + 2 (d Φ(t) + √v φ(t)) Σν,

and T(τ) = 2π e^{E(τ)} / sqrt(det M) times these, with the exponent written without cancellation as
E(τ) = −τ q_min − sᵀ* μ(τ) / (2σ²). D is the same expression at τ = 0.

Rounding. Where W_t is nearly singular, det W_t, adj W_t w, wᵀ adj W_t w and the row's adjugate forms
lose digits to cancellation (~ε cond W_t); rounded apart, each moved the answer by its own error (up to
3e-7 at cond W_t ~ 1e10 in an independent 30-digit check), although an ulp of W's entries moves the
exact answer by ~ε. They are therefore summed as in twice the working precision (Ogita, Rump and
Oishi's Dot2), and every quantity of a node is a sum of two terms of one sign or the other
(M⁻¹ = (I/σ² + 2τ adj W_t) / det M). The peak's integral depends on q_min, which the rounding of W's
entries moves by up to ε Σ |W_ik| |s̃*_i| |s̃*_k|. dN/dq_min = −∫ τ T dτ is summed on the same nodes, and
the reported error is the largest of the level difference, this sensitivity and the rounding of the
sums, 4 ε Σ |terms| in each component of P, taken through W. No level reduces the last two: where they
exceed rtol the estimate says so (as the graded rule's, :func:`mbimpact.averaging.refinement.refine`).
Against a 30-digit reference (176 cases, cond W_t up to 1e10, σ from 0.01 to 5, β up to 89.9°) the
true error of every settled velocity was within its estimate.

The module is imported on first use only (numba costs ~0.3 s to import). Run with
``NUMBA_DISABLE_JIT=1``, the same source runs interpreted.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .primitives import (CAPPED, DEGENERATE_FACET, EPS, NOT_SETTLED, SETTLED, dot2, level_decision)

__all__ = ["laplace_average", "jit_seconds", "FIRST_STEP",
           "LEVELS"]

#: The first level's step in x (the DE map's variable); each level halves it.
FIRST_STEP = 0.5

#: Levels at most (steps 1/2 … 1/128): a velocity not settled by then is CAPPED.
LEVELS = 7

# the relative rounding of a node's terms (a few exp, an erfc, ~30 operations): against 40-digit sums of the
# same rule, the float64 sums erred by up to 1.9 ε |W| Σ|terms| / |W P|
_ROUNDING = 4 * EPS

# the τ-integrand's tails are cut where a node adds less than this share of the sum of |terms| so far
_TAIL = 1e-18

# and, at the upper end, only once e^{−τ q_min} bounds every later node below e^{−40} of its size
_DECAY = 40.0

# Φ(t) rounds to 1 and t φ(t) to below ε for t beyond this
_WHOLE = 9.0

_SQRT_HALF = math.sqrt(0.5)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)


@njit(cache=True, error_model="numpy")
def _half_plane(d: float, v: float) -> tuple[float, float]:  # pragma: no cover — compiled
    """E[(ξ − u_n)² 1_H] and E[(ξ − u_n) 1_H] for ξ normal with d = mean − u_n and variance v, H = {ξ > u_n}."""
    if not v > 0.0:  # ν = 0: the whole plane faces u (d = −u_n > 0)
        return (d * d, d) if d > 0.0 else (0.0, 0.0)
    sv = math.sqrt(v)
    if d > _WHOLE * sv:  # Φ(t) = 1 and φ(t) = 0 to the last bit: H holds the whole Gaussian
        return d * d + v, d
    t = d / sv
    cdf = 0.5 * math.erfc(-t * _SQRT_HALF)
    pdf = _INV_SQRT_2PI * math.exp(-0.5 * t * t)
    return (d * d + v) * cdf + sv * d * pdf, d * cdf + sv * pdf


@njit(cache=True, error_model="numpy")
def _add_node(sums: NDArray[np.float64], x: float, c: float, a: float,
              shape: tuple[float, float, float, float, float, float, float, float, float],
              row: tuple[float, float, float, float, float, float, float, float, float]
              ) -> tuple[float, float]:  # pragma: no cover — compiled
    """Add the node x of the DE map τ = c exp(x − e^{−x}) to ``sums``: T(τ) dτ/dx / 2π (the vector
    integrand of N in the module docstring) to sums[0:3], τ times it to sums[3:6] (dN/dq_min), its
    absolute values to sums[6:9] and their total to sums[9]. Returns the node's |terms| and τ.

    ``shape`` is (tr W_t, det W_t, w_x, w_y, (adj W_t w)_x, (adj W_t w)_y, s*ᵀW_t s*, |s*|², q_min) and
    ``row`` (ν_x, ν_y, u_n, |ν|², (adj W_t ν)_x, (adj W_t ν)_y, νᵀ adj W_t ν, νᵀw, νᵀ adj W_t w), those
    that cancel computed accurately: with M⁻¹ = (a I + 2τ adj W_t) / det M every quantity below is a
    sum of two terms whose rounding is that of the result."""
    tr, det_t, wx, wy, ax, ay, sws, s2, q_min = shape
    nx, ny, un, n2, bx, by, nan, nw, naw = row
    g = math.exp(-x)
    tau = c * math.exp(x - g)
    if not tau > 0.0:
        return 0.0, 0.0
    t2 = 2.0 * tau
    inv = 1.0 / (a * (a + t2 * tr) + t2 * t2 * det_t)  # 1 / det M, M = I/σ² + 2τ W_t: positive terms
    mux = -t2 * (a * wx + t2 * ax) * inv  # μ = M⁻¹ (−2τ w)
    muy = -t2 * (a * wy + t2 * ay) * inv
    snx = (a * nx + t2 * bx) * inv  # Σν
    sny = (a * ny + t2 * by) * inv
    second, first = _half_plane(-t2 * (a * nw + t2 * naw) * inv - un, (a * n2 + t2 * nan) * inv)
    # the exponent −τ q_min − s*ᵀμ / 2σ², with s*ᵀμ = 2τ (a s*ᵀW_t s* + 2τ det W_t |s*|²) / det M ≥ 0
    scale = math.exp(-tau * q_min - 0.5 * a * t2 * (a * sws + t2 * det_t * s2) * inv) * math.sqrt(inv) * tau * (1.0 + g)
    fx = scale * (second * mux + 2.0 * first * snx)
    fy = scale * (second * muy + 2.0 * first * sny)
    fz = scale * second
    sums[0] += fx
    sums[1] += fy
    sums[2] += fz
    sums[3] += tau * fx
    sums[4] += tau * fy
    sums[5] += tau * fz
    sums[6] += abs(fx)
    sums[7] += abs(fy)
    sums[8] += abs(fz)
    size = abs(fx) + abs(fy) + abs(fz)
    sums[9] += size
    return size, tau


@njit(cache=True, error_model="numpy", nogil=True)
def laplace_average(W: NDArray[np.float64], U: NDArray[np.float64], sigma: float, e: float, rtol: float,
                    degenerate: float, P: NDArray[np.float64], error: NDArray[np.float64]
                    ) -> tuple[int, int]:  # pragma: no cover — compiled
    """(2.8) with the physical flux on :class:`~mbimpact.GaussianSlopes` (σ) for unit velocities ``U``.

    Parameters
    ----------
    W : ndarray, shape (3, 3)
        Delassus matrix, local frame.
    U : ndarray, shape (B, 3)
        Unit contact velocities, local frame, ``U[:, 2] < 0``.
    sigma, e, rtol : float
        RMS slope, facet restitution, relative accuracy asked for.
    degenerate : float
        A facet with mᵀWm ≤ degenerate · tr W cannot be pushed
        (:data:`mbimpact.common.geometry.DEGENERATE`).
    P : ndarray, shape (B, 3)
        Written: the contact impulses (every row, if SETTLED).
    error : ndarray, shape (B,)
        Written: their estimated relative errors (of W P).

    Returns
    -------
    (status, nodes) : (int, int)
        :data:`SETTLED`, or why not for the first row that is not: :data:`DEGENERATE_FACET` (the
        slope where q is least is a facet the mechanism cannot push, q_min / |s̃*|² ≤ degenerate tr W),
        :data:`STALLED` (the levels' differences stopped shrinking above rtol, at rounding amplified by
        |W| |P| / |W P|) or :data:`CAPPED` (:data:`LEVELS` levels unsettled);
        and the nodes of the most refined level that ran.
    """
    a = 1.0 / (sigma * sigma)
    Wxx, Wxy, Wyy, wx, wy, Wzz = W[0, 0], W[0, 1], W[1, 1], W[0, 2], W[1, 2], W[2, 2]
    trace = Wxx + Wyy + Wzz
    # what cancels where W_t is nearly singular, accurately: det W_t, adj W_t w and wᵀ adj W_t w (the
    # exact answer hardly depends on an ulp of W's entries, but these three, rounded apart, would each
    # move it by their own error, ~1e-12 at cond W_t ~ 1e4)
    det_t = dot2(((Wxx, Wyy, 1.0), (Wxy, Wxy, -1.0)))
    if not (Wxx > 0.0 and det_t > 0.0):
        return DEGENERATE_FACET, 0
    ax = dot2(((Wyy, wx, 1.0), (Wxy, wy, -1.0)))
    ay = dot2(((Wxx, wy, 1.0), (Wxy, wx, -1.0)))
    waw = dot2(((wx, wx, Wyy), (wx, wy, -2.0 * Wxy), (wy, wy, Wxx)))
    # s*: the least q(s) = sᵀW_t s + 2 sᵀw + W_zz (W_t s* = −w); q_min = q(s*) = W_zz − wᵀW_t⁻¹w
    sx, sy = -ax / det_t, -ay / det_t
    sws = waw / det_t  # s*ᵀ W_t s* = wᵀ W_t⁻¹ w
    q_min = Wzz - sws
    if not q_min > degenerate * trace * (1.0 + sx * sx + sy * sy):
        return DEGENERATE_FACET, 0
    # how far the rounding of W's entries can move q_min (as it moves q(s*))
    dq = EPS * (abs(Wxx) * sx * sx + 2.0 * abs(Wxy * sx * sy) + abs(Wyy) * sy * sy
                 + 2.0 * abs(wx * sx) + 2.0 * abs(wy * sy) + abs(Wzz))
    c = 1.0 / (trace * (1.0 + sigma * sigma))  # τ beyond which the bulk of g feels e^{−τq}
    nodes = 0
    shape = (Wxx + Wyy, det_t, wx, wy, ax, ay, sws, sx * sx + sy * sy, q_min)
    coarse, fine, sums = np.empty(3), np.empty(3), np.empty(10)
    for b in range(U.shape[0]):
        nx, ny, un = -U[b, 0], -U[b, 1], U[b, 2]
        row = (nx, ny, un, nx * nx + ny * ny, dot2(((Wyy, nx, 1.0), (Wxy, ny, -1.0))),
               dot2(((Wxx, ny, 1.0), (Wxy, nx, -1.0))),
               dot2(((nx, nx, Wyy), (nx, ny, -2.0 * Wxy), (ny, ny, Wxx))), nx * wx + ny * wy,
               dot2(((nx, wx, Wyy), (nx, wy, -Wxy), (ny, wx, -Wxy), (ny, wy, Wxx))))
        # D: the same Gaussian integral at τ = 0 (precision a, centred at 0)
        D = _half_plane(-un, (nx * nx + ny * ny) / a)[1] / a
        # level 0: walk out from x = 0 until the tails are negligible; later levels fill in [lo, hi]
        h = FIRST_STEP
        sums[:] = 0.0
        k = 0
        while True:  # x = 0, h, 2h, …
            size, tau = _add_node(sums, k * h, c, a, shape, row)
            k += 1
            if tau * q_min > _DECAY and size <= _TAIL * sums[9]:
                break
        hi = k - 1
        k = 1
        while True:  # x = −h, −2h, …
            size, tau = _add_node(sums, -k * h, c, a, shape, row)
            if tau < 1e-3 * c and size <= _TAIL * sums[9]:
                break
            k += 1
        lo = -k
        count = hi - lo + 1
        factor = (1.0 + e) / D
        for i in range(3):
            coarse[i] = factor * h * sums[i]
        status, previous = NOT_SETTLED, math.inf
        level = 1
        while level < LEVELS:
            h *= 0.5
            lo, hi = 2 * lo, 2 * hi
            for j in range(lo + 1, hi, 2):  # the new nodes, at odd multiples of the new step
                _add_node(sums, j * h, c, a, shape, row)
            count = 2 * count - 1
            for i in range(3):
                fine[i] = factor * h * sums[i]
            status, diff = level_decision(coarse, fine, W, rtol, float(count), previous, P[b:b + 1],
                                          error[b:b + 1])
            if status != NOT_SETTLED:
                break
            previous = diff
            coarse[0], coarse[1], coarse[2] = fine[0], fine[1], fine[2]
            level += 1
        nodes = max(nodes, count)
        if status != SETTLED:
            return (CAPPED if status == NOT_SETTLED else status), nodes
        # what the level difference does not see, by W P: the shift of q_min's rounding,
        # dP = −(1+e)/D ∫ τ T dτ · dq, and the rounding of the sums, ~ε Σ |terms| in each component
        # (not ε |P|, the normwise floor: where W nearly annihilates P, P's components are far apart
        # in size and each is rounded on its own scale)
        ws, wa, wp = 0.0, 0.0, 0.0
        for i in range(3):
            si = (sums[3] * W[0, i] + sums[4] * W[1, i] + sums[5] * W[2, i]) * factor * h * dq
            ai = (sums[6] * abs(W[0, i]) + sums[7] * abs(W[1, i]) + sums[8] * abs(W[2, i])) * factor * h * _ROUNDING
            pi = P[b, 0] * W[0, i] + P[b, 1] * W[1, i] + P[b, 2] * W[2, i]
            ws += si * si
            wa += ai * ai
            wp += pi * pi
        # no level reduces these: where they exceed rtol the estimate says so (as the graded rule's)
        error[b] = max(error[b], math.sqrt(max(ws, wa) / wp) if wp > 0.0 else math.inf)
    return SETTLED, nodes


def jit_seconds() -> float:
    """Wall time to make :func:`laplace_average` callable in this process (loaded from numba's on-disk
    cache, or compiled); later calls return near 0."""
    start = time.perf_counter()
    laplace_average(np.diag([1e-6, 1.0, 1.0]), np.array([[0.6, 0.0, -0.8]]), 0.3, 0.5, 1e-12, 1e-14,
                    np.empty((1, 3)), np.empty(1))
    return time.perf_counter() - start

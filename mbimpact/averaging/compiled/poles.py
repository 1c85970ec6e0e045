"""A cone's peaked kernels of (2.8) integrated with their poles taken out, for one velocity: the compiled
rule of :class:`~mbimpact.averaging.Poles`.

With the physical flux of (2.7) the kernels of (2.8) on a cone of facets,
f_j(φ) = (mᵀu)² m_j / q(φ) with q = mᵀWm, are rational functions of z = e^{iφ}:
q(z) = m(z)ᵀ W m(z) with m(z) = (s (z + 1/z)/2, s (z − 1/z)/2i, c) is a Laurent polynomial of degree
2 whose zeros come in pairs (a, 1/ā). A nearly singular W puts a pair close to the unit circle, one
pair at each minimum of q on the ring, and f_j peaks there with the width ε of the minimum
(:func:`mbimpact.averaging.compiled.graded_cone.ring_minima_into`). Instead of grading the nodes towards the
peaks, :func:`poles` removes them: with r_j = T_j(a) / q'(a) the residue of f_j at a
(T_j = (mᵀu)² m_j), the function

    s_j(φ) = 2 Re[r_j / (e^{iφ} − a)]

has the poles of f_j at a and at 1/ā with their residues (f_j is real on the circle), so f_j − Σ s_j is
smooth there, and the plain rule of the facing arc (:func:`mbimpact.averaging.compiled.cone.rule_table`:
Gauss–Legendre on the arc, the trapezoid rule on the whole ring) integrates it with 32 or 64 nodes.
The subtracted part is integrated in closed form:

    ∫ dφ / (e^{iφ} − a) = log(1 − a e^{−iφ}) / (i a),

continuous along the circle for |a| < 1 (1 − a e^{−iφ} stays in the right half-plane), and zero over
the whole ring. The subtraction is exact for any a; how close a is to the zero decides only how smooth
the remainder is. The zeros are therefore polished by Newton's method on q(z) evaluated as m(z)ᵀWm(z)
from the entries of W, the arithmetic in which q is small where it is small; from the coefficients of
the Laurent polynomial they lose digits as ε² shrinks, and the remainder keeps a spike. Refinement and
stopping rule are those of the adaptive rule (:func:`mbimpact.averaging.compiled.primitives.level_decision`).

Level differences do not see how sensitive the answer is to the rounding of W itself: at a minimum of q,
an ulp of W's entries moves q by up to ε Σ |W_ik| |m_i| |m_k| relative to q_min, and the peak's integral,
which goes as q_min^(-1/2), by half that. Where this bound exceeds rtol (most velocities on rings through
W's null direction at cond W ≳ 1e5) the pass declines (STALLED) and the graded rule decides; elsewhere the
reported error is the largest of the level difference, this bound
(:func:`~mbimpact.averaging.compiled.graded_cone.minima_sensitivity`) and the rounding of P itself where W
nearly annihilates it (:func:`~mbimpact.averaging.compiled.primitives.rounding_floor`). Independent checks
against 36-digit references (734 cases, cond 1e3–1e8, the physical flux) found the true error of every
settled velocity within this estimate but one, 1.12× over it at 5e-14 (its 16 → 32 level difference
understated the 32-node error), and no error above rtol.

The configuration flux (kernels m / q^{3/2}) has branch points instead of poles: it is not handled here.
The module is imported on first use only (numba costs ~0.3 s to import). Run with
``NUMBA_DISABLE_JIT=1``, the same source runs interpreted.
"""

from __future__ import annotations

import cmath
import math
import time

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

from ...common.compiled import kernel
from .graded_cone import minima_sensitivity, ring_form, ring_minima_into
from .primitives import (CAPPED, DEGENERATE_FACET, EPS, NOT_FACING, NOT_PEAKED, NOT_SETTLED, SETTLED, STALLED,
                         UNRESOLVED, level_decision, rounding_floor)

__all__ = ["poles", "ring_zero", "jit_seconds"]

# Newton's iterations on a zero of q, and its stopping step relative to |a|
_NEWTON_STEPS = 60
_NEWTON_TOL = 4 * EPS

# rows of cone.rule_table
_GL_NODE, _GL_WEIGHT, _RING_COS, _RING_SIN, _RING_WEIGHT = range(5)


@njit(cache=True, error_model="numpy")
def _q_slope(s: float, c: float, W: NDArray[np.float64], z: complex
             ) -> tuple[complex, complex, complex, complex]:  # pragma: no cover — compiled
    """q(z) = m(z)ᵀ W m(z), dq/dz and the first two components of m(z), for complex z."""
    zi = 1.0 / z
    m0 = 0.5 * s * (z + zi)
    m1 = -0.5j * s * (z - zi)
    d0 = 0.5 * s * (1.0 - zi * zi)
    d1 = -0.5j * s * (1.0 + zi * zi)
    w0 = W[0, 0] * m0 + W[0, 1] * m1 + W[0, 2] * c
    w1 = W[1, 0] * m0 + W[1, 1] * m1 + W[1, 2] * c
    w2 = W[2, 0] * m0 + W[2, 1] * m1 + W[2, 2] * c
    return m0 * w0 + m1 * w1 + c * w2, 2.0 * (d0 * w0 + d1 * w1), m0, m1


@njit(cache=True, error_model="numpy")
def ring_zero(s: float, c: float, W: NDArray[np.float64], phi: float, eps: float) -> complex:  # pragma: no cover
    """The zero a of q(z) inside the unit disk near the minimum of q at azimuth ``phi`` with width ``eps``
    (q ≈ q_min + q'' (φ − φ*)² / 2 has its zeros at φ* ± i eps): Newton's method from e^{iφ* − eps};
    a zero it finds outside the disk is reflected (the zeros come in pairs a, 1/ā). Returns 0 where
    Newton does not converge."""
    a = cmath.exp(complex(-eps, phi))
    for _ in range(_NEWTON_STEPS):
        q, dq, _m0, _m1 = _q_slope(s, c, W, a)
        if dq == 0:
            return 0j
        step = q / dq
        a -= step
        if abs(step) <= _NEWTON_TOL * abs(a):
            size = abs(a)
            if not 0.0 < size < math.inf or size == 1.0:
                return 0j
            return a if size < 1.0 else 1.0 / a.conjugate()
    return 0j


_IN2 = types.Array(types.float64, 2, "A", readonly=True)
_TABLE = types.Array(types.float64, 2, "C", readonly=True)
_PASS = types.UniTuple(types.int64, 2)(types.float64, _IN2, _IN2, _TABLE, types.int64, types.float64, types.float64,
                                       types.float64, types.float64, types.float64[:, ::1], types.float64[::1])


@kernel(_PASS, error_model="numpy")
def poles(alpha: float, W: NDArray[np.float64], U: NDArray[np.float64], table: NDArray[np.float64], levels: int,
          peaked: float, e: float, rtol: float, degenerate: float, P: NDArray[np.float64],
          error: NDArray[np.float64]) -> tuple[int, int]:  # pragma: no cover — compiled
    """(2.8) for one unit velocity on a cone with the physical flux, its peaked kernels' poles subtracted
    and integrated in closed form, the smooth rest by the cone's rule refined as the adaptive rule refines
    it: n, 2n, 4n, … nodes until two successive levels agree.

    Parameters
    ----------
    alpha : float
        Tilt of the cone, 0 < α < π/2.
    W : ndarray, shape (3, 3)
        Delassus matrix in the local frame.
    U : ndarray, shape (1, 3)
        Unit contact velocity u in the local frame, u_n < 0.
    table : ndarray, shape (5, n (2^levels − 1))
        The cone's nodes of every level (:func:`mbimpact.averaging.compiled.cone.rule_table`).
    levels : int
        The number of levels in the table.
    peaked : float
        The peak width below which the poles are subtracted (:attr:`mbimpact.averaging.Graded.peaked`).
    e : float
        Facet restitution.
    rtol : float
        Two levels agree when their relative difference by W P is within this, or within the rounding
        floor 100 ε √K of a K-node sum.
    degenerate : float
        A facet with mᵀWm ≤ degenerate · tr W cannot be pushed by the mechanism.
    P : ndarray, shape (1, 3)
        Output: the last level's impulse P = (1+e) N / D.
    error : ndarray, shape (1,)
        Output: the error estimate: the largest of |W (P_m − P_{m/2})| / |W P_m|, the rounding of q at the
        minima (:func:`~mbimpact.averaging.compiled.graded_cone.minima_sensitivity`) and that of P
        (:func:`~mbimpact.averaging.compiled.primitives.rounding_floor`).

    Returns
    -------
    status : int
        ``SETTLED`` (``P`` and ``error`` are written); ``NOT_PEAKED`` where the kernels have no peak
        narrower than ``peaked`` (or one too narrow to treat); ``UNRESOLVED`` where a zero of q was not
        found; ``STALLED`` where the answer's sensitivity to an ulp of W exceeds rtol, or rounding stops
        the levels short of it, ``CAPPED`` at the last level of the table; ``DEGENERATE_FACET``,
        ``NOT_FACING`` (:mod:`~mbimpact.averaging.compiled.primitives`).
    nodes : int
        The node count of the last level computed.
    """
    s, c = math.sin(alpha), math.cos(alpha)
    phi_star, eps_star = np.empty(2), np.empty(2)
    k = ring_minima_into(ring_form(s, c, W), peaked, phi_star, eps_star)
    if k == 0:
        return NOT_PEAKED, 0
    # how far an ulp of W's entries moves the answer through q at each minimum (level differences do not see
    # it; the peak's integral goes as q_min^(-1/2)): beyond rtol the graded rule decides
    sensitivity = minima_sensitivity(s, c, W, phi_star, k, 0.5)
    if sensitivity == math.inf:
        return UNRESOLVED, 0
    if sensitivity > rtol:
        return STALLED, 0
    ux, uy, uz = U[0, 0], U[0, 1], U[0, 2]
    # the zeros near the minima, and the residues r_j = T_j(a) / q'(a) of the three kernels there
    zeros = np.zeros(2, dtype=np.complex128)
    residues = np.zeros((2, 3), dtype=np.complex128)
    for j in range(k):
        a = ring_zero(s, c, W, phi_star[j], eps_star[j])
        if a == 0 or (j == 1 and abs(a - zeros[0]) <= 1e-8):
            return UNRESOLVED, 0
        _q, dq, m0, m1 = _q_slope(s, c, W, a)
        mu = m0 * ux + m1 * uy + c * uz
        t = mu * mu / dq
        zeros[j] = a
        residues[j, 0], residues[j, 1], residues[j, 2] = t * m0, t * m1, t * c
    # the facing set: the whole ring, or the arc ψ + π ± h (facing_half_width)
    ut, un = math.hypot(ux, uy), abs(uz)
    psi = math.atan2(uy, ux)
    half = math.pi if s * ut <= c * un else math.pi - math.acos(min(1.0, max(-1.0, c * un / (s * ut))))
    full = half == math.pi
    # the subtracted parts over the arc, in closed form (zero over the whole ring); weights are dφ / 2π
    exact = np.zeros(3)
    if not full:
        z2, z1 = cmath.exp(complex(0.0, psi + math.pi + half)), cmath.exp(complex(0.0, psi + math.pi - half))
        for j in range(k):
            a = zeros[j]
            span = (cmath.log(1.0 - a / z2) - cmath.log(1.0 - a / z1)) / (1j * a)
            for i in range(3):
                exact[i] += 2.0 * (residues[j, i] * span).real / (2.0 * math.pi)
    floor = degenerate * (W[0, 0] + W[1, 1] + W[2, 2])
    n = table.shape[1] // ((1 << levels) - 1)
    coarse, fine = np.empty(3), np.empty(3)
    previous, start, m = math.inf, 0, n
    for level in range(levels):
        n0, n1, n2, d = exact[0], exact[1], exact[2], 0.0
        for node in range(start, start + m):
            if full:
                cp, sp, wt = table[_RING_COS, node], table[_RING_SIN, node], table[_RING_WEIGHT, node]
            else:
                phi = psi + math.pi + half * table[_GL_NODE, node]
                cp, sp, wt = math.cos(phi), math.sin(phi), half * table[_GL_WEIGHT, node]
            m0, m1 = s * cp, s * sp
            q = (m0 * (W[0, 0] * m0 + W[0, 1] * m1 + W[0, 2] * c) + m1 * (W[1, 0] * m0 + W[1, 1] * m1 + W[1, 2] * c)
                 + c * (W[2, 0] * m0 + W[2, 1] * m1 + W[2, 2] * c))
            if not q > floor:
                return DEGENERATE_FACET, m
            mu = m0 * ux + m1 * uy + c * uz
            g = mu * mu / q
            f0, f1, f2 = g * m0, g * m1, g * c
            z = complex(cp, sp)
            for j in range(k):
                inv = 1.0 / (z - zeros[j])
                f0 -= 2.0 * (residues[j, 0] * inv).real
                f1 -= 2.0 * (residues[j, 1] * inv).real
                f2 -= 2.0 * (residues[j, 2] * inv).real
            n0 += wt * f0
            n1 += wt * f1
            n2 += wt * f2
            d -= wt * mu
        if not d > 0.0:
            return NOT_FACING, m
        fine[0], fine[1], fine[2] = (1.0 + e) * n0 / d, (1.0 + e) * n1 / d, (1.0 + e) * n2 / d
        if level > 0:
            decision, err = level_decision(coarse, fine, W, rtol, m, previous, P, error)
            if decision == SETTLED:  # P and error written; the estimate includes the sensitivity to W and P's rounding
                error[0] = max(error[0], sensitivity, rounding_floor(P, W))
            if decision != NOT_SETTLED:  # settled, or stalled at rounding
                return decision, m
            previous = err
        coarse[0], coarse[1], coarse[2] = fine[0], fine[1], fine[2]
        start += m
        m *= 2
    return CAPPED, m // 2


def jit_seconds() -> float:
    """Wall time to make :func:`poles` callable in this process (numba's import excluded): its machine
    code loaded from numba's on-disk cache, or compiled when that cache is missing or stale."""
    from .cone import rule_table

    start = time.perf_counter()
    P, err = np.empty((1, 3)), np.empty(1)
    W = np.diag([1.0, 1e-6, 1e-6])
    poles(0.4, W, np.array([[0.3, 0.1, -0.9]]), rule_table(4, 2), 2, 0.15, 0.5, 1e-12, 1e-14, P, err)
    return time.perf_counter() - start

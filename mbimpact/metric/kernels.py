"""The compiled core of the contact metric: A⁻¹Jᵀ and W = J A⁻¹ Jᵀ from Pinocchio's factor of A(q).

``pin.cholesky.decompose`` leaves A = U D Uᵀ in the workspace (U unit upper triangular, D the
pivots). One impact needs A⁻¹Jᵀ (d ≤ 3 solves) and the Delassus matrix W = J A⁻¹ Jᵀ; from Python
that is a Pinocchio call per column, an assembly and a product, each costing a single impact more
than its arithmetic. :func:`delassus` does all of it in one compiled call on the factor's own
memory. The solves are the factor's triangular solves, as backward stable as Pinocchio's, so W
is as accurate as with ``pin.cholesky.solve``.

Imported on first use only (:data:`mbimpact.metric.delassus.KERNELS`): numba costs ~0.3 s to
import, and the import compiles the kernels' explicit signatures (or loads them from numba's disk
cache). Run with ``NUMBA_DISABLE_JIT=1``, the same source runs interpreted.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

__all__ = ["delassus", "contact_state", "outcome", "jit_seconds", "READY", "DECLINED", "U_NOT_FINITE", "SPEED_INF"]

# status codes of :func:`contact_state`
READY, DECLINED, U_NOT_FINITE, SPEED_INF = 0, 1, 2, 3

# Explicit signatures, compiled (or loaded from the cache) on import: read-only arrays of any layout, so
# that one machine code serves every caller (a frozen metric's J, Pinocchio's column-major U, a user's
# read-only v); numba would otherwise compile a specialisation, for seconds, at the first call of each.
_IN1, _IN2 = types.Array(types.float64, 1, "A", readonly=True), types.Array(types.float64, 2, "A", readonly=True)
_OUT1, _OUT2 = types.float64[::1], types.float64[:, ::1]
_DELASSUS = types.Tuple((_OUT2, _OUT2, types.boolean))(_IN2, _IN1, _IN2)
_STATE = types.Tuple((types.int64, _OUT1, _OUT2, _OUT2, types.float64, types.float64))(
    _IN2, _IN1, _IN2, _IN2, types.float64, types.float64)
_OUTCOME = types.boolean(_IN2, _IN2, types.float64, _IN2, _IN2, _IN1, _IN1, _OUT1)

# half the largest float: a W whose |W_ij| sum below it cannot overflow in any sum the laws form
_HALF_MAX = 0.5 * 1.7976931348623157e308


@njit(_DELASSUS, cache=True, error_model="numpy")
def delassus(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64]
             ) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:  # pragma: no cover — compiled
    """A⁻¹Jᵀ (as its transpose) and W = J A⁻¹ Jᵀ for A = U D Uᵀ.

    Parameters
    ----------
    U : ndarray, shape (n, n)
        Unit upper triangular factor (Pinocchio's ``data.U``, read in place).
    D : ndarray, shape (n,)
        Pivots, all > 0 (Pinocchio's ``data.D``).
    J : ndarray, shape (d, n)
        Contact Jacobian.

    Returns
    -------
    Yt : ndarray, shape (d, n)
        (A⁻¹Jᵀ)ᵀ: row r is A⁻¹ J_r, by U y = J_r, z = y / D, Uᵀ x = z.
    W : ndarray, shape (d, d)
        ½(J Y + (J Y)ᵀ), exactly symmetric.
    finite : bool
        Whether every entry of Yt and W is finite and the |W_ij| sum below half the largest
        float (else the caller names the overflow).
    """
    d, n = J.shape
    Yt = np.empty((d, n))
    for r in range(d):
        y = Yt[r]
        for i in range(n - 1, -1, -1):  # U y = J_r: back substitution, unit diagonal
            s = J[r, i]
            for k in range(i + 1, n):
                s -= U[i, k] * y[k]
            y[i] = s
        for i in range(n):
            y[i] /= D[i]
        for i in range(n):  # Uᵀ x = z: forward substitution, unit diagonal
            s = y[i]
            for k in range(i):
                s -= U[k, i] * y[k]
            y[i] = s
    W = np.empty((d, d))
    total, check = 0.0, 0.0
    for a in range(d):
        for b in range(a, d):
            s, t = 0.0, 0.0
            for k in range(n):
                s += J[a, k] * Yt[b, k]
                t += J[b, k] * Yt[a, k]
            w = 0.5 * (s + t)
            W[a, b] = w
            W[b, a] = w
            total += abs(w) * (1.0 if a == b else 2.0)
    for r in range(d):
        for k in range(n):
            check += Yt[r, k]
    finite = math.isfinite(check) and total < _HALF_MAX
    return Yt, W, finite


@njit(_STATE, cache=True, error_model="numpy")
def contact_state(J: NDArray[np.float64], v: NDArray[np.float64], W: NDArray[np.float64], R: NDArray[np.float64],
                  degenerate: float, rank_floor: float
                  ) -> tuple[int, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float, float
                             ]:  # pragma: no cover — compiled
    """One spatial impact in the form every law takes it: unit speed, W of unit trace, local frame.

    The laws are homogeneous of degree 1 in u and −1 in W (1°), so they see u / |u| and
    Rᵀ W R / tr W whatever the units and scale of the mechanism (no over- or underflow inside them).

    Parameters
    ----------
    J : ndarray, shape (3, n)
    v : ndarray, shape (n,)
    W : ndarray, shape (3, 3)
        Delassus matrix (world-aligned).
    R : ndarray, shape (3, 3)
        Contact frame, last column n⁰.
    degenerate : float
        n⁰ᵀWn⁰ ≤ degenerate · tr W means n⁰ is out of reach.
    rank_floor : float
        det W / (tr W)³ ≤ rank_floor means W is (nearly) rank-deficient.

    Returns
    -------
    status : int
        :data:`READY`; :data:`DECLINED` for what the general route treats or names (no approach, n⁰
        out of reach, a rank-deficient W); :data:`U_NOT_FINITE`; :data:`SPEED_INF` (|u| overflows).
    u : ndarray, shape (3,)
        Contact velocity J v.
    W_local : ndarray, shape (3, 3)
        Rᵀ W R / tr(Rᵀ W R).
    U_local : ndarray, shape (1, 3)
        uᵀR / |u|.
    speed, w_scale : float
        |u| and tr(Rᵀ W R).
    """
    n = v.shape[0]
    u = np.empty(3)
    Wl = np.empty((3, 3))
    Ul = np.empty((1, 3))
    for i in range(3):
        s = 0.0
        for k in range(n):
            s += J[i, k] * v[k]
        u[i] = s
    if not math.isfinite(u[0] + u[1] + u[2]):
        return U_NOT_FINITE, u, Wl, Ul, 0.0, 0.0
    n0, n1, n2 = R[0, 2], R[1, 2], R[2, 2]
    if not u[0] * n0 + u[1] * n1 + u[2] * n2 < 0.0:
        return DECLINED, u, Wl, Ul, 0.0, 0.0
    tr = 0.0 + W[0, 0] + W[1, 1] + W[2, 2]
    wnn = (n0 * (W[0, 0] * n0 + W[0, 1] * n1 + W[0, 2] * n2) + n1 * (W[1, 0] * n0 + W[1, 1] * n1 + W[1, 2] * n2)
           + n2 * (W[2, 0] * n0 + W[2, 1] * n1 + W[2, 2] * n2))
    if not (tr > 0.0 and wnn > degenerate * tr):
        return DECLINED, u, Wl, Ul, 0.0, 0.0
    a, b, c, d, e, f, g, h, k = (W[0, 0] / tr, W[0, 1] / tr, W[0, 2] / tr, W[1, 0] / tr, W[1, 1] / tr, W[1, 2] / tr,
                                 W[2, 0] / tr, W[2, 1] / tr, W[2, 2] / tr)
    if not a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g) > rank_floor:
        return DECLINED, u, Wl, Ul, 0.0, 0.0
    big = max(abs(u[0]), abs(u[1]), abs(u[2]))
    t0, t1, t2 = u[0] / big, u[1] / big, u[2] / big
    speed = big * math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    if speed == math.inf:
        return SPEED_INF, u, Wl, Ul, speed, 0.0
    for i in range(3):  # Rᵀ W R (exact when R is the identity)
        for j in range(3):
            s = 0.0
            for p in range(3):
                s += R[p, i] * (W[p, 0] * R[0, j] + W[p, 1] * R[1, j] + W[p, 2] * R[2, j])
            Wl[i, j] = s
    w_scale = Wl[0, 0] + Wl[1, 1] + Wl[2, 2]
    for i in range(3):
        for j in range(3):
            Wl[i, j] /= w_scale
        Ul[0, i] = (u[0] * R[0, i] + u[1] * R[1, i] + u[2] * R[2, i]) / speed
    return READY, u, Wl, Ul, speed, w_scale


@njit(_OUTCOME, cache=True, error_model="numpy")
def outcome(P_local: NDArray[np.float64], R: NDArray[np.float64], scale: float, Yt: NDArray[np.float64],
            W: NDArray[np.float64], u: NDArray[np.float64], v: NDArray[np.float64], out: NDArray[np.float64]
            ) -> bool:  # pragma: no cover — compiled
    """The impact's outcome by Lagrange's equations (1.1) from a law's local unit impulse.

    Parameters
    ----------
    P_local : ndarray, shape (1, 3)
        The law's impulse for the unit velocity and unit-trace W of :func:`contact_state`.
    R : ndarray, shape (3, 3)
    scale : float
        |u| / tr(RᵀWR): the impulse of the physical u and W (homogeneity, 1°).
    Yt : ndarray, shape (3, n)
        (A⁻¹Jᵀ)ᵀ.
    W : ndarray, shape (3, 3)
    u, v : ndarray, shapes (3,), (n,)
    out : ndarray, shape (6 + 2n,)
        Filled with P = R P_local · scale (world-aligned contact impulse), u₊ = u + W P, Δv = A⁻¹JᵀP
        and v₊ = v + Δv, in this order (one buffer: an array returned by a compiled function costs
        more to hand back to Python than a view costs to take).

    Returns
    -------
    bool
        Whether every entry of P, v₊ and u₊ is finite.
    """
    n = v.shape[0]
    for i in range(3):
        out[i] = (R[i, 0] * P_local[0, 0] + R[i, 1] * P_local[0, 1] + R[i, 2] * P_local[0, 2]) * scale
    p0, p1, p2 = out[0], out[1], out[2]
    total = 0.0
    for i in range(3):
        out[3 + i] = u[i] + (W[i, 0] * p0 + W[i, 1] * p1 + W[i, 2] * p2)
        total += out[3 + i] + out[i]
    for k in range(n):
        x = Yt[0, k] * p0 + Yt[1, k] * p1 + Yt[2, k] * p2
        out[6 + k] = x
        out[6 + n + k] = v[k] + x
        total += out[6 + n + k]
    return math.isfinite(total)


def jit_seconds() -> float:
    """Wall time of one call of each kernel once the module is imported: ~0, since the import itself
    compiles the explicit signatures, or loads them from numba's on-disk cache."""
    start = time.perf_counter()
    delassus(np.eye(2), np.ones(2), np.ones((1, 2)))
    J, v, R = np.eye(3), -np.ones(3), np.eye(3)
    _, u, Wl, Ul, speed, w_scale = contact_state(J, v, np.eye(3), R, 1e-14, 1e-12)
    outcome(Ul, R, speed / w_scale, J, np.eye(3), u, v, np.empty(12))
    return time.perf_counter() - start

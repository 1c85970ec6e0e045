"""The compiled core of the contact metric and of one impact, on Pinocchio's factor of A(q).

``pin.cholesky.decompose`` leaves A = U D Uᵀ in the workspace (U unit upper triangular, D the
pivots). One impact needs A⁻¹Jᵀ (d ≤ 3 solves) and the Delassus matrix W = J A⁻¹ Jᵀ; from Python
that is a Pinocchio call per column, an assembly and a product, each costing a single impact more
than its arithmetic. :func:`delassus` does all of it in one compiled call on the factor's own
memory. The solves are the factor's triangular solves, as backward stable as Pinocchio's, so W
is as accurate as with ``pin.cholesky.solve``.

A single spatial impact runs whole in two calls around the law: :func:`prepare_factor` (or
:func:`prepare_metric` for a metric already built) computes the metric, the checks and the state
the laws take (unit speed, W of unit trace, local frame), and :func:`finish` the outcome (1.1).
Both work in one buffer whose head is the result (:meth:`mbimpact.ImpactResult.from_buffer`).

Imported on first use only (:data:`mbimpact.metric.delassus.KERNELS`): numba costs ~0.3 s to
import. Each kernel compiles its explicit signature (or loads it from numba's disk cache) on its first
call (:func:`mbimpact.common.compiled.kernel`). Run with ``NUMBA_DISABLE_JIT=1``, the same source runs
interpreted.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

from ..common.compiled import kernel

__all__ = ["delassus", "prepare_factor", "prepare_metric", "finish", "single_size", "local_views", "solve_factor",
           "pivots_valid", "world_delassus", "prepare_into", "finish_into", "jit_seconds", "READY", "DECLINED", "U_NOT_FINITE",
           "SPEED_INF", "NEAR_SINGULAR", "FULL_RANK_RATIO"]

#: Status codes of :func:`prepare_factor` and :func:`prepare_metric`: the law may run; the general
#: route treats or names the case (no approach, n⁰ out of reach, an overflowing W, a singular A); J v
#: is not finite; |u| overflows; W is nearly rank-deficient (det W / (tr W)³ ≤ rank_floor, and
#: λ_min ≤ :data:`FULL_RANK_RATIO` tr W): the general route, whose range projector may cut it, takes it.
READY, DECLINED, U_NOT_FINITE, SPEED_INF, NEAR_SINGULAR = 0, 1, 2, 3, 4

#: λ_min / tr W above which a W that the determinant screens is kept whole (W − FULL_RANK_RATIO tr(W) I
#: positive definite): then λ_min > 1e-11 tr W ≥ 1e-11 λ_max, above the 1e-12 λ_max below which
#: :attr:`mbimpact.metric.ContactMetric.range_projector` cuts an eigenvalue, by a margin of 10 for
#: rounding. (Defined here, not imported: numba freezes it into this module's cached machine code, which
#: is rebuilt when this file changes.)
FULL_RANK_RATIO = 1e-11

# Explicit signatures, compiled (or loaded from the cache) on first use: read-only arrays of any layout, so
# that one machine code serves every caller (a frozen metric's J, Pinocchio's column-major U, a user's
# read-only v); numba would otherwise compile a specialisation, for seconds, at the first call of each.
_IN1, _IN2 = types.Array(types.float64, 1, "A", readonly=True), types.Array(types.float64, 2, "A", readonly=True)
_OUT1, _OUT2 = types.float64[::1], types.float64[:, ::1]
_F = types.float64
_DELASSUS = types.Tuple((_OUT2, _OUT2, types.boolean))(_IN2, _IN1, _IN2)
_PREPARE_FACTOR = types.Tuple((types.int64, _F, _F))(_IN2, _IN1, _IN2, _IN1, _IN2, _F, _F, _OUT1)
_PREPARE_METRIC = types.Tuple((types.int64, _F, _F))(_IN2, _IN2, _IN2, _IN1, _IN2, _F, _F, _OUT1)
_FINISH = types.Tuple((types.boolean, _F))(_IN2, _IN2, _F, _OUT1)

# half the largest float: a W whose |W_ij| sum below it cannot overflow in any sum the laws form
_HALF_MAX = 0.5 * 1.7976931348623157e308


# ---------------------------------------------------------------------------------------------------
# The buffer of one impact. Its head is the result, in the order ImpactResult.from_buffer reads it:
# v₋, v₊, Δv (n each), P, u₋, u₊, n⁰ (d each). A spatial impact of a rough law then keeps its work
# there too: W, W_local (9 each), U_local (3) and A⁻¹Jᵀ as (3, n) rows. One buffer, because every
# array a compiled function hands back costs a single impact more than a view of a buffer does.
def single_size(n: int) -> int:
    """Length of the buffer of one spatial impact of a mechanism with ``n`` velocities: 6n + 33."""
    return 6 * n + 33


def world_delassus(buffer: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """W (3, 3), world-aligned, as :func:`prepare_factor` and :func:`prepare_metric` leave it in ``buffer``."""
    w = 3 * n + 12
    return buffer[w:w + 9].reshape(3, 3)


def local_views(buffer: NDArray[np.float64], n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """W_local (3, 3) and U_local (1, 3), as :func:`prepare_factor` and :func:`prepare_metric` leave
    them in ``buffer``: what the law takes (:meth:`mbimpact.ImpactLaw.contact_impulses`)."""
    w = 3 * n + 21
    return buffer[w:w + 9].reshape(3, 3), buffer[w + 9:w + 12].reshape(1, 3)


@njit(cache=True, error_model="numpy", inline="always")
def solve_factor(U: NDArray[np.float64], D: NDArray[np.float64], y: NDArray[np.float64]) -> None:  # pragma: no cover
    """y ← A⁻¹ y for A = U D Uᵀ (U unit upper triangular): U z = y, z / D, Uᵀ x = z, in place."""
    n = y.shape[0]
    for i in range(n - 1, -1, -1):  # back substitution, unit diagonal
        s = y[i]
        for k in range(i + 1, n):
            s -= U[i, k] * y[k]
        y[i] = s
    for i in range(n):
        y[i] /= D[i]
    for i in range(n):  # forward substitution, unit diagonal
        s = y[i]
        for k in range(i):
            s -= U[k, i] * y[k]
        y[i] = s


@njit(cache=True, error_model="numpy", inline="always")
def pivots_valid(D: NDArray[np.float64]) -> bool:  # pragma: no cover — compiled
    """Every pivot finite and > 0: A positive definite."""
    for i in range(D.shape[0]):
        if not (D[i] > 0.0 and D[i] < math.inf):
            return False
    return True


@njit(cache=True, error_model="numpy")
def _delassus_into(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64],
                   Yt: NDArray[np.float64], W: NDArray[np.float64]) -> bool:  # pragma: no cover — compiled
    """:func:`delassus` into flat arrays: Yt (d n,) row after row, W (d d,)."""
    d, n = J.shape
    for r in range(d):
        y = Yt[r * n:(r + 1) * n]
        for k in range(n):
            y[k] = J[r, k]
        solve_factor(U, D, y)
    total, check = 0.0, 0.0
    for a in range(d):
        for b in range(a, d):
            s, t = 0.0, 0.0
            for k in range(n):
                s += J[a, k] * Yt[b * n + k]
                t += J[b, k] * Yt[a * n + k]
            w = 0.5 * (s + t)
            W[a * d + b] = w
            W[b * d + a] = w
            total += abs(w) * (1.0 if a == b else 2.0)
    for k in range(d * n):
        check += Yt[k]
    return math.isfinite(check) and total < _HALF_MAX


@kernel(_DELASSUS, error_model="numpy")
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
    Yt, W = np.empty(d * n), np.empty(d * d)
    finite = _delassus_into(U, D, J, Yt, W)
    return Yt.reshape((d, n)), W.reshape((d, d)), finite


@njit(cache=True, error_model="numpy", inline="always")
def _full_rank(W: NDArray[np.float64], tr: float) -> bool:  # pragma: no cover — compiled
    """Whether the range projector keeps all of W (9,) (row-major, trace ``tr``): W − τ I positive definite,
    τ = FULL_RANK_RATIO tr W, by the pivots of its Cholesky factorisation (backward stable: decided to
    ~ε tr W, where a closed form of the eigenvalues errs by up to ~1e-8 tr W for a nearly rank-1 W)."""
    tau = FULL_RANK_RATIO * tr
    d0 = W[0] - tau
    if not d0 > 0.0:
        return False
    l1, l2 = W[1] / d0, W[2] / d0
    d1 = (W[4] - tau) - l1 * W[1]
    if not d1 > 0.0:
        return False
    r = W[5] - l2 * W[1]
    return (W[8] - tau) - l2 * W[2] - (r / d1) * r > 0.0


@njit(cache=True, error_model="numpy")
def _state(J: NDArray[np.float64], v: NDArray[np.float64], R: NDArray[np.float64], degenerate: float,
           rank_floor: float, buf: NDArray[np.float64]) -> tuple[int, float, float]:  # pragma: no cover — compiled
    """The state of one spatial impact as every law takes it, from the W and A⁻¹Jᵀ already in ``buf``:
    v₋, u₋ = J v, n⁰, W_local = Rᵀ W R / tr(Rᵀ W R) and U_local = uᵀR / |u| (see :func:`prepare_factor`)."""
    n = v.shape[0]
    o = 3 * n  # P, then u₋ at o + 3, u₊ at o + 6, n⁰ at o + 9, W at o + 12, W_local at o + 21, U_local at o + 30
    for k in range(n):
        buf[k] = v[k]
    n0, n1, n2 = R[0, 2], R[1, 2], R[2, 2]
    buf[o + 9], buf[o + 10], buf[o + 11] = n0, n1, n2
    for i in range(3):
        s = 0.0
        for k in range(n):
            s += J[i, k] * v[k]
        buf[o + 3 + i] = s
    u0, u1, u2 = buf[o + 3], buf[o + 4], buf[o + 5]
    if not math.isfinite(u0 + u1 + u2):
        return U_NOT_FINITE, 0.0, 0.0
    if not u0 * n0 + u1 * n1 + u2 * n2 < 0.0:
        return DECLINED, 0.0, 0.0
    W = buf[o + 12:o + 21]
    tr = 0.0 + W[0] + W[4] + W[8]
    wnn = (n0 * (W[0] * n0 + W[1] * n1 + W[2] * n2) + n1 * (W[3] * n0 + W[4] * n1 + W[5] * n2)
           + n2 * (W[6] * n0 + W[7] * n1 + W[8] * n2))
    if not (tr > 0.0 and wnn > degenerate * tr):
        return DECLINED, 0.0, 0.0
    a, b, c, d, e, f, g, h, k = (W[0] / tr, W[1] / tr, W[2] / tr, W[3] / tr, W[4] / tr, W[5] / tr,
                                 W[6] / tr, W[7] / tr, W[8] / tr)
    # the determinant screens; a Cholesky test of W − τ I decides (a W whose eigenvalues are 1e7 apart, an
    # arm stretched out, is nearly singular by its determinant but kept whole by the range projector)
    if not a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g) > rank_floor and not _full_rank(W, tr):
        return NEAR_SINGULAR, 0.0, 0.0
    big = max(abs(u0), abs(u1), abs(u2))
    t0, t1, t2 = u0 / big, u1 / big, u2 / big
    speed = big * math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    if speed == math.inf:
        return SPEED_INF, speed, 0.0
    Wl = buf[o + 21:o + 30]
    for i in range(3):  # Rᵀ W R (exact when R is the identity)
        for j in range(3):
            s = 0.0
            for p in range(3):
                s += R[p, i] * (W[3 * p] * R[0, j] + W[3 * p + 1] * R[1, j] + W[3 * p + 2] * R[2, j])
            Wl[3 * i + j] = s
    w_scale = Wl[0] + Wl[4] + Wl[8]
    for i in range(9):
        Wl[i] /= w_scale
    for i in range(3):
        buf[o + 30 + i] = (u0 * R[0, i] + u1 * R[1, i] + u2 * R[2, i]) / speed
    return READY, speed, w_scale


@njit(cache=True, error_model="numpy", inline="always")
def prepare_into(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], v: NDArray[np.float64],
                 R: NDArray[np.float64], degenerate: float, rank_floor: float, buf: NDArray[np.float64]
                 ) -> tuple[int, float, float]:  # pragma: no cover — compiled
    """:func:`prepare_factor` without its explicit signature: for other kernels that run one impact whole
    (:mod:`mbimpact.laws.compiled_cone`, :mod:`mbimpact.laws.coulomb_kernels`), compiled into them for their own
    array types."""
    n = v.shape[0]
    if not pivots_valid(D):
        return DECLINED, 0.0, 0.0
    o = 3 * n + 12
    if not _delassus_into(U, D, J, buf[o + 21:o + 21 + 3 * n], buf[o:o + 9]):
        return DECLINED, 0.0, 0.0
    return _state(J, v, R, degenerate, rank_floor, buf)


@kernel(_PREPARE_FACTOR, error_model="numpy")
def prepare_factor(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], v: NDArray[np.float64],
                   R: NDArray[np.float64], degenerate: float, rank_floor: float, buf: NDArray[np.float64]
                   ) -> tuple[int, float, float]:  # pragma: no cover — compiled
    """One spatial impact of a mechanism, up to the law: the metric from Pinocchio's factor of A(q)
    (as :func:`delassus`) and the state the laws take, unit speed, W of unit trace, local frame.

    The laws are homogeneous of degree 1 in u and −1 in W (1°), so they see u / |u| and
    Rᵀ W R / tr W whatever the units and scale of the mechanism (no over- or underflow inside them).

    Parameters
    ----------
    U, D : ndarray, shapes (n, n), (n,)
        The factor A = U D Uᵀ (Pinocchio's ``data.U``, ``data.D``, read in place).
    J : ndarray, shape (3, n)
    v : ndarray, shape (n,)
    R : ndarray, shape (3, 3)
        Contact frame, last column n⁰.
    degenerate : float
        n⁰ᵀWn⁰ ≤ degenerate · tr W means n⁰ is out of reach.
    rank_floor : float
        det W / (tr W)³ ≤ rank_floor screens W as nearly rank-deficient; it is, for this route, where
        λ_min ≤ :data:`FULL_RANK_RATIO` tr W too (a Cholesky test of W − τ I). −inf skips the screen.
    buf : ndarray, shape (6n + 33,)
        Filled with v₋, u₋ = J v and n⁰ at their places in the result (:func:`single_size`), and
        with W, W_local (:func:`local_views`), U_local and A⁻¹Jᵀ after it.

    Returns
    -------
    status : int
        :data:`READY`; :data:`DECLINED` for what the general route treats or names (A(q) not
        positive definite, W overflowing, no approach, n⁰ out of reach); :data:`U_NOT_FINITE`;
        :data:`SPEED_INF` (|u| overflows); :data:`NEAR_SINGULAR` (W is nearly rank-deficient: the range projector
        of the general route may cut it; W, at its place in ``buf``, is filled, the rest of the state is
        not).
    speed, w_scale : float
        |u| and tr(Rᵀ W R).
    """
    return prepare_into(U, D, J, v, R, degenerate, rank_floor, buf)


@kernel(_PREPARE_METRIC, error_model="numpy")
def prepare_metric(Yt: NDArray[np.float64], W: NDArray[np.float64], J: NDArray[np.float64], v: NDArray[np.float64],
                   R: NDArray[np.float64], degenerate: float, rank_floor: float, buf: NDArray[np.float64]
                   ) -> tuple[int, float, float]:  # pragma: no cover — compiled
    """:func:`prepare_factor` for a metric whose (A⁻¹Jᵀ)ᵀ ``Yt`` (3, n) and W (3, 3) are known
    (:class:`mbimpact.metric.ContactMetric`): they are copied into ``buf``, the rest is the same."""
    n = v.shape[0]
    o = 3 * n + 12
    for i in range(3):
        for j in range(3):
            buf[o + 3 * i + j] = W[i, j]
        for k in range(n):
            buf[o + 21 + i * n + k] = Yt[i, k]
    return _state(J, v, R, degenerate, rank_floor, buf)


@njit(cache=True, error_model="numpy", inline="always")
def finish_into(P_local: NDArray[np.float64], R: NDArray[np.float64], scale: float, buf: NDArray[np.float64]
                ) -> tuple[bool, float]:  # pragma: no cover — compiled
    """:func:`finish` without its explicit signature, for kernels that run one impact whole."""
    n = (buf.shape[0] - 33) // 6
    o = 3 * n
    for i in range(3):
        buf[o + i] = (R[i, 0] * P_local[0, 0] + R[i, 1] * P_local[0, 1] + R[i, 2] * P_local[0, 2]) * scale
    p0, p1, p2 = buf[o], buf[o + 1], buf[o + 2]
    total = 0.0 + p0 + p1 + p2
    W = buf[o + 12:o + 21]
    un_plus = 0.0
    for i in range(3):
        x = buf[o + 3 + i] + (W[3 * i] * p0 + W[3 * i + 1] * p1 + W[3 * i + 2] * p2)
        buf[o + 6 + i] = x
        total += x
        un_plus += buf[o + 9 + i] * x
    y = o + 33
    for k in range(n):
        x = buf[y + k] * p0 + buf[y + n + k] * p1 + buf[y + 2 * n + k] * p2
        buf[2 * n + k] = x
        buf[n + k] = buf[k] + x
        total += buf[n + k]
    return math.isfinite(total), un_plus


@kernel(_FINISH, error_model="numpy")
def finish(P_local: NDArray[np.float64], R: NDArray[np.float64], scale: float, buf: NDArray[np.float64]
           ) -> tuple[bool, float]:  # pragma: no cover — compiled
    """The impact's outcome by Lagrange's equations (1.1) from a law's local unit impulse.

    Parameters
    ----------
    P_local : ndarray, shape (1, 3)
        The law's impulse for the unit velocity and unit-trace W of :func:`prepare_factor`.
    R : ndarray, shape (3, 3)
    scale : float
        |u| / tr(RᵀWR): the impulse of the physical u and W (homogeneity, 1°).
    buf : ndarray, shape (6n + 33,)
        As :func:`prepare_factor` left it; filled with P = R P_local · scale (world-aligned contact
        impulse), u₊ = u₋ + W P, Δv = A⁻¹JᵀP and v₊ = v₋ + Δv at their places in the result.

    Returns
    -------
    finite : bool
        Whether every entry of P, v₊ and u₊ is finite.
    un_plus : float
        n⁰ · u₊, the normal contact velocity after the impact.
    """
    return finish_into(P_local, R, scale, buf)


def jit_seconds() -> float:
    """Wall time to make the four kernels callable in this process (numba's import excluded): their machine
    code loaded from numba's on-disk cache, or compiled when that cache is missing or stale."""
    start = time.perf_counter()
    U, D, J, v, R = np.eye(3), np.ones(3), np.eye(3), -np.ones(3), np.eye(3)
    delassus(U, D, J)
    buf = np.empty(single_size(3))
    prepare_factor(U, D, J, v, R, 1e-14, 1e-12, buf)
    status, speed, w_scale = prepare_metric(J, np.eye(3), J, v, R, 1e-14, 1e-12, buf)
    finish(local_views(buf, 3)[1], R, speed / w_scale, buf)
    return time.perf_counter() - start

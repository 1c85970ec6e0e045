"""Newton's impact (1.2) of a mechanism, compiled on Pinocchio's factor of A(q): one solve along n⁰ᵀJ.

Δv = P_n y with y = A⁻¹ Jᵀn⁰ by the factor A = U D Uᵀ (what ``pin.impulseDynamics`` solves) and
P_n = −(1 + e) n⁰ᵀJ v / (n⁰ᵀJ y): no Delassus matrix. :func:`newton_impact` is one impact and
:func:`newton_batch` many at their own configurations, in the convention of
:class:`mbimpact.laws.compiled.CompiledImpact`. A (nearly) rank-deficient J stays here: Newton's impulse
is P_n n⁰ whatever the rank, and Δv = P_n y is exact.

Imported on first use (numba costs ~0.3 s to import); each kernel compiles its explicit signature, or
loads it from numba's disk cache, on its first call (:func:`mbimpact.common.compiled.kernel`).
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

from ..common.compiled import kernel
from ..metric.kernels import pivots_valid, single_size, solve_factor

__all__ = ["newton_impact", "newton_batch", "jit_seconds"]

# the statuses of mbimpact.laws.compiled: settled (by the first method), not prepared
_SETTLED, _NOT_PREPARED = 0, -2

_IN1, _IN2 = types.Array(types.float64, 1, "A", readonly=True), types.Array(types.float64, 2, "A", readonly=True)
_IN3 = types.Array(types.float64, 3, "A", readonly=True)
_F, _I = types.float64, types.int64
_OUT1, _OUT2 = types.float64[::1], types.float64[:, ::1]
_SINGLE = types.Tuple((_I, _I, _F, _F, _F, _F, types.boolean))(_IN2, _IN1, _IN2, _IN1, _IN2, _F, _F, _F, _OUT1)
_BATCH = types.none(_IN3, _IN2, _IN3, _IN2, _IN3, _F, _F, _F, _OUT2, types.int64[::1], types.int64[::1], _OUT2)


@njit(cache=True, error_model="numpy", inline="always")
def _impact(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], v: NDArray[np.float64],
            R: NDArray[np.float64], e: float, buf: NDArray[np.float64]) -> tuple[bool, float]:  # pragma: no cover
    """The impact into ``buf`` (v₋, v₊, Δv, P, u₋, u₊, n⁰): whether it is filled and finite, and n⁰ · u₊.
    Not filled: A(q) not positive definite, no approach, n⁰ out of reach (|n⁰ᵀJ|² ≤ 1e-8 |J|²)."""
    d, n = J.shape
    if not pivots_valid(D):
        return False, 0.0
    o = 3 * n
    jn = buf[n:2 * n]  # n⁰ᵀJ, in the place of v₊ until that is computed
    y = buf[2 * n:3 * n]  # A⁻¹ Jᵀn⁰, then Δv in place
    jj, un, jnjn = 0.0, 0.0, 0.0
    for k in range(n):
        s = 0.0
        for i in range(d):
            x = J[i, k]
            jj += x * x
            s += R[i, d - 1] * x
        jn[k] = s
        y[k] = s
        un += s * v[k]
        jnjn += s * s
    if not (un < 0.0 and jj < math.inf and jnjn > 1e-8 * jj):
        return False, 0.0
    solve_factor(U, D, y)
    wnn = 0.0
    for k in range(n):
        wnn += jn[k] * y[k]
    if not wnn > 0.0:
        return False, 0.0
    Pn = -(1.0 + e) * un / wnn
    total = Pn
    for k in range(n):
        x = Pn * y[k]
        y[k] = x
        buf[k] = v[k]
        buf[n + k] = v[k] + x
        total += buf[n + k]
    un_plus = 0.0
    for i in range(d):
        ni = R[i, d - 1]
        buf[o + i] = Pn * ni
        buf[o + 3 * d + i] = ni
        s, t = 0.0, 0.0
        for k in range(n):
            s += J[i, k] * v[k]
            t += J[i, k] * y[k]
        buf[o + d + i] = s
        buf[o + 2 * d + i] = s + t
        total += s + t
        un_plus += ni * (s + t)
    return math.isfinite(total), un_plus


@kernel(_SINGLE, error_model="numpy")
def newton_impact(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], v: NDArray[np.float64],
                  R: NDArray[np.float64], degenerate: float, rank_floor: float, e: float, buf: NDArray[np.float64]
                  ) -> tuple[int, int, float, float, float, float, bool]:  # pragma: no cover — compiled
    """One spatial impact of a mechanism by Newton's law (1.2), whole.

    Parameters
    ----------
    U, D : ndarray, shapes (n, n), (n,)
        The factor A = U D Uᵀ.
    J : ndarray, shape (3, n)
    v : ndarray, shape (n,)
    R : ndarray, shape (3, 3)
        Contact frame, last column n⁰.
    degenerate, rank_floor : float
        Unused (the convention's: Newton's impulse needs no Delassus matrix).
    e : float
        Restitution.
    buf : ndarray, shape (6n + 33,)
        Filled with the result: v₋, v₊, Δv, P, u₋, u₊, n⁰.

    Returns
    -------
    (status, nodes, error, speed, w_scale, un_plus, finite)
        Status 0 (settled) or −2 (not prepared: the pipeline names or treats the case); nodes 1, error 0,
        speed and w_scale 1 (read by nothing), n⁰ · u₊ ≥ 0, and whether the result is finite.
    """
    filled, un_plus = _impact(U, D, J, v, R, e, buf)
    if not filled:
        return _NOT_PREPARED, 1, 0.0, 1.0, 1.0, 0.0, True
    return _SETTLED, 1, 0.0, 1.0, 1.0, un_plus, True


@kernel(_BATCH, error_model="numpy", nogil=True)
def newton_batch(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], V: NDArray[np.float64],
                 R: NDArray[np.float64], degenerate: float, rank_floor: float, e: float, buf: NDArray[np.float64],
                 status: NDArray[np.int64], nodes: NDArray[np.int64], stats: NDArray[np.float64]
                 ) -> None:  # pragma: no cover — compiled
    """:func:`newton_impact` for B rows, each at its own configuration (shapes (B, …) of its arguments);
    ``stats`` (B, 5): error 0, speed and w_scale 1, n⁰ · u₊, and 1.0 where the row is finite."""
    for i in range(V.shape[0]):
        filled, un_plus = _impact(U[i], D[i], J[i], V[i], R[i], e, buf[i])
        status[i], nodes[i] = (_SETTLED if filled else _NOT_PREPARED), 1
        stats[i, 0], stats[i, 1], stats[i, 2], stats[i, 3] = 0.0, 1.0, 1.0, un_plus
        stats[i, 4] = 1.0 if filled and un_plus == un_plus else 0.0


def jit_seconds() -> float:
    """Wall time to make both kernels callable in this process (numba's import excluded): their machine
    code loaded from numba's on-disk cache, or compiled when that cache is missing or stale."""
    start = time.perf_counter()
    U, D, J, v, R = np.eye(3), np.ones(3), np.eye(3), -np.ones(3), np.eye(3)
    newton_impact(U, D, J, v, R, 1e-14, 1e-12, 0.5, np.empty(single_size(3)))
    newton_batch(U[None], D[None], J[None], v[None], R[None], 1e-14, 1e-12, 0.5, np.empty((1, single_size(3))),
                 np.empty(1, np.int64), np.empty(1, np.int64), np.empty((1, 5)))
    return time.perf_counter() - start

"""The compiled core of :class:`~mbimpact.CoulombLaw`: one impact per row, phase by phase.

The algorithm :mod:`mbimpact.laws.coulomb` describes (closed forms for the phases of constant tangential
rate, :mod:`~mbimpact.laws.coulomb_core`; a Dormand–Prince 8(5,3) integration of the 3-D slip that still
turns, :mod:`~mbimpact.laws.coulomb_slip`), compiled by numba (``njit``, cached on disk) and imported on
first use only: numba costs ~0.3 s to import, more than ``import mbimpact`` may take.

Entry points: :func:`impact_rows`, the rows of a batch at one Delassus matrix (what
:meth:`mbimpact.CoulombLaw.contact_impulses` calls); :func:`coulomb_impact` and :func:`coulomb_batch`, a
mechanism's whole spatial impact on Pinocchio's factor of A(q), one or many, in the convention of
:class:`mbimpact.laws.compiled.CompiledImpact`. All take the law as the tuple of :data:`LAW_SIZE` floats
``(μ, e, restitution, rtol, jam, u_n zero, stop, max phases, max steps, rank cut, degenerate)``.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

from ..common.compiled import kernel
from ..metric.kernels import READY, finish_into, prepare_into, single_size
from .coulomb_core import (BAD_TRACE, CAN_STICK, COMP, D, DEGENERATE, DET, ENERGETIC, FREE, INFINITE, INFO, JAMMED,
                           LAW_SIZE, MAX_PHASES, MODES, MU, NEWTON, NO_END, OUT_OF_REACH, P, PC, POISSON, PT1, PT2,
                           RESLIP_MODE, ROW_SIZE, RTOL, SLIP, STALLED, STEPS, STICK, TOO_MANY_PHASES, TOO_MANY_STEPS,
                           TR, U1, U2, UN0, W33, WC, WK, constant_phase, setup, stopped_mode, whole_impact)
from .coulomb_slip import turning_slip

__all__ = ["impact_rows", "coulomb_impact", "coulomb_batch", "jit_seconds", "NEWTON", "POISSON", "ENERGETIC",
           "MODES", "LAW_SIZE", "JAMMED", "NO_END", "INFINITE", "STALLED", "TOO_MANY_STEPS", "TOO_MANY_PHASES",
           "BAD_TRACE", "OUT_OF_REACH"]

# the statuses of mbimpact.laws.compiled: settled (by the first method), not prepared
_SETTLED, _NOT_PREPARED = 0, -2


@njit(cache=True, error_model="numpy")
def _run(S: NDArray[np.float64], X: NDArray[np.float64]) -> int:
    """One impact from u₋ = X[U1, U2, UN0]: the impulse into X[PT1], X[PT2], X[P] (for W / tr W) and
    the integration steps into X[STEPS]; returns the status."""
    X[P] = X[PT1] = X[PT2] = X[WK] = X[PC] = X[WC] = X[STEPS] = 0.0
    X[COMP] = 1.0
    v1, v2 = X[U1], X[U2]
    r = math.sqrt(v1 * v1 + v2 * v2)
    if whole_impact(S, X, r):
        return 0
    mu = S[MU]
    straight, d1, d2 = False, 0.0, 0.0  # the slip direction of a straight slip
    if mu == 0.0:
        mode = FREE
    elif r == 0.0:
        mode = STICK if S[CAN_STICK] != 0.0 else RESLIP_MODE
    elif S[D] == 2.0:
        mode, straight, d1 = SLIP, True, math.copysign(1.0, v1)
    else:
        mode = SLIP  # not straight: a 3-D slip that may turn
    for _ in range(int(S[MAX_PHASES])):
        if mode == SLIP and not straight:
            status, done, mode, straight, d1, d2 = turning_slip(S, X)
            if status or done:
                return status
            continue
        status, done, stopped = constant_phase(S, X, mode, d1, d2)
        if status or done:
            return status
        if mode == SLIP and stopped:
            mode, straight = stopped_mode(S, X), False
    X[INFO] = X[P]
    return TOO_MANY_PHASES




@njit(cache=True, error_model="numpy", inline="always")
def _flat(W: NDArray[np.float64]) -> tuple[float, float, float, float, float, float, float, float, float, float]:
    """W (d, d) as :func:`~mbimpact.laws.coulomb_core.setup` takes it: (d, w11, w12, w13, w21, w22, w23, w31,
    w32, w33), a planar W in the corners (the second tangential axis 0)."""
    if W.shape[0] == 3:
        return (3.0, W[0, 0], W[0, 1], W[0, 2], W[1, 0], W[1, 1], W[1, 2], W[2, 0], W[2, 1], W[2, 2])
    return (2.0, W[0, 0], 0.0, W[0, 1], 0.0, 0.0, 0.0, W[1, 0], 0.0, W[1, 1])


_ANY2 = types.Array(types.float64, 2, "A", readonly=True)
_LAW = types.UniTuple(types.float64, LAW_SIZE)
_ROWS = types.Tuple((types.int64, types.int64, types.int64, types.float64, types.float64, types.float64,
                     types.float64))(_ANY2, _LAW, _ANY2, types.float64[:, ::1], types.float64[::1])


@kernel(_ROWS, error_model="numpy")
def impact_rows(W: NDArray[np.float64], law: tuple[float, ...], U: NDArray[np.float64], out: NDArray[np.float64],
                error: NDArray[np.float64]) -> tuple[int, int, int, float, float, float, float]:  # pragma: no cover
    """Impacts from the unit velocities ``U`` (B, d), local frame, at the Delassus matrix ``W`` (d, d).

    Writes the impulses into ``out`` (B, d) (for W itself: the core's, for W / tr W, divided by tr W)
    and the error estimates into ``error`` (B,): rtol where a turning slip was integrated, else 0.
    Returns (row, status, the most integration steps a row took, the four numbers of the failure's
    message): row −1 when every row was computed, else the first that failed (the rows after it are
    not computed); BAD_TRACE (tr W) comes before any row.
    """
    S = setup(_flat(W), law)
    tr = S[TR]
    if not (tr > 0.0 and math.isfinite(tr)):
        return 0, BAD_TRACE, 0, tr, 0.0, 0.0, 0.0
    d = U.shape[1]
    X = np.zeros(ROW_SIZE)
    most = 0
    for i in range(U.shape[0]):
        X[U1] = U[i, 0]
        X[U2] = U[i, 1] if d == 3 else 0.0
        X[UN0] = U[i, d - 1]
        status = _run(S, X)
        if status:
            return i, status, most, X[INFO], X[INFO + 1], X[INFO + 2], X[INFO + 3]
        out[i, 0] = X[PT1] / tr
        if d == 3:
            out[i, 1] = X[PT2] / tr
        out[i, d - 1] = X[P] / tr
        steps = int(X[STEPS])
        error[i] = S[RTOL] if steps > 0 else 0.0
        most = max(most, steps)
    return -1, 0, most, 0.0, 0.0, 0.0, 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _impact_into(U: NDArray[np.float64], D_: NDArray[np.float64], J: NDArray[np.float64], v: NDArray[np.float64],
                 R: NDArray[np.float64], degenerate: float, rank_floor: float, law: tuple[float, ...],
                 buf: NDArray[np.float64], impulse: NDArray[np.float64], X: NDArray[np.float64]
                 ) -> tuple[int, int, float, float, float, float, bool]:  # pragma: no cover — compiled
    """:func:`coulomb_impact`'s body, with the work arrays ``impulse`` (1, 3) and X (ROW_SIZE,) given."""
    prepared, speed, w_scale = prepare_into(U, D_, J, v, R, degenerate, rank_floor, buf)
    if prepared != READY:
        return _NOT_PREPARED, 0, 0.0, speed, w_scale, 0.0, True
    w0 = 3 * v.shape[0] + 21  # W_local (row-major), then U_local (mbimpact.metric.kernels.local_views)
    w = (3.0, buf[w0], buf[w0 + 1], buf[w0 + 2], buf[w0 + 3], buf[w0 + 4], buf[w0 + 5], buf[w0 + 6], buf[w0 + 7],
         buf[w0 + 8])
    S = setup(w, law)
    tr = S[TR]
    # a rank-deficient W, n⁰ out of reach, or a failure of the law: the pipeline names or treats it
    if not (tr > 0.0 and math.isfinite(tr)) or not S[W33] > S[DEGENERATE] or not S[DET] > 1e-12:
        return _NOT_PREPARED, 0, 0.0, speed, w_scale, 0.0, True
    X[U1], X[U2], X[UN0] = buf[w0 + 9], buf[w0 + 10], buf[w0 + 11]
    if _run(S, X):
        return _NOT_PREPARED, 0, 0.0, speed, w_scale, 0.0, True
    impulse[0, 0], impulse[0, 1], impulse[0, 2] = X[PT1] / tr, X[PT2] / tr, X[P] / tr
    finite, un_plus = finish_into(impulse, R, speed / w_scale, buf)
    steps = int(X[STEPS])
    return _SETTLED, max(steps, 1), (S[RTOL] if steps > 0 else 0.0), speed, w_scale, un_plus, finite


_IN1, _IN2 = types.Array(types.float64, 1, "A", readonly=True), types.Array(types.float64, 2, "A", readonly=True)
_IN3, _OUT2 = types.Array(types.float64, 3, "A", readonly=True), types.float64[:, ::1]
_F, _I = types.float64, types.int64
_SINGLE = types.Tuple((_I, _I, _F, _F, _F, _F, types.boolean))(_IN2, _IN1, _IN2, _IN1, _IN2, _F, _F, _LAW,
                                                                 types.float64[::1])
_BATCH = types.none(_IN3, _IN2, _IN3, _IN2, _IN3, _F, _F, _LAW, _OUT2, types.int64[::1], types.int64[::1], _OUT2)


@kernel(_SINGLE, error_model="numpy")
def coulomb_impact(U: NDArray[np.float64], D_: NDArray[np.float64], J: NDArray[np.float64], v: NDArray[np.float64],
                   R: NDArray[np.float64], degenerate: float, rank_floor: float, law: tuple[float, ...],
                   buf: NDArray[np.float64]) -> tuple[int, int, float, float, float, float, bool]:  # pragma: no cover
    """One spatial impact of a mechanism by the Coulomb law: metric, impact and outcome (1.1) in one call.

    Parameters
    ----------
    U, D_, J, v, R, degenerate, rank_floor
        As :func:`mbimpact.metric.kernels.prepare_factor`.
    law : tuple
        The law tuple.
    buf : ndarray, shape (6n + 33,)
        The impact's buffer (:func:`mbimpact.metric.kernels.single_size`); its head is the result.

    Returns
    -------
    (status, nodes, error, speed, w_scale, un_plus, finite)
        Status 0, or −2 for what the pipeline names or treats (what the metric does not prepare, n⁰ out
        of reach, a rank-deficient W, a failure of the law); the integration steps (1 for closed forms),
        the error estimate (rtol where a turning slip was integrated, else 0), |u₋|, tr(RᵀWR), n⁰ · u₊ and
        whether the outcome is finite.
    """
    return _impact_into(U, D_, J, v, R, degenerate, rank_floor, law, buf, np.empty((1, 3)), np.zeros(ROW_SIZE))


@kernel(_BATCH, error_model="numpy", nogil=True)
def coulomb_batch(U: NDArray[np.float64], D_: NDArray[np.float64], J: NDArray[np.float64], V: NDArray[np.float64],
                  R: NDArray[np.float64], degenerate: float, rank_floor: float, law: tuple[float, ...],
                  buf: NDArray[np.float64], status: NDArray[np.int64], nodes: NDArray[np.int64],
                  stats: NDArray[np.float64]) -> None:  # pragma: no cover — compiled
    """:func:`coulomb_impact` for B rows, each at its own configuration (shapes (B, …) of its arguments;
    ``status``, ``nodes`` (B,) and ``stats`` (B, 5) as :class:`mbimpact.laws.compiled.CompiledImpact` reads
    them)."""
    impulse, X = np.empty((1, 3)), np.zeros(ROW_SIZE)
    for i in range(V.shape[0]):
        code, count, error, speed, w_scale, un_plus, finite = _impact_into(U[i], D_[i], J[i], V[i], R[i], degenerate,
                                                                           rank_floor, law, buf[i], impulse, X)
        status[i], nodes[i] = code, count
        stats[i, 0], stats[i, 1], stats[i, 2], stats[i, 3] = error, speed, w_scale, un_plus
        stats[i, 4] = 1.0 if finite else 0.0


def jit_seconds() -> float:
    """Wall time to make the three kernels callable in this process (numba's import excluded): their machine
    code loaded from numba's on-disk cache, or compiled when that cache is missing or stale."""
    start = time.perf_counter()
    law = (0.5, 0.5, float(ENERGETIC), 1e-10, 1e-14, 1e-12, 1e-2, 64.0, 100.0, 1e-12, 1e-14)
    impact_rows(np.eye(3) / 3.0, law, np.array([[0.6, 0.0, -0.8]]), np.empty((1, 3)), np.empty(1))
    n = 3
    Uf, Df, J, v, R = np.eye(n), np.ones(n), np.eye(n), -np.ones(n), np.eye(3)
    coulomb_impact(Uf, Df, J, v, R, 1e-14, 1e-12, law, np.empty(single_size(n)))
    coulomb_batch(Uf[None], Df[None], J[None], v[None], R[None], 1e-14, 1e-12, law, np.empty((1, single_size(n))),
                  np.empty(1, np.int64), np.empty(1, np.int64), np.empty((1, 5)))
    return time.perf_counter() - start

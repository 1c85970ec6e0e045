"""The compiled single impact of a :class:`~mbimpact.RoughLaw` on a :class:`~mbimpact.Cone`, whole.

A rough impact of a mechanism runs the pipeline in three compiled steps: the metric and the state
the laws take (:func:`mbimpact.metric.kernels.prepare_factor`), the law (2.8) by the first averaging
method of ``"auto"`` that settles it, and the outcome (1.1) (:func:`mbimpact.metric.kernels.finish`).
For one velocity on a cone the methods ``"auto"`` tries are compiled too: ``"pole-pass"`` (the physical
flux) and then ``"graded-pass"`` where W is nearly singular and the kernels of (2.8) peak on the ring,
else ``"cone-pair"`` (n and 2n nodes), then ``"cone-pass"`` (the further levels). Between the steps,
Python's dispatch, the averaging registry's screens and the arrays handed back cost more than the
arithmetic. :func:`cone_impact` runs all of it in one call, with the same arithmetic (the steps' own
compiled functions) and the same decisions, so that its result is the three steps' to the last bit:

* the poles are taken out (:func:`~mbimpact.averaging.pole_kernels.pole_levels`) where the graded
  rule would run, with the physical flux; where that does not settle, the graded rule runs;
* the graded rule runs where :func:`~mbimpact.averaging.graded_kernels.graded_levels` finds a peak
  narrower than ``peaked`` (the test :class:`~mbimpact.averaging.GradedPass` makes after its
  closed-form screens of W, which only rule out what that test rules out);
* the cone's levels n, 2n, 4n, … run on one table and settle as ``"cone-pair"`` at 2n nodes,
  as ``"cone-pass"`` beyond (the pair's levels are not computed twice);
* what neither settles (a graded rule short of rtol, a degenerate facet, rounding, ``max_nodes``,
  or the last level of the tables it was given) is :data:`DECLINED`: the prepared state stays in
  the buffer, and ``"auto"`` goes on from it in Python (the same methods with every level, then
  ``"graded"``, ``"adaptive"``), which names or treats the case.

Imported on first use (:data:`mbimpact.laws.rough.KERNELS`); the import compiles the explicit
signature, or loads it from numba's disk cache.
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

from ..averaging import cone_kernels, graded_kernels, pole_kernels
from ..metric.kernels import READY, finish_into, prepare_into, single_size

__all__ = ["cone_impact", "cone_batch", "jit_seconds", "GRADED_PASS", "CONE_PAIR", "CONE_PASS", "POLE_PASS", "DECLINED",
           "NOT_PREPARED"]

#: Status codes of :func:`cone_impact`: settled by the method of that name (its index in
#: :data:`METHODS`); prepared but not settled by these methods; not prepared (the metric's status says why).
GRADED_PASS, CONE_PAIR, CONE_PASS, POLE_PASS, DECLINED, NOT_PREPARED = 0, 1, 2, 3, 4, 5

#: The names of the averaging methods, by status code.
METHODS = ("graded-pass", "cone-pair", "cone-pass", "pole-pass")

_IN1, _IN2 = types.Array(types.float64, 1, "A", readonly=True), types.Array(types.float64, 2, "A", readonly=True)
_F, _I = types.float64, types.int64
# the node tables C-contiguous: strided indexing would keep the node loops out of SIMD lanes
_TABLE = types.Array(types.float64, 2, "C", readonly=True)
_CONE_IMPACT = types.Tuple((_I, _I, _F, _F, _F, _F, types.boolean))(
    _IN2, _IN1, _IN2, _IN1, _IN2, _F, _F, _F, _TABLE, _I, _F, _TABLE, _I, _TABLE, _I, types.boolean, _F, _F,
    types.float64[::1])
# the stacks of a batch read as any strides (a caller's V may be a view), its outputs C-contiguous
_IN3, _OUT2 = types.Array(types.float64, 3, "A", readonly=True), types.float64[:, ::1]
_CONE_BATCH = types.none(_IN3, _IN2, _IN3, _IN2, _IN3, _F, _F, _F, _TABLE, _I, _F, _TABLE, _I, _TABLE, _I,
                         types.boolean, _F, _F, _OUT2, types.int64[::1], types.int64[::1], _OUT2)


@njit(cache=True, error_model="numpy", inline="always")
def _cone_impact_into(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], v: NDArray[np.float64],
                      R: NDArray[np.float64], degenerate: float, rank_floor: float, alpha: float,
                      graded_table: NDArray[np.float64], graded_levels: int, peaked: float,
                      cone_table: NDArray[np.float64], cone_levels: int, pole_table: NDArray[np.float64],
                      pole_levels: int, configuration: bool, e: float, rtol: float,
                      buf: NDArray[np.float64]) -> tuple[int, int, float, float, float, float, bool]:  # pragma: no cover
    """:func:`cone_impact` without its explicit signature: compiled into it and into :func:`cone_batch`
    for their own array types."""
    prepared, speed, w_scale = prepare_into(U, D, J, v, R, degenerate, rank_floor, buf)
    if prepared != READY:
        return NOT_PREPARED, prepared, 0.0, speed, w_scale, 0.0, True
    w = 3 * v.shape[0] + 21  # W_local, then U_local (mbimpact.metric.kernels.local_views)
    W_local, U_local = buf[w:w + 9].reshape((3, 3)), buf[w + 9:w + 12].reshape((1, 3))
    P, error = np.empty((1, 3)), np.empty(1)
    # "pole-pass" (the physical flux only), then "graded-pass": both where the kernels peak on the ring (the
    # same test), neither where they do not
    status, nodes = graded_kernels.NOT_PEAKED, 0
    if not configuration:
        status, nodes = pole_kernels.pole_levels(alpha, W_local, U_local, pole_table, pole_levels, peaked, e, rtol,
                                                 degenerate, P, error)
    if status == pole_kernels.SETTLED:
        code = POLE_PASS
    else:
        if configuration or status != graded_kernels.NOT_PEAKED:
            status, nodes = graded_kernels.graded_levels(alpha, W_local, U_local, graded_table, graded_levels,
                                                         peaked, configuration, e, rtol, degenerate, P, error)
        if status == graded_kernels.SETTLED:
            code = GRADED_PASS
        elif status != graded_kernels.NOT_PEAKED:  # "graded" (numpy) takes over
            return DECLINED, nodes, 0.0, speed, w_scale, 0.0, True
        else:
            status, nodes = cone_kernels.adaptive_levels(alpha, W_local, U_local, cone_table, cone_levels, True,
                                                         configuration, e, rtol, degenerate, P, error)
            n = cone_table.shape[1] // ((1 << cone_levels) - 1)
            # at 2n nodes "cone-pair" (no stall test) and "cone-pass" decide alike: the stall test cannot
            # fire at the first comparison, which has no earlier difference to compare with
            if status != cone_kernels.SETTLED:
                return DECLINED, nodes, 0.0, speed, w_scale, 0.0, True
            code = CONE_PAIR if nodes == 2 * n else CONE_PASS
    finite, un_plus = finish_into(P, R, speed / w_scale, buf)
    return code, nodes, error[0], speed, w_scale, un_plus, finite


@njit(_CONE_IMPACT, cache=True, error_model="numpy")
def cone_impact(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], v: NDArray[np.float64],
                R: NDArray[np.float64], degenerate: float, rank_floor: float, alpha: float,
                graded_table: NDArray[np.float64], graded_levels: int, peaked: float, cone_table: NDArray[np.float64],
                cone_levels: int, pole_table: NDArray[np.float64], pole_levels: int, configuration: bool, e: float,
                rtol: float, buf: NDArray[np.float64]
                ) -> tuple[int, int, float, float, float, float, bool]:  # pragma: no cover — compiled
    """One spatial impact of a mechanism on a cone of facets: metric, (2.8) and outcome (1.1) in one call.

    Parameters
    ----------
    U, D, J, v, R, degenerate, rank_floor
        As :func:`mbimpact.metric.kernels.prepare_factor`: the factor A = U D Uᵀ (n, n), (n,); the
        contact Jacobian (3, n); the velocity (n,); the contact frame (3, 3); the screens of n⁰ out of
        reach and of a rank-deficient W.
    alpha : float
        Tilt of the cone, 0 < α < π/2.
    graded_table : ndarray
        The graded rule's nodes (:func:`mbimpact.averaging.graded_kernels.rule_table`) for
        ``graded_levels`` levels: all that ``max_nodes`` allows, or the first few (a velocity that
        needs more is :data:`DECLINED`; the Python methods go on with every level).
    peaked : float
        The peak width below which the rule is graded (:attr:`mbimpact.averaging.Graded.peaked`).
    cone_table : ndarray
        The cone's nodes (:func:`mbimpact.averaging.cone_kernels.rule_table`) for ``cone_levels``
        levels (at least 2), n and 2n first (those of ``"cone-pair"``); as for ``graded_table``, the
        first few levels may stand for all.
    pole_table, pole_levels : ndarray, int
        The cone's nodes of ``"pole-pass"``'s levels (:func:`mbimpact.averaging.pole_pass.pole_plan`).
    configuration, e, rtol
        The facet weight of (2.7) (True: ``"configuration"``), the facet restitution and the accuracy.
    buf : ndarray, shape (6n + 33,)
        The impact's buffer (:func:`mbimpact.metric.kernels.single_size`); its head is the result.

    Returns
    -------
    status : int
        :data:`POLE_PASS`, :data:`GRADED_PASS`, :data:`CONE_PAIR` or :data:`CONE_PASS`: settled, the result
        is in ``buf``;
        :data:`DECLINED`: prepared (``buf`` as ``prepare_factor`` leaves it), not settled by these
        methods; :data:`NOT_PREPARED`: ``prepare_factor``'s status was not READY (in ``nodes``).
    nodes : int
        The node count of the method that settled (a piece's, for the graded rule).
    error, speed, w_scale, un_plus : float
        The error estimate; |u| and tr(RᵀWR) (as ``prepare_factor`` returns them); n⁰ · u₊.
    finite : bool
        Whether P, v₊ and u₊ are finite (as :func:`mbimpact.metric.kernels.finish` says).
    """
    return _cone_impact_into(U, D, J, v, R, degenerate, rank_floor, alpha, graded_table, graded_levels, peaked,
                             cone_table, cone_levels, pole_table, pole_levels, configuration, e, rtol, buf)


@njit(_CONE_BATCH, cache=True, error_model="numpy", nogil=True)
def cone_batch(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], V: NDArray[np.float64],
               R: NDArray[np.float64], degenerate: float, rank_floor: float, alpha: float,
               graded_table: NDArray[np.float64], graded_levels: int, peaked: float, cone_table: NDArray[np.float64],
               cone_levels: int, pole_table: NDArray[np.float64], pole_levels: int, configuration: bool, e: float,
               rtol: float, buf: NDArray[np.float64], status: NDArray[np.int64], nodes: NDArray[np.int64],
               stats: NDArray[np.float64]
               ) -> None:  # pragma: no cover — compiled
    """:func:`cone_impact` for B impacts, each at its own configuration: row i is the call on
    ``U[i], D[i], J[i], V[i], R[i]`` and ``buf[i]``, the same arithmetic, so the same result to the bit.

    Parameters
    ----------
    U, D, J, V, R : ndarray, shapes (B, n, n), (B, n), (B, 3, n), (B, n), (B, 3, 3)
        Each row's factor of A(q), contact Jacobian, velocity and contact frame.
    degenerate, rank_floor, alpha, graded_table, graded_levels, peaked, cone_table, cone_levels,
    pole_table, pole_levels, configuration, e, rtol
        As for :func:`cone_impact`, shared by the rows.
    buf : ndarray, shape (B, 6n + 33)
        Each row's buffer, as :func:`cone_impact` fills it.
    status, nodes : ndarray, shape (B,)
        Output: :func:`cone_impact`'s status and node count of each row.
    stats : ndarray, shape (B, 5)
        Output: its error estimate, speed, w_scale and n⁰ · u₊, then 1.0 where P, v₊ and u₊ are finite
        (else 0.0).
    """
    for i in range(V.shape[0]):
        code, count, error, speed, w_scale, un_plus, finite = _cone_impact_into(
            U[i], D[i], J[i], V[i], R[i], degenerate, rank_floor, alpha, graded_table, graded_levels, peaked,
            cone_table, cone_levels, pole_table, pole_levels, configuration, e, rtol, buf[i])
        status[i], nodes[i] = code, count
        stats[i, 0], stats[i, 1], stats[i, 2], stats[i, 3] = error, speed, w_scale, un_plus
        stats[i, 4] = 1.0 if finite else 0.0


def jit_seconds() -> float:
    """Wall time of one call of :func:`cone_impact` once the module is imported: ~0, since the import
    compiles its explicit signature, or loads it from numba's on-disk cache."""
    start = time.perf_counter()
    n = 3
    U, D, J, v, R = np.eye(n), np.ones(n), np.eye(n), -np.ones(n), np.eye(3)
    cone_impact(U, D, J, v, R, 1e-14, 1e-12, 0.4, graded_kernels.rule_table(4, 2), 2, 0.15,
                cone_kernels.rule_table(4, 2), 2, cone_kernels.rule_table(4, 2), 2, False, 0.5, 1e-12,
                np.empty(single_size(n)))
    return time.perf_counter() - start

"""The compiled single impact of a :class:`~mbimpact.RoughLaw` on a :class:`~mbimpact.Cone`, whole.

A rough impact of a mechanism runs the pipeline in three compiled steps: the metric and the state the
laws take (:func:`mbimpact.metric.kernels.prepare_into`), the law (2.8) by the averaging rules of
``"auto"``, and the outcome (1.1) (:func:`mbimpact.metric.kernels.finish_into`). For one velocity on a
cone every rule that ``"auto"`` may run has a compiled step (:meth:`mbimpact.averaging.Averaging.cone_step`:
the pole rule, the graded rule, the adaptive rule), so that the whole impact is one call:
:func:`cone_impact` runs the steps the law gives it, in its order, each one the kernel of that rule's
compiled backend. A step settles the velocity, hands it on to the next
(:data:`mbimpact.averaging.compiled.codes.PASSES_ON`: the rule declines it), or ends the call DECLINED:
the prepared state stays in the buffer and the law goes on in Python from it, where the same rules run
with every level and their numpy forms name or treat the case.

The pole and graded rules run only where the kernels of (2.8) have a narrow peak; elsewhere both decline
at once (NOT_PEAKED), by the screen they share (:func:`~mbimpact.averaging.compiled.graded_cone.ring_minima_into`).
Most velocities of most mechanisms have none, and the two rules are most of what there is to compile, so
the impact comes as two kernels of the one body: :func:`cone_impact` runs every step; :func:`cone_unpeaked`,
compiled without the peaked rules, screens the ring itself and returns :data:`PEAKED` for a velocity whose
kernels peak, which :func:`cone_impact` then settles and, from then on, runs in its place
(:class:`mbimpact.laws.compiled.CompiledImpact`). For a velocity without a narrow peak the two are the same
arithmetic, to the bit. :func:`cone_batch` runs :func:`cone_impact` on each row.

Kernel convention: :class:`mbimpact.laws.compiled.CompiledImpact`. Imported on first use
(:data:`mbimpact.laws.cone_plan.KERNELS`); each kernel compiles its explicit signature, or loads it from
numba's disk cache, on its first call (:func:`mbimpact.common.compiled.kernel`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import types
from numpy.typing import NDArray

from ..averaging.compiled.cone import cone_adaptive
from ..averaging.compiled.cone import rule_table as cone_table
from ..averaging.compiled.graded_cone import graded_cone, ring_form, ring_minima_into
from ..averaging.compiled.graded_cone import rule_table as graded_table
from ..averaging.compiled.poles import poles as pole_rule
from ..averaging.compiled.primitives import NOT_PEAKED, SETTLED
from ..common.compiled import kernel
from ..metric.kernels import READY, finish_into, prepare_into, single_size

__all__ = ["cone_impact", "cone_unpeaked", "cone_batch", "jit_seconds", "PEAKED"]

# the step codes of mbimpact.averaging.compiled.codes, and the statuses of mbimpact.laws.compiled
_POLES, _GRADED, _ADAPTIVE = 0, 1, 2
_DECLINED, _NOT_PREPARED = -1, -2

#: Status of :func:`cone_unpeaked` for a velocity whose kernels have a narrow peak: prepared, not settled;
#: :func:`cone_impact` settles it (:data:`mbimpact.laws.compiled.PEAKED`).
PEAKED = -3

_IN1, _IN2 = types.Array(types.float64, 1, "A", readonly=True), types.Array(types.float64, 2, "A", readonly=True)
_F, _I = types.float64, types.int64
# the node tables C-contiguous: strided indexing would keep the node loops out of SIMD lanes
_TABLE = types.Array(types.float64, 2, "C", readonly=True)
_STEPS = types.Array(types.int64, 1, "C", readonly=True)
_PLAN = (_F, _STEPS, _TABLE, _I, _F, _TABLE, _I, _TABLE, _I, types.boolean, _F, _F)
_CONE_IMPACT = types.Tuple((_I, _I, _F, _F, _F, _F, types.boolean))(_IN2, _IN1, _IN2, _IN1, _IN2, _F, _F, *_PLAN,
                                                                      types.float64[::1])
# the stacks of a batch read as any strides (a caller's V may be a view), its outputs C-contiguous
_IN3, _OUT2 = types.Array(types.float64, 3, "A", readonly=True), types.float64[:, ::1]
_CONE_BATCH = types.none(_IN3, _IN2, _IN3, _IN2, _IN3, _F, _F, *_PLAN, _OUT2, types.int64[::1], types.int64[::1],
                         _OUT2)


def _single(every_rule: bool, name: str, doc: str) -> Callable[..., Any]:
    """The single impact, compiled with the pole and graded rules (``every_rule``) or without them: numba
    prunes the branch on the constant ``every_rule`` before it compiles, so that the rules it does not call
    are not compiled either."""

    def impact(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], v: NDArray[np.float64],
               R: NDArray[np.float64], degenerate: float, rank_floor: float, alpha: float, steps: NDArray[np.int64],
               graded: NDArray[np.float64], graded_levels: int, peaked: float, cone: NDArray[np.float64],
               cone_levels: int, poles: NDArray[np.float64], pole_levels: int, configuration: bool, e: float,
               rtol: float, buf: NDArray[np.float64]
               ) -> tuple[int, int, float, float, float, float, bool]:  # pragma: no cover — compiled
        prepared, speed, w_scale = prepare_into(U, D, J, v, R, degenerate, rank_floor, buf)
        if prepared != READY:
            return _NOT_PREPARED, prepared, 0.0, speed, w_scale, 0.0, True
        w = 3 * v.shape[0] + 21  # W_local, then U_local (mbimpact.metric.kernels.local_views)
        W_local, U_local = buf[w:w + 9].reshape((3, 3)), buf[w + 9:w + 12].reshape((1, 3))
        P, error = np.empty((1, 3)), np.empty(1)
        peaks = -1  # without the peaked rules: the ring's narrow minima, once a step needs them
        for k in range(steps.shape[0]):
            step = steps[k]
            if step == _ADAPTIVE:
                status, nodes = cone_adaptive(alpha, W_local, U_local, cone, cone_levels, configuration, e, rtol,
                                              degenerate, P, error)
            elif every_rule:
                if step == _POLES:
                    status, nodes = pole_rule(alpha, W_local, U_local, poles, pole_levels, peaked, e, rtol, degenerate,
                                              P, error)
                else:
                    status, nodes = graded_cone(alpha, W_local, U_local, graded, graded_levels, peaked, configuration,
                                                e, rtol, degenerate, P, error)
            else:  # the peaked rules' own screen: without a narrow peak both decline (NOT_PEAKED), and pass on
                if peaks < 0:
                    phi, eps = np.empty(2), np.empty(2)
                    peaks = ring_minima_into(ring_form(math.sin(alpha), math.cos(alpha), W_local), peaked, phi, eps)
                if peaks == 0:
                    continue
                return PEAKED, 0, 0.0, speed, w_scale, 0.0, True
            if status == SETTLED:
                finite, un_plus = finish_into(P, R, speed / w_scale, buf)
                return k, nodes, error[0], speed, w_scale, un_plus, finite
            # mbimpact.averaging.compiled.codes.PASSES_ON: the pole rule declines whatever stops it, the graded
            # rule where the kernels have no narrow peak; anything else goes to the rule's numpy form in Python
            if not (step == _POLES or (step == _GRADED and status == NOT_PEAKED)):
                break
        return _DECLINED, 0, 0.0, speed, w_scale, 0.0, True

    impact.__name__ = impact.__qualname__ = name  # numba's cache files and messages name it so
    impact.__doc__ = doc
    return kernel(_CONE_IMPACT, error_model="numpy")(impact)


cone_impact = _single(True, "cone_impact", """One spatial impact of a mechanism on a cone of facets: metric, (2.8) and
    outcome (1.1) in one call.

    Parameters
    ----------
    U, D, J, v, R, degenerate, rank_floor
        As :func:`mbimpact.metric.kernels.prepare_factor`.
    alpha : float
        Tilt of the cone, 0 < α < π/2.
    steps : ndarray of int
        The compiled steps of ``"auto"`` in its order (:mod:`mbimpact.averaging.compiled.codes`); the
        status of a settled impact is the index of the step that settled it.
    graded, graded_levels, peaked
        The graded rule's node table (:func:`mbimpact.averaging.compiled.graded_cone.rule_table`) for
        ``graded_levels`` levels (the first few: a velocity that needs more is declined, and the rule runs
        with every level in Python), and the peak width below which it grades.
    cone, cone_levels
        The adaptive rule's node table (:func:`mbimpact.averaging.compiled.cone.rule_table`), likewise.
    poles, pole_levels
        The pole rule's (:func:`mbimpact.averaging.poles.pole_plan`).
    configuration, e, rtol
        The facet weight of (2.7) (True: ``"configuration"``), the facet restitution and the accuracy.
    buf : ndarray, shape (6n + 33,)
        The impact's buffer (:func:`mbimpact.metric.kernels.single_size`); its head is the result.

    Returns
    -------
    (status, nodes, error, speed, w_scale, un_plus, finite)
        As :class:`mbimpact.laws.compiled.CompiledImpact` reads them.
    """)

cone_unpeaked = _single(False, "cone_unpeaked", """:func:`cone_impact` compiled without the pole and graded
    rules: the same impact for a velocity whose kernels have no narrow peak; for one that has, status
    :data:`PEAKED` (the state prepared in ``buf``), and :func:`cone_impact` settles it. Arguments and results
    as :func:`cone_impact`'s.""")


@kernel(_CONE_BATCH, error_model="numpy", nogil=True)
def cone_batch(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], V: NDArray[np.float64],
               R: NDArray[np.float64], degenerate: float, rank_floor: float, alpha: float, steps: NDArray[np.int64],
               graded: NDArray[np.float64], graded_levels: int, peaked: float, cone: NDArray[np.float64],
               cone_levels: int, poles: NDArray[np.float64], pole_levels: int, configuration: bool, e: float,
               rtol: float, buf: NDArray[np.float64], status: NDArray[np.int64], nodes: NDArray[np.int64],
               stats: NDArray[np.float64]) -> None:  # pragma: no cover — compiled
    """:func:`cone_impact` for B impacts, each at its own configuration: row i is the call on
    ``U[i], D[i], J[i], V[i], R[i]`` and ``buf[i]`` (shapes (B, …) of its arguments; ``status``, ``nodes``
    (B,) and ``stats`` (B, 5) as :class:`mbimpact.laws.compiled.CompiledImpact` reads them)."""
    for i in range(V.shape[0]):
        code, count, error, speed, w_scale, un_plus, finite = cone_impact(
            U[i], D[i], J[i], V[i], R[i], degenerate, rank_floor, alpha, steps, graded, graded_levels, peaked, cone,
            cone_levels, poles, pole_levels, configuration, e, rtol, buf[i])
        status[i], nodes[i] = code, count
        stats[i, 0], stats[i, 1], stats[i, 2], stats[i, 3] = error, speed, w_scale, un_plus
        stats[i, 4] = 1.0 if finite else 0.0


def jit_seconds() -> float:
    """Wall time to make the three kernels callable in this process (numba's import excluded): their machine
    code loaded from numba's on-disk cache, or compiled when that cache is missing or stale."""
    start = time.perf_counter()
    n = 3
    U, D, J, v, R = np.eye(n), np.ones(n), np.eye(n), -np.ones(n), np.eye(3)
    args = (1e-14, 1e-12, 0.4, np.array([_POLES, _GRADED, _ADAPTIVE]), graded_table(4, 2), 2, 0.15, cone_table(4, 2),
            2, cone_table(4, 2), 2, False, 0.5, 1e-12)
    cone_unpeaked(U, D, J, v, R, *args, np.empty(single_size(n)))
    cone_impact(U, D, J, v, R, *args, np.empty(single_size(n)))
    cone_batch(U[None], D[None], J[None], v[None], R[None], *args, np.empty((1, single_size(n))),
               np.empty(1, np.int64), np.empty(1, np.int64), np.empty((1, 5)))
    return time.perf_counter() - start

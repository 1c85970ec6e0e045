"""A spatial impact of a mechanism computed on Pinocchio's factor of A(q), with the metric and the
outcome (1.1) compiled around the law.

A single impact is a few microseconds of arithmetic; from Python, the calls around it cost more. On a
mechanism the pipeline therefore works on the factor A = U D Uᵀ (``pin.cholesky``, what
``pin.impulseDynamics`` uses) in one buffer per impact (:func:`mbimpact.metric.kernels.single_size`):

* :meth:`mbimpact.ImpactLaw.apply_metric`: the metric and the state every law takes (unit speed, W of
  unit trace, local frame) in one compiled call (:func:`mbimpact.metric.kernels.prepare_factor`), the
  law's :meth:`~mbimpact.ImpactLaw.contact_impulses` in Python, and the outcome in one more
  (:func:`finish_prepared`);
* :class:`CompiledImpact`: a law that declares one (:meth:`mbimpact.ImpactLaw.compiled_impact`) runs all
  of it in one compiled call, and a batch of impacts at many configurations in one call for all rows
  (:meth:`CompiledImpact.run_stack`).

What the compiled calls do not prepare (no approach, n⁰ out of reach, a nearly rank-deficient W, an
overflow, a singular A) returns None here: the pipeline on :class:`~mbimpact.metric.ContactMetric`
then names the error or treats the case.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..common.compiled import KernelModule
from ..common.geometry import DEGENERATE
from ..common.threads import over_rows
from ..common.validation import check_in_range
from ..metric.delassus import KERNELS as METRIC_KERNELS
from ..results.impact import BatchResult, ImpactResult
from ..results.quantities import SEPARATION_RTOL

if TYPE_CHECKING:
    from .base import ImpactLaw

__all__ = ["CompiledImpact", "finish_prepared", "RANK_FLOOR", "DECLINED", "NOT_PREPARED", "PEAKED"]

#: det W / (tr W)³ at or below which W may be rank-deficient (ContactMetric.range_projector's screen; the
#: compiled metric keeps W where λ_min > :data:`mbimpact.metric.kernels.FULL_RANK_RATIO` tr W).
RANK_FLOOR = 1e-12

#: Status of a compiled impact prepared but not settled: the law goes on in Python from the prepared state.
DECLINED = -1
#: Status of a compiled impact the metric did not prepare: the pipeline on ContactMetric names or treats it.
NOT_PREPARED = -2
#: Status of a compiled impact compiled without some of its law's steps, for a velocity that needs them:
#: :attr:`CompiledImpact.whole` runs it (:mod:`mbimpact.laws.compiled_cone`).
PEAKED = -3


@dataclass(frozen=True, eq=False)
class CompiledImpact:
    """A law's whole spatial impact as compiled code on Pinocchio's factor of A(q).

    The kernels follow one convention. ``single(U, D, J, v, R, degenerate, rank_floor, *args, buf)``
    returns ``(status, nodes, error, speed, w_scale, un_plus, finite)``: status k ≥ 0 when settled by the
    k-th of ``methods`` (the result in ``buf``, :func:`mbimpact.metric.kernels.single_size`),
    :data:`DECLINED`, :data:`NOT_PREPARED` or, from a ``single`` that leaves steps to ``whole``, :data:`PEAKED`;
    |u₋|, tr(RᵀWR), n⁰ · u₊ and whether P, v₊, u₊ are finite.
    ``batch(U, D, J, V, R, degenerate, rank_floor, *args, buf, status, nodes, stats)`` does the same for
    B rows at their own configurations, each row what ``single`` gives it (stats: error, speed, w_scale,
    un_plus, finite as 1.0 or 0.0), and releases the GIL.

    Attributes
    ----------
    kernels : KernelModule
        The module of the kernels, loaded on first use.
    single, batch : str
        The kernels' names in it.
    args : tuple
        The law's own arguments of both kernels.
    methods : tuple of str
        The ``method`` of a result settled with each status code.
    front : callable or None
        The whole impact with stage 1 in one call of the compiled front end (:mod:`mbimpact.mechanism.front`),
        if it has one: ``front(native, bound, q, v, frame, point, basis, out)`` returns the front end's
        status, ``native.DONE`` where ``out`` holds the packed result (:meth:`ImpactResult.from_packed`).
    overlap : bool
        Whether :meth:`run_stack` runs the batch kernel on other threads while the rows are gathered:
        False where the kernel costs a row less than Pinocchio's work to gather it (Newton's one solve),
        so that handing blocks between threads would cost more than it overlaps.
    whole : str or None
        A kernel of every step of the law, where ``single`` is the same impact compiled without some (those
        that take the most compiling and that few velocities reach): the first velocity ``single`` returns
        :data:`PEAKED` for is run by ``whole``, which :meth:`run` then calls in its place (``whole`` compiles
        only if a velocity needs it; for a velocity both settle, both are the same arithmetic; ``single``
        never returns PEAKED where ``whole`` is None).
    """

    kernels: KernelModule
    single: str
    batch: str
    args: tuple[Any, ...]
    methods: tuple[str, ...]
    front: Callable[..., int] | None = None
    overlap: bool = True
    whole: str | None = None
    # the single kernel that run calls: single, until a velocity needs whole
    _in_use: list[str] = field(default_factory=list, init=False, repr=False)

    def __post_init__(self) -> None:
        self._in_use.append(self.single)

    def run(self, law: ImpactLaw, A: NDArray[np.float64], U: NDArray[np.float64], D: NDArray[np.float64],
            J: NDArray[np.float64], v: NDArray[np.float64], R: NDArray[np.float64], trusted: bool
            ) -> ImpactResult | None:
        """The impact at the factor A = U D Uᵀ, contact Jacobian ``J`` (3, n), velocity ``v`` (n,) and frame
        ``R`` (3, 3), or None where the metric does not prepare it. ``trusted``: the arrays are the compiled
        front end's, of the kernel's types (numba's dispatch is skipped: :meth:`KernelModule.unchecked`)."""
        name = self._in_use[0]
        call = self.kernels.unchecked(name) if trusted else getattr(self.kernels.get(), name)
        buffer = np.empty(6 * len(v) + 33)  # mbimpact.metric.kernels.single_size
        status, nodes, error, speed, w_scale, un_plus, finite = call(U, D, J, v, R, DEGENERATE, RANK_FLOOR, *self.args,
                                                                     buffer)
        if status == PEAKED:  # from now on this compiled impact runs every step
            assert self.whole is not None
            self._in_use[0] = self.whole
            return self.run(law, A, U, D, J, v, R, trusted)
        if status >= 0:
            return _result(law, A, J, buffer, speed, finite, un_plus, error, nodes, self.methods[status])
        if status == DECLINED:
            return finish_prepared(law, A, J, R, buffer, speed, w_scale)
        return None

    def run_stack(self, law: ImpactLaw, A: NDArray[np.float64], U: NDArray[np.float64], D: NDArray[np.float64],
                  J: NDArray[np.float64], V: NDArray[np.float64], R: NDArray[np.float64],
                  row: Callable[[int], ImpactResult], fill: Callable[[int, int], None] | None = None) -> BatchResult:
        """Impacts at many configurations from Pinocchio's factors, each row what :meth:`run` gives it.

        Parameters
        ----------
        A, U, J, V, R : ndarray, shapes (B, n, n), (B, n, n), (B, 3, n), (B, n), (B, 3, 3)
            Each row's A(q), factor U, contact Jacobian, velocity and frame.
        D : ndarray, shape (B, n)
            Each row's pivots.
        row : callable
            ``row(i)`` is row i's :class:`ImpactResult` by :func:`mbimpact.impact`: for the rows the
            kernel does not settle (it names their errors and treats their degenerate cases).
        fill : callable, optional
            ``fill(a, b)`` fills rows ``a`` to ``b`` of ``A``, ``U`` and ``D`` (Pinocchio's work), called for
            each block of rows in order; the kernel's calls on the rows filled overlap the filling of the next
            (:func:`mbimpact.common.threads.over_rows`).
        """
        kernel = getattr(self.kernels.get(), self.batch)
        getattr(kernel, "ensure_compiled", lambda: None)()  # here, before other threads call it
        B, n = V.shape
        # stats zeroed: a row the kernel leaves (not prepared) is read too, and must hold no NaN
        buffer, status, nodes, stats = np.empty((B, 6 * n + 33)), np.empty(B, np.int64), np.empty(B, np.int64), \
            np.zeros((B, 5))

        def rows(a: int, b: int) -> None:
            kernel(U[a:b], D[a:b], J[a:b], V[a:b], R[a:b], DEGENERATE, RANK_FLOOR, *self.args, buffer[a:b],
                   status[a:b], nodes[a:b], stats[a:b])

        if self.overlap:
            over_rows(rows, B, fill)
        else:
            if fill is not None:
                fill(0, B)
            rows(0, B)
        settled = (status >= 0) & (stats[:, 4] == 1.0)
        methods = {self.methods[code] for code in np.unique(status[settled])}
        return _stack_result(law, A, J, buffer, settled, nodes, stats, methods, row)


def finish_prepared(law: ImpactLaw, A: NDArray[np.float64], J: NDArray[np.float64], R: NDArray[np.float64],
                    buffer: NDArray[np.float64], speed: float, w_scale: float) -> ImpactResult:
    """The law and the outcome (1.1) of a spatial impact that a ``prepare_*`` kernel made ready in
    ``buffer`` (:mod:`mbimpact.metric.kernels`), and the result made of that buffer."""
    kernels = METRIC_KERNELS.get()
    W_local, U_local = kernels.local_views(buffer, J.shape[1])
    out = law.contact_impulses(W_local, U_local)
    finite, un_plus = kernels.finish(out.P, R, speed / w_scale, buffer)
    return _result(law, A, J, buffer, speed, finite, un_plus, float(out.error[0]), out.nodes, out.method)


def _result(law: ImpactLaw, A: NDArray[np.float64], J: NDArray[np.float64], buffer: NDArray[np.float64],
            speed: float, finite: bool, un_plus: float, error: float, nodes: int, method: str) -> ImpactResult:
    """The result of a spatial impact whose outcome a compiled ``finish`` wrote in ``buffer`` (``finite``
    and ``un_plus`` are what it returned, ``speed`` is |u₋|): the overflow named, and a contact that still
    approaches warned of."""
    result = ImpactResult.from_buffer(buffer, A, J, law, error, nodes, method)
    if not finite:
        check_in_range("the impact's outcome (P, v₊ or u₊)", result.P, result.v_plus, result.u_plus)
    if not un_plus >= -SEPARATION_RTOL * speed:
        law.warn_no_separation()
    return result


def _stack_result(law: ImpactLaw, A: NDArray[np.float64], J: NDArray[np.float64], buffer: NDArray[np.float64],
                  settled: NDArray[np.bool_], nodes: NDArray[np.int64], stats: NDArray[np.float64],
                  methods: set[str], row: Callable[[int], ImpactResult]) -> BatchResult:
    """The result of a stack whose kernel ran each row's compiled impact into ``buffer[i]``: the rows
    ``settled`` there, the others ``row(i)``. As the row-by-row loop of :func:`mbimpact.impact`: errors
    come in row order, and a settled row whose contact still approaches warns (once for the batch: the
    single impact's text) before the rows after it."""
    B, n = len(buffer), A.shape[-1]
    error = stats[:, 0].copy()
    nodes = np.maximum(nodes, 1)
    approaching = np.flatnonzero(settled & ~(stats[:, 3] >= -SEPARATION_RTOL * stats[:, 1]))
    first = int(approaching[0]) if approaching.size else B
    for i in np.flatnonzero(~settled).tolist():
        if i > first:
            law.warn_no_separation()
            first = B
        result = row(i)
        buffer[i, :3 * n + 12] = np.concatenate([result.v_minus, result.v_plus, result.dv, result.P,
                                                 result.u_minus, result.u_plus, result.n0])
        error[i], nodes[i] = result.error_estimate, result.nodes
        methods.add(result.method)
    if first < B:
        law.warn_no_separation()
    v_minus, v_plus, dv, P, u_minus, u_plus, n0 = np.split(buffer[:, :3 * n + 12], np.cumsum([n, n, n, 3, 3, 3]),
                                                           axis=1)  # the single result's layout
    return BatchResult(V_minus=v_minus, V_plus=v_plus, dV=dv, P=P, U_minus=u_minus, U_plus=u_plus, n0=n0, A=A, J=J,
                       law=law, error_estimate=error, nodes=int(nodes.max()), method="+".join(sorted(methods)))

"""Impact laws: the shared pipeline from the metric to the result.

Every law shares one pipeline (:mod:`mbimpact.theory`, §5):

1. metric — A(q) factorised once, W = J A⁻¹ Jᵀ, u = J v (:mod:`mbimpact.metric`);
2. law — a contact impulse P from (W, u) in the local frame of the base surface
   (:meth:`ImpactLaw.contact_impulses`, the only step that differs between laws);
3. result — Δv = A⁻¹ Jᵀ P and I = Jᵀ P, Lagrange's equations (1.1).

Entry points: :meth:`ImpactLaw.apply` and :meth:`ImpactLaw.apply_batch` on arrays,
:func:`mbimpact.impact` on a mechanism (through :meth:`ImpactLaw.apply_mechanism`), and
:meth:`ImpactLaw.impulses` for contact velocities given directly (a moving surface).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from types import ModuleType
from typing import TYPE_CHECKING, Any, Callable, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.compiled import KernelModule
from ..common.geometry import DEGENERATE
from ..common.threads import over_rows, single_blas_thread
from ..common.validation import as_array, check_in_range, quiet_overflow
from ..errors import NoImpactError, NonFiniteError, NoSeparationWarning, RoughnessError, ShapeError, ignored, warn
from ..metric.basis import local_basis
from ..metric.delassus import KERNELS as METRIC_KERNELS
from ..metric.delassus import ContactMetric
from ..results.impact import BatchResult, ContactImpulses, ImpactResult
from ..results.quantities import SEPARATION_RTOL

if TYPE_CHECKING:
    from ..mechanism.mechanism import Mechanism

__all__ = ["ImpactLaw"]

#: det W / (tr W)³ at or below which W may be rank-deficient (ContactMetric.range_projector's screen; the
#: compiled route keeps W where λ_min > :data:`mbimpact.metric.kernels.FULL_RANK_RATIO` tr W)
RANK_FLOOR = 1e-12


class ImpactLaw(ABC):
    """Base class: the pipeline metric → contact impulse → result.

    Subclasses implement :meth:`contact_impulses` in the local frame of the base
    surface (last axis along n⁰) for unit contact velocities.

    Attributes
    ----------
    e : float
        Restitution (of the facets, for the rough law).
    block_rows : int
        Rows per block of a batch: keeps (rows × nodes × d) work arrays in cache.
    """

    e: float
    block_rows: ClassVar[int] = 2048

    @property
    def dim(self) -> int | None:
        """Contact-space dimension the law requires (None: 2 or 3)."""
        return None

    @abstractmethod
    def contact_impulses(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        """Contact impulses for a batch of unit contact velocities, local frame.

        Parameters
        ----------
        W : ndarray, shape (d, d)
            Delassus matrix in the local frame, Rᵀ W R.
        U : ndarray, shape (B, d)
            Unit pre-impact contact velocities, ``U[:, -1] < 0``.

        Returns
        -------
        ContactImpulses
            P (B, d) in the local frame, error estimates (B,), nodes, method.
        """

    def single_impulse(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        """:meth:`contact_impulses` for one velocity, ``U`` of shape (1, d): what the compiled single
        impacts call (:meth:`apply_mechanism`). A law with a cheaper path for one row overrides it."""
        return self.contact_impulses(W, U)

    # ------------------------------------------------------------------ core
    def impulses(self, metric: ContactMetric, U: NDArray[np.float64], R: NDArray[np.float64]) -> ContactImpulses:
        """Contact impulses P (B, d), world frame, for contact velocities U (B, d).

        ``U`` is the velocity of the contact point relative to the surface; it differs
        from J v when the surface moves (a vibrating table). ``R`` (d, d) is the local
        frame, last column n⁰.

        Raises
        ------
        NoImpactError
            A row does not approach the surface, or the mechanism cannot move the contact
            point along n⁰ (n⁰ᵀWn⁰ ≈ 0).
        RoughnessError
            The law needs another contact-space dimension.
        """
        d = metric.d
        if self.dim is not None and self.dim != d:
            raise RoughnessError(f"{self!r} needs a {self.dim}-D contact space but J has {d} rows")
        W, n0 = metric.W, R[:, -1]
        check_in_range("the contact velocity", U)
        with quiet_overflow():  # extreme magnitudes overflow silently here and are named below
            P, err, nodes, method = self._local_impulses(metric, W, U, R, n0)
        check_in_range("the contact impulse P", P)
        return ContactImpulses(P, err, nodes, method)

    def _local_impulses(self, metric: ContactMetric, W: NDArray[np.float64], U: NDArray[np.float64],
                        R: NDArray[np.float64], n0: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                                                   NDArray[np.float64], int, str]:
        un = U @ n0
        if not un.max() < 0.0:
            bad = np.flatnonzero(~(un < 0.0))
            where = "" if len(un) == 1 else f" (rows {bad[:5].tolist()}{'...' if bad.size > 5 else ''})"
            raise NoImpactError(
                f"the contact point does not approach the surface{where}: "
                f"n0·(J v) = {un[bad[0]]:.6g} must be < 0"
            )
        if not float(n0 @ W @ n0) > DEGENERATE * float(np.trace(W)):
            raise NoImpactError(
                "the mechanism cannot move the contact point along n0 (n0ᵀ W n0 ≈ 0); no impact can occur"
            )
        # Every law is positively homogeneous of degree 1 in u (1°): work with unit
        # directions so that velocity scales far from 1 neither under- nor overflow.
        big = np.abs(U).max(axis=1)
        speed = big * np.linalg.norm(U / big[:, None], axis=1)
        check_in_range("the magnitude |u| of the contact velocity", speed)
        # and of degree −1 in W: the law sees W of unit trace, whatever the units and scale of the
        # mechanism (mass matrices from 1e-100 to 1e100 neither under- nor overflow inside it)
        W_local = R.T @ W @ R
        w_scale = float(np.trace(W_local))
        W_local = W_local / w_scale
        U_local = (U @ R) / speed[:, None]
        if len(U) <= self.block_rows:
            out = self.contact_impulses(W_local, U_local)
            P, err, nodes, method = out.P, out.error, out.nodes, out.method
        else:
            P, err, nodes, methods = np.empty_like(U), np.empty(len(U)), 0, set()
            for start in range(0, len(U), self.block_rows):
                block = slice(start, start + self.block_rows)
                out = self.contact_impulses(W_local, U_local[block])
                P[block], err[block], nodes = out.P, out.error, max(nodes, out.nodes)
                methods.add(out.method)
            method = "+".join(sorted(methods))
        P = P @ R.T
        proj = metric.range_projector
        if proj is not None:
            # rank-deficient J: report the minimum-norm impulse, the only one that
            # does not depend on how the quadrature split the part in null(Jᵀ)
            P = P @ proj
        return P * (speed / w_scale)[:, None], err, nodes, method

    # ------------------------------------------------------------------ single
    def apply_mechanism(self, mech: Mechanism, q: NDArray[np.float64], v: NDArray[np.float64],
                        J: NDArray[np.float64], R: NDArray[np.float64],
                        factor: tuple[NDArray[np.float64], ...] | None = None) -> ImpactResult:
        """The impact of a mechanism at a validated state (q, v), contact Jacobian ``J`` (d, nv) and
        contact frame ``R`` (d, d): the metric of A(q) (stage 2), then :meth:`apply_metric`.

        ``factor`` is (A, U, D), A(q) and its factor as :meth:`Mechanism.factor_arrays` returns them,
        where the caller has them already (the compiled front end, :mod:`mbimpact.mechanism.front`);
        it is read only where :meth:`reads_factor` is True. A caller that gives it vouches for every
        array as the front end makes them (float64, of the shapes above: v (n,), J and R as said, A
        and U (n, n), D (n,)): compiled kernels then take them without checking their types.

        :func:`mbimpact.impact` calls this. A spatial impact of a law that keeps this pipeline runs it
        compiled on Pinocchio's factor of A(q) (:func:`mbimpact.metric.kernels.prepare_factor`), with
        the same checks, scalings and impulse as :meth:`apply_metric`, to rounding; the cases that
        route declines (no approach, n⁰ out of reach, a W whose range projector is not the
        identity, magnitudes that overflow, a singular A) take :meth:`apply_metric`, which names
        or treats them. A law with a counterpart in Pinocchio overrides this
        (:class:`NewtonLaw`: ``pin.impulseDynamics``), and so does a law that runs the whole impact
        in one compiled call (:class:`RoughLaw` on a cone).
        """
        if len(R) == 3 and self._compiled_route():
            kernels = METRIC_KERNELS.get()
            A, U, D, prepare = self._on_factor(mech, q, factor, METRIC_KERNELS, "prepare_factor")
            buffer = np.empty(6 * len(v) + 33)  # kernels.single_size
            status, speed, w_scale = prepare(U, D, J, v, R, DEGENERATE, RANK_FLOOR, buffer)
            if status == kernels.READY:
                return self._finish_single(kernels, A, J, R, buffer, speed, w_scale)
        return self.apply_metric(ContactMetric.from_mechanism(mech, q, J), v, R)

    @staticmethod
    def _on_factor(mech: Mechanism, q: NDArray[np.float64], factor: tuple[NDArray[np.float64], ...] | None,
                   kernels: KernelModule, name: str
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], Callable[..., Any]]:
        """A(q), its factor U, D and the compiled kernel ``name`` that takes them: the caller's factor and the
        kernel without numba's dispatch (:meth:`KernelModule.unchecked`: :meth:`apply_mechanism`'s caller
        vouches for the arrays' types), or the mechanism's factor and the dispatching kernel."""
        if factor is not None:
            A, U, D = factor
            return A, U, D, kernels.unchecked(name)
        A, U, D = mech.factor_arrays(q)
        return A, U, D, getattr(kernels.get(), name)

    def reads_factor(self) -> bool:
        """Whether a spatial impact of this law on a mechanism starts from A(q)'s factor
        (:meth:`apply_mechanism` then takes it from the caller where given)."""
        return self._compiled_route()

    def apply_metric(self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]) -> ImpactResult:
        """The impact at a validated metric, velocity ``v`` (n,) and contact frame ``R`` (d, d)."""
        if len(R) == 3 and self._single_route() and self.dim in (None, 3):
            compiled = self._compiled_single(metric, v, R)
            if compiled is not None:
                return compiled
        # (ndarray.dot rather than @ on this path: the same BLAS call, without the generalised ufunc's overhead)
        with quiet_overflow():  # extreme magnitudes overflow silently here and are named below
            u = metric.J.dot(v)
            check_in_range("the contact velocity J v", u)
            out = self.impulses(metric, u[None, :], R)
            P, err, nodes, method = out.P[0], float(out.error[0]), out.nodes, out.method
            dv = metric.AinvJt.dot(P)
            u_plus = u + metric.W.dot(P)
            v_plus = v + dv
        check_in_range("the impact's outcome (P, v₊ or u₊)", P, v_plus, u_plus)
        n0 = R[:, -1].copy()
        result = ImpactResult(
            v_minus=v.copy(), v_plus=v_plus, dv=dv, P=P, u_minus=u, u_plus=u_plus, n0=n0, A=metric.A, J=metric.J,
            law=self, error_estimate=err, nodes=nodes, method=method,
        )
        if not result.separates:
            self._warn_no_separation()
        return result

    def _compiled_single(self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]
                         ) -> ImpactResult | None:
        """:meth:`apply_metric` for one spatial impact, its arithmetic around the law compiled
        (:func:`mbimpact.metric.kernels.prepare_metric` and :func:`~mbimpact.metric.kernels.finish`):
        the same checks, scalings and impulse as :meth:`impulses` for the contact velocity it reports
        (to the last bit in a world-aligned contact frame, to rounding in another), in two calls
        instead of some thirty on 3-vectors. None for what the general route treats: no approach,
        n⁰ out of reach, a W whose range projector is not the identity (rank-deficient)."""
        kernels = METRIC_KERNELS.get()
        buffer = np.empty(6 * len(v) + 33)  # kernels.single_size
        status, speed, w_scale = kernels.prepare_metric(metric.AinvJt.T, metric.W, metric.J, v, R, DEGENERATE,
                                                        RANK_FLOOR, buffer)
        if status:
            if status == kernels.U_NOT_FINITE:
                n = len(v)
                check_in_range("the contact velocity J v", buffer[3 * n + 3:3 * n + 6])
            if status == kernels.SPEED_INF:
                raise NonFiniteError("the magnitude |u| of the contact velocity: beyond the float range (inf); "
                                     "the inputs are finite but too large together (rescale the velocities)")
            return None
        return self._finish_single(kernels, metric.A, metric.J, R, buffer, speed, w_scale)

    def _finish_single(self, kernels: ModuleType, A: NDArray[np.float64], J: NDArray[np.float64],
                       R: NDArray[np.float64], buffer: NDArray[np.float64], speed: float, w_scale: float
                       ) -> ImpactResult:
        """The law and the outcome (1.1) of a spatial impact that a ``prepare_*`` kernel made ready in
        ``buffer``, and the result made of that buffer (:meth:`ImpactResult.from_buffer`)."""
        W_local, U_local = kernels.local_views(buffer, J.shape[1])
        out = self.single_impulse(W_local, U_local)
        finite, un_plus = kernels.finish(out.P, R, speed / w_scale, buffer)
        return self._single_result(A, J, buffer, speed, finite, un_plus, float(out.error[0]), out.nodes, out.method)

    def _single_result(self, A: NDArray[np.float64], J: NDArray[np.float64], buffer: NDArray[np.float64],
                       speed: float, finite: bool, un_plus: float, error: float, nodes: int, method: str
                       ) -> ImpactResult:
        """The result of a spatial impact whose outcome a compiled ``finish`` wrote in ``buffer``
        (``finite`` and ``un_plus`` are what it returned, ``speed`` is |u₋|): the overflow named, and a
        contact that still approaches warned of."""
        result = ImpactResult.from_buffer(buffer, A, J, self, error, nodes, method)
        if not finite:
            check_in_range("the impact's outcome (P, v₊ or u₊)", result.P, result.v_plus, result.u_plus)
        if not un_plus >= -SEPARATION_RTOL * speed:
            self._warn_no_separation()
        return result

    def _warn_no_separation(self) -> None:
        """The :class:`NoSeparationWarning` of an impact whose contact still approaches (κ < 0). Its text
        is the same for every impact of this law (κ is on the result): Python's default filter then
        shows it once per line of the caller, not once per impact of a loop."""
        if ignored(NoSeparationWarning):  # silenced in a loop of impacts: not even the text is made
            return
        warn(NoSeparationWarning, f"{self!r}: the contact still approaches the surface after the impact "
             f"(kappa < 0, the result's kappa says by how much); {self.separation_advice()}")

    def separation_advice(self) -> str:
        """What a :class:`NoSeparationWarning` of this law tells the user to do about a contact that
        still approaches after the impact."""
        return "further micro-impacts follow (a RoughLaw with repeat=True applies them)"

    def _single_route(self) -> bool:
        """Whether :meth:`apply_metric` may take :meth:`_compiled_single`: only while :meth:`impulses` is
        this class's own (a law that overrides it keeps its own route)."""
        return type(self).impulses is ImpactLaw.impulses

    def _compiled_route(self) -> bool:
        """Whether :meth:`apply_mechanism` may run the spatial impact compiled on Pinocchio's factor: only
        while :meth:`apply_metric` is this class's own and would take :meth:`_compiled_single`."""
        return type(self).apply_metric is ImpactLaw.apply_metric and self._single_route() and self.dim in (None, 3)

    def apply(self, A: ArrayLike, J: ArrayLike, v: ArrayLike, frame: ArrayLike) -> ImpactResult:
        """Post-impact state for mass matrix ``A``, contact Jacobian ``J``, velocity ``v``.

        Parameters
        ----------
        A : array_like, shape (n, n)
            Symmetric positive definite mass matrix A(q).
        J : array_like, shape (d, n)
            World-aligned translational contact Jacobian, d = 2 or 3.
        v : array_like, shape (n,)
            Pre-impact generalised velocity.
        frame : array_like, shape (d,) or (d, d)
            Base normal n⁰, or a rotation whose last column is n⁰.

        Returns
        -------
        ImpactResult

        Raises
        ------
        ShapeError, NonFiniteError, NotPositiveDefiniteError
            Invalid arrays.
        NoImpactError
            The contact point does not approach the base surface.
        NoFacingFacetError
            No facet faces the velocity (G* of (2.7) is empty).
        """
        metric = ContactMetric.from_arrays(A, J)
        v = as_array("v", v, 1, (metric.n,))
        return self.apply_metric(metric, v, local_basis(frame, metric.d))

    # ------------------------------------------------------------------ stacks
    def apply_stack(self, A: NDArray[np.float64], J: NDArray[np.float64], V: NDArray[np.float64],
                    R: NDArray[np.float64]) -> BatchResult | None:
        """Impacts at many configurations at once, vectorised across rows, or None.

        A law whose contact impulse is a closed form in (W, u) overrides this; the others
        return None and :func:`mbimpact.impact_batch` applies them row by row (or through
        :meth:`apply_factored_stack` where :meth:`factored_stack` says so). None also
        means "not for these rows" (a degenerate row the row-by-row route names or treats).

        Parameters
        ----------
        A : ndarray, shape (B, n, n)
            Validated mass matrices (symmetric, finite).
        J : ndarray, shape (B, d, n)
            Contact Jacobians.
        V : ndarray, shape (B, n)
            Pre-impact velocities.
        R : ndarray, shape (B, d, d)
            Contact frames, last columns n⁰.
        """
        return None

    def factored_stack(self) -> bool:
        """Whether :func:`mbimpact.impact_batch` hands this law's rows to :meth:`apply_factored_stack`
        (with Pinocchio's factor of each A(q)) rather than to :meth:`apply_stack`. False here."""
        return False

    def apply_factored_stack(self, A: NDArray[np.float64], U: NDArray[np.float64], D: NDArray[np.float64],
                             J: NDArray[np.float64], V: NDArray[np.float64], R: NDArray[np.float64],
                             row: Callable[[int], ImpactResult],
                             fill: Callable[[int, int], None] | None = None) -> BatchResult:
        """Impacts at many configurations from Pinocchio's factors of A(q), for a law whose
        :meth:`factored_stack` is True: each row as :func:`mbimpact.impact` would compute it.

        Parameters
        ----------
        A, J, V, R : ndarray, shapes (B, n, n), (B, 3, n), (B, n), (B, 3, 3)
            As for :meth:`apply_stack`.
        U, D : ndarray, shapes (B, n, n), (B, n)
            Each row's factor A = U D Uᵀ (:meth:`mbimpact.Mechanism.factor_arrays`).
        row : callable
            ``row(i)`` is row i's :class:`ImpactResult` by :func:`mbimpact.impact`: for the rows the
            law's own route declines (it names their errors and treats their degenerate cases).
        fill : callable, optional
            ``fill(a, b)`` fills rows ``a`` to ``b`` of ``A``, ``U`` and ``D`` (Pinocchio's work); given, it
            is called for each block of rows, in order, before the law reads them, and the law's
            compiled calls on the rows filled overlap the filling of the next
            (:func:`mbimpact.common.threads.over_rows`). Without it the stacks are read as given.
        """
        raise NotImplementedError(f"{type(self).__name__} has no route for factored stacks (factored_stack() is False)")

    def _factored_run(self, kernel: Callable[..., None], args: tuple[object, ...], U: NDArray[np.float64],
                      D: NDArray[np.float64], J: NDArray[np.float64], V: NDArray[np.float64], R: NDArray[np.float64],
                      fill: Callable[[int, int], None] | None
                      ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
        """A factored stack's kernel, ``kernel(U, D, J, V, R, DEGENERATE, RANK_FLOOR, *args, buffer, status,
        nodes, stats)`` on blocks of rows (on the kernel threads, overlapping ``fill``:
        :func:`mbimpact.common.threads.over_rows`), and what it fills for B rows of n velocities: each row's
        single-impact buffer (B, 6n + 33) (:func:`mbimpact.metric.kernels.single_size`), its status and node
        count (B,), and its error estimate, |u₋|, tr W, n⁰ · u₊ and finiteness (B, 5) (:meth:`_factored_result`
        reads them)."""
        B, n = V.shape
        # stats zeroed: a row the kernel leaves (not prepared) is read too, and must hold no NaN
        buffer, status, nodes, stats = np.empty((B, 6 * n + 33)), np.empty(B, np.int64), np.empty(B, np.int64), \
            np.zeros((B, 5))

        def rows(a: int, b: int) -> None:
            kernel(U[a:b], D[a:b], J[a:b], V[a:b], R[a:b], DEGENERATE, RANK_FLOOR, *args, buffer[a:b], status[a:b],
                   nodes[a:b], stats[a:b])

        over_rows(rows, B, fill)
        return buffer, status, nodes, stats

    def _factored_result(self, A: NDArray[np.float64], J: NDArray[np.float64], buffer: NDArray[np.float64],
                         settled: NDArray[np.bool_], nodes: NDArray[np.int64], stats: NDArray[np.float64],
                         methods: set[str], row: Callable[[int], ImpactResult]) -> BatchResult:
        """The result of a factored stack (:meth:`apply_factored_stack`) whose kernel ran each row's compiled
        single impact into ``buffer[i]`` (B, ≥ 3n + 12): the rows ``settled`` there, the others ``row(i)``.

        ``nodes`` (B,) and ``stats`` (B, ≥ 4: error estimate, |u₋|, tr W, n⁰ · u₊) are the kernel's for the
        settled rows, whose averaging methods are ``methods``. As the row-by-row loop of
        :func:`mbimpact.impact`: the fields are its own to the bit, ``nodes`` and ``method`` what
        :meth:`BatchResult.stack` reports, errors come in row order, and a settled row whose contact
        still approaches warns (once for the batch: the single impact's text) before the rows after it.
        """
        B, n = len(buffer), A.shape[-1]
        error = stats[:, 0].copy()
        # as _single_result: a compiled row whose contact still approaches after the impact (κ < 0) warns, once,
        # before the rows after it (a later row's error, or a filter that raises the warning, comes in row order)
        approaching = np.flatnonzero(settled & ~(stats[:, 3] >= -SEPARATION_RTOL * stats[:, 1]))
        first = int(approaching[0]) if approaching.size else B
        for i in np.flatnonzero(~settled).tolist():
            if i > first:
                self._warn_no_separation()
                first = B
            result = row(i)
            buffer[i, :3 * n + 12] = np.concatenate([result.v_minus, result.v_plus, result.dv, result.P,
                                                     result.u_minus, result.u_plus, result.n0])
            error[i], nodes[i] = result.error_estimate, result.nodes
            methods.add(result.method)
        if first < B:
            self._warn_no_separation()
        v_minus, v_plus, dv, P, u_minus, u_plus, n0 = np.split(buffer[:, :3 * n + 12], np.cumsum([n, n, n, 3, 3, 3]),
                                                               axis=1)  # the single result's layout
        return BatchResult(V_minus=v_minus, V_plus=v_plus, dV=dv, P=P, U_minus=u_minus, U_plus=u_plus, n0=n0, A=A, J=J,
                           law=self, error_estimate=error, nodes=int(nodes.max()), method="+".join(sorted(methods)))

    # ------------------------------------------------------------------ batch
    def apply_batch(self, A: ArrayLike, J: ArrayLike, V: ArrayLike, frame: ArrayLike) -> BatchResult:
        """:meth:`apply` for many velocities at one configuration, vectorised.

        Parameters
        ----------
        A : array_like, shape (n, n)
        J : array_like, shape (d, n)
        V : array_like, shape (B, n), B ≥ 1
            Pre-impact velocities, one per row; every row must approach the surface.
        frame : array_like, shape (d,) or (d, d)

        Returns
        -------
        BatchResult
        """
        metric = ContactMetric.from_arrays(A, J)
        V = as_array("V", V, 2, (None, metric.n))
        if not len(V):
            raise ShapeError("V must have at least one row (one velocity per impact)")
        R = local_basis(frame, metric.d)
        # one BLAS thread: the batch's products are thin ((B, d) by (d, d)), threads only cost
        with single_blas_thread(len(V)), quiet_overflow():  # overflows are named below
            U = V @ metric.J.T
            out = self.impulses(metric, U, R)  # names a U beyond the float range
            dV = out.P @ metric.AinvJt.T
            V_plus, U_plus = V + dV, U + out.P @ metric.W
        check_in_range("the impacts' outcome (V₊ or U₊)", V_plus, U_plus)
        result = BatchResult(
            V_minus=V.copy(), V_plus=V_plus, dV=dV, P=out.P, U_minus=U, U_plus=U_plus,
            n0=R[:, -1].copy(), A=metric.A, J=metric.J, law=self, error_estimate=out.error, nodes=out.nodes,
            method=out.method,
        )
        approaching = np.flatnonzero(~result.separates)
        if approaching.size:
            warn(NoSeparationWarning, f"{self!r}: {approaching.size} of {len(V)} contacts still approach the surface "
                 f"after the impact (kappa < 0, e.g. row {approaching[0]}); {self.separation_advice()}")
        return result

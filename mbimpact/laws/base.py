"""Impact laws: the contract, and the pipeline from the metric to the result.

Every law shares one pipeline (:mod:`mbimpact.theory`, §5):

1. metric — A(q) factorised once, W = J A⁻¹ Jᵀ, u = J v (:mod:`mbimpact.metric`);
2. law — a contact impulse P from (W, u) in the local frame of the base surface
   (:meth:`ImpactLaw.contact_impulses`, the only step that differs between laws);
3. result — Δv = A⁻¹ Jᵀ P and I = Jᵀ P, Lagrange's equations (1.1).

A law is a subclass of :class:`ImpactLaw`, which says, as scipy's ``OdeSolver`` does, what a
subclass provides:

========================= ==============================================================================
``contact_impulses(W, U)`` **required**: the contact impulses for unit velocities at a unit-trace W
``dim``                   the contact-space dimension the law needs (default: 2 or 3)
``homogeneous``           whether the law is of degree 1 in u (default True; False: it gets physical speeds)
``compiled_impact()``     its whole single impact as compiled code, if it has one (default None)
``separation_advice()``   what to do about a contact that still approaches after the impact
========================= ==============================================================================

A law with a closed form may also override :meth:`ImpactLaw.apply_metric` (one impact at a metric) and
:meth:`ImpactLaw.apply_batch` (many velocities at one configuration). Entry points: :meth:`apply` and
:meth:`apply_batch` on arrays, :func:`mbimpact.impact` on a mechanism (:mod:`mbimpact.pipeline`), and
:meth:`impulses` for contact velocities given directly (a moving surface).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.geometry import DEGENERATE
from ..common.threads import single_blas_thread
from ..common.validation import as_array, check_in_range, quiet_overflow
from ..errors import NoImpactError, NonFiniteError, NoSeparationWarning, RoughnessError, ShapeError, ignored, warn
from ..common.basis import local_basis
from ..metric.delassus import KERNELS as METRIC_KERNELS
from ..metric.delassus import ContactMetric
from ..results.impact import BatchResult, ContactImpulses, ImpactResult
from .compiled import RANK_FLOOR, finish_prepared

if TYPE_CHECKING:
    from .compiled import CompiledImpact

__all__ = ["ImpactLaw", "WrappedLaw"]


class ImpactLaw(ABC):
    """Base class: the pipeline metric → contact impulse → result (see the module docstring for the
    contract a subclass fulfils).

    Attributes
    ----------
    e : float
        Restitution (of the facets, for the rough law).
    """

    e: float

    @property
    def dim(self) -> int | None:
        """Contact-space dimension the law requires (None: 2 or 3)."""
        return None

    @property
    def homogeneous(self) -> bool:
        """Whether the law is positively homogeneous of degree 1 in u (1°): :meth:`contact_impulses` then
        gets unit velocities. A law for which the speed matters overrides :meth:`impulses` to hand it on."""
        return True

    @abstractmethod
    def contact_impulses(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        """Contact impulses for a batch of unit contact velocities, local frame.

        Parameters
        ----------
        W : ndarray, shape (d, d)
            Delassus matrix in the local frame, Rᵀ W R, of unit trace.
        U : ndarray, shape (B, d)
            Unit pre-impact contact velocities, ``U[:, -1] < 0``.

        Returns
        -------
        ContactImpulses
            P (B, d) in the local frame, error estimates (B,), nodes, method.
        """

    def compiled_impact(self) -> CompiledImpact | None:
        """The law's whole spatial impact of a mechanism as compiled code (metric, law and outcome in one
        call, :class:`~mbimpact.laws.compiled.CompiledImpact`), or None: the pipeline then runs
        :meth:`contact_impulses` between compiled metric steps. A law with one returns None from a
        subclass, which may change any step."""
        return None

    def separation_advice(self) -> str:
        """What a :class:`NoSeparationWarning` of this law tells the user to do about a contact that
        still approaches after the impact."""
        return "further micro-impacts follow (a RoughLaw with repeat=True applies them)"

    def warn_no_separation(self) -> None:
        """The :class:`NoSeparationWarning` of an impact whose contact still approaches (κ < 0). Its text
        is the same for every impact of this law (κ is on the result): Python's default filter then
        shows it once per line of the caller, not once per impact of a loop."""
        if ignored(NoSeparationWarning):  # silenced in a loop of impacts: not even the text is made
            return
        warn(NoSeparationWarning, f"{self!r}: the contact still approaches the surface after the impact "
             f"(kappa < 0, the result's kappa says by how much); {self.separation_advice()}")

    # ------------------------------------------------------------------ the pipeline
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
        check_in_range("the contact velocity", U)
        with quiet_overflow():  # extreme magnitudes overflow silently here and are named below
            P, err, nodes, method = self._local_impulses(metric, metric.W, U, R)
        check_in_range("the contact impulse P", P)
        return ContactImpulses(P, err, nodes, method)

    def _local_impulses(self, metric: ContactMetric, W: NDArray[np.float64], U: NDArray[np.float64],
                        R: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], int, str]:
        n0 = R[:, -1]
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
        out = self.contact_impulses(W_local, U_local)
        P, err, nodes, method = out.P @ R.T, out.error, out.nodes, out.method
        proj = metric.range_projector
        if proj is not None:
            # rank-deficient J: report the minimum-norm impulse, the only one that
            # does not depend on how the quadrature split the part in null(Jᵀ)
            P = P @ proj
        return P * (speed / w_scale)[:, None], err, nodes, method

    def apply_metric(self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]) -> ImpactResult:
        """The impact at a validated metric, velocity ``v`` (n,) and contact frame ``R`` (d, d).

        A spatial impact of a homogeneous law runs with its metric steps compiled (the checks, scalings
        and impulse of :meth:`impulses` for the contact velocity, in two compiled calls around
        :meth:`contact_impulses`); what they decline (no approach, n⁰ out of reach, a rank-deficient W)
        and planar impacts take :meth:`impulses`, which names or treats them.
        """
        if len(R) == 3 and self.homogeneous and self.dim in (None, 3):
            compiled = self._on_metric(metric, v, R)
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
        result = ImpactResult(
            v_minus=v.copy(), v_plus=v_plus, dv=dv, P=P, u_minus=u, u_plus=u_plus, n0=R[:, -1].copy(), A=metric.A,
            J=metric.J, law=self, error_estimate=err, nodes=nodes, method=method,
        )
        if not result.separates:
            self.warn_no_separation()
        return result

    def _on_metric(self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]) -> ImpactResult | None:
        """:meth:`apply_metric` for one spatial impact with the metric steps compiled
        (:func:`mbimpact.metric.kernels.prepare_factor` on a :class:`~mbimpact.metric.FactoredMetric`'s factor,
        else :func:`~mbimpact.metric.kernels.prepare_metric`; then :func:`~mbimpact.laws.compiled.finish_prepared`),
        or None for what the general route treats."""
        kernels = METRIC_KERNELS.get()
        buffer = np.empty(6 * len(v) + 33)  # kernels.single_size
        factor = metric.factor
        if factor is not None:  # A(q)'s factor at hand: the metric and the state in one call on it
            prepare = METRIC_KERNELS.unchecked("prepare_factor") if metric.trusted else kernels.prepare_factor
            status, speed, w_scale = prepare(factor[0], factor[1], metric.J, v, R, DEGENERATE, RANK_FLOOR, buffer)
        else:
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
        return finish_prepared(self, metric.A, metric.J, R, buffer, speed, w_scale)

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


class WrappedLaw(ImpactLaw):
    """A law that runs another law's pipeline with a core of its own (the rough law at given speeds, the
    outcome machinery's capture and replay of impulses): its dimension, restitution and name are the
    wrapped law's; a subclass implements :meth:`contact_impulses`."""

    def __init__(self, law: ImpactLaw) -> None:
        self.law, self.e = law, law.e

    @property
    def dim(self) -> int | None:
        return self.law.dim

    def __repr__(self) -> str:
        return repr(self.law)

"""Newton's frictionless impact (1.2): the law of one smooth facet, and of a smooth surface."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.compiled import KernelModule
from ..common.threads import single_blas_thread
from ..common.validation import as_array, quiet_overflow
from ..common.basis import local_basis
from ..metric.delassus import ContactMetric
from ..results.impact import BatchResult, ContactImpulses, ImpactResult
from .base import ImpactLaw
from .compiled import CompiledImpact
from ..facets.restitution import restitution_from

__all__ = ["NewtonLaw", "KERNELS"]

#: The compiled impact of :class:`NewtonLaw` (:mod:`mbimpact.laws.newton_kernels`), loaded on first use.
KERNELS = KernelModule("mbimpact.laws.newton_kernels")


def _compiled(e: float) -> CompiledImpact:
    """The compiled impact of a restitution ``e``, made once (:meth:`NewtonLaw.compiled_impact` looks it up)."""
    if len(_COMPILED) > 256:
        _COMPILED.clear()
    def front(native: Any, bound: Any, q: Any, v: Any, frame: int, point: Any, basis: Any, out: Any) -> Any:
        return native.newton(bound, q, v, frame, point, basis, e, out)  # stage 1 and (1.2) in one C++ call

    made = _COMPILED[e] = CompiledImpact(KERNELS, "newton_impact", "newton_batch", (e,), ("closed-form",), front,
                                         overlap=False)
    return made


_COMPILED: dict[float, CompiledImpact] = {}


_BIG = 1e300  # squares below it: magnitudes below 1e150, whose sums and products of two cannot overflow
_HUGE = 1e150  # magnitudes below it: their products of two, and sums of those, stay finite


class NewtonLaw(ImpactLaw):
    """Frictionless Newton impact (1.2): Δv = −(1+e)(N, v₋) N / |N|².

    Equal to ``pin.impulseDynamics(model, data, q, v, n0ᵀJ[None, :], e, 0.0)`` to rounding: the
    same factor of A(q), one solve along n⁰ᵀJ. On a mechanism (:func:`mbimpact.impact`) it needs no
    Delassus matrix (:meth:`compiled_impact`). The reported contact impulse is P = P_n n⁰ whatever
    the rank of J: the frictionless impulse is normal, and Δv = P_n A⁻¹Jᵀn⁰ needs no projection
    (other laws report the minimum-norm P of a rank-deficient J).

    Parameters
    ----------
    e : float, optional
        Restitution in [0, 1].
    k : float, optional
        Kelvin–Voigt damping ratio in [0, 1] instead of ``e`` (e = e_from_k(k)).
    """

    def __init__(self, e: float | None = None, *, k: float | None = None) -> None:
        self.e = restitution_from(e, k)

    def __repr__(self) -> str:
        return f"NewtonLaw(e={self.e:g})"

    def contact_impulses(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        P = np.zeros_like(U)
        P[:, -1] = -(1.0 + self.e) * U[:, -1] / W[-1, -1]
        return ContactImpulses(P, np.zeros(len(U)))

    def compiled_impact(self) -> CompiledImpact | None:
        """One compiled call on Pinocchio's factor (:func:`mbimpact.laws.newton_kernels.newton_impact`), and
        the compiled front end's whole impact at a point contact (``native.newton``: stage 1 and (1.2) in one
        C++ call); None for a subclass."""
        if type(self) is not NewtonLaw:
            return None
        made = _COMPILED.get(self.e)
        return _compiled(self.e) if made is None else made

    def apply_metric(self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]) -> ImpactResult:
        # Newton's impulse needs A⁻¹ along one direction only, y = A⁻¹ Jᵀn⁰: one solve with
        # the factor of A (what pin.impulseDynamics does), not the whole Delassus matrix
        # (ndarray.dot rather than @: the same BLAS call, without the generalised ufunc's overhead)
        J, n0 = metric.J, R[:, -1]
        with quiet_overflow():  # extreme magnitudes overflow silently here; the general route names them
            jn = n0.dot(J)
            un = float(jn.dot(v))
            # degenerate cases (no approach, n⁰ out of reach) take the general route, which names
            # the error, and so do the magnitudes that overflow; |J|² = tr(J Jᵀ). A (nearly)
            # rank-deficient J stays here: Newton's impulse is P_n n⁰ whatever the rank, and Δv = P_n y
            # is exact, where projecting P on range(W) would move Δv by up to √(λ_min/λ_max) |Δv|
            if not -_BIG < un < 0.0:
                return super().apply_metric(metric, v, R)
            jj = float(np.vdot(J, J))
            if not (float(jn.dot(jn)) > 1e-8 * jj and jj < _BIG):
                return super().apply_metric(metric, v, R)
            y = metric.solver(jn)
            wnn = float(jn.dot(y))
            Pn = -(1.0 + self.e) * un / wnn if wnn > 0.0 else math.inf
            # |Δv|, |v| and |J Δv| ≤ |J| |Δv| below 1e150: the sums below stay finite
            if not (Pn * Pn * float(y.dot(y)) * (1.0 + jj) < _BIG and float(v.dot(v)) < _BIG):
                return super().apply_metric(metric, v, R)
            dv = Pn * y
            u = J.dot(v)
        return ImpactResult(
            v_minus=v.copy(), v_plus=v + dv, dv=dv, P=Pn * n0, u_minus=u, u_plus=u + J.dot(dv),
            n0=n0.copy(), A=metric.A, J=J, law=self,
        )

    def apply_batch(self, A: ArrayLike, J: ArrayLike, V: ArrayLike, frame: ArrayLike) -> BatchResult:
        """:meth:`ImpactLaw.apply_batch` in closed form: Δv = P_n y for every row, with
        y = A⁻¹ Jᵀn⁰ solved once and P_n = −(1 + e) n⁰ᵀJ v / (n⁰ᵀJ y).

        Only the normal impulses are computed here: the result forms V₊, Δv, P, U₋ and U₊ on first
        access (:meth:`BatchResult.along_normal`), so that a batch pays for the fields it reads.
        The degenerate cases (a row that does not approach, n⁰ out of reach, magnitudes that
        could overflow) take the general route, which names them or treats them. No row
        can still approach after a Newton impact (n⁰ᵀu₊ = −e n⁰ᵀu₋ ≥ 0): no check is needed for it.
        """
        metric = ContactMetric.from_arrays(A, J)
        V = as_array("V", V, 2, (None, metric.n))
        R = local_basis(frame, metric.d)
        Jm, n0 = metric.J, R[:, -1]
        # one BLAS thread for the thin products; the general route names what overflows
        with single_blas_thread(len(V)), quiet_overflow():
            jn = n0.dot(Jm)
            jj = float(np.vdot(Jm, Jm))
            if not (len(V) and float(jn.dot(jn)) > 1e-8 * jj and jj < _BIG):
                return super().apply_batch(A, J, V, frame)
            y = metric.solver(jn)
            wnn = float(jn.dot(y))
            un = V.dot(jn)  # (B,): one pass over V
            un_min, un_max = float(un.min()), float(un.max())
            if not (wnn > 0.0 and -_BIG < un_min and un_max < 0.0):
                return super().apply_batch(A, J, V, frame)
            Pn = un
            Pn *= -(1.0 + self.e) / wnn  # in place: a batch's time goes to fresh memory
            # the outcome is formed on access (BatchResult.along_normal); bounds instead of its sums
            # keep it finite: |V|, |Δv| ≤ max|P_n| max|y| and |J Δv| ≤ max|P_n| max|J y| below 1e150,
            # and |J|² < 1e300 (jj above), so that every product of two and their sums stay finite.
            # What fails them takes the general route, which names what overflows
            Jy = Jm.dot(y)
            v_max = max(float(V.max()), -float(V.min()))
            pn_max = float(-(1.0 + self.e) / wnn * un_min)
            jump_max = pn_max * max(float(np.abs(y).max()), float(np.abs(Jy).max()))
        if not (v_max < _HUGE and jump_max < _HUGE):
            return super().apply_batch(A, J, V, frame)
        return BatchResult.along_normal(V.copy(), Pn, y, Jy, n0.copy(), metric.A, Jm, self)

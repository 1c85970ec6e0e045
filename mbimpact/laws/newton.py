"""Newton's frictionless impact (1.2): the law of one smooth facet, and of a smooth surface."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.threads import single_blas_thread
from ..common.validation import as_array, quiet_overflow
from ..metric.basis import local_basis
from ..metric.delassus import KERNELS as METRIC_KERNELS
from ..metric.delassus import ContactMetric
from ..results.impact import BatchResult, ContactImpulses, ImpactResult
from .base import ImpactLaw
from .restitution import restitution_from

if TYPE_CHECKING:
    from ..mechanism.mechanism import Mechanism

__all__ = ["NewtonLaw"]

_BIG = 1e300  # squares below it: magnitudes below 1e150, whose sums and products of two cannot overflow
_HUGE = 1e150  # magnitudes below it: their products of two, and sums of those, stay finite


class NewtonLaw(ImpactLaw):
    """Frictionless Newton impact (1.2): Δv = −(1+e)(N, v₋) N / |N|².

    Equal to ``pin.impulseDynamics(model, data, q, v, n0ᵀJ[None, :], e, 0.0)`` to rounding: the
    same factor of A(q), one solve along n⁰ᵀJ. On a mechanism (:func:`mbimpact.impact`) it needs no
    Delassus matrix (:meth:`apply_mechanism`). The reported contact impulse is P = P_n n⁰ whatever
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

    def apply_mechanism(self, mech: Mechanism, q: NDArray[np.float64], v: NDArray[np.float64],
                        J: NDArray[np.float64], R: NDArray[np.float64],
                        factor: tuple[NDArray[np.float64], ...] | None = None) -> ImpactResult:
        """:meth:`apply_metric` without the metric: Newton's impulse needs A⁻¹ along n⁰ᵀJ only, one
        solve with Pinocchio's factor of A(q), and the whole impact is one compiled call on it
        (:func:`mbimpact.metric.kernels.newton`), the closed form of :meth:`apply_metric` to rounding.

        The degenerate cases (no approach, n⁰ out of reach, A(q) not positive definite) and
        magnitudes that overflow take the general route, which names them or treats them; so does a
        subclass that overrides :meth:`apply_metric`.
        """
        if type(self).apply_metric is NewtonLaw.apply_metric:
            kernels = METRIC_KERNELS.get()
            A, U, D = factor if factor is not None else mech.factor_arrays(q)
            d = len(R)
            buffer = np.empty(3 * len(v) + 4 * d)
            if kernels.newton(U, D, J, v, R, self.e, buffer):
                return ImpactResult.from_buffer(buffer, A, J, self)
        return self.apply_metric(ContactMetric.from_mechanism(mech, q, J), v, R)

    def reads_factor(self) -> bool:
        """:meth:`ImpactLaw.reads_factor`: True (one solve with the factor, :meth:`apply_mechanism`)."""
        return True

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

    def apply_stack(self, A: NDArray[np.float64], J: NDArray[np.float64], V: NDArray[np.float64],
                    R: NDArray[np.float64]) -> BatchResult | None:
        """:meth:`apply_metric` for rows of (A, J, v, R), vectorised: one batched Cholesky and solve.

        Returns None when a row needs the general route (no approach, n⁰ out of reach,
        A not positive definite, magnitudes that overflow): the caller then
        applies the law row by row, which names the error or treats the row.
        """
        n0 = R[:, :, -1]
        with quiet_overflow():
            jn = np.einsum("bd,bdn->bn", n0, J)
            un = np.einsum("bn,bn->b", jn, V)
            if not (np.all(un < 0.0) and np.all(un > -_BIG)):
                return None
            jj = np.einsum("bdn,bdn->b", J, J)
            if not (np.all(np.einsum("bn,bn->b", jn, jn) > 1e-8 * jj) and np.all(jj < _BIG)):
                return None
            try:
                L = np.linalg.cholesky(A)
            except np.linalg.LinAlgError:
                return None
            y = np.linalg.solve(L.transpose(0, 2, 1), np.linalg.solve(L, jn[:, :, None]))[:, :, 0]
            wnn = np.einsum("bn,bn->b", jn, y)
            Pn = -(1.0 + self.e) * un / wnn
            dV = Pn[:, None] * y
            U = np.einsum("bdn,bn->bd", J, V)
            U_plus = U + np.einsum("bdn,bn->bd", J, dV)
            V_plus = V + dV
            if not (np.all(wnn > 0.0) and np.isfinite(V_plus).all() and np.isfinite(U_plus).all()):
                return None
        return BatchResult(
            V_minus=V.copy(), V_plus=V_plus, dV=dV, P=Pn[:, None] * n0, U_minus=U, U_plus=U_plus, n0=n0.copy(),
            A=A, J=J, law=self, error_estimate=np.zeros(len(V)),
        )

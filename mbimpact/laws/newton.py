"""Newton's frictionless impact (1.2): the law of one smooth facet, and of a smooth surface."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..metric.delassus import ContactMetric, spread_bound
from ..results.impact import ContactImpulses, ImpactResult
from .base import ImpactLaw
from .restitution import restitution_from

__all__ = ["NewtonLaw"]


class NewtonLaw(ImpactLaw):
    """Frictionless Newton impact (1.2): Δv = −(1+e)(N, v₋) N / |N|².

    Equal to ``pin.impulseDynamics(model, data, q, v, n0ᵀJ[None, :], e, 0.0)``.

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

    def apply_metric(self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]) -> ImpactResult:
        # Newton's impulse needs A⁻¹ along one direction only, y = A⁻¹ Jᵀn⁰: one solve with
        # the factor of A (what pin.impulseDynamics does), not the whole Delassus matrix
        # (ndarray.dot rather than @: the same BLAS call, without the generalised ufunc's overhead)
        J, n0 = metric.J, R[:, -1]
        jn = n0.dot(J)
        un = float(jn.dot(v))
        # degenerate cases (no approach, n⁰ out of reach, rank-deficient J) take the
        # general route, which names the error or reports the minimum-norm impulse;
        # |J|² = tr(J Jᵀ), and the rank test reads the same Gram matrix (in floats)
        if not un < 0.0:
            return super().apply_metric(metric, v, R)
        gram = J.dot(J.T).tolist()
        if not float(jn.dot(jn)) > 1e-8 * sum([gram[i][i] for i in range(len(gram))]) or spread_bound(gram) <= 1e-12:
            return super().apply_metric(metric, v, R)
        y = metric.solver(jn)
        Pn = -(1.0 + self.e) * un / float(jn.dot(y))
        dv = Pn * y
        u = J.dot(v)
        return ImpactResult(
            v_minus=v.copy(), v_plus=v + dv, dv=dv, P=Pn * n0, u_minus=u, u_plus=u + J.dot(dv),
            n0=n0.copy(), A=metric.A, J=J, law=self,
        )

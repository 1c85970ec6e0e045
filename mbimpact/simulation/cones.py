"""Unilateral contacts with Coulomb friction, solved by Pinocchio's ADMM constraint solver.

A set of k point contacts, each with a local frame whose last axis is the normal, gives
the contact-space Delassus matrix G = Jc A⁻¹ Jcᵀ (3k × 3k, Jc the stacked Rᵢᵀ Jᵢ) and a
free contact velocity g. Pinocchio's :class:`pinocchio.ADMMConstraintSolver` finds the
impulses λ in the cones |λ_t| ≤ μ λ_n, λ_n ≥ 0 with σ = Gλ + g satisfying the Coulomb
complementarity (De Saxcé's form, so that a sliding contact's friction opposes its
slip): normal velocity ≥ 0, zero where the contact pushes; sticking inside the cone,
sliding against the friction on its boundary. μ = 0 gives frictionless unilateral
contacts. The same problem serves persistent contact (velocity-level time stepping)
and plastic or Newton impacts at several contacts (g shifted by the restitution).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..errors import IntegrationError

__all__ = ["ConeSolver"]


def _dummy_model() -> Any:
    """The constraint models only carry the cones to the solver: a one-body model will do."""
    model = pin.Model()
    jid = model.addJoint(0, pin.JointModelTranslation(), pin.SE3.Identity(), "body")
    model.appendBodyToJoint(jid, pin.Inertia.FromSphere(1.0, 0.1), pin.SE3.Identity())
    return model, jid


class ConeSolver:
    """Solves Coulomb cone complementarity problems (G, g, μ) with Pinocchio's ADMM, and with its
    projected Gauss–Seidel (PGS) where ADMM does not converge.

    ADMM is the default: it converges on the rank-deficient G of a body resting on more than three
    points, where PGS is slow. It can stall on a single well-conditioned sliding contact (an ANYmal
    foot, cond(G) = 120: residual 0.06 after 5e4 iterations), which PGS solves in 30 sweeps.

    Parameters
    ----------
    tolerance : float
        Feasibility and complementarity tolerance of the solver (relative and absolute).
    max_iterations : int
    """

    def __init__(self, tolerance: float = 1e-12, max_iterations: int = 5000) -> None:
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self._model, self._joint = _dummy_model()
        self._sets: dict[tuple[float, ...], tuple[Any, Any]] = {}
        self._previous: dict[tuple[float, ...], NDArray[np.float64]] = {}
        self._solvers: dict[int, tuple[Any, Any]] = {}
        self._pgs: dict[int, tuple[Any, Any]] = {}
        self._pgs_settings = pgs = pin.PGSSolverSettings()
        pgs.absolute_feasibility_tol = pgs.relative_feasibility_tol = tolerance
        pgs.absolute_complementarity_tol = pgs.relative_complementarity_tol = tolerance
        pgs.max_iterations = 10 * max_iterations
        self._settings = pin.ADMMSolverSettings()
        st = self._settings
        st.absolute_feasibility_tol = st.relative_feasibility_tol = tolerance
        st.absolute_complementarity_tol = st.relative_complementarity_tol = tolerance
        st.max_iterations = max_iterations

    def warm_start(self, mus: tuple[float, ...]) -> NDArray[np.float64] | None:
        """The impulses of the last problem solved with frictions ``mus`` (the next one's first guess)."""
        return self._previous.get(mus)

    def remember(self, mus: tuple[float, ...], lam: NDArray[np.float64]) -> None:
        """Record ``lam`` as the solution of a problem with frictions ``mus``, solved elsewhere (the
        compiled contact step), so that the next solve here starts from it."""
        self._previous[mus] = np.array(lam, dtype=float)

    def _cones(self, mus: tuple[float, ...]) -> tuple[Any, Any]:
        hit = self._sets.get(mus)
        if hit is None:
            models, datas = pin.StdVec_ConstraintModel(), pin.StdVec_ConstraintData()
            for mu in mus:
                cm = pin.PointContactConstraintModel(self._model, 0, pin.SE3.Identity(), self._joint, pin.SE3.Identity())
                cm.setFriction(float(mu))
                models.append(cm)
            for i in range(len(mus)):
                datas.append(models[i].createData())
            hit = self._sets[mus] = (models, datas)
        return hit

    def solve(self, G: NDArray[np.float64], g: NDArray[np.float64], mus: tuple[float, ...],
              warm: bool = True) -> NDArray[np.float64]:
        """Impulses λ (3k,) for Delassus matrix G (3k, 3k), free velocity g (3k,) and frictions μ (k,).

        Raises
        ------
        IntegrationError
            The solver did not converge.
        """
        models, datas = self._cones(mus)
        n = len(g)
        # scaled to unit size: the solver's absolute tolerances then mean relative ones
        scale_g = float(np.abs(g).max()) or 1.0
        scale_G = float(np.abs(np.diag(G)).max()) or 1.0
        if n not in self._solvers:
            self._solvers[n] = (pin.ADMMConstraintSolver(n), pin.ADMMSolverResult())
        solver, result = self._solvers[n]
        settings = self._settings
        previous = self._previous.get(mus)
        guess = (previous * (scale_G / scale_g) if warm and previous is not None and previous.shape == (n,)
                 else np.zeros(n))
        # a rigid body resting on more than three points has a rank-deficient G (4 corners: rank 6 of 12);
        # ADMM then converges slowly but surely: a second attempt gets ten times the iterations, then PGS
        bad = np.inf
        for attempt, iterations in enumerate((self.max_iterations, 10 * self.max_iterations, 0)):
            if attempt < 2:
                settings.max_iterations = iterations
                result.setConstraintImpulseGuess(guess)
                # a fresh Delassus operator per solve: the solver leaves its damping in the one it is given
                solver.solve(pin.DelassusOperatorDense(G / scale_G), g / scale_g, models, datas, settings, result)
                lam = np.array(result.retrieveConstraintImpulses()) * (scale_g / scale_G)
                if result.converged and np.all(np.isfinite(lam)):
                    break
            else:
                if n not in self._pgs:
                    self._pgs[n] = (pin.PGSConstraintSolver(n), pin.PGSSolverResult())
                pgs, pgs_result = self._pgs[n]
                pgs_result.setConstraintImpulseGuess(np.zeros(n))
                pgs.solve(pin.DelassusOperatorDense(G / scale_G), g / scale_g, models, datas, self._pgs_settings,
                          pgs_result)
                lam = np.array(pgs_result.retrieveConstraintImpulses()) * (scale_g / scale_G)
            # the solution is still checked: ADMM's stopping test can be stricter than needed
            sigma = G @ lam + g
            bad = max(float(-lam[2::3].min(initial=0.0)), float(-sigma[2::3].min(initial=0.0)) / scale_g * scale_G,
                      float(np.abs(lam[2::3] @ sigma[2::3])) / (scale_g * scale_g / scale_G))
            if np.all(np.isfinite(lam)) and bad <= 1e-6:
                break
        else:
            raise IntegrationError(f"the contact solver (Pinocchio ADMM, then PGS) did not converge for {len(mus)} "
                                   f"contacts (residual {bad:.3g})")
        self._previous[mus] = lam
        return lam

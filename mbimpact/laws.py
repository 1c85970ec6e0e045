"""Impact laws: the shared pipeline and Newton's frictionless law (1.2).

Every law shares one pipeline (THEORY §5):

1. metric — factorise A once, W = J A⁻¹ Jᵀ, u = J v (:mod:`mbimpact.metric`);
2. law — a contact impulse P from (W, u) in the local frame of the base surface;
3. result — Δv = A⁻¹ Jᵀ P and I = Jᵀ P, Lagrange's equations (1.1).

Only step 2 differs between laws (:class:`NewtonLaw` here, :class:`RoughLaw`
in :mod:`mbimpact.roughlaw`, :class:`CoulombLaw` in :mod:`mbimpact.coulomb`), and
it is written once for a batch of velocities (rows); a single impact is a batch of one
(with scalar checks around it, and shortcuts where one velocity allows them).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._validate import as_array, as_scalar
from .errors import AccuracyWarning, NoImpactError, NoSeparationWarning, ParameterError, RoughnessError, warn
from .metric import ContactMetric, local_basis, spread_bound
from .restitution import e_from_k
from .result import BatchResult, ImpactResult

if TYPE_CHECKING:
    from .mechanism import Mechanism

__all__ = ["ImpactLaw", "NewtonLaw", "AccuracyWarning"]

# A facet (or base normal) with mᵀWm below this fraction of trace(W) cannot be
# moved along by the mechanism (Jᵀm ≈ 0): it carries no flux and is skipped.
_DEGENERATE = 1e-14
# Rows per block in batch evaluation: keeps (rows × nodes × d) work arrays in cache.
_BLOCK = 2048


def warn_accuracy(message: str) -> None:
    """Issue an :class:`AccuracyWarning` at the user's line."""
    warn(AccuracyWarning, message)


def _restitution(e: float | None, k: float | None) -> float:
    """The facet restitution e from exactly one of e or the damping ratio k."""
    if (e is None) == (k is None):
        raise ParameterError("give exactly one of e (restitution) or k (Kelvin–Voigt damping ratio)")
    if e is not None:
        return as_scalar("e", e, 0.0, 1.0)
    return e_from_k(k)  # type: ignore[arg-type]


def _relative_change(fine: NDArray[np.float64], coarse: NDArray[np.float64], W: NDArray[np.float64]) -> NDArray[np.float64]:
    """Relative difference of two impulse estimates, measured by the contact-velocity
    change Δu = W P they produce: with a rank-deficient J, P is only defined up to
    the null space of Jᵀ (= that of W), while Δu is always well defined."""
    diff, ref = (fine - coarse) @ W, fine @ W
    return np.sqrt(np.einsum("bd,bd->b", diff, diff) / np.einsum("bd,bd->b", ref, ref))


class ImpactLaw(ABC):
    """Base class: the pipeline metric → contact impulse → result.

    Subclasses implement :meth:`contact_impulses` in the local frame of the base
    surface (last axis along n⁰) for unit contact velocities.
    """

    e: float

    @property
    def dim(self) -> int | None:
        """Contact-space dimension the law requires (None: 2 or 3)."""
        return None

    @abstractmethod
    def contact_impulses(
        self, W: NDArray[np.float64], U: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """Contact impulses for a batch of unit contact velocities, local frame.

        Parameters
        ----------
        W : ndarray, shape (d, d)
            Delassus matrix in the local frame, Rᵀ W R.
        U : ndarray, shape (B, d)
            Unit pre-impact contact velocities, ``U[:, -1] < 0``.

        Returns
        -------
        P : ndarray, shape (B, d)
            Contact impulses in the local frame.
        error_estimate : ndarray, shape (B,)
            Relative error estimates of ``P`` (0 when exact).
        nodes : int
            Facet nodes (or samples) used in the final evaluation.
        """

    # ------------------------------------------------------------------ single
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

    def apply_mechanism(
        self, mech: Mechanism, q: NDArray[np.float64], v: NDArray[np.float64], J: NDArray[np.float64],
        R: NDArray[np.float64],
    ) -> ImpactResult:
        """:meth:`apply` for a mechanism at a validated state, with the contact Jacobian
        ``J`` (d, nv) and contact basis ``R`` (d, d) at q (:func:`mbimpact.impact`)."""
        A = mech.factorise(q)
        # A⁻¹Jᵀ by the factor, a solve per row of J: backward stable, whereas the product with
        # an explicit inverse (pin.computeMinverse) errs by ~ε cond(A) in every entry
        metric = ContactMetric.from_solved(A, J, np.column_stack([mech.solve(row) for row in J]))
        return self.apply_metric(metric, v, R)

    def apply_metric(
        self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]
    ) -> ImpactResult:
        """:meth:`apply` on an already validated metric and contact basis ``R`` (d, d)."""
        u = metric.J @ v
        P, err, nodes = self.impulse_for(metric, u, R)
        dv = metric.AinvJt @ P
        result = ImpactResult(
            v_minus=v.copy(),
            v_plus=v + dv,
            dv=dv,
            P=P,
            u_minus=u,
            u_plus=u + metric.W @ P,
            n0=R[:, -1].copy(),
            A=metric.A,
            J=metric.J,
            law=self,
            error_estimate=err,
            nodes=nodes,
        )
        if not result.separates:
            warn(NoSeparationWarning, f"{self!r}: the contact still approaches the surface after the impact "
                 f"(kappa = {result.kappa:.6g} < 0); further micro-impacts follow: use repeat=True to apply them")
        return result

    def impulse_for(
        self, metric: ContactMetric, u: NDArray[np.float64], R: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], float, int]:
        """:meth:`impulses_for` for one contact velocity ``u`` (d,): P (d,), error estimate, nodes."""
        # the same steps in scalar checks and (d,) products: a single impact is called in loops
        W, n0 = metric.W, R[:, -1]
        if (self.dim is not None and self.dim != metric.d) or not float(u @ n0) < 0.0 \
                or not float(n0 @ W @ n0) > _DEGENERATE * float(W.trace()):
            P, err, nodes = self.impulses_for(metric, u[None, :], R)  # raises the named error
            return P[0], float(err[0]), nodes
        speed = math.sqrt(float(u @ u))
        P, err, nodes = self.contact_impulses(R.T @ W @ R, (u @ R)[None, :] / speed)
        P = R @ P[0]
        proj = metric.range_projector
        if proj is not None:
            P = proj @ P  # the minimum-norm impulse, as in impulses_for
        return P * speed, float(err[0]), nodes

    # ------------------------------------------------------------------ batch
    def apply_batch(self, A: ArrayLike, J: ArrayLike, V: ArrayLike, frame: ArrayLike) -> BatchResult:
        """:meth:`apply` for many velocities at one configuration, vectorised.

        Parameters
        ----------
        A : array_like, shape (n, n)
        J : array_like, shape (d, n)
        V : array_like, shape (B, n)
            Pre-impact velocities, one per row; every row must approach the surface.
        frame : array_like, shape (d,) or (d, d)

        Returns
        -------
        BatchResult
        """
        metric = ContactMetric.from_arrays(A, J)
        V = as_array("V", V, 2, (None, metric.n))
        R = local_basis(frame, metric.d)
        P, U, err, nodes = self._impulses(metric, V, R)
        dV = P @ metric.AinvJt.T
        result = BatchResult(
            V_minus=V.copy(), V_plus=V + dV, dV=dV, P=P, U_minus=U, U_plus=U + P @ metric.W,
            n0=R[:, -1].copy(), A=metric.A, J=metric.J, law=self, error_estimate=err, nodes=nodes,
        )
        approaching = np.flatnonzero(~result.separates)
        if approaching.size:
            warn(NoSeparationWarning, f"{self!r}: {approaching.size} of {len(V)} contacts still approach the surface "
                 f"after the impact (kappa < 0, e.g. row {approaching[0]}); further micro-impacts follow: "
                 "use repeat=True to apply them")
        return result

    def _impulses(
        self, metric: ContactMetric, V: NDArray[np.float64], R: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], int]:
        """World-frame impulses P (B, d), contact velocities U (B, d), errors (B,), nodes."""
        U = V @ metric.J.T
        P, err, nodes = self.impulses_for(metric, U, R)
        return P, U, err, nodes

    def impulses_for(
        self, metric: ContactMetric, U: NDArray[np.float64], R: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """Contact impulses P (B, d), world frame, for given contact velocities U (B, d).

        ``U`` is the velocity of the contact point relative to the surface; it
        differs from J v when the surface moves (a vibrating table).
        """
        d = metric.d
        if self.dim is not None and self.dim != d:
            raise RoughnessError(f"{self!r} needs a {self.dim}-D contact space but J has {d} rows")
        n0 = R[:, -1]
        un = U @ n0
        if not un.max() < 0.0:
            bad = np.flatnonzero(~(un < 0.0))
            where = "" if len(un) == 1 else f" (rows {bad[:5].tolist()}{'...' if bad.size > 5 else ''})"
            raise NoImpactError(
                f"the contact point does not approach the surface{where}: "
                f"n0·(J v) = {un[bad[0]]:.6g} must be < 0"
            )
        if float(n0 @ metric.W @ n0) <= _DEGENERATE * float(np.trace(metric.W)):
            raise NoImpactError(
                "the mechanism cannot move the contact point along n0 (n0ᵀ W n0 ≈ 0); no impact can occur"
            )
        # Every law is positively homogeneous of degree 1 in u (1°): work with unit
        # directions so that velocity scales far from 1 neither under- nor overflow.
        speed = np.sqrt(np.einsum("bd,bd->b", U, U))
        W_local = R.T @ metric.W @ R
        U_local = (U @ R) / speed[:, None]
        if len(U) <= _BLOCK:
            P, err, nodes = self.contact_impulses(W_local, U_local)
        else:
            P, err, nodes = np.empty_like(U), np.empty(len(U)), 0
            for start in range(0, len(U), _BLOCK):
                block = slice(start, start + _BLOCK)
                P[block], err[block], nodes_b = self.contact_impulses(W_local, U_local[block])
                nodes = max(nodes, nodes_b)
        P = P @ R.T
        proj = metric.range_projector
        if proj is not None:
            # rank-deficient J: report the minimum-norm impulse, the only one that
            # does not depend on how the quadrature split the part in null(Jᵀ)
            P = P @ proj
        return P * speed[:, None], err, nodes


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
        self.e = _restitution(e, k)

    def __repr__(self) -> str:
        return f"NewtonLaw(e={self.e:g})"

    def contact_impulses(
        self, W: NDArray[np.float64], U: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        P = np.zeros_like(U)
        P[:, -1] = -(1.0 + self.e) * U[:, -1] / W[-1, -1]
        return P, np.zeros(len(U)), 1

    def apply_mechanism(
        self, mech: Mechanism, q: NDArray[np.float64], v: NDArray[np.float64], J: NDArray[np.float64],
        R: NDArray[np.float64],
    ) -> ImpactResult:
        # Newton's impulse needs A⁻¹ along one direction only, y = A⁻¹ Jᵀn⁰: one solve
        # with the sparse Cholesky factor of A (what pin.impulseDynamics does), not W.
        n0 = R[:, -1]
        jn = n0 @ J
        un = float(jn @ v)
        # degenerate cases (no approach, n⁰ out of reach, rank-deficient J) take the
        # general route, which names the error or reports the minimum-norm impulse
        if not un < 0.0 or not float(jn @ jn) > 1e-8 * float(np.vdot(J, J)) or spread_bound(J @ J.T) <= 1e-12:
            return super().apply_mechanism(mech, q, v, J, R)
        A = mech.factorise(q)
        y = mech.solve(jn)
        Pn = -(1.0 + self.e) * un / float(jn @ y)
        dv = Pn * y
        u = J @ v
        return ImpactResult(
            v_minus=v.copy(), v_plus=v + dv, dv=dv, P=Pn * n0, u_minus=u, u_plus=u + J @ dv,
            n0=n0.copy(), A=A, J=J, law=self,
        )

    def impulse_for(
        self, metric: ContactMetric, u: NDArray[np.float64], R: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], float, int]:
        # One velocity: P = −(1+e) (n⁰·u) / (n⁰ᵀWn⁰) n⁰ in a handful of float
        # operations (no local frame needed); the checks are those of impulses_for.
        if metric.range_projector is not None:
            return super().impulse_for(metric, u, R)
        n0 = R[:, -1]
        un = float(u @ n0)
        w_nn = float(n0 @ metric.W @ n0)
        if not un < 0.0 or not w_nn > _DEGENERATE * float(metric.W.trace()):
            return super().impulse_for(metric, u, R)  # raises the named error
        return (-(1.0 + self.e) * un / w_nn) * n0, 0.0, 1

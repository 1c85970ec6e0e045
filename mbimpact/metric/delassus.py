"""The A-metric of the paper (2.1) seen from the contact point: the Delassus matrix.

For a contact point with world-aligned translational Jacobian ``J`` (d, n) the
A-metric normal of a facet with physical unit normal ``m`` is
N_m = A⁻¹ Jᵀ m / √(mᵀ W m) with the Delassus matrix W = J A⁻¹ Jᵀ, and its flux is
(N_m, v) = mᵀ u / √(mᵀ W m) with u = J v (:mod:`mbimpact.theory`, §3). Everything
the impact laws need is therefore one factorisation of A, ``A⁻¹ Jᵀ`` and ``W``;
:class:`ContactMetric` computes the last two on demand, so that Newton's law,
which needs A⁻¹ along one direction only, pays for one solve.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_array
from ..errors import NotPositiveDefiniteError, ShapeError

if TYPE_CHECKING:
    from ..mechanism.mechanism import Mechanism

__all__ = ["ContactMetric", "spread_bound", "eigen_ratio"]

# Relative asymmetry of A tolerated before it is called non-symmetric.
_SYMMETRY_RTOL = 1e-9


@dataclass(frozen=True, eq=False)
class ContactMetric:
    """Mass matrix, contact Jacobian and the Delassus quantities derived from them.

    Attributes
    ----------
    A : ndarray, shape (n, n)
        Symmetric positive definite mass matrix A(q).
    J : ndarray, shape (d, n)
        World-aligned translational contact Jacobian, d = 2 or 3.
    AinvJt : ndarray, shape (n, d)
        A⁻¹ Jᵀ (computed on first use): maps a contact impulse P to Δv = A⁻¹ Jᵀ P.
    W : ndarray, shape (d, d)
        Delassus matrix J A⁻¹ Jᵀ (on first use; exactly symmetric, positive semidefinite).
    """

    A: NDArray[np.float64]
    J: NDArray[np.float64]
    solver: Callable[[NDArray[np.float64]], NDArray[np.float64]] = field(repr=False)

    @classmethod
    def from_arrays(cls, A: ArrayLike, J: ArrayLike) -> ContactMetric:
        """Validate ``A`` and ``J`` and factorise ``A`` once (Cholesky).

        Raises
        ------
        ShapeError, NonFiniteError, NotPositiveDefiniteError
        """
        A = as_array("A", A, 2)
        n = A.shape[0]
        if A.shape != (n, n) or n == 0:
            raise ShapeError(f"A must be a non-empty square matrix, got shape {A.shape}")
        J = as_array("J", J, 2)
        if J.shape[0] not in (2, 3) or J.shape[1] != n:
            raise ShapeError(f"J must have shape (d, {n}) with d = 2 or 3, got {J.shape}")
        scale = float(np.max(np.abs(A)))
        asym = float(np.max(np.abs(A - A.T)))
        if asym > _SYMMETRY_RTOL * scale:
            raise NotPositiveDefiniteError(
                f"A is not symmetric: max |A - Aᵀ| = {asym:.3g} (max |A| = {scale:.3g})"
            )
        return cls.from_symmetric(A, J)

    @classmethod
    def from_symmetric(cls, A: NDArray[np.float64], J: NDArray[np.float64]) -> ContactMetric:
        """For a mass matrix known to be symmetric and finite: only positive definiteness is
        checked, by the Cholesky factorisation itself."""
        # scaled first: a Cholesky of 1e300·I overflows and of 1e-300·I underflows
        scale = float(np.max(np.abs(np.diag(A)))) if A.size else 1.0
        if not scale > 0.0:
            raise NotPositiveDefiniteError("A is not positive definite: its diagonal is zero")
        try:
            L = np.linalg.cholesky(A / scale)
        except np.linalg.LinAlgError:
            lam = float(np.linalg.eigvalsh(0.5 * (A + A.T))[0])
            raise NotPositiveDefiniteError(
                f"A is not positive definite: smallest eigenvalue {lam:.6g} (must be > 0)"
            ) from None
        _freeze(A, J)

        def solve(b: NDArray[np.float64]) -> NDArray[np.float64]:
            import scipy.linalg  # deferred: the import costs more than most impacts

            return scipy.linalg.cho_solve((L, True), b, check_finite=False) / scale

        return cls(A, J, solve)

    @classmethod
    def from_mechanism(cls, mech: Mechanism, q: NDArray[np.float64], J: NDArray[np.float64]) -> ContactMetric:
        """A(q) by ``pin.crba`` with its sparse Cholesky factor (``pin.cholesky``, what
        ``pin.impulseDynamics`` uses); solves by that factor are backward stable, whereas a
        product with the explicit inverse errs by ~ε cond(A) in every entry.

        Raises
        ------
        NotPositiveDefiniteError
            A(q) is singular (massless links) or not positive definite.
        """
        A, factor = mech.factorise(q)
        if not factor.valid:
            lam = float(np.linalg.eigvalsh(A)[0]) if np.all(np.isfinite(A)) else math.nan
            raise NotPositiveDefiniteError(
                f"the mass matrix of {mech.name} at q is not positive definite (smallest eigenvalue "
                f"{lam:.6g}); its URDF may have massless links or joints without inertia"
            )
        _freeze(A, J)
        return cls(A, J, factor.solve)

    def solve(self, b: NDArray[np.float64]) -> NDArray[np.float64]:
        """A⁻¹ b for b of shape (n,) or (n, k)."""
        return self.solver(b)

    @cached_property
    def AinvJt(self) -> NDArray[np.float64]:  # noqa: N802 — the paper's notation
        out = self.solver(np.ascontiguousarray(self.J.T))
        out.flags.writeable = False
        return out

    @cached_property
    def W(self) -> NDArray[np.float64]:  # noqa: N802
        W = self.J @ self.AinvJt
        W = 0.5 * (W + W.T)  # exact symmetry; rounding would otherwise leak into mᵀWm
        W.flags.writeable = False
        return W

    @cached_property
    def range_projector(self) -> NDArray[np.float64] | None:
        """Orthogonal projector onto range(W), or None when W has full rank."""
        W = self.W
        if spread_bound(W) > 1e-12:  # clearly full rank
            return None
        lam, vec = np.linalg.eigh(W)
        keep = lam > 1e-12 * lam[-1]
        return vec[:, keep] @ vec[:, keep].T

    @property
    def d(self) -> int:
        """Dimension of contact space (2 or 3)."""
        return int(self.J.shape[0])

    @property
    def n(self) -> int:
        """Number of generalised velocities."""
        return int(self.A.shape[0])


def _freeze(*arrays: NDArray[np.float64]) -> None:
    for a in arrays:
        a.flags.writeable = False


def spread_bound(W: NDArray[np.float64]) -> float:
    """A lower bound det W / tr(W)^d of λ_min / λ_max for a positive semidefinite W (d ≤ 3).

    Computed in floats on W / tr W (no over- or underflow whatever the scale of W): for
    2 × 2 and 3 × 3 matrices this is far cheaper than LAPACK.
    """
    tr = float(sum(W[i, i] for i in range(len(W))))
    if not tr > 0.0:
        return 0.0
    w = (W / tr).tolist()
    if len(w) == 2:
        return float(w[0][0] * w[1][1] - w[0][1] * w[1][0])
    return float(w[0][0] * (w[1][1] * w[2][2] - w[1][2] * w[2][1]) - w[0][1] * (w[1][0] * w[2][2] - w[1][2] * w[2][0])
                 + w[0][2] * (w[1][0] * w[2][1] - w[1][1] * w[2][0]))


def eigen_ratio(W: NDArray[np.float64]) -> float:
    """λ_min / λ_max of a symmetric positive semidefinite 3 × 3 matrix, in closed form.

    Smith's trigonometric solution of the characteristic cubic in floats (a few µs
    instead of LAPACK's tens); λ_min carries an absolute error of order ε λ_max,
    enough to tell a well-conditioned W from a nearly singular one.
    """
    tr = float(W[0, 0] + W[1, 1] + W[2, 2])
    if not tr > 0.0:
        return 0.0
    (a, b, c), (_, d, f), (_, _, g) = (W / tr).tolist()  # unit trace: no over- or underflow
    q = (a + d + g) / 3.0
    off = b * b + c * c + f * f
    p = math.sqrt(((a - q) ** 2 + (d - q) ** 2 + (g - q) ** 2 + 2.0 * off) / 6.0)
    if p <= 1e-300 or q <= 0.0:
        return 1.0 if q > 0.0 else 0.0
    a, d, g = (a - q) / p, (d - q) / p, (g - q) / p
    b, c, f = b / p, c / p, f / p
    r = 0.5 * (a * (d * g - f * f) - b * (b * g - f * c) + c * (b * f - d * c))
    phi = math.acos(min(1.0, max(-1.0, r))) / 3.0
    largest = q + 2.0 * p * math.cos(phi)
    smallest = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    return max(smallest, 0.0) / largest

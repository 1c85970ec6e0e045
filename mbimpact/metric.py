"""The A-metric of the paper (2.1) seen from the contact point.

For a contact point with world-aligned translational Jacobian ``J`` (d, n) the
A-metric normal of a facet with physical unit normal ``m`` is
N_m = A⁻¹ Jᵀ m / sqrt(mᵀ W m) with the Delassus matrix W = J A⁻¹ Jᵀ, and its
flux is (N_m, v) = mᵀ u / sqrt(mᵀ W m) with u = J v (THEORY §3). Everything the
impact laws need is therefore the factorisation of A once, ``A⁻¹ Jᵀ`` and ``W``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ._validate import as_array
from .errors import NotPositiveDefiniteError, ShapeError

__all__ = ["ContactMetric", "local_basis", "spread_bound", "eigen_ratio"]

# Relative asymmetry of A tolerated before it is called non-symmetric.
_SYMMETRY_RTOL = 1e-9


@dataclass(frozen=True, eq=False)
class ContactMetric:
    """Mass matrix, contact Jacobian and the derived Delassus quantities.

    Attributes
    ----------
    A : ndarray, shape (n, n)
        Symmetric positive definite mass matrix A(q).
    J : ndarray, shape (d, n)
        World-aligned translational contact Jacobian, d = 2 or 3.
    AinvJt : ndarray, shape (n, d)
        A⁻¹ Jᵀ: maps a contact impulse P to the velocity jump, Δv = A⁻¹ Jᵀ P.
    W : ndarray, shape (d, d)
        Delassus matrix J A⁻¹ Jᵀ (symmetric positive semidefinite).
    """

    A: NDArray[np.float64]
    J: NDArray[np.float64]
    AinvJt: NDArray[np.float64]
    W: NDArray[np.float64]

    @classmethod
    def from_arrays(cls, A: ArrayLike, J: ArrayLike) -> ContactMetric:
        """Validate ``A`` and ``J`` and factorise ``A`` once.

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
        """Fast path for a mass matrix known to be symmetric and finite (``pin.crba``).

        Only positive definiteness is checked, by the Cholesky factorisation itself.
        """
        try:
            L = np.linalg.cholesky(A)
        except np.linalg.LinAlgError:
            lam = float(np.linalg.eigvalsh(0.5 * (A + A.T))[0])
            raise NotPositiveDefiniteError(
                f"A is not positive definite: smallest eigenvalue {lam:.6g} (must be > 0)"
            ) from None
        return cls.from_factorised(A, J, scipy.linalg.cho_solve((L, True), J.T, check_finite=False))

    @classmethod
    def from_factorised(
        cls, A: NDArray[np.float64], J: NDArray[np.float64], AinvJt: NDArray[np.float64]
    ) -> ContactMetric:
        """Build from already validated arrays and a precomputed A⁻¹Jᵀ."""
        W = J @ AinvJt
        W = 0.5 * (W + W.T)  # exact symmetry; rounding would otherwise leak into mᵀWm
        for arr in (A, J, AinvJt, W):
            arr.flags.writeable = False
        return cls(A, J, AinvJt, W)

    @classmethod
    def from_solved(cls, A: NDArray[np.float64], J: NDArray[np.float64], AinvJt: NDArray[np.float64]) -> ContactMetric:
        """Fast path with A⁻¹Jᵀ already solved (the sparse Cholesky factor of ``pin.crba``);
        falls back to the checked factorisation if it is not finite (a singular mass matrix)."""
        if not math.isfinite(np.vdot(AinvJt, AinvJt)):  # a NaN or ∞ anywhere (or overflow) takes the checked route
            return cls.from_symmetric(A, J)
        return cls.from_factorised(A, J, AinvJt)

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
        return self.J.shape[0]

    @property
    def n(self) -> int:
        """Number of generalised velocities."""
        return self.A.shape[0]


def local_basis(frame: ArrayLike, d: int) -> NDArray[np.float64]:
    """Orthonormal contact basis whose last column is the base normal n⁰.

    Parameters
    ----------
    frame : array_like, shape (d,) or (d, d)
        Either the base normal n⁰ (normalised here; the tangent directions are
        then an arbitrary right-handed completion) or a rotation whose last
        column is n⁰ (needed when the facet set is anisotropic).
    d : int
        Contact-space dimension, 2 or 3.

    Returns
    -------
    ndarray, shape (d, d)
        Rotation R: local facet coordinates → world-aligned contact coordinates.
    """
    f = as_array("frame", frame, np.ndim(frame))
    if f.shape == (d,):
        # in floats: a basis is built on every call of ImpactLaw.apply
        n = f.tolist()
        norm = math.sqrt(sum(x * x for x in n))
        if norm == 0.0:
            raise ShapeError("the base normal n0 is the zero vector")
        n = [x / norm for x in n]
        if d == 2:
            return np.array([[n[1], n[0]], [-n[0], n[1]]])
        k = min(range(3), key=lambda i: abs(n[i]))  # the world axis least aligned with n0
        t = [(1.0 if i == k else 0.0) - n[k] * n[i] for i in range(3)]
        tn = math.sqrt(sum(x * x for x in t))
        t = [x / tn for x in t]
        b = [n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0]]
        return np.array([[t[0], b[0], n[0]], [t[1], b[1], n[1]], [t[2], b[2], n[2]]])
    if f.shape == (d, d):
        err = float(np.max(np.abs(f.T @ f - np.eye(d))))
        if err > 1e-9:
            raise ShapeError(f"frame is not a rotation matrix: max |RᵀR - I| = {err:.3g}")
        return f.copy()
    raise ShapeError(
        f"frame must be the base normal, shape ({d},), or a rotation, shape ({d}, {d}), "
        f"to match J with {d} rows; got shape {f.shape}"
    )


def spread_bound(W: NDArray[np.float64]) -> float:
    """A lower bound det W / tr(W)^d of λ_min / λ_max for a positive semidefinite W (d ≤ 3).

    Computed in floats: for 2 × 2 and 3 × 3 matrices this is far cheaper than LAPACK.
    """
    w = W.tolist()
    if len(w) == 2:
        tr, det = w[0][0] + w[1][1], w[0][0] * w[1][1] - w[0][1] * w[1][0]
    else:
        tr = w[0][0] + w[1][1] + w[2][2]
        det = (w[0][0] * (w[1][1] * w[2][2] - w[1][2] * w[2][1]) - w[0][1] * (w[1][0] * w[2][2] - w[1][2] * w[2][0])
               + w[0][2] * (w[1][0] * w[2][1] - w[1][1] * w[2][0]))
    return det / tr ** len(w) if tr > 0 else 0.0


def eigen_ratio(W: NDArray[np.float64]) -> float:
    """λ_min / λ_max of a symmetric positive semidefinite 3 × 3 matrix, in closed form.

    Smith's trigonometric solution of the characteristic cubic in floats (a few µs
    instead of LAPACK's tens); λ_min carries an absolute error of order ε λ_max,
    enough to tell a well-conditioned W from a nearly singular one.
    """
    (a, b, c), (_, d, f), (_, _, g) = W.tolist()
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

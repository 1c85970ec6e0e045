"""Point contacts of a mechanism with a plane, and :func:`impact` on them.

A contact names the frame (and optionally a point fixed to it) that hits a
surface with base normal n⁰. :func:`impact` assembles the pipeline on
Pinocchio: A(q) and J(q) → the law → the result by (1.1).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._validate import as_array
from .errors import ShapeError
from .laws import ImpactLaw
from .mechanism import Mechanism
from .metric import local_basis
from .result import BatchResult, ImpactResult

__all__ = ["PointContact", "impact", "impact_batch"]


def _unit(name: str, x: ArrayLike) -> NDArray[np.float64]:
    a = as_array(name, x, 1, (3,))
    norm = float(np.linalg.norm(a))
    if norm == 0.0:
        raise ShapeError(f"{name} is the zero vector")
    return a / norm


@dataclass(frozen=True, eq=False)
class PointContact:
    """A point of the mechanism striking a surface with world normal ``normal``.

    Parameters
    ----------
    frame : str
        Frame the contact point is attached to.
    normal : array_like, shape (3,)
        Base normal n⁰ of the surface in the world frame (normalised here).
    point : array_like, shape (3,)
        Offset of the contact point from the frame origin, in the frame's axes.
    tangent : array_like, shape (3,), optional
        First tangent direction of the local facet frame (projected orthogonal to
        n⁰). For a spatial contact it orients anisotropic facet sets; for a planar
        contact (a law whose roughness is 2-D) it spans, with n⁰, the plane of
        motion. Default: the world axis least aligned with n⁰, projected.
    """

    frame: str
    normal: NDArray[np.float64] = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    point: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    tangent: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.frame, str):
            raise ShapeError(f"frame must be a frame name (str), got {type(self.frame).__name__}")
        n0 = _unit("normal", self.normal)
        object.__setattr__(self, "normal", n0)
        object.__setattr__(self, "point", as_array("point", self.point, 1, (3,)))
        if self.tangent is not None:
            t = _unit("tangent", self.tangent)
            t = t - (t @ n0) * n0
            if np.linalg.norm(t) < 1e-9:
                raise ShapeError("tangent is parallel to the normal")
            object.__setattr__(self, "tangent", t / np.linalg.norm(t))
        if self.tangent is None:
            R = local_basis(n0, 3)
        else:
            R = np.column_stack([self.tangent, np.cross(n0, self.tangent), n0])
        R.flags.writeable = False
        object.__setattr__(self, "_basis", R)
        object.__setattr__(self, "_offset", self.point if np.any(self.point) else None)

    def basis(self) -> NDArray[np.float64]:
        """World rotation (3, 3): columns t₁, t₂, n⁰."""
        return self._basis  # type: ignore[attr-defined, no-any-return]

    def jacobian(self, mech: Mechanism, q: NDArray[np.float64], d: int = 3) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Contact Jacobian and contact frame for a d-dimensional contact space.

        Returns
        -------
        J : ndarray, shape (d, nv)
            World-aligned for d = 3; rows (t₁, n⁰) of the plane of motion for d = 2.
        frame : ndarray, shape (d, d)
            Rotation whose last column is n⁰ in the coordinates of ``J``.
        """
        Jp = mech.point_jacobian(q, self.frame, self._offset)  # type: ignore[attr-defined]
        R = self.basis()
        if d == 3:
            return Jp, R
        if d == 2:
            return R[:, [0, 2]].T @ Jp, np.eye(2)
        raise ShapeError(f"contact-space dimension must be 2 or 3, got {d}")


def impact(
    mech: Mechanism, q: ArrayLike, v: ArrayLike, contact: PointContact, law: ImpactLaw
) -> ImpactResult:
    """Impact of a mechanism at configuration ``q`` with velocity ``v`` on a contact.

    Parameters
    ----------
    mech : Mechanism
    q : array_like, shape (nq,)
        Configuration (free-flyer quaternions normalised).
    v : array_like, shape (nv,)
        Pre-impact generalised velocity.
    contact : PointContact
    law : ImpactLaw
        :class:`NewtonLaw`, :class:`RoughLaw`, ...

    Returns
    -------
    ImpactResult
        With ``A = pin.crba(q)`` and ``J`` the contact Jacobian at ``q``.
    """
    q, v = mech.check_state(q, v)
    d = law.dim or 3
    J, R = contact.jacobian(mech, q, d)
    return law.apply_mechanism(mech, q, v, J, R)


def impact_batch(
    mech: Mechanism, Q: ArrayLike, V: ArrayLike, contact: PointContact, law: ImpactLaw
) -> BatchResult:
    """:func:`impact` for many configurations, one velocity each.

    Parameters
    ----------
    Q : array_like, shape (B, nq)
    V : array_like, shape (B, nv)

    Returns
    -------
    BatchResult
        With per-row ``A`` (B, nv, nv) and ``J`` (B, d, nv).
    """
    Q = as_array("Q", Q, 2, (None, mech.nq))
    V = as_array("V", V, 2, (Q.shape[0], mech.nv))
    results = [impact(mech, q, v, contact, law) for q, v in zip(Q, V)]
    if not results:
        raise ShapeError("Q and V must have at least one row")
    stack = lambda name: np.stack([getattr(r, name) for r in results])  # noqa: E731
    return BatchResult(
        V_minus=V.copy(), V_plus=stack("v_plus"), dV=stack("dv"), P=stack("P"),
        U_minus=stack("u_minus"), U_plus=stack("u_plus"), n0=stack("n0"), A=stack("A"), J=stack("J"),
        law=law, error_estimate=np.array([r.error_estimate for r in results]),
        nodes=max(r.nodes for r in results),
    )

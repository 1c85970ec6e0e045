"""One gap: the signed distance between a collision object of the mechanism and another object,
with its witness points, normal and first-order kinematics.

For a pair (body B, other O), where O is an obstacle or another collision object:

* ``distance`` f(q) is coal's signed distance: > 0 separated, < 0 penetrating (minus the depth);
* ``normal`` n is the unit normal pointing FROM O TOWARDS B, in the world frame (coal's normal of
  the pair (B, O) points from B to O; it is negated here). For a half-space it is the half-space's
  outward normal, whatever the depth;
* ``point`` p_B is the witness point on B and ``other_point`` p_O the one on O (world frame), with
  p_B − p_O = f n: when separated they are the nearest points, in penetration p_B is B's deepest
  point inside O and p_O the point of O's surface it must reach;
* ``jacobian`` J (3, nv) is the world-aligned translational Jacobian of the material point of B at
  p_B, minus that of the material point of O at p_O when O moves with the mechanism (the relative
  Jacobian of a self-collision pair; an obstacle does not move);
* ``gradient`` ∇f(q) = nᵀJ (nv,), in the tangent space of the configuration manifold: for a
  direction δv, f(q ⊕ ε δv) = f(q) + ε ∇f·δv + O(ε²) with ⊕ = ``pin.integrate`` (the witness
  points also slide along the surfaces, orthogonally to n, so that motion drops out). Where the
  witness set is not one point (a face or an edge lying on the obstacle) f has a kink: ∇f is then
  the gradient of one of its pieces, and :meth:`GapModel.contact_points` gives every piece.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_array
from ..errors import ShapeError

__all__ = ["Gap", "contact_frame"]


def contact_frame(normal: NDArray[np.float64], tangent: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Rotation (3, 3) with columns t₁, t₂, n: the local contact frame of a gap.

    ``tangent`` (a unit (3,) vector) is projected orthogonal to n; without it t₁ is the world
    axis least aligned with n, projected (the convention of :func:`mbimpact.local_basis` and
    :class:`mbimpact.PointContact`).

    Raises
    ------
    ShapeError
        The tangent is parallel to the normal.
    """
    if tangent is None:
        # local_basis's convention (the world axis least aligned with n, projected), in floats: this
        # is on the path of every impact on a GeometryContact
        n = normal.tolist()
        k = min(range(3), key=lambda i: abs(n[i]))
        t = [(1.0 if i == k else 0.0) - n[k] * n[i] for i in range(3)]
        tn = math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2])
        t = [x / tn for x in t]
        b = [n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0]]
        return np.array([[t[0], b[0], n[0]], [t[1], b[1], n[1]], [t[2], b[2], n[2]]])
    u = tangent - float(tangent @ normal) * normal
    nu = float(np.linalg.norm(u))
    if nu < 1e-9:
        raise ShapeError("tangent is parallel to the gap normal; pick a tangent across the normal")
    u = u / nu
    return np.column_stack([u, np.cross(normal, u), normal])


@dataclass(frozen=True, eq=False)
class Gap:
    """The gap of one pair at one configuration (see the module docstring for the conventions).

    Attributes
    ----------
    body : str
        Collision object of the mechanism the normal points towards.
    other : str
        The obstacle's name, or the other collision object of a self-collision pair.
    distance : float
        Signed distance f(q) [m], negative when penetrating.
    normal : ndarray, shape (3,)
        Unit normal from ``other`` towards ``body``, world frame.
    point : ndarray, shape (3,)
        Witness point on ``body``, world frame.
    other_point : ndarray, shape (3,)
        Witness point on ``other``, world frame.
    jacobian : ndarray, shape (3, nv)
        World-aligned translational Jacobian of ``point`` (relative to ``other_point`` for a
        self-collision pair).
    gradient : ndarray, shape (nv,)
        ∇f(q) = normalᵀ jacobian.
    pair : int
        Index of the pair in the :class:`~mbimpact.geometry.GapModel` that computed it.
    """

    body: str
    other: str
    distance: float
    normal: NDArray[np.float64]
    point: NDArray[np.float64]
    other_point: NDArray[np.float64]
    jacobian: NDArray[np.float64]
    gradient: NDArray[np.float64]
    pair: int = 0

    def __post_init__(self) -> None:
        arrays = (self.normal, self.point, self.other_point, self.jacobian, self.gradient)
        if not all(type(a) is np.ndarray for a in arrays):
            for name in ("normal", "point", "other_point", "jacobian", "gradient"):
                object.__setattr__(self, name, np.array(getattr(self, name), dtype=float))
            arrays = (self.normal, self.point, self.other_point, self.jacobian, self.gradient)
        for a in arrays:
            a.setflags(write=False)
        J = self.jacobian
        if J.ndim != 2 or J.shape[0] != 3 or self.gradient.shape != (J.shape[1],) or self.normal.shape != (3,):
            raise ShapeError(f"a gap's normal must have shape (3,), its jacobian (3, nv) and its gradient (nv,); "
                             f"got {self.normal.shape}, {J.shape} and {self.gradient.shape}")

    @classmethod
    def trusted(cls, body: str, other: str, distance: float, normal: NDArray[np.float64], point: NDArray[np.float64],
                other_point: NDArray[np.float64], jacobian: NDArray[np.float64], gradient: NDArray[np.float64],
                pair: int) -> Gap:
        """A gap from arrays already of the right shapes and owned by the caller (the hot path of
        :class:`~mbimpact.geometry.GapModel`): no checks; the arrays are made read-only."""
        g = object.__new__(cls)
        g.__dict__.update(body=body, other=other, distance=distance, normal=normal, point=point,
                          other_point=other_point, jacobian=jacobian, gradient=gradient, pair=pair)
        normal.setflags(write=False)
        point.setflags(write=False)
        other_point.setflags(write=False)
        jacobian.setflags(write=False)
        gradient.setflags(write=False)
        return g

    @property
    def penetrating(self) -> bool:
        """distance < 0."""
        return self.distance < 0.0

    def frame(self, tangent: ArrayLike | None = None) -> NDArray[np.float64]:
        """Local contact frame (3, 3): columns t₁, t₂, n with n = :attr:`normal` (see :func:`contact_frame`)."""
        t = None if tangent is None else as_array("tangent", tangent, 1, (3,))
        return contact_frame(self.normal, t)

    def velocity(self, v: ArrayLike) -> NDArray[np.float64]:
        """Velocity (3,) of the witness point (relative to ``other``'s), J v, for v (nv,)."""
        return self.jacobian @ as_array("v", v, 1, (self.jacobian.shape[1],))

    def normal_velocity(self, v: ArrayLike) -> float:
        """ḟ = ∇f · v (< 0: approaching)."""
        return float(self.gradient @ as_array("v", v, 1, (self.gradient.shape[0],)))


@dataclass(frozen=True, eq=False)
class GapArrays:
    """The gaps of many pairs as stacked arrays (what a simulator assembles constraints from).

    Same conventions as :class:`Gap`, one row per pair kept, in the order of the gap model's pairs.

    Attributes
    ----------
    pairs : ndarray of int, shape (P,)
        Index of each row's pair in the :class:`~mbimpact.geometry.GapModel`.
    distance : ndarray, shape (P,)
    normal : ndarray, shape (P, 3)
    point : ndarray, shape (P, 3)
    other_point : ndarray, shape (P, 3)
    jacobian : ndarray, shape (P, 3, nv)
    gradient : ndarray, shape (P, nv)
    """

    pairs: NDArray[np.int_]
    distance: NDArray[np.float64]
    normal: NDArray[np.float64]
    point: NDArray[np.float64]
    other_point: NDArray[np.float64]
    jacobian: NDArray[np.float64]
    gradient: NDArray[np.float64]

    def __post_init__(self) -> None:
        P = self.distance.shape[0]
        if (self.pairs.shape != (P,) or self.normal.shape != (P, 3) or self.point.shape != (P, 3)
                or self.other_point.shape != (P, 3) or self.jacobian.shape[:2] != (P, 3)
                or self.gradient.shape != (P, self.jacobian.shape[2])):
            raise ShapeError("inconsistent gap arrays: pairs (P,), distance (P,), normal, point, other_point (P, 3), "
                             "jacobian (P, 3, nv), gradient (P, nv)")
        for a in (self.pairs, self.distance, self.normal, self.point, self.other_point, self.jacobian, self.gradient):
            a.setflags(write=False)

    def __len__(self) -> int:
        return int(self.distance.shape[0])

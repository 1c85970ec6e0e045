"""Contacts of a mechanism: where it strikes and the local frame of the base surface there.

A contact supplies what stage 1 of the pipeline needs besides A(q): the contact
Jacobian J(q) (d, nv) of the striking point, world-aligned, and the rotation R whose
last column is the base normal n⁰. :class:`PointContact` is a point fixed to a frame
of the mechanism striking a plane of given normal.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_array
from ..errors import ParameterError, ShapeError
from ..common.basis import check_dimension, local_basis
from .mechanism import Mechanism

__all__ = ["Contact", "PointContact", "unit_vector"]

# Largest offset of a contact point from its frame: the offset enters J through [r]ₓ J_ang, and J
# enters the impact squared (J Jᵀ, J A⁻¹ Jᵀ), which overflows for entries beyond ~1e154.
_MAX_OFFSET = 1e150


def unit_vector(name: str, x: ArrayLike) -> NDArray[np.float64]:
    """A (3,) vector normalised to unit length (:class:`ShapeError` if zero)."""
    a = as_array(name, x, 1, (3,))
    big = float(np.abs(a).max())
    if big == 0.0:
        raise ShapeError(f"{name} is the zero vector")
    a = a / big  # scaled first: the norm of a tiny or huge vector neither under- nor overflows
    return a / float(np.linalg.norm(a))


class Contact(ABC):
    """Base class of contacts: the Jacobian and local frame of a striking point at q."""

    @abstractmethod
    def jacobian(self, mech: Mechanism, q: NDArray[np.float64], d: int = 3
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Contact Jacobian and contact frame at a validated configuration ``q``.

        Returns
        -------
        J : ndarray, shape (d, nv)
            World-aligned for d = 3; rows (t₁, n⁰) of the plane of motion for d = 2. A new array
            at every call: :func:`mbimpact.impact` makes it read-only and its result keeps it.
        frame : ndarray, shape (d, d)
            Rotation whose last column is n⁰ in the coordinates of ``J``.
        """

    def fill_jacobians(self, mech: Mechanism, Q: NDArray[np.float64], d: int, J: NDArray[np.float64],
                       R: NDArray[np.float64]) -> int:
        """:meth:`jacobian` for the rows of a validated ``Q`` (B, nq) in order, into ``J[i]`` (B, d, nv) and
        ``R[i]`` (B, d, d) (:func:`mbimpact.impact_batch` gathers its stacks so). A contact may
        override it with a leaner loop that fills the same values.

        Returns
        -------
        int
            The rows filled: B, or the index of the first row whose :meth:`jacobian` raises or returns
            arrays of other shapes than ``J[i]`` and ``R[i]`` (:func:`mbimpact.impact_batch` then takes
            the row-by-row route, which raises that row's error in row order).
        """
        for i, q in enumerate(Q):
            try:
                Ji, Ri = self.jacobian(mech, q, d)
            except Exception:  # noqa: BLE001 — any error is the row's, raised by the caller in row order
                return i
            if Ji.shape != J.shape[1:] or Ri.shape != R.shape[1:]:
                return i
            J[i], R[i] = Ji, Ri
        return len(Q)


@dataclass(frozen=True, eq=False)
class PointContact(Contact):
    """A point of the mechanism striking a surface with world normal ``normal``.

    Parameters
    ----------
    frame : str
        Frame the contact point is attached to.
    normal : array_like, shape (3,)
        Base normal n⁰ of the surface in the world frame (normalised here).
    point : array_like, shape (3,)
        Offset of the contact point from the frame origin, in the frame's axes; entries
        at most 1e150 in magnitude.
    tangent : array_like, shape (3,), optional
        First tangent direction of the local facet frame (projected orthogonal to
        n⁰). For a spatial contact it orients anisotropic facet sets; for a planar
        contact (a law whose roughness is 2-D) it spans, with n⁰, the plane of
        motion. Default: the world axis least aligned with n⁰, projected.

    Raises
    ------
    ShapeError, NonFiniteError
        A vector of the wrong shape, zero or non-finite; a tangent parallel to the normal.
    ParameterError
        An offset ``point`` beyond 1e150.
    """

    frame: str
    normal: NDArray[np.float64] = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    point: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    tangent: NDArray[np.float64] | None = None
    _basis: NDArray[np.float64] = field(init=False, repr=False)
    _offset: NDArray[np.float64] | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.frame, str):
            raise ShapeError(f"frame must be a frame name (str), got {type(self.frame).__name__}")
        n0 = unit_vector("normal", self.normal)
        object.__setattr__(self, "normal", n0)
        point = as_array("point", self.point, 1, (3,))
        big = float(np.max(np.abs(point)))
        if not big <= _MAX_OFFSET:
            raise ParameterError(
                f"point = {point.tolist()} lies too far from the frame origin: its entries must be at most "
                f"{_MAX_OFFSET:g} in magnitude (the Jacobian of a point that far, squared in J A⁻¹ Jᵀ, overflows)"
            )
        object.__setattr__(self, "point", point)
        if self.tangent is not None:
            t = unit_vector("tangent", self.tangent)
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
        return self._basis

    def jacobian(self, mech: Mechanism, q: NDArray[np.float64], d: int = 3
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        Jp = mech.frame_jacobian(q, mech.frame_id(self.frame), self._offset)
        R = self.basis()  # (a subclass's own, where it has one)
        if d.__class__ is not int:  # an array would make `d == 3` ambiguous
            d = check_dimension(d)
        if d == 3:
            return Jp, R
        if d == 2:
            return R[:, [0, 2]].T @ Jp, np.eye(2)
        raise ShapeError(f"contact-space dimension must be 2 or 3, got {d}")

    def fill_jacobians(self, mech: Mechanism, Q: NDArray[np.float64], d: int, J: NDArray[np.float64],
                       R: NDArray[np.float64]) -> int:
        """:meth:`Contact.fill_jacobians` in one lean loop of Pinocchio calls for a spatial contact
        (:meth:`Mechanism.fill_frame_jacobians`): the rows are :meth:`jacobian`'s, to the bit. (A subclass
        gets the base class's loop of its own :meth:`jacobian`.)"""
        if d.__class__ is not int or d != 3 or type(self) is not PointContact:
            return super().fill_jacobians(mech, Q, d, J, R)
        mech.fill_frame_jacobians(Q, mech.frame_id(self.frame), self._offset, J)
        R[:] = self._basis
        return len(Q)

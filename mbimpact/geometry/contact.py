"""A contact found by collision detection: usable wherever a :class:`~mbimpact.PointContact` is.

:class:`GeometryContact` names a collision object of the mechanism and what it strikes: a world
obstacle (``obstacle=HalfSpace(...)``) or another collision object of the same mechanism
(``other="name"``, self-collision). At a configuration q its contact point is the witness point of
the pair (the nearest point, or the deepest one in penetration), its base normal n⁰ the gap normal
there (from the obstacle towards the body), and its Jacobian the world-aligned Jacobian of that
point, relative to the other body's witness point for a self-collision pair. The contact frame R
has n⁰ as its last column, so a rough law orients its facets about the local normal at the
witness point, not about a fixed plane.

Only the single nearest pair of points is used: when a face or an edge lies on the obstacle (the
witness set is not a point), the contact is one point of that set; use
:meth:`GapModel.contact_points` for all of them (simultaneous impacts are the simulator's).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..common.validation import as_array
from ..errors import ParameterError, ShapeError
from ..mechanism.contact import Contact
from ..mechanism.mechanism import Mechanism
from .gap import Gap, contact_frame
from .gap_model import GapModel
from .queries import gap_model
from .shapes import Shape

__all__ = ["GeometryContact"]


@dataclass(frozen=True, eq=False)
class GeometryContact(Contact):
    """A collision object of the mechanism striking an obstacle or another collision object.

    Parameters
    ----------
    body : str
        Collision object of the mechanism (:meth:`mbimpact.Mechanism.collision_names`).
    obstacle : Shape, optional
        World obstacle it strikes.
    other : str, optional
        Or: another collision object of the mechanism (self-collision); the impulse acts on
        ``body`` along +n⁰ and on ``other`` along −n⁰.
    tangent : array_like, shape (3,), optional
        First tangent of the contact frame, projected across n⁰ (orients anisotropic roughness;
        with a planar law it spans, with n⁰, the plane of motion). Default: the world axis least
        aligned with n⁰, projected.

    Raises
    ------
    ParameterError
        Neither or both of ``obstacle`` and ``other``; an obstacle that is not a shape; ``other``
        equal to ``body``.
    CollisionNotFoundError
        (At first use on a mechanism) ``body`` or ``other`` is not one of its collision objects.
    """

    body: str
    obstacle: Shape | None = None
    other: str | None = None
    tangent: NDArray[np.float64] | None = None
    _last: Any = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.body, str):
            raise ParameterError(f"body must be the name of a collision object (str), got {type(self.body).__name__}")
        if (self.obstacle is None) == (self.other is None):
            raise ParameterError("give exactly one of obstacle= (a world shape) and other= (a collision object "
                                 "of the mechanism)")
        if self.obstacle is not None and not isinstance(self.obstacle, Shape):
            raise ParameterError(f"obstacle must be a shape (HalfSpace, Box, Sphere, Capsule, Cylinder, Mesh), "
                                 f"got {type(self.obstacle).__name__}")
        if self.other is not None:
            if not isinstance(self.other, str):
                raise ParameterError(f"other must be the name of a collision object (str), got {type(self.other).__name__}")
            if self.other == self.body:
                raise ParameterError(f"other must differ from body ({self.body!r}): an object does not strike itself")
        if self.tangent is not None:
            t = as_array("tangent", self.tangent, 1, (3,))
            nt = float(np.linalg.norm(t))
            if nt == 0.0:
                raise ShapeError("tangent is the zero vector")
            t = t / nt
            t.flags.writeable = False
            object.__setattr__(self, "tangent", t)

    def model(self, mech: Mechanism) -> GapModel:
        """The one-pair :class:`GapModel` of this contact on ``mech`` (cached with the mechanism, rebuilt
        when shapes were attached to it since)."""
        # the last model used, held weakly (the mechanism's cache owns it): no lookup on repeated calls
        last = self._last
        version = mech.collision_model().version
        if last is not None and last[0]() is mech and last[1] == version:
            gm = last[2]()
            if gm is not None:
                return gm
        if self.obstacle is not None:
            gm = gap_model(mech, (self.obstacle,), bodies=(self.body,))
        else:
            assert self.other is not None
            gm = gap_model(mech, self_pairs=((self.body, self.other),))
        object.__setattr__(self, "_last", (weakref.ref(mech), version, weakref.ref(gm)))
        return gm

    def gap(self, mech: Mechanism, q: NDArray[np.float64]) -> Gap:
        """The pair's :class:`Gap` at ``q`` (distance, normal, witness points, Jacobian)."""
        return self.model(mech).gap(q, 0)

    def jacobian(self, mech: Mechanism, q: NDArray[np.float64], d: int = 3
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Jacobian of the witness point and the contact frame, for :func:`mbimpact.impact`.

        Returns
        -------
        J : ndarray, shape (d, nv)
            World-aligned (relative for a self-collision pair) for d = 3; rows (t₁, n⁰) for d = 2.
        frame : ndarray, shape (d, d)
            Columns t₁, t₂, n⁰ (d = 3), with n⁰ the gap normal; the identity for d = 2.
        """
        g = self.gap(mech, q)
        R = contact_frame(g.normal, self.tangent)
        if d == 3:
            return np.array(g.jacobian), R
        if d == 2:
            return R[:, [0, 2]].T @ g.jacobian, np.eye(2)
        raise ShapeError(f"contact-space dimension must be 2 or 3, got {d}")

"""The collision objects of a mechanism: a ``pinocchio.GeometryModel`` with names that explain themselves.

A :class:`CollisionModel` is what :meth:`mbimpact.Mechanism.collision_model` returns: the
``<collision>`` elements of the mechanism's URDF (or the collision geoms of its MJCF), each
attached to a joint of the kinematic model, with meshes replaced by their convex hulls. Shapes can
be attached to frames afterwards (:meth:`CollisionModel.add`), e.g. the capsules URDF cannot
describe. Gap models (:class:`mbimpact.geometry.GapModel`) copy the objects they use when they
are built and check :attr:`CollisionModel.version` to notice later additions.
"""

from __future__ import annotations

import threading
from typing import Any

import pinocchio as pin

from ..errors import CollisionNotFoundError, FrameNotFoundError, GeometryError, ParameterError
from ..mechanism.robots import close_matches
from .shapes import Shape

__all__ = ["CollisionModel"]


class CollisionModel:
    """Named collision objects of a mechanism, each fixed to a joint.

    Parameters
    ----------
    model : pinocchio.Model
        The mechanism's kinematic model (the joints the objects hang on).
    geometry_model : pinocchio.GeometryModel
        Its collision objects (taken over: do not modify it afterwards).
    owner : str
        Name of the mechanism, for messages.

    Attributes
    ----------
    version : int
        Incremented by every :meth:`add`.
    """

    def __init__(self, model: Any, geometry_model: Any, owner: str = "mechanism") -> None:
        if not isinstance(model, pin.Model):
            raise ParameterError(f"model must be a pinocchio.Model, got {type(model).__name__}")
        if not isinstance(geometry_model, pin.GeometryModel):
            raise ParameterError(f"geometry_model must be a pinocchio.GeometryModel, got {type(geometry_model).__name__}")
        self.model = model
        self.owner = owner
        self.version = 0
        self._gm = geometry_model
        self._lock = threading.Lock()
        self._index = {go.name: i for i, go in enumerate(geometry_model.geometryObjects)}
        if len(self._index) != geometry_model.ngeoms:
            raise GeometryError(f"{owner} has several collision objects with the same name")
        for go in geometry_model.geometryObjects:
            go.geometry.computeLocalAABB()

    # ------------------------------------------------------------ lookup
    @property
    def geometry_model(self) -> Any:
        """The ``pinocchio.GeometryModel`` (read it, never modify it: use :meth:`add`)."""
        return self._gm

    @property
    def names(self) -> list[str]:
        """Names of the collision objects, in index order."""
        return [go.name for go in self._gm.geometryObjects]

    @property
    def moving(self) -> list[str]:
        """Names of the objects that move with q (their parent joint is not the universe)."""
        return [go.name for go in self._gm.geometryObjects if go.parentJoint != 0]

    def __len__(self) -> int:
        return int(self._gm.ngeoms)

    def __contains__(self, name: object) -> bool:
        return name in self._index

    def __repr__(self) -> str:
        return f"CollisionModel({self.owner!r}, {len(self)} objects: {', '.join(self.names[:6])}{', ...' if len(self) > 6 else ''})"

    def index(self, name: str) -> int:
        """Index of a collision object.

        Raises
        ------
        CollisionNotFoundError
            No object of that name (the message lists close matches, or all names).
        """
        i = self._index.get(name) if isinstance(name, str) else None
        if i is None:
            raise self.unknown(name)
        return i

    def unknown(self, name: object) -> CollisionNotFoundError:
        """The error for an unknown collision object name (close matches, or the known names)."""
        if not isinstance(name, str):
            return CollisionNotFoundError(f"a collision object is named by a string, got {type(name).__name__}")
        names = self.names
        if not names:
            return CollisionNotFoundError(
                f"{self.owner} has no collision objects, so none is named {name!r}: its model file has no "
                "<collision> element; attach shapes with mech.collision_model().add(name, frame, shape)")
        close = close_matches(name, names)
        hint = f"close matches: {', '.join(close)}" if close else f"known: {', '.join(names[:20])}" + (
            ", ..." if len(names) > 20 else "")
        return CollisionNotFoundError(f"{self.owner} has no collision object {name!r}; {hint}")

    def joint(self, name: str) -> int:
        """Index of the joint the object is fixed to (0: the universe)."""
        return int(self._gm.geometryObjects[self.index(name)].parentJoint)

    def geometry(self, name: str) -> Any:
        """The object's coal geometry (read only)."""
        return self._gm.geometryObjects[self.index(name)].geometry

    def placement(self, name: str) -> Any:
        """The object's placement in its parent joint's frame (``pinocchio.SE3``)."""
        return pin.SE3(self._gm.geometryObjects[self.index(name)].placement)

    # ------------------------------------------------------------ attaching shapes
    def add(self, name: str, frame: str, shape: Shape) -> int:
        """Attach a shape to a frame of the mechanism; returns its index.

        Parameters
        ----------
        name : str
            Name of the new collision object (unique).
        frame : str
            Frame it is fixed to (``"universe"`` for a fixed part of the mechanism).
        shape : Shape
            :class:`~mbimpact.geometry.Sphere`, :class:`~mbimpact.geometry.Box`,
            :class:`~mbimpact.geometry.Capsule`, ...; its ``position`` and ``rotation`` are read in
            the frame's axes, relative to the frame origin.

        Raises
        ------
        GeometryError
            The name is taken.
        FrameNotFoundError
            No frame of that name (close matches listed).
        """
        if not isinstance(shape, Shape):
            raise ParameterError(f"shape must be an mbimpact shape (Sphere, Box, Capsule, ...), got {type(shape).__name__}")
        if not isinstance(name, str) or not name:
            raise ParameterError(f"name must be a non-empty string, got {name!r}")
        if not isinstance(frame, str):
            raise FrameNotFoundError(f"a frame is named by a string, got {type(frame).__name__}")
        if not self.model.existFrame(frame):
            names = [f.name for f in self.model.frames]
            close = close_matches(frame, names)
            hint = f"close matches: {', '.join(close)}" if close else f"e.g. {', '.join(names[-5:])}"
            raise FrameNotFoundError(f"frame {frame!r} not found in {self.owner}; {hint}")
        with self._lock:
            if name in self._index:
                raise GeometryError(f"{self.owner} already has a collision object named {name!r}")
            fid = self.model.getFrameId(frame)
            f = self.model.frames[fid]
            go = pin.GeometryObject(name, int(f.parentJoint), int(fid), f.placement * shape.placement(), shape.geometry())
            i = int(self._gm.addGeometryObject(go))
            self._index[name] = i
            self.version += 1
        return i

"""Collision shapes as immutable value objects: obstacles of the world, or bodies attached to a frame.

Every shape wraps one coal geometry and a pose (``position`` (3,), ``rotation`` (3, 3)) of its
own frame, given in the world for an obstacle and in the parent frame for a shape attached to a
mechanism (:meth:`mbimpact.geometry.CollisionModel.add`). The conventions are coal's:

* :class:`HalfSpace` ``(normal n, offset d)`` is the solid ``{x : n·x ≤ d}`` (unbounded, no pose:
  n and d are already world quantities); its free side is the one n points to.
* :class:`Box` ``size`` holds the FULL side lengths along the local axes (as URDF and coal).
* :class:`Capsule` and :class:`Cylinder` have their axis along local z; ``length`` is the FULL
  length of the cylindrical part (as URDF and coal; MJCF's half-height is ``length / 2``).
* :class:`Mesh` loads a mesh file (STL, DAE, OBJ, ... through coal's loader) and, by default,
  replaces it by its convex hull: a triangle soup against a half-space gives wrong penetration
  depths (a triangle soup has no inside) and costs about 300 times more.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import coal
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from ..common.geometry import scaled_norm
from ..common.validation import as_array, as_scalar
from ..errors import GeometryError, ParameterError, ShapeError

__all__ = ["Shape", "HalfSpace", "Box", "Sphere", "Capsule", "Cylinder", "Mesh", "as_rotation", "convex_hull"]


def as_rotation(name: str, R: ArrayLike) -> NDArray[np.float64]:
    """A validated rotation matrix (3, 3): orthonormal to 1e-9 with determinant +1.

    Raises
    ------
    ShapeError
        Wrong shape, or not a proper rotation.
    NonFiniteError
        NaN or infinity.
    """
    a = as_array(name, R, 2, (3, 3))
    big = float(np.abs(a).max())
    if big > 2.0:  # the entries of a rotation lie in [−1, 1]: refused before RᵀR or det(R) overflow
        raise ShapeError(f"{name} must be a rotation matrix (orthonormal, det +1); it has an entry of "
                         f"magnitude {big:.3g} > 1")
    err = float(np.max(np.abs(a.T @ a - np.eye(3))))
    if err > 1e-9 or np.linalg.det(a) < 0.0:
        raise ShapeError(f"{name} must be a rotation matrix (orthonormal, det +1); "
                         f"max |RᵀR − I| = {err:.3g}, det = {np.linalg.det(a):.3g}")
    return a


def convex_hull(geometry: Any, what: str) -> Any:
    """The convex hull (``coal.Convex``, by qhull) of a triangle mesh (``coal.BVHModelBase``).

    ``buildConvexHull`` is used, not ``buildConvexRepresentation``: the latter wraps the mesh's own
    vertices and triangles as they are (no hull), and on a non-convex mesh its hill-climbing
    support function stops at local maxima (solo12's base: 0.325 m above the ground instead of
    0.275 m, and GJK distances that change from one call to the next).

    Raises
    ------
    GeometryError
        qhull failed (a degenerate or empty mesh).
    """
    try:
        geometry.buildConvexHull(True, "Qt")  # returns False even when the hull is built: check it instead
        hull = geometry.convex
    except Exception as exc:  # qhull errors come through as RuntimeError or ValueError
        raise GeometryError(f"could not build the convex hull of {what}: {exc}") from exc
    if hull is None or hull.num_points < 4:
        raise GeometryError(f"could not build the convex hull of {what} (empty or flat mesh?)")
    hull.computeLocalAABB()
    return hull


def _frozen(a: NDArray[np.float64]) -> NDArray[np.float64]:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


def _positive(name: str, x: object) -> float:
    return as_scalar(name, x, 0.0, math.inf, lo_open=True, hi_open=True)


class Shape(ABC):
    """A collision shape: one coal geometry with a pose.

    Attributes
    ----------
    kind : str
        ``"halfspace"``, ``"box"``, ``"sphere"``, ``"capsule"``, ``"cylinder"`` or ``"mesh"``
        (the default name of the shape).
    """

    kind: ClassVar[str]
    name: str | None

    @abstractmethod
    def geometry(self) -> Any:
        """The coal geometry (shared by every use of this shape; never modify it)."""

    @abstractmethod
    def placement(self) -> Any:
        """Pose of the geometry's frame as a ``pinocchio.SE3`` (world, or relative to the parent frame)."""

    @property
    def bounded(self) -> bool:
        """False for the unbounded :class:`HalfSpace`: bounding spheres (the broad phase) skip it."""
        return True

    @property
    def label(self) -> str:
        """``name`` if given, otherwise ``kind``."""
        return self.name if self.name is not None else self.kind

    def _check_name(self) -> None:
        if self.name is not None and (not isinstance(self.name, str) or not self.name):
            raise ParameterError(f"name must be a non-empty string or None, got {self.name!r}")


def _identity() -> NDArray[np.float64]:
    return np.eye(3)


def _origin() -> NDArray[np.float64]:
    return np.zeros(3)


@dataclass(frozen=True, eq=False)
class _Posed(Shape):
    """Shared pose handling: ``position`` (3,) and ``rotation`` (3, 3), validated, read-only and
    keyword-only (the shape's own parameters come first, positionally), and the coal geometry."""

    position: NDArray[np.float64] = field(default_factory=_origin, kw_only=True)
    rotation: NDArray[np.float64] = field(default_factory=_identity, kw_only=True)
    name: str | None = field(default=None, kw_only=True)
    _geometry: Any = field(init=False, repr=False)
    _placement: Any = field(init=False, repr=False)

    def _finish(self, geom: Any, aabb: bool = True) -> None:
        """Validate the name and pose and keep ``geom`` (its local AABB computed for the broad phase)."""
        self._check_name()
        object.__setattr__(self, "position", _frozen(as_array("position", self.position, 1, (3,))))
        object.__setattr__(self, "rotation", _frozen(as_rotation("rotation", self.rotation)))
        object.__setattr__(self, "_placement", pin.SE3(np.array(self.rotation), np.array(self.position)))
        if aabb:
            geom.computeLocalAABB()
        object.__setattr__(self, "_geometry", geom)

    def placement(self) -> Any:
        return pin.SE3(self._placement)

    def geometry(self) -> Any:
        return self._geometry


@dataclass(frozen=True, eq=False)
class HalfSpace(Shape):
    """The solid ``{x : n·x ≤ offset}`` (ground, walls, slopes).

    Parameters
    ----------
    normal : array_like, shape (3,)
        Outward normal n (towards the free side), normalised here.
    offset : float
        Signed distance of the boundary plane from the origin along n.
    name : str, optional
    """

    normal: NDArray[np.float64] = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    offset: float = 0.0
    name: str | None = None
    kind: ClassVar[str] = "halfspace"
    _geometry: Any = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._check_name()
        n = as_array("normal", self.normal, 1, (3,))
        norm = float(scaled_norm(n))  # no overflow of the squares
        if norm == 0.0:
            raise ShapeError("normal is the zero vector; a half-space needs a direction")
        offset = as_scalar("offset", self.offset, -math.inf, math.inf, lo_open=True, hi_open=True)
        object.__setattr__(self, "normal", _frozen(n / norm))
        object.__setattr__(self, "offset", offset)
        object.__setattr__(self, "_geometry", coal.Halfspace(np.array(self.normal), offset))

    def geometry(self) -> Any:
        return self._geometry

    def placement(self) -> Any:
        return pin.SE3.Identity()

    @property
    def bounded(self) -> bool:
        return False


@dataclass(frozen=True, eq=False)
class Box(_Posed):
    """A box centred on its frame.

    Parameters
    ----------
    size : array_like, shape (3,)
        FULL side lengths along the local x, y, z axes (> 0).
    position : array_like, shape (3,)
    rotation : array_like, shape (3, 3)
    name : str, optional
    """

    size: NDArray[np.float64] = field(default_factory=lambda: np.ones(3))
    kind: ClassVar[str] = "box"

    def __post_init__(self) -> None:
        size = as_array("size", self.size, 1, (3,))
        if np.any(size <= 0.0):
            raise ParameterError(f"size must hold three positive full side lengths, got {size.tolist()}")
        object.__setattr__(self, "size", _frozen(size))
        self._finish(coal.Box(*map(float, size)))


@dataclass(frozen=True, eq=False)
class Sphere(_Posed):
    """A sphere centred on its frame.

    Parameters
    ----------
    radius : float
        > 0.
    position : array_like, shape (3,)
    rotation : array_like, shape (3, 3)
        Accepted for uniformity with the other shapes (a sphere does not depend on it).
    name : str, optional
    mass : float, optional
        Mass (kg, > 0). Collision queries ignore it; with it the sphere is also a body for
        :func:`mbimpact.fit` (a solid ball with spin, inertia 2/5 m R²).
    """

    radius: float = 1.0
    mass: float | None = field(default=None, kw_only=True)
    kind: ClassVar[str] = "sphere"

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _positive("radius", self.radius))
        if self.mass is not None:
            object.__setattr__(self, "mass", _positive("mass", self.mass))
        self._finish(coal.Sphere(self.radius))


@dataclass(frozen=True, eq=False)
class Capsule(_Posed):
    """A capsule (a segment swept by a ball) along its local z axis, centred on its frame.

    Parameters
    ----------
    radius : float
        > 0.
    length : float
        FULL length of the cylindrical part (≥ 0); the capsule spans z ∈ ±(length/2 + radius).
    position : array_like, shape (3,)
    rotation : array_like, shape (3, 3)
    name : str, optional
    """

    radius: float = 1.0
    length: float = 1.0
    kind: ClassVar[str] = "capsule"

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _positive("radius", self.radius))
        object.__setattr__(self, "length", as_scalar("length", self.length, 0.0, math.inf, hi_open=True))
        self._finish(coal.Capsule(self.radius, self.length))


@dataclass(frozen=True, eq=False)
class Cylinder(_Posed):
    """A solid cylinder along its local z axis, centred on its frame.

    Parameters
    ----------
    radius : float
        > 0.
    length : float
        FULL length (> 0).
    position : array_like, shape (3,)
    rotation : array_like, shape (3, 3)
    name : str, optional
    """

    radius: float = 1.0
    length: float = 1.0
    kind: ClassVar[str] = "cylinder"

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _positive("radius", self.radius))
        object.__setattr__(self, "length", _positive("length", self.length))
        self._finish(coal.Cylinder(self.radius, self.length))


@dataclass(frozen=True, eq=False)
class Mesh(_Posed):
    """A mesh file, by default as its convex hull.

    Parameters
    ----------
    path : str or Path
        Mesh file (any format coal's loader reads: STL, DAE, OBJ, ...).
    scale : float or array_like, shape (3,)
        Scale factors applied to the file's coordinates (> 0).
    position : array_like, shape (3,)
    rotation : array_like, shape (3, 3)
    convex : bool
        Replace the triangles by their convex hull (default). With ``False`` the triangle soup
        is kept: correct while separated, but penetration depths against half-spaces and boxes
        are wrong (the first triangle found, not the deepest point) and queries cost ~1 ms.
    name : str, optional

    Raises
    ------
    GeometryError
        The file is missing or unreadable, or its hull cannot be built.
    """

    path: str | Path = ""
    scale: float | NDArray[np.float64] = 1.0
    convex: bool = True
    kind: ClassVar[str] = "mesh"

    def __post_init__(self) -> None:
        if not isinstance(self.path, (str, Path)):
            raise ParameterError(f"path must be a file path, got {type(self.path).__name__}")
        path = Path(self.path)
        if not path.is_file():
            raise GeometryError(f"mesh file {str(path)!r} not found")
        if not isinstance(self.convex, bool):
            raise ParameterError(f"convex must be True or False, got {self.convex!r}")
        scale = as_array("scale", self.scale, np.ndim(self.scale))
        if scale.shape not in ((), (3,)) or np.any(scale <= 0.0):
            raise ParameterError(f"scale must be a positive number or three positive numbers, got {scale.tolist()}")
        object.__setattr__(self, "path", path)
        object.__setattr__(self, "scale", _frozen(np.broadcast_to(scale, (3,))))
        try:
            geom = coal.MeshLoader().load(str(path), np.array(self.scale))
        except Exception as exc:
            raise GeometryError(f"could not read mesh {str(path)!r}: {exc}") from exc
        if self.convex:  # the hull comes with its AABB
            self._finish(convex_hull(geom, f"mesh {path.name!r}"), aabb=False)
        else:
            self._finish(geom)

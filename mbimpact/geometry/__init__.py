"""Collision geometry on Pinocchio and coal: gaps f(q), their normals, witness points and Jacobians.

A mechanism's collision objects (its URDF ``<collision>`` elements or MJCF geoms, meshes as convex
hulls) are loaded on first use (:meth:`mbimpact.Mechanism.collision_model`); point contacts on
frames never load them. Against world obstacles (:class:`HalfSpace`, :class:`Box`,
:class:`Sphere`, :class:`Capsule`, :class:`Cylinder`, :class:`Mesh`) or each other, every pair
gives a :class:`Gap`: signed distance, unit normal from the other object towards the body,
witness points, Jacobian and gradient ∇f = nᵀJ.

Modules, one idea each:

* :mod:`~mbimpact.geometry.shapes` — obstacles and attachable shapes (immutable);
* :mod:`~mbimpact.geometry.collision_model` — a mechanism's named collision objects;
* :mod:`~mbimpact.geometry.loading` — reading them from URDF or MJCF, once;
* :mod:`~mbimpact.geometry.gap` — the :class:`Gap` value and its conventions;
* :mod:`~mbimpact.geometry.gap_model` — all pairs at once (distances, gaps, contact points);
* :mod:`~mbimpact.geometry.broadphase` — bounding-sphere pruning when pairs are many;
* :mod:`~mbimpact.geometry.patches` — several witness points per pair (contact patches);
* :mod:`~mbimpact.geometry.contact` — :class:`GeometryContact`, a :class:`~mbimpact.Contact`;
* :mod:`~mbimpact.geometry.queries` — one-call :func:`gaps` and :func:`contact_points`;
* :mod:`~mbimpact.geometry.cache` — what is remembered per mechanism.
"""

from .broadphase import BROAD_PHASE_MIN_PAIRS
from .collision_model import CollisionModel
from .contact import GeometryContact
from ..errors import CollisionNotFoundError, GeometryError
from .gap import Gap, GapArrays
from .gap_model import GapModel
from .queries import contact_points, gap_model, gaps
from .shapes import Box, Capsule, Cylinder, HalfSpace, Mesh, Shape, Sphere

__all__ = [
    "Shape",
    "HalfSpace",
    "Box",
    "Sphere",
    "Capsule",
    "Cylinder",
    "Mesh",
    "CollisionModel",
    "Gap",
    "GapArrays",
    "GapModel",
    "GeometryContact",
    "gaps",
    "gap_model",
    "contact_points",
    "BROAD_PHASE_MIN_PAIRS",
    "CollisionNotFoundError",
    "GeometryError",
]

"""The contacts of a scene: a frame's point on a declared surface (:class:`SceneContact`), or a
collision object of the mechanism against an obstacle or another of its objects
(:class:`SceneCollision`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_array, as_scalar
from ..errors import SceneError
from ..geometry.shapes import Shape
from ..laws.base import ImpactLaw
from ..mechanism.mechanism import Mechanism
from .scene_keys import accepts_file_keys, collision_keys, contact_keys
from .surfaces import Surface, scene_errors

__all__ = ["SceneContact", "SceneCollision", "unit_tangent", "collision_gap"]


def unit_tangent(tangent: ArrayLike, normal: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """A contact's ``tangent`` as a unit vector (across ``normal``, when given).

    Parameters
    ----------
    tangent : array_like, shape (3,)
        Any finite nonzero vector, however large or small.
    normal : ndarray, shape (3,), optional
        The unit normal of the surface: the part of ``tangent`` along it is removed.

    Raises
    ------
    SceneError
        Not a finite (3,) vector, the zero vector, or parallel to ``normal``.
    """
    with scene_errors():
        t = as_array("tangent", tangent, 1, (3,))
    big = float(np.abs(t).max())
    if big == 0.0:
        raise SceneError("a contact's tangent must not be the zero vector; give a direction across the normal")
    # scaled to a largest entry of 1 first: t·n and |t| of a huge (1e200) or tiny vector neither
    # over- nor underflow, and the test for parallel below is relative
    t = t / big
    if normal is not None:
        t = t - float(t @ normal) * normal
    length = float(np.linalg.norm(t))
    if not length > 1e-9:
        raise SceneError("a contact's tangent must not be parallel to its surface normal; give a direction "
                         "across the normal")
    return t / length


@accepts_file_keys(contact_keys)
@dataclass(frozen=True, eq=False)
class SceneContact:
    """A point of the mechanism, the surface it strikes, its impact law and its persistent contact.

    Parameters
    ----------
    frame : str
        Frame the contact point is attached to.
    law : ImpactLaw
        The impact law (a rough law acts about the local normal of the surface).
    surface : Surface
    point : array_like, shape (3,)
        Offset of the contact point from the frame origin, in the frame's axes.
    friction : float
        Coulomb friction coefficient μ ≥ 0 of the persistent (resting, sliding) contact.
    tangent : array_like, shape (3,), optional
        With the normal, the plane in which a planar (2-D) roughness acts; default the
        world x axis projected onto the tangent plane.
    stiffness : float
        Kelvin–Voigt stiffness M of (2.3) used by the "compliant" rule for contacts that
        strike together.

    The keys of a scene file's ``[[contacts]]`` table are accepted too (:mod:`.scene_keys`): ``law`` by
    name with ``e``, ``k``, ``roughness``, ``flux``, ``facet``, ``mu``, ``restitution``, and ``surface`` by
    name with ``normal``, ``origin``, ``rho``, ``motion``; e.g. ``SceneContact(frame="mass", law="newton",
    e=0.5, friction=0.3, normal=[0, 0, 1], origin=[0, 0, 0])``.
    """

    frame: str
    law: ImpactLaw
    surface: Surface = field(default_factory=Surface)
    point: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    friction: float = 0.0
    tangent: NDArray[np.float64] | None = None
    stiffness: float = 1e5

    def __post_init__(self) -> None:
        with scene_errors():
            self._validate()

    def _validate(self) -> None:
        if not isinstance(self.frame, str):
            raise SceneError(f"a contact's frame is a frame name, got {type(self.frame).__name__}")
        if not isinstance(self.law, ImpactLaw):
            raise SceneError(f"a contact's law must be an impact law, got {type(self.law).__name__}")
        if not isinstance(self.surface, Surface):
            raise SceneError(f"a contact's surface must be a Surface, got {type(self.surface).__name__}")
        object.__setattr__(self, "point", as_array("point", self.point, 1, (3,)))
        object.__setattr__(self, "friction", as_scalar("friction", self.friction, 0.0, math.inf))
        object.__setattr__(self, "stiffness", as_scalar("stiffness", self.stiffness, 0.0, math.inf, lo_open=True))
        if self.tangent is not None:
            object.__setattr__(self, "tangent", unit_tangent(self.tangent, self.surface.normal))

    @property
    def label(self) -> str:
        """The contact in messages and plots: its frame."""
        return self.frame


@accepts_file_keys(collision_keys)
@dataclass(frozen=True, eq=False)
class SceneCollision:
    """Collision objects of the mechanism striking an obstacle, or each other.

    The gap is the signed distance of the pair (coal), its normal points from the obstacle
    (or ``other``) towards ``body``, and the contact points are the pair's witness points: one
    for a sphere or a corner, the whole contact patch (within the scene's ``patch_tolerance``)
    when an edge or a face lands. A rough law acts about the local normal at each point.

    Parameters
    ----------
    body : str or sequence of str
        Collision object(s) of the mechanism (:meth:`mbimpact.Mechanism.collision_names`), or
        ``"all"``: every object that moves (with an obstacle) or every pair the mechanism allows
        (with ``other="all"``: objects on different joints, not parent and child).
    law : ImpactLaw
    obstacle : Shape, optional
        A world obstacle (:class:`mbimpact.HalfSpace`, ``Box``, ``Sphere``, ``Capsule``,
        ``Cylinder``, ``Mesh``).
    other : str, optional
        Or another collision object of the mechanism (self-collision), or ``"all"``.
    friction, tangent, stiffness
        As for :class:`SceneContact`.

    The keys of a scene file's collision contact are accepted too (``law="rough", e=0.5,
    roughness={"kind": "cone", "alpha": 0.2}``, ...), as for :class:`SceneContact`.

    A :class:`Scene` expands every :class:`SceneCollision` into one per pair (``body`` and
    ``other`` single names), each a contact of its own in the trajectory.
    """

    body: str | tuple[str, ...]
    law: ImpactLaw
    obstacle: Shape | None = None
    other: str | None = None
    friction: float = 0.0
    tangent: NDArray[np.float64] | None = None
    stiffness: float = 1e5

    def __post_init__(self) -> None:
        with scene_errors():
            self._validate()

    def _validate(self) -> None:
        body = self.body
        if isinstance(body, str):
            pass
        elif isinstance(body, (list, tuple)) and body and all(isinstance(b, str) for b in body):
            object.__setattr__(self, "body", tuple(body))
        else:
            raise SceneError(f"a collision contact's body is a collision object name, a list of names or 'all'; "
                             f"got {body!r}")
        if not isinstance(self.law, ImpactLaw):
            raise SceneError(f"a contact's law must be an impact law, got {type(self.law).__name__}")
        if (self.obstacle is None) == (self.other is None):
            raise SceneError("a collision contact needs exactly one of obstacle (a world shape) and other "
                             "(a collision object of the mechanism, or 'all')")
        if self.obstacle is not None and not isinstance(self.obstacle, Shape):
            raise SceneError(f"obstacle must be a shape (HalfSpace, Box, Sphere, Capsule, Cylinder, Mesh), "
                             f"got {type(self.obstacle).__name__}")
        if self.other is not None and not isinstance(self.other, str):
            raise SceneError(f"other must be a collision object name or 'all', got {self.other!r}")
        if self.other is not None and self.other == self.body != "all":
            raise SceneError(f"other must differ from body ({self.body!r}): an object does not strike itself")
        object.__setattr__(self, "friction", as_scalar("friction", self.friction, 0.0, math.inf))
        object.__setattr__(self, "stiffness", as_scalar("stiffness", self.stiffness, 0.0, math.inf, lo_open=True))
        if self.tangent is not None:
            object.__setattr__(self, "tangent", unit_tangent(self.tangent))

    @property
    def concrete(self) -> bool:
        """One pair: ``body`` and ``other`` are single names (not lists, not "all")."""
        return isinstance(self.body, str) and self.body != "all" and self.other != "all"

    @property
    def label(self) -> str:
        """The pair in messages and plots: ``body | obstacle`` or ``body | other``."""
        body = self.body if isinstance(self.body, str) else ",".join(self.body)
        other = self.obstacle.label if self.obstacle is not None else self.other
        return f"{body} | {other}"

    def pairs(self, mech: Mechanism) -> list[SceneCollision]:
        """One concrete :class:`SceneCollision` per pair on ``mech`` ("all" and lists expanded).

        Raises
        ------
        CollisionNotFoundError
            A name that is not a collision object of ``mech``.
        SceneError
            "all" finds no pair.
        """
        from dataclasses import replace

        from ..geometry.queries import gap_model

        cm = mech.collision_model()
        names = self.body if isinstance(self.body, tuple) else (self.body,)
        if self.obstacle is not None:
            bodies = cm.moving if names == ("all",) else [cm.names[cm.index(n)] for n in names]
            out = [replace(self, body=b) for b in bodies]
        else:
            if self.other == "all":
                allowed = gap_model(mech, self_pairs="all").pairs if len(cm) > 1 else ()
                out = [replace(self, body=a, other=b) for a, b in allowed
                       if names == ("all",) or a in names or b in names]
            else:
                cm.index(self.other)  # type: ignore[arg-type]
                out = [replace(self, body=cm.names[cm.index(n)]) for n in
                       (cm.moving if names == ("all",) else names) if n != self.other]
        if not out:
            raise SceneError(f"the collision contact {self.label} has no pair on {mech.name}")
        return out


def collision_gap(mech: Mechanism, c: SceneCollision, q: NDArray[np.float64]) -> float:
    """Signed distance of one concrete collision pair at q."""
    from ..geometry.queries import gap_model

    if c.obstacle is not None:
        gm = gap_model(mech, (c.obstacle,), bodies=(str(c.body),))
    else:
        gm = gap_model(mech, self_pairs=((str(c.body), str(c.other)),))
    return float(gm.distances(q)[0])

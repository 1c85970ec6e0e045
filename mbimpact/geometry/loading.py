"""Loading a mechanism's collision geometry from its model file, once, when it is first asked for.

:func:`collision_model` is what :meth:`mbimpact.Mechanism.collision_model` calls: the URDF's
``<collision>`` elements (``pin.buildGeomFromUrdf``) or the MJCF's collision geoms
(``pin.buildGeomFromMJCF``), built against the mechanism's own ``pinocchio.Model`` (so a free-flyer
root added by ``floating=True`` is taken into account), and cached per mechanism. Nothing is
loaded before: point contacts on frames never pay for meshes.

Mesh paths ``package://<pkg>/...`` resolve against, in order, the folder that holds
example-robot-data's packages (:func:`mbimpact.mechanism.robots.robots_share_dir`), then the
URDF's folder and its three parents. Meshes become convex hulls (qhull): against half-spaces and
primitives, a hull gives the exact signed distance in penetration and costs ~3 µs per query,
where the triangle soup gives wrong depths and ~1 ms (see :mod:`mbimpact.geometry.shapes`).
Non-convex links are thereby approximated from outside.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import coal
import pinocchio as pin

from ..errors import GeometryError, ImpactError
from ..mechanism.robots import robots_share_dir
from .cache import mechanism_cache
from .collision_model import CollisionModel
from .shapes import convex_hull

if TYPE_CHECKING:
    from ..mechanism.mechanism import Mechanism

__all__ = ["collision_model", "load_collision_model", "is_mjcf", "package_dirs"]

def is_mjcf(path: Path) -> bool:
    """True when the file is MJCF (its root element is ``<mujoco``), False for URDF."""
    if path.suffix.lower() == ".urdf":
        return False
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            head = fh.read(4096)
    except OSError:
        return False
    return "<mujoco" in head


def package_dirs(path: Path) -> list[str]:
    """Folders searched for ``package://`` mesh paths of the URDF at ``path``."""
    dirs: list[str] = []
    try:
        dirs.append(str(robots_share_dir()))
    except ImpactError:  # example-robot-data missing: the URDF's own folders only
        pass
    parent = path.resolve().parent
    for p in (parent, *list(parent.parents)[:3]):
        dirs.append(str(p))
    return dirs


def _hulls(gm: Any, owner: str) -> None:
    """Replace every triangle mesh of ``gm`` by its convex hull (in place)."""
    for go in gm.geometryObjects:
        g = go.geometry
        if isinstance(g, coal.BVHModelBase):
            go.geometry = convex_hull(g, f"{go.name!r} of {owner} (mesh {Path(go.meshPath).name})")
        else:
            g.computeLocalAABB()


def load_collision_model(mech: Mechanism) -> CollisionModel:
    """Build the collision model of a mechanism from its source file (not cached: see :func:`collision_model`).

    A mechanism built from a ``pinocchio.Model`` without a source file gets an empty model, to
    which shapes can be attached.

    Raises
    ------
    GeometryError
        A mesh cannot be found or read, or the file's collision elements cannot be parsed.
    """
    model, src = mech.model, mech.source
    if src is None:
        return CollisionModel(model, pin.GeometryModel(), mech.name)
    path = Path(src)
    if not path.is_file():
        raise GeometryError(f"the model file {str(path)!r} of {mech.name} is gone; its collision geometry cannot be loaded")
    try:
        if is_mjcf(path):
            gm = pin.buildGeomFromMJCF(model, str(path), pin.GeometryType.COLLISION)
        else:
            gm = pin.buildGeomFromUrdf(model, str(path), pin.GeometryType.COLLISION, None, package_dirs(path))
    except (RuntimeError, ValueError, OSError) as exc:
        raise GeometryError(f"could not load the collision geometry of {mech.name} from {str(path)!r}: {exc}") from exc
    _hulls(gm, mech.name)
    return CollisionModel(model, gm, mech.name)


def collision_model(mech: Mechanism) -> CollisionModel:
    """The mechanism's collision model, loaded on the first call and cached with the mechanism."""
    store = mechanism_cache(mech)
    cm = store.get("collision_model")
    if cm is None:
        with store["lock"]:
            cm = store.get("collision_model")
            if cm is None:
                cm = store["collision_model"] = load_collision_model(mech)
    return cm

"""The scene file's keys in Python: :class:`Scene`, :class:`SceneContact`, :class:`SceneCollision` and
:class:`PD` take the keys of the TOML tables they stand for (:data:`mbimpact.simulation.schema.SCHEMA`)
besides their own fields.

A contact takes ``law="newton", e=0.5`` as in a file, or ``law=mbi.NewtonLaw(0.5)``; ``surface="plane",
normal=..., origin=...`` or ``surface=mbi.Surface(...)``. A scene takes the leaf keys of the file's
``[initial]``, ``[forces]``, ``[simulation]`` and ``[record]`` tables (``q``, ``v``, ``posture``, ``gravity``,
``pd``, ``duration``, ``states``, ...) or the tables themselves as dicts (``simulation={"duration": 2.0}``),
``mechanism`` as a :class:`~mbimpact.Mechanism` or as the ``[mechanism]`` table, and ``contacts`` as
objects or as ``[[contacts]]`` tables. A key that is neither a field nor a file key is a
:class:`~mbimpact.SceneError` naming it and the valid keys.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from ..errors import SceneError

__all__ = ["accepts_file_keys", "contact_keys", "collision_keys", "scene_keys", "pd_keys"]

_C = TypeVar("_C", bound=type)

#: The keys that build a contact's impact law when ``law`` is not an impact law object.
LAW_KEYS = ("e", "k", "roughness", "flux", "facet", "mu", "restitution")
#: The keys that build a frame contact's surface when ``surface`` is not a Surface.
SURFACE_KEYS = ("normal", "origin", "rho", "motion")


def accepts_file_keys(translate: Callable[[str, dict[str, Any]], dict[str, Any]]) -> Callable[[_C], _C]:
    """A class decorator for a dataclass: its constructor also takes the scene file's keys, which
    ``translate(class name, keyword arguments)`` turns into the dataclass's fields."""

    def decorate(cls: _C) -> _C:
        init = cls.__init__  # type: ignore[misc]
        names = [f.name for f in dataclasses.fields(cls) if f.init]

        @functools.wraps(init)
        def __init__(self: Any, *args: Any, **kwargs: Any) -> None:  # noqa: N807
            if len(args) > len(names):
                raise SceneError(f"{cls.__name__} takes at most {len(names)} positional arguments "
                                 f"({', '.join(names)}), got {len(args)}")
            for name, value in zip(names, args):
                if name in kwargs:
                    raise SceneError(f"{cls.__name__}: {name} given twice (by position and by key)")
                kwargs[name] = value
            init(self, **translate(cls.__name__, kwargs))

        cls.__init__ = __init__  # type: ignore[misc]
        return cls

    return decorate


def _unknown(owner: str, keys: list[str], valid: set[str], hint: str = "") -> SceneError:
    key = keys[0]
    close = difflib.get_close_matches(key, sorted(valid), n=1, cutoff=0.6)
    return SceneError(f"{owner}: unknown key {key!r}" + (f" (did you mean {close[0]!r}?)" if close else "")
                      + hint + f"; valid keys: {', '.join(sorted(valid))}")


def _law(owner: str, kw: dict[str, Any]) -> None:
    """Replace the law keys of ``kw`` by ``kw["law"]``, an impact law."""
    from ..laws.base import ImpactLaw
    from .scene_file import law_from_keys

    given = {k: kw.pop(k) for k in LAW_KEYS if k in kw}
    law = kw.get("law")
    if isinstance(law, ImpactLaw):
        if given:
            raise SceneError(f"{owner}: {sorted(given)[0]} applies to a law given by name (law = 'newton', 'rough' "
                             f"or 'coulomb'); the law object {law!r} carries its own parameters")
        return
    if law is None and not given:
        raise SceneError(f"{owner}: a contact needs a law: an impact law (law=mbimpact.NewtonLaw(0.5), RoughLaw, "
                         "CoulombLaw, ...) or the scene file's keys (law='newton', e=0.5)")
    if law is not None and not isinstance(law, str):
        raise SceneError(f"{owner}: law must be an impact law (NewtonLaw, RoughLaw, CoulombLaw, ...) or one of "
                         f"'newton', 'rough', 'coulomb'; got {type(law).__name__}")
    keys = dict(given, **({"law": law} if law is not None else {}))
    if law is not None and law not in ("newton", "rough", "coulomb"):
        raise SceneError(f"{owner}: law must be one of 'newton', 'rough', 'coulomb' (or an impact law object), "
                         f"got {law!r}")
    try:
        kw["law"] = law_from_keys(keys, owner)
    except SceneError as exc:
        if law is None:
            raise
        raise SceneError(f"{exc} (for law = {law!r}, given by name as in a scene file; or give the law object, "
                         f"e.g. law=mbimpact.NewtonLaw(0.5))") from exc


def contact_keys(owner: str, kw: dict[str, Any]) -> dict[str, Any]:
    """:class:`SceneContact`'s fields from its fields and the keys of a frame contact's table."""
    from .schema import COLLISION_KEYS, SCHEMA
    from .surfaces import Surface

    file_keys = set(SCHEMA["properties"]["contacts"]["items"]["properties"])
    fields = {"frame", "law", "surface", "point", "friction", "tangent", "stiffness"}
    wrong = [k for k in kw if k in COLLISION_KEYS]
    if wrong:
        raise SceneError(f"{owner}: {wrong[0]} applies to collision contacts (mbimpact.SceneCollision) only")
    unknown = sorted(set(kw) - fields - file_keys)
    if unknown:
        raise _unknown(owner, unknown, (fields | file_keys) - set(COLLISION_KEYS))
    _law(owner, kw)
    surface = kw.get("surface")
    given = {k: kw.pop(k) for k in SURFACE_KEYS if k in kw}
    if isinstance(surface, Surface):
        if given:
            raise SceneError(f"{owner}: {sorted(given)[0]} applies to a surface given by name (surface = 'plane' or "
                             "'paraboloid'); the Surface object carries its own")
    elif surface is not None or given:
        if surface is not None and surface not in ("plane", "paraboloid"):
            raise SceneError(f"{owner}: surface must be 'plane', 'paraboloid' or an mbimpact.Surface, got {surface!r}")
        from .scene_file import surface_from_keys

        kw["surface"] = surface_from_keys(dict(given, **({"surface": surface} if surface else {})), owner)
    return kw


def collision_keys(owner: str, kw: dict[str, Any]) -> dict[str, Any]:
    """:class:`SceneCollision`'s fields from its fields and the keys of a collision contact's table."""
    from .schema import FRAME_KEYS, SCHEMA

    file_keys = set(SCHEMA["properties"]["contacts"]["items"]["properties"])
    fields = {"body", "law", "obstacle", "other", "friction", "tangent", "stiffness"}
    wrong = [k for k in kw if k in FRAME_KEYS]
    if wrong:
        raise SceneError(f"{owner}: {wrong[0]} applies to frame contacts (mbimpact.SceneContact) only; a collision "
                         "contact's surface is its obstacle")
    unknown = sorted(set(kw) - fields - file_keys)
    if unknown:
        raise _unknown(owner, unknown, (fields | file_keys) - set(FRAME_KEYS))
    if isinstance(kw.get("obstacle"), str):
        raise SceneError(f"{owner}: obstacle must be a shape (mbimpact.HalfSpace, Box, ...) here; {kw['obstacle']!r} "
                         "names an obstacle of a scene: give this contact as a table in Scene(contacts=..., "
                         "obstacles=...)")
    _law(owner, kw)
    return kw


def pd_keys(owner: str, kw: dict[str, Any]) -> dict[str, Any]:
    """:class:`PD`'s fields; ``q`` (the file's key) is ``q_ref``."""
    valid = {"kp", "kd", "q", "q_ref"}
    unknown = sorted(set(kw) - valid)
    if unknown:
        raise _unknown(owner, unknown, valid)
    if "q" in kw:
        if "q_ref" in kw:
            raise SceneError(f"{owner}: give q or q_ref (the same reference), not both")
        kw["q_ref"] = kw.pop("q")
    if isinstance(kw.get("q_ref"), str):
        raise SceneError(f"{owner}: q = {kw['q_ref']!r} refers to a scene's state: give it in the pd table of "
                         "Scene(pd={...}), or the configuration itself")
    return kw


#: A scene's file tables whose keys a Scene also takes one by one.
_TABLES = ("initial", "forces", "simulation")


def scene_keys(owner: str, kw: dict[str, Any]) -> dict[str, Any]:
    """:class:`Scene`'s fields from its fields, the file's top-level keys and their tables' keys."""
    from ..mechanism.mechanism import Mechanism
    from .scene import PD
    from .scene_contacts import SceneCollision, SceneContact
    from .schema import SCHEMA

    top = SCHEMA["properties"]
    leaves = {table: set(top[table]["properties"]) for table in _TABLES}
    fields = {"mechanism", "q0", "v0", "contacts", "gravity", "damping", "torque", "pd", "duration",
              "rest_velocity", "contact_step", "chatter_time", "rtol", "tolerance", "patch_tolerance", "simultaneous",
              "max_impacts", "max_events_per_second", "max_wall_time", "samples", "record", "name"}
    valid = fields | set(top) | set().union(*leaves.values()) | {"states"}
    unknown = sorted(set(kw) - valid)
    if unknown:
        raise _unknown(owner, unknown, valid)
    for table in _TABLES:  # a table given whole: its keys, one by one
        if table in kw:
            content = kw.pop(table)
            if not isinstance(content, dict):
                raise SceneError(f"{owner}: {table} is a table (a dict of {', '.join(sorted(leaves[table]))}), "
                                 f"got {type(content).__name__}")
            extra = sorted(set(content) - leaves[table])
            if extra:
                raise _unknown(f"{owner}: {table}", extra, leaves[table])
            for key, value in content.items():
                if key in kw:
                    raise SceneError(f"{owner}: {key} given twice (alone and in {table})")
                kw[key] = value
    if isinstance(kw.get("record"), dict):
        record = kw.pop("record")
        if set(record) - {"states"}:
            raise _unknown(f"{owner}: record", sorted(set(record) - {"states"}), {"states"})
        kw["states"] = record.get("states", ())
    if "states" in kw:
        if "record" in kw:
            raise SceneError(f"{owner}: give record or states (the same list), not both")
        kw["record"] = tuple(kw.pop("states"))
    mech = kw.get("mechanism")
    if isinstance(mech, dict):
        mech = kw["mechanism"] = _mechanism(owner, mech)
    for short, field in (("q", "q0"), ("v", "v0")):
        if short in kw:
            if field in kw:
                raise SceneError(f"{owner}: give {short} or {field} (the same state), not both")
            kw[field] = kw.pop(short)
    posture = kw.pop("posture", None)
    if posture is not None:
        if posture != "neutral":
            raise SceneError(f"{owner}: posture must be 'neutral', got {posture!r}")
        if "q0" in kw:
            raise SceneError(f"{owner}: give q or posture, not both")
    if isinstance(mech, Mechanism):
        kw.setdefault("q0", mech.neutral())  # the file's default: the neutral posture, at rest
        kw.setdefault("v0", np.zeros(mech.nv))
    if isinstance(kw.get("pd"), dict):
        pd = dict(kw["pd"])
        ref = pd.get("q", pd.get("q_ref", "initial"))
        if isinstance(ref, str):  # the file's references to the scene's states
            if ref not in ("initial", "neutral"):
                raise SceneError(f"{owner}: pd: q must be 'initial', 'neutral' or a configuration, got {ref!r}")
            if not isinstance(mech, Mechanism):
                raise SceneError(f"{owner}: pd: q = {ref!r} needs the scene's mechanism")
            pd.pop("q_ref", None)
            pd["q"] = kw.get("q0") if ref == "initial" else mech.neutral()
        kw["pd"] = PD(**pd_keys(f"{owner}: pd", pd))
    obstacles = _obstacles(owner, kw.pop("obstacles", None))
    contacts = kw.get("contacts")
    if isinstance(contacts, (list, tuple)):
        out: list[Any] = []
        for i, c in enumerate(contacts):
            if isinstance(c, dict):
                c = dict(c)
                where = f"{owner}: contacts[{i}]"
                if "body" in c:
                    if isinstance(c.get("obstacle"), str):
                        if c["obstacle"] not in obstacles:
                            raise SceneError(f"{where}: no obstacle {c['obstacle']!r}; obstacles: "
                                             f"{', '.join(obstacles) or 'none (give obstacles=[...])'}")
                        c["obstacle"] = obstacles[c["obstacle"]]
                    c = SceneCollision(**c)
                else:
                    c = SceneContact(**c)
            out.append(c)
        kw["contacts"] = tuple(out)
    return kw


def _mechanism(owner: str, table: dict[str, Any]) -> Any:
    """A mechanism from the file's [mechanism] table (a urdf relative to the working directory)."""
    from ..errors import ImpactError
    from ..mechanism.mechanism import Mechanism
    from .schema import SCHEMA

    valid = set(SCHEMA["properties"]["mechanism"]["properties"])
    extra = sorted(set(table) - valid)
    if extra:
        raise _unknown(f"{owner}: mechanism", extra, valid)
    sources = [k for k in ("robot", "model", "urdf") if k in table]
    if len(sources) != 1:
        raise SceneError(f"{owner}: mechanism: give exactly one of robot, model or urdf"
                         + (f" (got {', '.join(sources)})" if sources else ""))
    floating = table.get("floating")
    try:
        if "robot" in table:
            return Mechanism.from_robot(table["robot"], floating)
        if "model" in table:
            return Mechanism.from_model(table["model"], bool(floating))
        return Mechanism.from_urdf(table["urdf"], bool(floating))
    except ImpactError as exc:
        raise SceneError(f"{owner}: mechanism.{sources[0]}: {exc}") from exc


def _obstacles(owner: str, items: Any) -> dict[str, Any]:
    """``obstacles``: shapes or [[obstacles]] tables, by name."""
    from ..geometry.shapes import Shape
    from .scene_file import obstacles_from_keys

    if items is None:
        return {}
    if not isinstance(items, (list, tuple)):
        raise SceneError(f"{owner}: obstacles is a list of shapes or obstacle tables, got {type(items).__name__}")
    tables = [o for o in items if isinstance(o, dict)]
    out = obstacles_from_keys(tables, f"{owner}: obstacles", Path.cwd()) if tables else {}
    for o in items:
        if isinstance(o, Shape):
            out[o.label] = o
        elif not isinstance(o, dict):
            raise SceneError(f"{owner}: an obstacle is a shape (mbimpact.HalfSpace, Box, ...) or a table, "
                             f"got {type(o).__name__}")
    return out

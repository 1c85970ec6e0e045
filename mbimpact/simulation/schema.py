"""The scene file format: a strict schema, its reader, and its reference text.

A scene file is TOML. Every key is checked against :data:`SCHEMA` (a JSON Schema, validated
with ``jsonschema``): unknown or misspelled keys, wrong types, NaN or infinite numbers,
out-of-range values and contradictory keys are :class:`mbimpact.SceneError` s that name
the key and its line. :func:`reference` prints the schema (``mbimpact scene --help``).
"""

from __future__ import annotations

import difflib
import math
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ImpactError, SceneError
from ..facets import FacetLaw, facet_law
from ..geometry.shapes import Box, Capsule, Cylinder, HalfSpace, Mesh, Shape, Sphere
from ..laws.base import ImpactLaw
from ..laws.coulomb import CoulombLaw
from ..laws.newton import NewtonLaw
from ..laws.rough import RoughLaw
from ..mechanism.mechanism import Mechanism
from ..roughness import Cone, GaussianSlopes, Roughness, Sawtooth, Smooth
from .scene import DAMPING_MAX, PD, SIMULTANEOUS_RULES, Scene, SceneCollision, SceneContact, scene_path
from .surfaces import Surface

__all__ = ["SCHEMA", "load_scene", "reference"]


def _num(description: str, minimum: float | None = None, maximum: float | None = None, exclusive: bool = False,
         default: Any = None) -> dict[str, Any]:
    out: dict[str, Any] = {"type": "number", "finite": True, "description": description}
    if minimum is not None:
        out["exclusiveMinimum" if exclusive else "minimum"] = minimum
    if maximum is not None:
        out["maximum"] = maximum
    if default is not None:
        out["default"] = default
    return out


def _vec(description: str, size: int | None = None, default: Any = None) -> dict[str, Any]:
    out: dict[str, Any] = {"type": "array", "items": {"type": "number", "finite": True}, "description": description}
    if size is not None:
        out["minItems"] = out["maxItems"] = size
    if default is not None:
        out["default"] = default
    return out


def _table(description: str, properties: dict[str, Any], required: tuple[str, ...] = ()) -> dict[str, Any]:
    out: dict[str, Any] = {"type": "object", "additionalProperties": False, "properties": properties,
                           "description": description}
    if required:
        out["required"] = list(required)
    return out


_ROUGHNESS = _table("facet measure of the rough law", {
    "kind": {"enum": ["smooth", "sawtooth", "cone", "gaussian"], "description": "the measure"},
    "alpha": _num("facet tilt [rad] (sawtooth, cone), 0 ≤ α < π/2", 0.0, math.pi / 2),
    "sigma": _num("RMS slope per component (gaussian), > 0", 0.0, exclusive=True),
    "dim": {"enum": [2, 3], "description": "gaussian: 3 spatial (default), 2 planar"},
}, ("kind",))

#: Keys of a frame contact that a collision contact does not have, and the other way round.
FRAME_KEYS = ("frame", "point", "surface", "normal", "origin", "rho", "motion")
COLLISION_KEYS = ("body", "obstacle", "other")

_CONTACT = _table("a contact: a frame's point on a surface (frame = ...), or a collision object of the mechanism "
                  "against an obstacle or another of its objects (body = ...); its laws", {
    "frame": {"type": "string", "description": "frame the contact point is attached to"},
    "body": {"anyOf": [{"type": "string"}, {"type": "array", "items": {"type": "string"}, "minItems": 1}],
             "description": "instead of frame: collision object(s) of the mechanism, or \"all\""},
    "obstacle": {"type": "string", "description": "with body: the name of an [[obstacles]] table"},
    "other": {"type": "string", "description": "with body: another collision object, or \"all\" (self-collision)"},
    "point": _vec("offset of the point from the frame origin, frame axes [m]", 3, [0, 0, 0]),
    "surface": {"enum": ["plane", "paraboloid"], "description": "the surface", "default": "plane"},
    "normal": _vec("unit normal of the surface (normalised), out of it", 3, [0, 0, 1]),
    "origin": _vec("a point of the surface (a paraboloid's vertex) [m]", 3, [0, 0, 0]),
    "rho": _num("paraboloid: radius of curvature on the axis [m], |rho| ≥ 1e-6 (< 0: a dome)"),
    "tangent": _vec("with the normal, the plane of a planar roughness (default: world x projected)", 3),
    "law": {"enum": ["newton", "rough", "coulomb"],
            "description": "impact law (default: rough with a roughness, else newton)"},
    "e": _num("restitution (of the facets, for the rough law), 0 ≤ e ≤ 1", 0.0, 1.0),
    "k": _num("Kelvin–Voigt damping ratio instead of e, 0 ≤ k ≤ 1", 0.0, 1.0),
    "roughness": _ROUGHNESS,
    "flux": {"enum": ["physical", "configuration"], "description": "rough law: facet weight of (2.7)",
             "default": "physical"},
    "facet": _table("rough law: the impact on one facet (default Newton's with e)", {
        "kind": {"enum": ["newton", "coulomb", "compliant", "hunt-crossley"], "description": "the facet law"},
        "mu": _num("coulomb, compliant: friction coefficient on the facet, ≥ 0", 0.0),
        "restitution": {"enum": ["newton", "poisson", "energetic"],
                        "description": "coulomb: restitution hypothesis", "default": "energetic"},
        "stiffness_ratio": _num("compliant: tangential to normal stiffness ratio, > 0", 0.0, exclusive=True),
        "alpha": _num("hunt-crossley: damping [s/m], e(v) ≈ 1 − α v (no e then)", 0.0, exclusive=True),
    }, ("kind",)),
    "mu": _num("coulomb law: friction coefficient of the impact, ≥ 0", 0.0),
    "restitution": {"enum": ["newton", "poisson", "energetic"], "description": "coulomb law: restitution hypothesis",
                    "default": "energetic"},
    "friction": _num("Coulomb μ of the persistent (resting, sliding) contact, ≥ 0", 0.0, default=0.0),
    "stiffness": _num("Kelvin–Voigt M [1/s] for the compliant rule of simultaneous impacts", 0.0, exclusive=True,
                      default=1e5),
    "motion": _table("harmonic motion of the surface along its normal, a = A sin(2π f t + φ)", {
        "amplitude": _num("A [m]", default=0.0),
        "frequency": _num("f [Hz], ≥ 0", 0.0, default=0.0),
        "phase": _num("φ [rad]", default=0.0),
    }),
})

_OBSTACLE = _table("a world obstacle for collision contacts", {
    "name": {"type": "string", "description": "its name, used by contacts' obstacle = ... (required)"},
    "shape": {"enum": ["halfspace", "box", "sphere", "capsule", "cylinder", "mesh"], "description": "the shape"},
    "normal": _vec("halfspace: outward unit normal (normalised)", 3, [0, 0, 1]),
    "offset": _num("halfspace: the solid is n·x ≤ offset [m]", default=0.0),
    "size": _vec("box: full side lengths [m], > 0", 3),
    "radius": _num("sphere, capsule, cylinder: radius [m], > 0", 0.0, exclusive=True),
    "length": _num("capsule, cylinder: full length of the axis (local z) [m], > 0", 0.0, exclusive=True),
    "path": {"type": "string", "description": "mesh: the file, relative to the scene file"},
    "scale": _num("mesh: scale of the file's coordinates, > 0", 0.0, exclusive=True, default=1.0),
    "position": _vec("centre [m] (not for a halfspace)", 3, [0, 0, 0]),
    "rpy": _vec("orientation as roll, pitch, yaw [rad] (not for a halfspace)", 3, [0, 0, 0]),
}, ("name", "shape"))

#: Keys each obstacle shape takes (besides name and shape).
SHAPE_KEYS = {"halfspace": {"normal", "offset"}, "box": {"size", "position", "rpy"},
              "sphere": {"radius", "position", "rpy"}, "capsule": {"radius", "length", "position", "rpy"},
              "cylinder": {"radius", "length", "position", "rpy"}, "mesh": {"path", "scale", "position", "rpy"}}
SHAPE_NEEDS = {"halfspace": set(), "box": {"size"}, "sphere": {"radius"}, "capsule": {"radius", "length"},
               "cylinder": {"radius", "length"}, "mesh": {"path"}}

#: The JSON Schema of a scene file (plus the keyword ``finite``: no NaN or infinity).
SCHEMA: dict[str, Any] = _table("a scene", {
    "name": {"type": "string", "description": "scene name (default: the file stem)"},
    "mechanism": _table("the mechanism: exactly one of robot, model, urdf", {
        "robot": {"type": "string", "description": "an example-robot-data robot (mbimpact.robot_names())"},
        "model": {"type": "string", "description": "one of mbimpact's own models (mbimpact.model_names())"},
        "urdf": {"type": "string", "description": "a URDF file, relative to the scene file"},
        "floating": {"type": "boolean", "description": "add a free-flyer root (robots: their default)"},
    }),
    "initial": _table("initial state (q or posture, and v)", {
        "q": _vec("configuration (nq entries)"),
        "posture": {"enum": ["neutral"], "description": "instead of q: the neutral configuration", "default": "neutral"},
        "v": _vec("velocity (nv entries)", default="zeros"),
    }),
    "obstacles": {"type": "array", "items": _OBSTACLE, "description": "[[obstacles]] tables: world shapes"},
    "contacts": {"type": "array", "minItems": 1, "items": _CONTACT, "description": "[[contacts]] tables, at least one"},
    "forces": _table("the forces present, and only those", {
        "gravity": {"type": "boolean", "description": "gravity along −z", "default": True},
        # the upper bound DAMPING_MAX is checked by Scene, whose message says why (a locked joint)
        "damping": _num(f"joint damping: τ = −damping · v, 0 ≤ damping ≤ {DAMPING_MAX:g} (beyond: a locked joint)",
                        0.0, default=0.0),
        "torque": _vec("constant joint torques (nv entries)"),
        "pd": _table("joint PD torques τ = kp (q_ref − q) − kd v on actuated joints", {
            "kp": _num("stiffness, ≥ 0", 0.0),
            "kd": _num("damping, ≥ 0", 0.0),
            "q": {"description": "reference: a list of nq numbers, or \"initial\" (default) or \"neutral\"",
                  "anyOf": [{"enum": ["initial", "neutral"]}, {"type": "array", "items": {"type": "number", "finite": True}}]},
        }, ("kp", "kd")),
    }),
    "simulation": _table("run settings", {
        "duration": _num("simulated time [s], > 0", 0.0, exclusive=True, default=1.0),
        "rest_velocity": _num("rebound [m/s] below which a contact comes to rest (after the Zeno tail)", 0.0,
                              default=1e-3),
        "contact_step": _num("time step of persistent-contact phases [s], > 0", 0.0, exclusive=True, default=1e-3),
        "chatter_time": _num("a contact striking again sooner than this [s] becomes persistent (default "
                             "10 contact steps)", 0.0),
        "rtol": _num("relative tolerance of the free flight, 1e-14 … 1e-3", 1e-14, 1e-3, default=1e-10),
        "tolerance": _num("penetration tolerated [m], > 0", 0.0, exclusive=True, default=1e-8),
        "patch_tolerance": _num("collision contacts: witness points this close [m] to the nearest one strike or "
                                "rest together (a face landing flat), > 0", 0.0, exclusive=True, default=1e-6),
        "simultaneous": {"enum": list(SIMULTANEOUS_RULES), "description": "rule for contacts striking together",
                         "default": "auto"},
        "samples": {"type": "integer", "minimum": 2, "description": "facet realisations of the rough rule",
                    "default": 256},
        "max_impacts": {"type": "integer", "minimum": 1, "description": "stop after this many impacts",
                        "default": 100000},
        "max_events_per_second": _num("stop beyond this many impacts and contact switches per simulated second",
                                      0.0, exclusive=True, default=1e5),
        "max_wall_time": _num("stop after this many wall-clock seconds", 0.0, exclusive=True, default=600.0),
    }),
    "record": _table("what to plot", {
        "states": {"type": "array", "items": {"type": "string", "pattern": "^[qv][0-9]+$"},
                   "description": "states, e.g. [\"q2\", \"v0\"]"},
    }),
}, ("mechanism", "contacts"))


def _validator() -> Any:
    import jsonschema

    def finite(validator: Any, value: bool, instance: Any, schema: Any) -> Iterator[Any]:
        if value and isinstance(instance, float) and not math.isfinite(instance):
            yield jsonschema.ValidationError(f"{instance} is not a finite number")

    cls = jsonschema.validators.extend(jsonschema.Draft202012Validator, {"finite": finite})
    return cls(SCHEMA)


def _line(text: str, path: list[Any]) -> str:
    """' (line N)' for a key path such as ['contacts', 2, 'law'], or ''."""
    lines = text.splitlines()
    start, table = 0, ""
    keys = [p for p in path if isinstance(p, str)]
    if path and path[0] in ("contacts", "obstacles") and len(path) > 1 and isinstance(path[1], int):
        headers = [i for i, ln in enumerate(lines) if ln.strip().startswith(f"[[{path[0]}]]")]
        if path[1] < len(headers):
            start = headers[path[1]]
            stop = headers[path[1] + 1] if path[1] + 1 < len(headers) else len(lines)
            keys = keys[1:]
            if not keys:
                return f" (line {start + 1})"
            for i in range(start, stop):
                stripped = lines[i].strip()
                if any(stripped.startswith(k) and stripped[len(k):].lstrip().startswith("=") for k in keys[:1]):
                    return f" (line {i + 1})"
            return f" (line {start + 1})"
    if len(keys) >= 1:
        table = keys[0]
        for i, ln in enumerate(lines):
            stripped = ln.strip()
            if stripped in (f"[{table}]", f"[[{table}]]"):
                if len(keys) == 1:
                    return f" (line {i + 1})"
                for j in range(i + 1, len(lines)):
                    s2 = lines[j].strip()
                    if s2.startswith("["):
                        break
                    if s2.startswith(keys[1]) and s2[len(keys[1]):].lstrip()[:1] in ("=", "."):
                        return f" (line {j + 1})"
                return f" (line {i + 1})"
            if len(keys) == 1 and stripped.startswith(table) and stripped[len(table):].lstrip().startswith("="):
                return f" (line {i + 1})"
    return ""


def _where(path: list[Any]) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "scene"


def _message(error: Any) -> str:
    """A jsonschema error in words: what was wrong and what is valid."""
    if error.validator == "additionalProperties":
        allowed = sorted(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(allowed))
        hints = []
        for key in extra:
            close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
            hints.append(f"unknown key {key!r}" + (f" (did you mean {close[0]!r}?)" if close else ""))
        return "; ".join(hints) + f"; valid keys: {', '.join(allowed)}"
    if error.validator == "type":
        return f"must be of type {error.validator_value}, got {error.instance!r}"
    if error.validator == "enum":
        return f"must be one of {', '.join(repr(x) for x in error.validator_value)}, got {error.instance!r}"
    if error.validator == "required":
        return error.message
    return str(error.message)


def _check(doc: dict[str, Any], text: str, source: str) -> None:
    errors = sorted(_validator().iter_errors(doc), key=lambda e: list(e.absolute_path))
    if errors:
        error = errors[0]
        path = list(error.absolute_path)
        if error.validator == "additionalProperties":
            extra = sorted(set(error.instance) - set(error.schema.get("properties", {})))
            path = path + extra[:1]
        raise SceneError(f"{source}: {_where(path)}{_line(text, path)}: {_message(error)}")


class _Reader:
    """Conversion of a validated document into scene objects, with errors naming key and line."""

    def __init__(self, text: str, source: str) -> None:
        self.text, self.source = text, source

    def fail(self, path: list[Any], msg: str) -> SceneError:
        return SceneError(f"{self.source}: {_where(path)}{_line(self.text, path)}: {msg}")

    def roughness(self, spec: dict[str, Any], path: list[Any]) -> Roughness:
        kind = spec["kind"]
        needs = {"smooth": set(), "sawtooth": {"alpha"}, "cone": {"alpha"}, "gaussian": {"sigma"}}[kind]
        allowed = needs | ({"dim"} if kind == "gaussian" else set()) | {"kind"}
        for key in set(spec) - allowed:
            raise self.fail(path + [key], f"does not apply to a {kind} roughness (keys for it: {', '.join(sorted(allowed))})")
        for key in needs - set(spec):
            raise self.fail(path, f"a {kind} roughness needs {key}")
        try:
            if kind == "smooth":
                return Smooth()
            if kind == "sawtooth":
                return Sawtooth(spec["alpha"])
            if kind == "cone":
                return Cone(spec["alpha"])
            return GaussianSlopes(spec["sigma"], spec.get("dim", 3))
        except ImpactError as exc:
            raise self.fail(path, str(exc)) from exc

    def facet(self, spec: dict[str, Any], e: float | None, path: list[Any]) -> FacetLaw:
        kind = spec["kind"]
        needs = {"newton": set(), "coulomb": {"mu"}, "compliant": {"mu", "stiffness_ratio"},
                 "hunt-crossley": {"alpha"}}[kind]
        allowed = needs | ({"restitution"} if kind == "coulomb" else set()) | {"kind"}
        for key in sorted(set(spec) - allowed):
            raise self.fail(path + [key], f"does not apply to a {kind} facet (keys for it: {', '.join(sorted(allowed))})")
        for key in sorted(needs - set(spec)):
            raise self.fail(path, f"a {kind} facet needs {key}")
        params = {k: v for k, v in spec.items() if k != "kind"}
        if kind != "hunt-crossley":
            params["e"] = e
        try:
            return facet_law(kind, **params)
        except ImpactError as exc:
            raise self.fail(path, str(exc)) from exc

    def law(self, c: dict[str, Any], path: list[Any]) -> ImpactLaw:
        kind = c.get("law", "rough" if "roughness" in c else "newton")
        speed_law = c.get("facet", {}).get("kind") == "hunt-crossley"
        if speed_law and ("e" in c or "k" in c):
            raise self.fail(path + ["e" if "e" in c else "k"], "a hunt-crossley facet has no e or k: its restitution "
                                                                "e(v) ≈ 1 − α v follows from alpha")
        if not speed_law and ("e" in c) == ("k" in c):
            raise self.fail(path + ["e"], "give exactly one of e (restitution) or k (Kelvin–Voigt damping ratio)")
        if "facet" in c and "k" in c:
            raise self.fail(path + ["k"], "a facet law takes e, not k")
        own = {"newton": set(), "rough": {"roughness", "flux", "facet"}, "coulomb": {"mu", "restitution"}}
        for other, keys in own.items():
            if other != kind:
                for key in sorted(keys & set(c)):
                    raise self.fail(path + [key], f"does not apply to law = {kind!r} (it belongs to law = {other!r})")
        restitution = {"e": c["e"]} if "e" in c else {"k": c["k"]} if "k" in c else {}
        try:
            if kind == "newton":
                return NewtonLaw(**restitution)
            if kind == "rough":
                if "roughness" not in c:
                    raise self.fail(path + ["law"], "law = 'rough' needs a roughness table, e.g. "
                                                    "roughness = { kind = \"cone\", alpha = 0.2 }")
                rough = self.roughness(c["roughness"], path + ["roughness"])
                if "facet" in c:
                    facet = self.facet(c["facet"], c.get("e"), path + ["facet"])
                    return RoughLaw(rough, facet=facet, flux=c.get("flux", "physical"), repeat=True)
                return RoughLaw(rough, flux=c.get("flux", "physical"), repeat=True, **restitution)
            if "mu" not in c:
                raise self.fail(path + ["law"], "law = 'coulomb' needs mu, the friction coefficient of the impact")
            return CoulombLaw(mu=c["mu"], restitution=c.get("restitution", "energetic"), **restitution)
        except SceneError:
            raise
        except ImpactError as exc:
            raise self.fail(path, str(exc)) from exc

    def obstacles(self, items: list[dict[str, Any]], base: Path) -> dict[str, Shape]:
        """The [[obstacles]] tables as shapes, by name."""
        out: dict[str, Shape] = {}
        for i, o in enumerate(items):
            path: list[Any] = ["obstacles", i]
            kind = o["shape"]
            for key in sorted(set(o) - SHAPE_KEYS[kind] - {"name", "shape"}):
                raise self.fail(path + [key], f"does not apply to shape = {kind!r} (its keys: "
                                              f"{', '.join(sorted(SHAPE_KEYS[kind]))})")
            for key in sorted(SHAPE_NEEDS[kind] - set(o)):
                raise self.fail(path + ["shape"], f"a {kind} needs {key}")
            if o["name"] in out:
                raise self.fail(path + ["name"], f"obstacle {o['name']!r} is declared twice")
            pose: dict[str, Any] = {}
            if kind != "halfspace":
                import pinocchio as pin

                pose = {"position": np.array(o.get("position", [0.0, 0.0, 0.0])),
                        "rotation": pin.rpy.rpyToMatrix(np.array(o.get("rpy", [0.0, 0.0, 0.0]), dtype=float))}
            try:
                if kind == "halfspace":
                    shape: Shape = HalfSpace(np.array(o.get("normal", [0.0, 0.0, 1.0])), o.get("offset", 0.0),
                                             name=o["name"])
                elif kind == "box":
                    shape = Box(np.array(o["size"]), name=o["name"], **pose)
                elif kind == "sphere":
                    shape = Sphere(o["radius"], name=o["name"], **pose)
                elif kind == "capsule":
                    shape = Capsule(o["radius"], o["length"], name=o["name"], **pose)
                elif kind == "cylinder":
                    shape = Cylinder(o["radius"], o["length"], name=o["name"], **pose)
                else:
                    mesh = Path(o["path"])
                    shape = Mesh(mesh if mesh.is_absolute() else base / mesh, o.get("scale", 1.0), name=o["name"],
                                 **pose)
            except ImpactError as exc:
                raise self.fail(path, str(exc)) from exc
            out[o["name"]] = shape
        return out

    def contact(self, c: dict[str, Any], i: int, mech: Mechanism, obstacles: dict[str, Shape]
                ) -> SceneContact | SceneCollision:
        path: list[Any] = ["contacts", i]
        if ("frame" in c) == ("body" in c):
            raise self.fail(path, "a contact needs exactly one of frame (a point on a surface) or body (a collision "
                                  "object against an obstacle or another object)")
        if "body" in c:
            return self.collision(c, path, mech, obstacles)
        for key in COLLISION_KEYS[1:]:
            if key in c:
                raise self.fail(path + [key], "applies to collision contacts (body = ...) only")
        try:
            mech.frame_id(c["frame"])
        except ImpactError as exc:
            raise self.fail(path + ["frame"], str(exc)) from exc
        kind = c.get("surface", "plane")
        if kind == "paraboloid" and "rho" not in c:
            raise self.fail(path + ["surface"], "a paraboloid needs rho, its radius of curvature on the axis")
        if kind == "plane" and "rho" in c:
            raise self.fail(path + ["rho"], "rho applies to surface = 'paraboloid' only")
        motion = c.get("motion", {})
        try:
            surface = Surface(kind, np.array(c.get("normal", [0.0, 0.0, 1.0])), np.array(c.get("origin", [0.0, 0.0, 0.0])),
                              c.get("rho", math.inf), motion.get("amplitude", 0.0), motion.get("frequency", 0.0),
                              motion.get("phase", 0.0))
            return SceneContact(c["frame"], self.law(c, path), surface, np.array(c.get("point", [0.0, 0.0, 0.0])),
                                c.get("friction", 0.0), np.array(c["tangent"]) if "tangent" in c else None,
                                c.get("stiffness", 1e5))
        except SceneError as exc:
            if str(exc).startswith(self.source):
                raise
            raise self.fail(path, str(exc)) from exc
        except ImpactError as exc:
            raise self.fail(path, str(exc)) from exc

    def collision(self, c: dict[str, Any], path: list[Any], mech: Mechanism, obstacles: dict[str, Shape]
                  ) -> SceneCollision:
        for key in FRAME_KEYS[1:]:
            if key in c:
                raise self.fail(path + [key], "applies to frame contacts (frame = ...) only; a collision contact's "
                                              "surface is its obstacle")
        if ("obstacle" in c) == ("other" in c):
            raise self.fail(path + ["body"], "a collision contact needs exactly one of obstacle (an [[obstacles]] "
                                             "name) or other (a collision object, or \"all\")")
        obstacle = None
        if "obstacle" in c:
            obstacle = obstacles.get(c["obstacle"])
            if obstacle is None:
                close = difflib.get_close_matches(c["obstacle"], list(obstacles), n=1, cutoff=0.6)
                raise self.fail(path + ["obstacle"], f"no obstacle {c['obstacle']!r}" + (
                    f" (did you mean {close[0]!r}?)" if close else "") + (
                    f"; obstacles: {', '.join(obstacles)}" if obstacles else "; declare it in an [[obstacles]] table"))
        body = c["body"] if isinstance(c["body"], str) else tuple(c["body"])
        try:
            out = SceneCollision(body, self.law(c, path), obstacle, c.get("other"), c.get("friction", 0.0),
                                 np.array(c["tangent"]) if "tangent" in c else None, c.get("stiffness", 1e5))
            out.pairs(mech)  # the names exist
            return out
        except SceneError as exc:
            if str(exc).startswith(self.source):
                raise
            raise self.fail(path + ["body"], str(exc)) from exc
        except ImpactError as exc:
            raise self.fail(path + ["body"], str(exc)) from exc


def load_scene(source: str | Path) -> Scene:
    """Read and validate a scene: a shipped name (:func:`mbimpact.scene_names`) or a TOML path.

    Raises
    ------
    SceneError
        Anything wrong with the file; the message names the key and its line.
    """
    path = scene_path(source)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:  # unreadable, or not text (TOML is UTF-8)
        raise SceneError(f"{path.name}: cannot be read as a UTF-8 TOML file: {exc}") from exc
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path.name}: not valid TOML: {exc}") from exc
    _check(doc, text, path.name)
    r = _Reader(text, path.name)
    m = doc["mechanism"]
    sources = [k for k in ("robot", "model", "urdf") if k in m]
    if len(sources) != 1:
        raise r.fail(["mechanism"] + sources[1:2], "give exactly one of robot, model or urdf"
                     + (f" (got {', '.join(sources)})" if sources else ""))
    try:
        if "robot" in m:
            mech = Mechanism.from_robot(m["robot"], m.get("floating"))
        elif "model" in m:
            mech = Mechanism.from_model(m["model"], m.get("floating", False))
        else:
            urdf = Path(m["urdf"])
            mech = Mechanism.from_urdf(urdf if urdf.is_absolute() else path.parent / urdf, m.get("floating", False))
    except ImpactError as exc:
        raise r.fail(["mechanism", sources[0]], str(exc)) from exc
    init = doc.get("initial", {})
    if "q" in init and "posture" in init:
        raise r.fail(["initial", "posture"], "give q or posture, not both")
    q0 = np.array(init["q"], dtype=float) if "q" in init else mech.neutral()
    v0 = np.array(init.get("v", [0.0] * mech.nv), dtype=float)
    for key, vec, size in (("q", q0, mech.nq), ("v", v0, mech.nv)):
        if vec.shape != (size,):
            raise r.fail(["initial", key], f"must have {size} entries for {mech.name}, got {vec.shape[0]}")
    obstacles = r.obstacles(doc.get("obstacles", []), path.parent)
    contacts = tuple(r.contact(c, i, mech, obstacles) for i, c in enumerate(doc["contacts"]))
    forces = doc.get("forces", {})
    torque = forces.get("torque")
    if torque is not None and len(torque) != mech.nv:
        raise r.fail(["forces", "torque"], f"must have {mech.nv} entries, got {len(torque)}")
    pd = None
    if "pd" in forces:
        ref = forces["pd"].get("q", "initial")
        q_ref = q0 if ref == "initial" else mech.neutral() if ref == "neutral" else np.array(ref, dtype=float)
        if q_ref.shape != (mech.nq,):
            raise r.fail(["forces", "pd", "q"], f"must have {mech.nq} entries, got {q_ref.shape[0]}")
        pd = PD(forces["pd"]["kp"], forces["pd"]["kd"], q_ref)
    sim = doc.get("simulation", {})
    try:
        return Scene(
            mech, q0, v0, contacts, gravity=forces.get("gravity", True), damping=forces.get("damping", 0.0),
            torque=None if torque is None else np.array(torque, dtype=float), pd=pd,
            duration=sim.get("duration", 1.0), rest_velocity=sim.get("rest_velocity", 1e-3),
            contact_step=sim.get("contact_step", 1e-3), chatter_time=sim.get("chatter_time"), rtol=sim.get("rtol", 1e-10),
            tolerance=sim.get("tolerance", 1e-8), patch_tolerance=sim.get("patch_tolerance", 1e-6),
            simultaneous=sim.get("simultaneous", "auto"),
            max_impacts=sim.get("max_impacts", 100_000), max_events_per_second=sim.get("max_events_per_second", 1e5),
            max_wall_time=sim.get("max_wall_time", 600.0), samples=sim.get("samples", 256),
            record=tuple(doc.get("record", {}).get("states", ())), name=doc.get("name", path.stem),
        )
    except SceneError as exc:
        where: list[Any] = ["initial"] if "initial" in str(exc) or "inside its surface" in str(exc) else ["simulation"]
        if "contacts[" in str(exc):
            idx = int(str(exc).split("contacts[")[1].split("]")[0])
            where = ["contacts", idx]
        elif "record" in str(exc):
            where = ["record", "states"]
        elif str(exc).startswith("damping"):  # its range is checked by Scene (DAMPING_MAX)
            where = ["forces", "damping"]
        raise r.fail(where, str(exc)) from exc
    except ImpactError as exc:
        raise r.fail(["scene"], str(exc)) from exc


def reference() -> str:
    """The complete scene-file reference, generated from :data:`SCHEMA` (``mbimpact scene --help``)."""
    out = ["Scene files are TOML. Every key is checked: unknown keys, wrong types, NaN or infinite numbers,",
           "values out of range and contradictory keys are errors naming the key and its line.",
           "A contact point may not start inside its surface (deeper than [simulation] tolerance).",
           "A contact is either a frame's point on a surface (frame = ...) or a collision object of the",
           "mechanism (body = ..., its <collision> geometry) against an [[obstacles]] shape or another object.", ""]

    def describe(schema: dict[str, Any]) -> str:
        bits = [schema.get("description", "")]
        if "enum" in schema:
            bits.append("one of " + " | ".join(repr(x) for x in schema["enum"]))
        elif "type" in schema:
            bits.append(f"({schema['type']})")
        if "default" in schema:
            bits.append(f"default {schema['default']!r}")
        return "; ".join(b for b in bits if b)

    def table(name: str, schema: dict[str, Any], array: bool = False) -> None:
        out.append(f"[[{name}]]" if array else f"[{name}]" + f"   {schema.get('description', '')}")
        if array:
            out[-1] += f"   {schema.get('description', '')}"
        for key, sub in schema["properties"].items():
            if sub.get("type") == "object":
                out.append(f"  {key} = {{ ... }}   {sub.get('description', '')}")
                for k2, s2 in sub["properties"].items():
                    out.append(f"      {k2:<12} {describe(s2)}")
            else:
                out.append(f"  {key:<16} {describe(sub)}")
        out.append("")

    out.append(f"name               {describe(SCHEMA['properties']['name'])}")
    out.append("")
    for name, schema in SCHEMA["properties"].items():
        if name == "name":
            continue
        if name in ("contacts", "obstacles"):
            table(name, schema["items"], array=True)
        else:
            table(name, schema)
    out.append("Contradictions that are errors: more than one of robot/model/urdf; q with posture; e with k;")
    out.append("a roughness or flux with law = \"newton\" or \"coulomb\"; mu or restitution without law = \"coulomb\";")
    out.append("law = \"rough\" without a roughness; rho on a plane; a paraboloid without rho; frame with body;")
    out.append("a facet with law other than \"rough\"; e or k with a hunt-crossley facet; k with a facet;")
    out.append("surface keys (point, surface, normal, origin, rho, motion) on a body contact; obstacle with other;")
    out.append("an obstacle key its shape does not take.")
    return "\n".join(out)

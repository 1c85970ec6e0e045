"""The scene file format: a strict schema and its reference text (the reader: :mod:`.scene_file`).

A scene file is TOML. Every key is checked against :data:`SCHEMA` (a JSON Schema, validated
with ``jsonschema``): unknown or misspelled keys, wrong types, NaN or infinite numbers,
out-of-range values and contradictory keys are :class:`mbimpact.SceneError` s that name
the key and its line. :func:`reference` prints the schema (``mbimpact scene --help``).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterator
from typing import Any

from ..errors import SceneError
from .scene import DAMPING_MAX, SIMULTANEOUS_RULES

__all__ = ["SCHEMA", "check", "scene_error", "reference"]


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
    # the bounds are checked by Cone and Sawtooth, whose message gives the open one, π/2
    "alpha": _num("facet tilt [rad] (sawtooth, cone), 0 ≤ α < π/2"),
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


def scene_error(source: str, text: str, path: list[Any], message: str) -> SceneError:
    """A :class:`~mbimpact.SceneError` naming the file, the key at ``path`` (such as
    ``['contacts', 2, 'law']``) and its line in ``text``."""
    return SceneError(f"{source}: {_where(path)}{_line(text, path)}: {message}")


def check(doc: dict[str, Any], text: str, source: str) -> None:
    """Validate a parsed scene file against :data:`SCHEMA`; the first error found is raised.

    Raises
    ------
    SceneError
        The first key that is wrong, with its line and what is valid there.
    """
    errors = sorted(_validator().iter_errors(doc), key=lambda e: list(e.absolute_path))
    if errors:
        error = errors[0]
        path = list(error.absolute_path)
        if error.validator == "additionalProperties":
            extra = sorted(set(error.instance) - set(error.schema.get("properties", {})))
            path = path + extra[:1]
        raise scene_error(source, text, path, _message(error))


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

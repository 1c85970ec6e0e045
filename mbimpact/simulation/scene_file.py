"""Reading a scene file: a validated TOML document (:mod:`.schema`) turned into a :class:`Scene`."""

from __future__ import annotations

import difflib
import math
import tomllib
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
from .scene import PD, Scene, scene_path
from .scene_contacts import SceneCollision, SceneContact
from .schema import COLLISION_KEYS, FRAME_KEYS, SHAPE_KEYS, SHAPE_NEEDS, check, scene_error
from .surfaces import Surface

__all__ = ["load_scene", "law_from_keys", "surface_from_keys", "obstacles_from_keys"]


class _Reader:
    """Conversion of a validated document into scene objects, with errors naming key and line."""

    def __init__(self, text: str, source: str) -> None:
        self.text, self.source = text, source

    def fail(self, path: list[Any], msg: str) -> SceneError:
        return scene_error(self.source, self.text, path, msg)

    def roughness(self, spec: dict[str, Any] | Roughness, path: list[Any]) -> Roughness:
        if isinstance(spec, Roughness):  # a scene built in Python may give the measure itself
            return spec
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

    def facet(self, spec: dict[str, Any] | FacetLaw, e: float | None, path: list[Any]) -> FacetLaw:
        if isinstance(spec, FacetLaw):
            return spec
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
        facet = c.get("facet", {})
        if isinstance(facet, FacetLaw) and ("e" in c or "k" in c):
            raise self.fail(path + ["e" if "e" in c else "k"], "a facet law given as an object carries its own "
                                                                "restitution: give no e or k with it")
        speed_law = isinstance(facet, FacetLaw) or facet.get("kind") == "hunt-crossley"
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

    def surface(self, c: dict[str, Any], path: list[Any]) -> Surface:
        """The surface of a frame contact from its keys surface, normal, origin, rho and motion."""
        kind = c.get("surface", "plane")
        if kind == "paraboloid" and "rho" not in c:
            raise self.fail(path + ["surface"], "a paraboloid needs rho, its radius of curvature on the axis")
        if kind == "plane" and "rho" in c:
            raise self.fail(path + ["rho"], "rho applies to surface = 'paraboloid' only")
        motion = c.get("motion", {})
        if not isinstance(motion, dict) or set(motion) - {"amplitude", "frequency", "phase"}:
            raise self.fail(path + ["motion"], "motion is a table of amplitude, frequency and phase")
        try:
            return Surface(kind, np.array(c.get("normal", [0.0, 0.0, 1.0])), np.array(c.get("origin", [0.0, 0.0, 0.0])),
                           c.get("rho", math.inf), motion.get("amplitude", 0.0), motion.get("frequency", 0.0),
                           motion.get("phase", 0.0))
        except ImpactError as exc:
            raise self.fail(path, str(exc)) from exc

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
        try:
            surface = self.surface(c, path)
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


def law_from_keys(keys: dict[str, Any], where: str) -> ImpactLaw:
    """The impact law of a contact from its scene-file keys (law, e, k, roughness, flux, facet, mu,
    restitution); ``roughness`` and ``facet`` may be tables or objects. A :class:`SceneError` prefixed by
    ``where`` names a key that is wrong."""
    return _Reader("", where).law(keys, [])


def surface_from_keys(keys: dict[str, Any], where: str) -> Surface:
    """The surface of a frame contact from its scene-file keys (surface, normal, origin, rho, motion)."""
    return _Reader("", where).surface(keys, [])


def obstacles_from_keys(items: list[dict[str, Any]], where: str, base: Path) -> dict[str, Shape]:
    """[[obstacles]] tables as shapes by name (mesh paths relative to ``base``)."""
    return _Reader("", where).obstacles(items, base)


def load_scene(source: str | Path) -> Scene:
    """Read and validate a scene: the path of a scene file (TOML, whatever its suffix) or a shipped name
    (:func:`mbimpact.scene_names`).

    Raises
    ------
    SceneError
        No such file or shipped scene (the message suggests close names); a file that is not TOML; anything
        wrong in the file (the message names the key and its line).
    """
    path = scene_path(source)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:  # unreadable, or not text (TOML is UTF-8)
        raise SceneError(f"{path.name}: cannot be read as a UTF-8 TOML file: {exc}") from exc
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path.name}: not a valid TOML scene file: {exc}") from exc
    check(doc, text, path.name)
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

"""Scenes: a mechanism, its contacts and surfaces, the forces present, what to record.

A scene is a TOML file or the equivalent :class:`Scene` object. Only what a scene
declares is simulated (:mod:`mbimpact.simulate`): no roughness means the Newton
path, no gravity means no gravity terms, a fixed surface means no surface motion.

TOML layout (every table but ``mechanism`` and ``[[contacts]]`` optional)::

    [mechanism]   robot = "ur5" | model = "point_mass_3d" | urdf = "path.urdf"; floating = false
    [initial]     q = [...] | posture = "neutral"; v = [...]
    [[contacts]]  frame = "mass"; point = [0, 0, 0]
                  surface = "plane" | "paraboloid"; normal = [0, 0, 1]; origin = [0, 0, 0]; rho = 1.0
                  law = "newton" | "rough" | "coulomb"; e = 0.8 | k = 0.07; mu = 0.3
                  roughness = { kind = "cone", alpha = 0.2 }   # smooth, sawtooth, cone, gaussian
                  motion = { amplitude = 0.01, frequency = 5.0, phase = 0.0 }   # along the normal
                  M = 1e5   # stiffness used when contacts strike together
                  rest = "slide" | "stick"   # resting contact: frictionless, or the point pinned
    [forces]      gravity = true; damping = 0.0; torque = [...]
    [simulation]  duration = 1.0; rest_velocity = 1e-3; max_impacts = 10000; rtol = 1e-9
    [record]      states = ["q2", "v2"]
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..laws.coulomb import CoulombLaw
from ..errors import ImpactError, SceneError
from ..laws.base import ImpactLaw
from ..laws.newton import NewtonLaw
from ..mechanism.mechanism import Mechanism
from ..laws.rough import RoughLaw
from ..roughness import Cone, Roughness, Sawtooth, Smooth
from ..roughness.slopes import GaussianSlopes

__all__ = ["SceneError", "Surface", "SceneContact", "Scene", "load_scene", "scene_names", "scene_path"]


@dataclass(frozen=True, eq=False)
class Surface:
    """A plane or a paraboloid of revolution, fixed or moving harmonically along its axis.

    The gap is f(p, t) = n·(p − o) − a(t) for a plane and
    f = n·(p − o) − |p_t|² / (2ρ) − a(t) for a paraboloid (p_t: the part of p − o
    across n), with a(t) = amplitude · sin(2π frequency t + phase).
    """

    kind: str = "plane"
    normal: NDArray[np.float64] = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    origin: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    rho: float = math.inf
    amplitude: float = 0.0
    frequency: float = 0.0
    phase: float = 0.0

    @property
    def moving(self) -> bool:
        return self.amplitude != 0.0 and self.frequency != 0.0

    def offset(self, t: float) -> tuple[float, float]:
        """Displacement a(t) and velocity ȧ(t) of the surface along its normal."""
        w = 2 * math.pi * self.frequency
        return self.amplitude * math.sin(w * t + self.phase), self.amplitude * w * math.cos(w * t + self.phase)

    def gap(self, p: NDArray[np.float64], a: float) -> tuple[float, NDArray[np.float64]]:
        """Gap f and its unit gradient (the local normal) at point p, surface offset a."""
        d = p - self.origin
        h = float(self.normal @ d)
        if self.kind == "plane":
            return h - a, self.normal
        lateral = d - h * self.normal
        grad = self.normal - lateral / self.rho
        return h - float(lateral @ lateral) / (2 * self.rho) - a, grad / np.linalg.norm(grad)


@dataclass(frozen=True, eq=False)
class SceneContact:
    """A point of the mechanism, its surface and its impact law."""

    frame: str
    law: ImpactLaw
    surface: Surface = field(default_factory=Surface)
    point: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    M: float = 1e5
    rest: str = "slide"  # resting contact: "slide" (normal constraint) or "stick" (point pinned)


@dataclass(frozen=True, eq=False)
class Scene:
    """Everything a simulation needs, and nothing it does not declare."""

    mechanism: Mechanism
    q0: NDArray[np.float64]
    v0: NDArray[np.float64]
    contacts: tuple[SceneContact, ...]
    gravity: bool = True
    damping: float = 0.0
    torque: NDArray[np.float64] | None = None
    duration: float = 1.0
    rest_velocity: float = 1e-3
    max_impacts: int = 10_000
    rtol: float = 1e-9
    record: tuple[str, ...] = ()
    name: str = "scene"

    def __post_init__(self) -> None:
        mech = self.mechanism
        if self.q0.shape != (mech.nq,) or self.v0.shape != (mech.nv,):
            raise SceneError(f"initial q and v must have {mech.nq} and {mech.nv} entries")
        for c in self.contacts:
            mech.frame_id(c.frame)
        for name in self.record:
            kind, idx = name[:1], name[1:]
            size = mech.nq if kind == "q" else mech.nv
            if kind not in "qv" or not idx.isdigit() or int(idx) >= size:
                raise SceneError(f"record entry {name!r}: use q0…q{mech.nq - 1} or v0…v{mech.nv - 1}")


def scene_names() -> list[str]:
    """Scenes shipped under ``models/scenes``."""
    from ..mechanism.robots import models_dir

    return sorted(p.stem for p in (models_dir() / "scenes").glob("*.toml"))


def scene_path(name: str) -> Path:
    """A shipped scene by name, or a path to a TOML file."""
    from ..mechanism.robots import models_dir

    p = Path(name)
    if p.suffix == ".toml" and p.is_file():
        return p
    shipped = models_dir() / "scenes" / f"{name}.toml"
    if shipped.is_file():
        return shipped
    raise SceneError(f"scene {name!r} not found; shipped scenes: {', '.join(scene_names())}")


class _Reader:
    """Typed access to a TOML table with errors that name the key and its line."""

    def __init__(self, text: str, source: str) -> None:
        self.lines = text.splitlines()
        self.source = source

    def line_of(self, key: str) -> str:
        leaf = key.split(".")[-1].split("[")[0]
        for i, line in enumerate(self.lines, 1):
            stripped = line.strip()
            if stripped.startswith(leaf) and stripped[len(leaf):].lstrip().startswith("=") or f"[{leaf}]" in stripped:
                return f" (line {i})"
        return ""

    def fail(self, key: str, msg: str) -> SceneError:
        return SceneError(f"{self.source}: {key}{self.line_of(key)}: {msg}")

    def number(self, table: dict, key: str, path: str, default: float | None = None, lo: float = -math.inf) -> float:
        val = table.get(key, default)
        if val is None:
            raise self.fail(f"{path}.{key}", "missing (a number is required)")
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val) or val < lo:
            raise self.fail(f"{path}.{key}", f"must be a finite number ≥ {lo:g}, got {val!r}")
        return float(val)

    def vector(self, table: dict, key: str, path: str, size: int | None, default: list[float]) -> NDArray[np.float64]:
        vec = self.optional_vector(table, key, path, size)
        return np.array(default, dtype=float) if vec is None else vec

    def optional_vector(self, table: dict, key: str, path: str, size: int | None) -> NDArray[np.float64] | None:
        val = table.get(key)
        if val is None:
            return None
        if not isinstance(val, list) or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in val):
            raise self.fail(f"{path}.{key}", f"must be a list of numbers, got {val!r}")
        if size is not None and len(val) != size:
            raise self.fail(f"{path}.{key}", f"must have {size} entries, got {len(val)}")
        return np.array(val, dtype=float)


def _roughness(r: _Reader, spec: Any, path: str) -> Roughness:
    if not isinstance(spec, dict) or "kind" not in spec:
        raise r.fail(path, "must be a table with a 'kind': smooth, sawtooth, cone or gaussian")
    kind = spec["kind"]
    try:
        if kind == "smooth":
            return Smooth()
        if kind == "sawtooth":
            return Sawtooth(r.number(spec, "alpha", path))
        if kind == "cone":
            return Cone(r.number(spec, "alpha", path))
        if kind == "gaussian":
            return GaussianSlopes(r.number(spec, "sigma", path), int(spec.get("dim", 3)))
    except ImpactError as exc:
        raise r.fail(path, str(exc)) from exc
    raise r.fail(f"{path}.kind", f"unknown roughness {kind!r}; valid: smooth, sawtooth, cone, gaussian")


def _law(r: _Reader, c: dict, path: str) -> ImpactLaw:
    kind = c.get("law", "rough" if "roughness" in c else "newton")
    if ("e" in c) == ("k" in c):
        raise r.fail(f"{path}.e", "give exactly one of e (restitution) or k (damping ratio)")
    rest = {"e": r.number(c, "e", path)} if "e" in c else {"k": r.number(c, "k", path)}
    try:
        if kind == "newton":
            return NewtonLaw(e=rest.get("e"), k=rest.get("k"))
        if kind == "rough":
            rough = _roughness(r, c.get("roughness", {"kind": "smooth"}), f"{path}.roughness")
            return RoughLaw(rough, e=rest.get("e"), k=rest.get("k"))
        if kind == "coulomb":
            return CoulombLaw(mu=r.number(c, "mu", path), restitution=c.get("restitution", "energetic"),
                              e=rest.get("e"), k=rest.get("k"))
    except ImpactError as exc:
        raise r.fail(path, str(exc)) from exc
    raise r.fail(f"{path}.law", f"unknown law {kind!r}; valid: newton, rough, coulomb")


def load_scene(source: str | Path) -> Scene:
    """Read and validate a scene (a shipped name or a TOML path)."""
    path = scene_path(str(source))
    text = path.read_text()
    r = _Reader(text, path.name)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path.name}: not valid TOML: {exc}") from exc
    known = {"name", "mechanism", "initial", "contacts", "forces", "simulation", "record"}
    for key in doc:
        if key not in known:
            raise r.fail(key, f"unknown table; valid: {', '.join(sorted(known))}")
    mtab = doc.get("mechanism")
    if not isinstance(mtab, dict):
        raise r.fail("mechanism", "missing [mechanism] table (robot, model or urdf)")
    floating = bool(mtab.get("floating", False))
    try:
        if "robot" in mtab:
            mech = Mechanism.from_robot(mtab["robot"], mtab.get("floating"))
        elif "model" in mtab:
            mech = Mechanism.from_model(mtab["model"], floating)
        elif "urdf" in mtab:
            urdf = Path(mtab["urdf"])
            mech = Mechanism.from_urdf(urdf if urdf.is_absolute() else path.parent / urdf, floating)
        else:
            raise r.fail("mechanism", "give one of robot, model or urdf")
    except SceneError:
        raise
    except ImpactError as exc:
        raise r.fail("mechanism", str(exc)) from exc
    init = doc.get("initial", {})
    q0 = r.optional_vector(init, "q", "initial", mech.nq)
    if q0 is None:
        posture = init.get("posture", "neutral")
        if posture != "neutral":
            raise r.fail("initial.posture", f"unknown posture {posture!r}; valid: neutral (or give q)")
        q0 = mech.neutral()
    v0 = r.vector(init, "v", "initial", mech.nv, [0.0] * mech.nv)
    contacts = []
    ctabs = doc.get("contacts", [])
    if not isinstance(ctabs, list) or not ctabs:
        raise r.fail("contacts", "at least one [[contacts]] table is needed")
    for i, c in enumerate(ctabs):
        p = f"contacts[{i}]"
        if "frame" not in c:
            raise r.fail(p, "missing frame")
        kind = c.get("surface", "plane")
        if kind not in ("plane", "paraboloid"):
            raise r.fail(f"{p}.surface", f"unknown surface {kind!r}; valid: plane, paraboloid")
        normal = r.vector(c, "normal", p, 3, [0.0, 0.0, 1.0])
        if np.linalg.norm(normal) == 0:
            raise r.fail(f"{p}.normal", "is the zero vector")
        motion = c.get("motion", {})
        surface = Surface(
            kind, normal / np.linalg.norm(normal), r.vector(c, "origin", p, 3, [0.0, 0.0, 0.0]),
            r.number(c, "rho", p) if kind == "paraboloid" else math.inf,
            r.number(motion, "amplitude", f"{p}.motion", 0.0), r.number(motion, "frequency", f"{p}.motion", 0.0, lo=0.0),
            r.number(motion, "phase", f"{p}.motion", 0.0),
        )
        if kind == "paraboloid" and not surface.rho > 0:
            raise r.fail(f"{p}.rho", "must be > 0")
        rest = c.get("rest", "slide")
        if rest not in ("slide", "stick"):
            raise r.fail(f"{p}.rest", f"unknown resting mode {rest!r}; valid: slide, stick")
        contacts.append(SceneContact(c["frame"], _law(r, c, p), surface, r.vector(c, "point", p, 3, [0.0, 0.0, 0.0]),
                                     r.number(c, "M", p, 1e5, lo=1e-300), rest))
    forces = doc.get("forces", {})
    sim = doc.get("simulation", {})
    rec = doc.get("record", {}).get("states", [])
    try:
        return Scene(
            mech, q0, v0, tuple(contacts), bool(forces.get("gravity", True)), r.number(forces, "damping", "forces", 0.0, 0.0),
            r.optional_vector(forces, "torque", "forces", mech.nv), r.number(sim, "duration", "simulation", 1.0, 0.0),
            r.number(sim, "rest_velocity", "simulation", 1e-3, 0.0), int(r.number(sim, "max_impacts", "simulation", 10_000, 1)),
            r.number(sim, "rtol", "simulation", 1e-9, 1e-14), tuple(rec), str(doc.get("name", path.stem)),
        )
    except SceneError as exc:
        raise r.fail("initial" if "initial" in str(exc) else "record", str(exc)) from exc
    except ImpactError as exc:
        raise r.fail("contacts", str(exc)) from exc

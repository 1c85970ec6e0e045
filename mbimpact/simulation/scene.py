"""Scenes: a mechanism, its contacts and surfaces, the forces present, what to record.

A scene is a :class:`Scene` object or a TOML file (:func:`mbimpact.load_scene`, schema in
:mod:`mbimpact.simulation.schema`). Only what a scene declares is simulated
(:func:`mbimpact.simulate`): no roughness means the Newton path, no gravity means no
gravity terms, a fixed surface means no surface motion, no friction means no friction
cone in persistent contact, frame contacts mean no collision detection.

Two kinds of contacts:

* :class:`SceneContact` — a point fixed to a frame, striking a declared surface (plane,
  paraboloid, moving or not);
* :class:`SceneCollision` — a collision object of the mechanism (its URDF ``<collision>``
  geometry) striking an obstacle shape or another of its collision objects: the gap is
  coal's signed distance, the contact points are the witness points (whole contact patches
  when a face or an edge lands), and they move over the body as it rolls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..common.validation import as_array, as_count, as_scalar
from ..errors import ImpactError, SceneError
from ..mechanism.mechanism import Mechanism
from .scene_contacts import SceneCollision, SceneContact, collision_gap
from .scene_keys import accepts_file_keys, pd_keys, scene_keys
from .surfaces import scene_errors

__all__ = ["Scene", "PD", "scene_names", "scene_path", "SIMULTANEOUS_RULES"]

#: Largest joint damping [N s/m, N m s/rad]. Beyond it a joint with an inertia ≥ 1e-3 (kg, kg m²)
#: stops within a nanosecond: a locked joint, to be modelled as fixed (near 1e308, −damping·v
#: overflows). Up to it the stiffness of the damping is integrated implicitly (Radau in flight,
#: :mod:`~mbimpact.simulation.flight`; the persistent-contact step, :mod:`~mbimpact.simulation.persistent`).
DAMPING_MAX = 1e6

#: Rules for contacts that strike together (:mod:`mbimpact.simulation.multi`).
SIMULTANEOUS_RULES = ("auto", "newton", "rough", "compliant", "sequential")


@accepts_file_keys(pd_keys)
@dataclass(frozen=True, eq=False)
class PD:
    """Joint-space PD torques τ = kp (q_ref − q) − kd v on the actuated joints (a declared force).

    ``q_ref`` (the scene file's ``q``) has the mechanism's nq entries; on a floating base the free-flyer
    part is ignored.
    """

    kp: float
    kd: float
    q_ref: NDArray[np.float64]

    def __post_init__(self) -> None:
        with scene_errors("pd: "):
            self._validate()

    def _validate(self) -> None:
        object.__setattr__(self, "kp", as_scalar("kp", self.kp, 0.0, math.inf))
        object.__setattr__(self, "kd", as_scalar("kd", self.kd, 0.0, math.inf))
        object.__setattr__(self, "q_ref", as_array("q_ref", self.q_ref, 1))


@accepts_file_keys(scene_keys)
@dataclass(frozen=True, eq=False)
class Scene:
    """Everything a simulation needs, and nothing it does not declare.

    Besides its fields, a Scene takes the keys of a scene file (:mod:`.scene_keys`): ``q``, ``v`` and
    ``posture`` (default: neutral, at rest), the keys of ``[forces]`` and ``[simulation]``, ``states``, those
    tables as dicts, ``mechanism`` as the ``[mechanism]`` table, ``contacts`` as ``[[contacts]]`` tables
    (with ``obstacles``).

    Parameters
    ----------
    mechanism : Mechanism
    q0, v0 : ndarray, shapes (nq,), (nv,)
        Initial state; no contact point may start inside its surface (deeper than ``tolerance``).
    contacts : tuple of SceneContact or SceneCollision
        Collision contacts are expanded to one per pair (see :class:`SceneCollision`).
    gravity : bool
    damping : float
        Joint damping τ = −damping · v, 0 ≤ damping ≤ :data:`DAMPING_MAX`. A stiff damping (fast decay
        against the mass matrix) is integrated implicitly.
    torque : ndarray, shape (nv,), optional
        Constant joint torques.
    pd : PD, optional
        Joint PD torques.
    duration : float
        Simulated time [s].
    rest_velocity : float
        A contact whose rebound is slower than this [m/s] comes to rest (becomes persistent),
        after the geometric tail of its accumulating bounces (Zeno).
    contact_step : float
        Time step [s] of the persistent-contact phases (velocity-level, first order).
    chatter_time : float, optional
        A contact that strikes again sooner than this after its last impact [s] becomes
        persistent: its micro-impacts are below what the scene resolves (a foot sliding over
        a rough surface, which the law throws up at grazing incidence again and again).
        Default ten contact steps.
    rtol : float
        Relative tolerance of the free-flight integration (DOP853).
    tolerance : float
        Penetration tolerated [m]: gaps are never reported below −tolerance. Above its surface a
        contact touches it up to min(tolerance, 1e-8 m) (:data:`~mbimpact.simulation.run.BAND_MAX`):
        a large tolerance loosens the guarantee, not where contacts rest, strike and lift off.
    patch_tolerance : float
        Witness points of a collision pair within this distance [m] of its nearest point strike
        or rest together (a face landing flat strikes at its corners at once).
    simultaneous : {"auto", "newton", "rough", "compliant", "sequential"}
        Rule for contacts that strike together (:mod:`mbimpact.simulation.multi`).
    max_impacts : int
        Impacts after which the run stops (status ``"max_impacts"``).
    max_events_per_second : float
        Impacts and contact switches per simulated second beyond which the run stops
        (status ``"event_limit"``).
    max_wall_time : float
        Wall-clock seconds after which the run stops (status ``"wall_time"``).
    samples : int
        Facet realisations of the "rough" rule for contacts striking together.
    record : tuple of str
        States to plot, ``"q3"``, ``"v0"``…
    name : str
    """

    mechanism: Mechanism
    q0: NDArray[np.float64]
    v0: NDArray[np.float64]
    contacts: tuple[SceneContact | SceneCollision, ...]
    gravity: bool = True
    damping: float = 0.0
    torque: NDArray[np.float64] | None = None
    pd: PD | None = None
    duration: float = 1.0
    rest_velocity: float = 1e-3
    contact_step: float = 1e-3
    chatter_time: float | None = None
    rtol: float = 1e-10
    tolerance: float = 1e-8
    patch_tolerance: float = 1e-6
    simultaneous: Literal["auto", "newton", "rough", "compliant", "sequential"] = "auto"
    max_impacts: int = 100_000
    max_events_per_second: float = 1e5
    max_wall_time: float = 600.0
    samples: int = 256
    record: tuple[str, ...] = ()
    name: str = "scene"

    def __post_init__(self) -> None:
        with scene_errors():
            self._validate()

    def _validate(self) -> None:
        mech = self.mechanism
        if not isinstance(mech, Mechanism):
            raise SceneError(f"mechanism must be an mbimpact.Mechanism, got {type(mech).__name__}")
        try:
            q0, v0 = mech.check_state(self.q0, self.v0)
        except ImpactError as exc:
            raise SceneError(f"initial state: {exc}") from exc
        object.__setattr__(self, "q0", q0.copy())
        object.__setattr__(self, "v0", v0.copy())
        contacts = self._contact_tuple()
        if not contacts:
            raise SceneError("a scene needs at least one contact")
        expanded: list[SceneContact | SceneCollision] = []
        for i, c in enumerate(contacts):
            if isinstance(c, SceneContact):
                with scene_errors(f"contacts[{i}] ({c.label}): "):
                    mech.frame_id(c.frame)
                expanded.append(c)
            elif isinstance(c, SceneCollision):
                try:
                    expanded += c.pairs(mech)
                except ImpactError as exc:
                    raise SceneError(f"contacts[{i}] ({c.label}): {exc}") from exc
            else:
                raise SceneError(f"contacts[{i}] must be a SceneContact or a SceneCollision, got {type(c).__name__}")
        seen: dict[tuple[str, int | str], int] = {}
        for i, c in enumerate(expanded):
            if isinstance(c, SceneCollision):
                key = (str(c.body), id(c.obstacle) if c.obstacle is not None else str(c.other))
                twin = seen.get(key, seen.get((str(c.other), str(c.body))))
                if twin is not None:
                    raise SceneError(f"the pair {c.label} is declared twice (contacts {twin} and {i} after expansion)")
                seen[key] = i
        contacts = tuple(expanded)
        object.__setattr__(self, "contacts", contacts)
        if not isinstance(self.gravity, (bool, np.bool_)):
            raise SceneError(f"gravity must be true or false, got {self.gravity!r}")
        object.__setattr__(self, "gravity", bool(self.gravity))
        damping = as_scalar("damping", self.damping, -math.inf, math.inf)  # a finite real number
        if not 0.0 <= damping <= DAMPING_MAX:
            raise SceneError(f"damping = {damping:g} is outside [0, {DAMPING_MAX:g}]" + (
                ": a larger damping stops a joint within nanoseconds (model a locked joint as fixed instead)"
                if damping > 0.0 else ""))
        object.__setattr__(self, "damping", damping)
        if self.torque is not None:
            object.__setattr__(self, "torque", as_array("torque", self.torque, 1, (mech.nv,)))
        if self.pd is not None:
            if not isinstance(self.pd, PD):
                raise SceneError(f"pd must be a PD, got {type(self.pd).__name__}")
            if self.pd.q_ref.shape != (mech.nq,):
                raise SceneError(f"pd.q_ref must have {mech.nq} entries, got {self.pd.q_ref.shape[0]}")
        for name, lo, lo_open in (("duration", 0.0, True), ("rest_velocity", 0.0, False), ("contact_step", 0.0, True),
                                  ("tolerance", 0.0, True), ("patch_tolerance", 0.0, True),
                                  ("max_events_per_second", 0.0, True),
                                  ("max_wall_time", 0.0, True)):
            object.__setattr__(self, name, as_scalar(name, getattr(self, name), lo, math.inf, lo_open=lo_open))
        object.__setattr__(self, "rtol", as_scalar("rtol", self.rtol, 1e-14, 1e-3))
        chatter = 10.0 * self.contact_step if self.chatter_time is None else self.chatter_time
        object.__setattr__(self, "chatter_time", as_scalar("chatter_time", chatter, 0.0, math.inf))
        object.__setattr__(self, "max_impacts", as_count("max_impacts", self.max_impacts, 1, 10**9))
        object.__setattr__(self, "samples", as_count("samples", self.samples, 2, 10**6))
        # a str first: `in` on an array compares elementwise, and its truth value is ambiguous
        if not isinstance(self.simultaneous, str) or self.simultaneous not in SIMULTANEOUS_RULES:
            raise SceneError(f"simultaneous must be one of {', '.join(SIMULTANEOUS_RULES)}; got {self.simultaneous!r}")
        object.__setattr__(self, "record", self._record_tuple())
        if not isinstance(self.name, str):
            raise SceneError(f"name must be a string, got {type(self.name).__name__}")
        self._check_start()

    def _contact_tuple(self) -> tuple[object, ...]:
        """``contacts`` as a tuple (its entries are checked by the caller)."""
        contacts = self.contacts
        if isinstance(contacts, (SceneContact, SceneCollision)):
            raise SceneError("contacts must be a list or tuple of SceneContact or SceneCollision; for one contact "
                             "write (contact,)")
        if isinstance(contacts, (str, bytes)):
            raise SceneError(f"contacts must be a list or tuple of SceneContact or SceneCollision, got {contacts!r}")
        try:
            return tuple(contacts)
        except TypeError:  # not iterable: None, a number, ...
            raise SceneError(f"contacts must be a list or tuple of SceneContact or SceneCollision, got "
                             f"{type(contacts).__name__}") from None

    def _record_tuple(self) -> tuple[str, ...]:
        """``record`` checked: a sequence of state names ``"q<i>"``, ``"v<i>"`` within the mechanism."""
        mech = self.mechanism
        valid = f"use q0…q{mech.nq - 1} or v0…v{mech.nv - 1}"
        record = self.record
        if isinstance(record, (str, bytes)) or not isinstance(record, (list, tuple, np.ndarray)):
            raise SceneError(f"record must be a list or tuple of state names such as ['q0', 'v0'] ({valid}); "
                             f"got {record!r}")
        if isinstance(record, np.ndarray) and record.ndim != 1:
            raise SceneError(f"record must be a flat list of state names ({valid}); got an array of shape "
                             f"{record.shape}")
        out = []
        for name in record:
            if not isinstance(name, str):  # np.str_ is a str
                raise SceneError(f"record entry {name!r} is not a state name: {valid}")
            kind, idx = name[:1], name[1:]
            size = mech.nq if kind == "q" else mech.nv
            # ASCII digits only: int() also reads other scripts' digits, and isdigit() accepts '²'
            if kind not in ("q", "v") or not (idx.isascii() and idx.isdigit()) or int(idx) >= size:
                raise SceneError(f"record entry {name!r}: {valid}")
            out.append(str(name))
        return tuple(out)

    def _check_start(self) -> None:
        """A start inside a surface is an error (rule documented in the schema)."""
        mech = self.mechanism
        for i, c in enumerate(self.contacts):
            if isinstance(c, SceneContact):
                f = c.surface.gap(mech.frame_position(self.q0, c.frame, c.point), 0.0)
                what = "its surface"
            else:
                f = collision_gap(mech, c, self.q0)
                what = "what it strikes"
            if f < -self.tolerance:
                raise SceneError(
                    f"contacts[{i}] ({c.label}) starts {-f:.3g} m inside {what}; start every contact "
                    f"outside or on it (gap ≥ −tolerance = {-self.tolerance:g} m)"
                )


def scene_names() -> list[str]:
    """Scenes shipped under ``models/scenes``."""
    from ..mechanism.robots import models_dir

    return sorted(p.stem for p in (models_dir() / "scenes").glob("*.toml"))


def scene_path(name: str | Path) -> Path:
    """A scene file: an existing file at ``name`` (whatever its suffix), else a shipped scene by name.

    Raises
    ------
    SceneError
        Neither: the message suggests the shipped scenes whose names are close to ``name``.
    """
    import difflib

    from ..mechanism.robots import models_dir

    if not isinstance(name, (str, Path)):  # Path() raises TypeError on None, numbers, ...
        raise SceneError(f"a scene is a shipped scene's name ({', '.join(scene_names())}) or the path of a TOML "
                         f"file, got {type(name).__name__}")
    p = Path(name)
    if _is_file(p):
        return p
    shipped = models_dir() / "scenes" / f"{name}.toml"
    if p.name == str(name) and _is_file(shipped):
        return shipped
    names = scene_names()
    bare = p.name == str(name)  # a name, not a path into a directory: it may be a shipped scene's, mistyped
    close = difflib.get_close_matches(p.stem if p.suffix == ".toml" else p.name, names, n=3, cutoff=0.6) if bare else []
    hint = f"did you mean {' or '.join(repr(c) for c in close)}? " if close else ""
    raise SceneError(f"scene {str(name)!r} not found: no such file, and no shipped scene of that name; {hint}"
                     f"shipped scenes: {', '.join(names)}")


def _is_file(p: Path) -> bool:
    """``p.is_file()``, False where the OS cannot even look (a name too long, a NUL byte)."""
    try:
        return p.is_file()
    except (OSError, ValueError):
        return False

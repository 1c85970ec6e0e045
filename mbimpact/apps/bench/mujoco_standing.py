"""The contact phase of the MuJoCo comparison (:mod:`~mbimpact.apps.bench.mujoco`): robots resting on
point contacts, mostly in persistent contact, mbimpact at its 1 ms contact step.

* Solo12 of ``models/scenes/solo12_landing.toml`` on four point feet (its foot frames), its joints
  held by the same PD torques at the same posture, lowered until its lowest foot is :data:`DROP` above
  the ground: it lands (Newton, e = 0.2, μ = 0.8) and stands.
* Talos standing on the 8 corners of its soles, and a UR5 whose PD-held arm sags under gravity onto a
  table :data:`DROP` below its tool and rests there (:mod:`~mbimpact.apps.bench.mujoco_poses`); full
  runs only (``--quick``: Solo12 alone).

Each runs for :data:`SECONDS` (``--quick``: :data:`QUICK_SECONDS`) simulated seconds. mbimpact's timed
runs record 2 output samples (the start and the end; every event is still logged), as MuJoCo's timed
run records only its final state. MuJoCo: the same robot from its URDF, a sphere of
:data:`~mbimpact.apps.bench.mujoco_models.FOOT_RADIUS` centred at each contact point, position servos
with the same kp, kd, elliptic cones, dt = 1 ms, ``solref = (2 dt, 1)``
(:func:`~mbimpact.apps.bench.mujoco_models.standing_xml`), Euler and RK4.

The outcome is the simulated seconds per wall second of each, and where each leaves the contact
points: their heights above their planes at the end (mbimpact's points, the centres of MuJoCo's
spheres, at 0 when touching).
"""

from __future__ import annotations

import math
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...laws import NewtonLaw
from ...simulation import Scene, SceneContact, load_scene, simulate
from .common import BenchRow
from .mujoco_models import Unsupported, first_line, initial_state, point_heights, standing_xml
from .mujoco_poses import talos_scene, ur5_scene
from .mujoco_runs import timed_run, unstable
from .mujoco_scenes import INTEGRATORS, QUICK_REPEATS, REPEATS, Setting, timings

__all__ = ["STANDING", "SOLO12", "TALOS", "UR5", "SECONDS", "QUICK_SECONDS", "DROP", "STEP", "TIMED_SAMPLES",
           "standing_scene", "standing_rows", "case_rows", "contact_heights"]

#: The case names of the contact-phase rows (each row's case starts with one of them).
SOLO12, TALOS, UR5 = "solo12 standing", "talos standing", "ur5 resting"
STANDING = (SOLO12, TALOS, UR5)
#: Simulated seconds, full and ``--quick``.
SECONDS, QUICK_SECONDS = 3.0, 1.0
#: Height of the lowest contact point above its surface at the start [m].
DROP = 1e-3
#: mbimpact's contact step and MuJoCo's time step [s].
STEP = 1e-3
#: Output samples of mbimpact's timed runs: the start and the end.
TIMED_SAMPLES = 2

#: What the row calls the contact points of each case.
_POINTS = {SOLO12: "feet", TALOS: "sole corners", UR5: "tool"}


def standing_scene(seconds: float) -> Scene:
    """Solo12 standing on point feet (see the module docstring)."""
    landing = load_scene("solo12_landing")
    mech = landing.mechanism
    feet = [c for c in landing.contacts if isinstance(c, SceneContact)]
    q0 = landing.q0.copy()
    q0[2] -= min(float(mech.frame_position(q0, c.frame)[2]) for c in feet) - DROP
    contacts = tuple(SceneContact(c.frame, NewtonLaw(0.2), friction=c.friction) for c in feet)
    return replace(landing, q0=q0, v0=np.zeros_like(landing.v0), contacts=contacts, duration=seconds,
                   contact_step=STEP, name="solo12_standing")


def contact_heights(scene: Scene, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Heights of the scene's contact points above their planes at q [m]."""
    mech = scene.mechanism
    return np.array([float(c.surface.normal @ (mech.frame_position(q, c.frame, c.point) - c.surface.origin))
                     for c in scene.contacts if isinstance(c, SceneContact)])


def standing_rows(mujoco: Any, quick: bool) -> list[BenchRow]:
    """The contact-phase rows (see :mod:`~mbimpact.apps.bench.mujoco`): Solo12, and (full runs) Talos and the UR5."""
    seconds = QUICK_SECONDS if quick else SECONDS
    cases: list[tuple[str, Callable[[float], Scene]]] = [(SOLO12, standing_scene)]
    if not quick:
        cases += [(TALOS, partial(talos_scene, drop=DROP, step=STEP)), (UR5, partial(ur5_scene, drop=DROP, step=STEP))]
    return [row for name, build in cases for row in case_rows(mujoco, name, build(seconds), quick)]


def _simulate_wall(scene: Scene) -> float:
    """Wall time of one run recording :data:`TIMED_SAMPLES` output samples."""
    start = time.perf_counter()
    simulate(scene, samples=TIMED_SAMPLES)
    return time.perf_counter() - start


def case_rows(mujoco: Any, name: str, scene: Scene, quick: bool) -> list[BenchRow]:
    """The rows of one contact-phase case: mbimpact, MuJoCo Euler and RK4, timed warm and in alternation.

    Parameters
    ----------
    mujoco : module
    name : str
        The case (one of :data:`STANDING`).
    scene : Scene
        Point contacts on fixed planes, the mechanism read from a URDF.
    quick : bool
        One timed run of each (else :data:`~mbimpact.apps.bench.mujoco_scenes.REPEATS`).

    Returns
    -------
    list of BenchRow
        mbimpact's row first; one skipped row if MuJoCo cannot express the scene.
    """
    seconds = scene.duration
    case = f"{name} ({seconds:g} s, mbimpact contact step {STEP * 1e3:g} ms, MuJoCo dt = {STEP * 1e3:g} ms)"
    points = _POINTS.get(name, "points")
    tr = simulate(scene)  # untimed: warm
    heights = contact_heights(scene, tr.q[-1])
    floating = scene.mechanism.model.joints[1].shortname() == "JointModelFreeFlyer"
    base = f"base z {tr.q[-1, 2]:.5f} m, " if floating else ""
    mbi = Setting(f"mbimpact ({tr.status}, {sum(e.kind == 'impact' for e in tr.events)} impacts; timed with "
                  f"{TIMED_SAMPLES} output samples)", partial(_simulate_wall, scene), [math.nan],
                  max(0.0, -tr.min_gap), f"{base}{points} z {_mm(heights)}")
    settings = [mbi]
    version = getattr(mujoco, "__version__", "?")
    with tempfile.TemporaryDirectory(prefix="mbimpact-mujoco-") as tmp:
        for integrator in INTEGRATORS:
            label = f"MuJoCo {version} {integrator}, dt={STEP:g} s, solref ({2 * STEP:g}, 1)"
            try:
                m = mujoco.MjModel.from_xml_string(standing_xml(mujoco, scene, STEP, integrator, Path(tmp)))
            except (Unsupported, ValueError) as exc:
                return [BenchRow("mujoco", case, f"MuJoCo: skipped ({first_line(exc)})", math.nan, math.nan,
                                 math.nan, math.nan)]
            init = partial(initial_state, scene=scene)
            _, d = timed_run(mujoco, m, init, seconds)  # untimed: warm, and the state at the end
            mj_heights = point_heights(m, d, scene)
            bad = unstable(mujoco, d)
            mj_base = f"base z {d.qpos[2]:.5f} m, " if floating else ""
            settings.append(Setting(label, partial(lambda m, init: timed_run(mujoco, m, init, seconds)[0], m, init),
                                    [math.nan if bad else float(np.max(np.abs(mj_heights - heights)))],
                                    math.nan if bad else max(0.0, -float(mj_heights.min())),
                                    "unstable" if bad else f"{mj_base}{points} z {_mm(mj_heights)}"))
    timings(settings, QUICK_REPEATS if quick else REPEATS)
    return [BenchRow("mujoco", case, f"{s.label}: {s.what}", seconds / s.wall, s.errors[0], s.wall, s.wall / mbi.wall)
            for s in settings]


def _mm(heights: NDArray[np.float64]) -> str:
    return "(" + ", ".join(f"{1e3 * h:+.3f}" for h in heights) + ") mm"

"""The contact phase of the MuJoCo comparison (:mod:`~mbimpact.apps.bench.mujoco`): Solo12 standing.

Solo12 of ``models/scenes/solo12_landing.toml`` on four point feet (its foot frames), its joints
held by the same PD torques at the same posture, lowered until its lowest foot is
:data:`DROP` above the ground: it lands (Newton, e = 0.2, μ = 0.8) and stands for
:data:`SECONDS` (``--quick``: :data:`QUICK_SECONDS`) simulated seconds, mostly in persistent contact,
mbimpact at its 1 ms contact step. MuJoCo: the same robot from its URDF, a sphere of
:data:`~mbimpact.apps.bench.mujoco_models.FOOT_RADIUS` centred at each foot frame, position servos
with the same kp, kd, elliptic cones, dt = 1 ms, ``solref = (2 dt, 1)``
(:func:`~mbimpact.apps.bench.mujoco_models.standing_xml`), Euler and RK4.

The outcome is the simulated seconds per wall second of each, and where each leaves the feet: their
heights at the end (mbimpact's foot points, the centres of MuJoCo's spheres, at z = 0 when touching).
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ...laws import NewtonLaw
from ...simulation import Scene, SceneContact, load_scene, simulate
from .common import BenchRow
from .mujoco_models import Unsupported, first_line, initial_state, standing_xml
from .mujoco_runs import timed_run, unstable
from .mujoco_scenes import INTEGRATORS, QUICK_REPEATS, REPEATS, Setting, simulate_wall, timings

__all__ = ["STANDING", "SECONDS", "QUICK_SECONDS", "DROP", "STEP", "standing_scene", "standing_rows"]

#: The case name of the contact-phase rows.
STANDING = "solo12 standing"
#: Simulated seconds, full and ``--quick``.
SECONDS, QUICK_SECONDS = 3.0, 1.0
#: Height of the lowest foot above the ground at the start [m].
DROP = 1e-3
#: mbimpact's contact step and MuJoCo's time step [s].
STEP = 1e-3


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


def standing_rows(mujoco: Any, quick: bool) -> list[BenchRow]:
    """The contact-phase rows (see :mod:`~mbimpact.apps.bench.mujoco`)."""
    seconds = QUICK_SECONDS if quick else SECONDS
    scene = standing_scene(seconds)
    feet = [c.frame for c in scene.contacts if isinstance(c, SceneContact)]
    case = f"{STANDING} ({seconds:g} s, mbimpact contact step {STEP * 1e3:g} ms, MuJoCo dt = {STEP * 1e3:g} ms)"
    tr = simulate(scene)  # untimed: warm
    mech = scene.mechanism
    heights = np.array([float(mech.frame_position(tr.q[-1], f)[2]) for f in feet])
    mbi = Setting(f"mbimpact ({tr.status}, {sum(e.kind == 'impact' for e in tr.events)} impacts)",
                   partial(simulate_wall, scene), [math.nan], max(0.0, -tr.min_gap),
                   f"base z {tr.q[-1, 2]:.5f} m, feet z {_mm(heights)}")
    settings = [mbi]
    ends: dict[str, Any] = {}
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
            ends[label] = d
            mj_heights = np.array([float(d.xpos[m.body(f).id][2]) for f in feet])
            bad = unstable(mujoco, d)
            settings.append(Setting(label, partial(lambda m, init: timed_run(mujoco, m, init, seconds)[0], m, init),
                                     [math.nan if bad else float(np.max(np.abs(mj_heights - heights)))],
                                     math.nan if bad else max(0.0, -float(mj_heights.min())),
                                     "unstable" if bad else f"base z {d.qpos[2]:.5f} m, feet z {_mm(mj_heights)}"))
    timings(settings, QUICK_REPEATS if quick else REPEATS)
    return [BenchRow("mujoco", case, f"{s.label}: {s.what}", seconds / s.wall, s.errors[0], s.wall, s.wall / mbi.wall)
            for s in settings]


def _mm(heights: np.ndarray) -> str:
    return "(" + ", ".join(f"{1e3 * h:+.3f}" for h in heights) + ") mm"

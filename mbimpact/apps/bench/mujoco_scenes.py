"""The impact scenes of the MuJoCo comparison (:mod:`~mbimpact.apps.bench.mujoco`): accuracy rows per
setting of each simulator, the oblique sphere, and the wall time at equal accuracy."""

from __future__ import annotations

import math
import statistics
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...simulation import Scene, SceneContact, Trajectory, load_scene, simulate
from .common import BenchRow
from .mujoco_contact import STIFFNESS, contact_solref
from .mujoco_models import (BALL_RADIUS, Init, Unsupported, ball_xml, first_line, impact_law, initial_state,
                            robot_xml, sphere_xml)
from .mujoco_runs import base_velocity, first_impact, through_contact, timed_run

__all__ = ["SCENES", "PHASES", "INTEGRATORS", "TIMESTEPS", "QUICK_TIMESTEPS", "RTOLS", "QUICK_RTOLS",
           "REFERENCE_RTOL", "REPEATS", "QUICK_REPEATS", "TOLERANCES", "WINDOW", "OBLIQUE_E", "OBLIQUE_MU",
           "OBLIQUE_RATIO", "OBLIQUE_SPEED", "OBLIQUE", "scene_rows", "oblique_rows", "equal_accuracy_rows",
           "oblique_scene", "measure", "timings", "Measure", "Setting", "simulate_wall",
           "first_impact_time"]

#: The shipped scenes compared, in order.
SCENES = ("ball_drop", "ur5_forearm_box", "solo12_geometry_landing")
#: Contact-onset phases per MuJoCo setting (the step grid shifted by φ·dt, φ = 1/PHASES … 1).
PHASES = 8
#: MuJoCo's integrators.
INTEGRATORS = ("Euler", "RK4")
#: MuJoCo time steps of the full bench and of ``--quick`` [s]. MuJoCo asks for a time constant of at
#: least 2 dt: 1/ω₀ ≈ 0.32 ms here, dt ≤ 0.16 ms; 3e-4 s is the one step beyond (at 1e-3 s it blows up).
TIMESTEPS = (3e-4, 1e-4, 3e-5, 1e-5)
QUICK_TIMESTEPS = (1e-4,)
#: mbimpact's free-flight tolerances of the full bench and of ``--quick``.
RTOLS = (1e-6, 1e-8, 1e-10)
QUICK_RTOLS = (1e-10,)
#: mbimpact's tolerance whose wall time the ratios divide by (and Solo12's reference).
REFERENCE_RTOL = 1e-10
#: Timed runs per setting, full and ``--quick`` (their median is reported).
REPEATS = 3
QUICK_REPEATS = 1
#: Accuracies at which the wall times are compared.
TOLERANCES = (1e-2, 1e-3, 1e-4)
#: Solo12: the base's vertical velocity is compared from WINDOW[0] to WINDOW[1] after the first impact [s].
WINDOW = (1e-3, 20e-3)
#: The oblique sphere: restitution, friction, tangential/normal velocity before, normal speed [m/s].
OBLIQUE_E, OBLIQUE_MU, OBLIQUE_RATIO, OBLIQUE_SPEED = 0.8, 0.3, 0.25, 2.0
#: Its case name.
OBLIQUE = "oblique sphere"

_GAP = 2e-3  # the oblique sphere starts this high above the plane [m]


@dataclass
class Setting:
    """One simulator setting on one scene: its measured errors (per phase) and wall times."""

    label: str
    run: Callable[[], float]  # one timed run; its wall time [s]
    errors: list[float]
    penetration: float
    what: str
    walls: list[float] = field(default_factory=list)

    @property
    def worst(self) -> float:
        finite = [x for x in self.errors if math.isfinite(x)]
        return max(finite, key=abs) if len(finite) == len(self.errors) and finite else math.nan

    @property
    def wall(self) -> float:
        return statistics.median(self.walls) if self.walls else math.nan


def timings(settings: list[Setting], repeats: int) -> None:
    """Time every setting ``repeats`` times, the settings in alternation, round after round."""
    for _ in range(repeats):
        for s in settings:
            s.walls.append(s.run())


def simulate_wall(scene: Scene) -> float:
    start = time.perf_counter()
    simulate(scene)
    return time.perf_counter() - start


def _skipped(case: str, reason: str) -> BenchRow:
    return BenchRow("mujoco", case, f"MuJoCo: skipped ({reason})", math.nan, math.nan, math.nan, math.nan)


def first_impact_time(tr: Trajectory) -> float:
    impacts = [e.t for e in tr.events if e.kind == "impact"]
    if not impacts:
        raise Unsupported("no impact in mbimpact's run")
    return min(impacts)


def _base_vz(tr: Trajectory) -> NDArray[np.float64]:
    """World vertical velocity of the free base's origin at each sample (pinocchio's v is in the base frame)."""
    x, y, z, w = tr.q[:, 3], tr.q[:, 4], tr.q[:, 5], tr.q[:, 6]
    row = np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1)  # R[2, :]
    return np.einsum("ij,ij->i", row, tr.v[:, :3])


def _after_jumps(t: NDArray[np.float64], x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The samples without those before a jump: an event's instant, and the end of each persistent-contact
    step, are sampled twice, before and after the velocity jumps; the state after it is kept."""
    last = np.append(np.diff(t) != 0.0, True)
    return t[last], x[last]


def _ball_apex(scene: Scene, tr: Trajectory, t_touch: float) -> float:
    """The ballistic apex after the first impact, from the first sample after it."""
    g = -float(scene.mechanism.model.gravity.linear[2])
    i = int(np.searchsorted(tr.t, t_touch, side="right"))
    z, vz = float(tr.q[i, -1]), float(tr.v[i, -1])
    return z + vz * vz / (2 * g) if vz > 0 else math.nan


def _first_kappas(tr: Trajectory) -> tuple[float, ...]:
    impacts = [e for e in tr.events if e.kind == "impact"]
    return tuple(e.kappa for e in impacts if e.t <= impacts[0].t + 1e-12) if impacts else ()


def _worst_kappa(kappa: tuple[float, ...], e: float) -> float:
    errors = [k / e - 1.0 for k in kappa]
    return max(errors, key=abs) if errors else math.nan


class Measure:
    """What one scene's outcome is, and how each simulator's run of it is scored."""

    def __init__(self, scene: Scene, reference: Trajectory) -> None:
        self.scene, self.e = scene, impact_law(scene)[0]
        self.t_touch = first_impact_time(reference)
        self.kind = ("ball" if isinstance(scene.contacts[0], SceneContact) else
                     "base" if scene.mechanism.model.joints[1].shortname() == "JointModelFreeFlyer" else "kappa")
        if self.kind == "base":
            vz = _base_vz(reference)
            self.v_minus = abs(float(vz[reference.before(self.t_touch)]))
            t, vz = _after_jumps(reference.t, vz)
            inside = (t >= self.t_touch + WINDOW[0]) & (t <= self.t_touch + WINDOW[1])
            self.t_window, self.vz_reference = t[inside], vz[inside]
        self.exact = self.e * self.e * float(scene.q0[-1]) if self.kind == "ball" else math.nan

    def mbimpact(self, tr: Trajectory) -> tuple[float, str]:
        """The relative error of an mbimpact run and what it measured."""
        if self.kind == "ball":
            apex = _ball_apex(self.scene, tr, first_impact_time(tr))  # its own: rtol moves it by rounding
            return apex / self.exact - 1.0, f"apex {apex:.6f} m (e²h = {self.exact:.6g} m)"
        if self.kind == "kappa":
            kappa = _first_kappas(tr)
            return _worst_kappa(kappa, self.e), f"first impact κ = {', '.join(f'{k:.4f}' for k in kappa)} (e = {self.e:g})"
        vz = np.interp(self.t_window, *_after_jumps(tr.t, _base_vz(tr)))
        error = float(np.max(np.abs(vz - self.vz_reference))) / self.v_minus
        return error, f"base v_z {WINDOW[0] * 1e3:g}–{WINDOW[1] * 1e3:g} ms after landing against rtol={REFERENCE_RTOL:g}"

    def mujoco(self, mujoco: Any, m: Any, init: Init, phase: float) -> tuple[float, float, float]:
        """(relative error, deepest penetration [m], the phase's κ or restitution) of one MuJoCo run."""
        t0 = self.t_touch
        if self.kind == "ball":
            c = through_contact(mujoco, m, init, t0, phase, t0 + 0.1)
            if c is None:
                return math.nan, math.nan, math.nan
            g = -float(m.opt.gravity[2])
            z, vz = float(c.qpos_after[2]) - BALL_RADIUS, float(c.qvel_after[2])
            return (z + vz * vz / (2 * g)) / self.exact - 1.0, c.penetration, -vz / float(c.qvel_before[2])
        if self.kind == "kappa":
            kappa, penetration = first_impact(mujoco, m, init, t0, phase, min(self.scene.duration, t0 + 0.2))
            return _worst_kappa(kappa, self.e), penetration, min(kappa, key=lambda k: -abs(k / self.e - 1.0),
                                                                 default=math.nan)
        times, vzs, penetration = base_velocity(mujoco, m, init, t0, phase, t0 + WINDOW[1] + 2 * m.opt.timestep)
        if not times.size:
            return math.nan, math.nan, math.nan
        difference = np.max(np.abs(np.interp(self.t_window, times, vzs) - self.vz_reference))
        return float(difference) / self.v_minus, penetration, math.nan


def measure(mujoco: Any, m: Any, init: Init, score: Callable[[Any, Any, Init, float], tuple[float, float, float]]
            ) -> tuple[list[float], float, list[float]]:
    """Errors, the deepest penetration and the measured κ or restitution over the :data:`PHASES` onset phases."""
    errors, penetration, values = [], 0.0, []
    for i in range(PHASES):
        error, pen, value = score(mujoco, m, init, (i + 1) / PHASES)
        errors.append(error)
        values.append(value)
        penetration = max(penetration, pen) if math.isfinite(pen) else math.nan
    return errors, penetration, values


def _mujoco_settings(mujoco: Any, scene: Scene, quick: bool, build: Callable[[float, str, Path], tuple[str, Init]],
                     score: Callable[[Any, Any, Init, float], tuple[float, float, float]], value_name: str,
                     tmp: Path) -> list[Setting]:
    version = getattr(mujoco, "__version__", "?")
    settings = []
    for integrator in INTEGRATORS:
        for dt in QUICK_TIMESTEPS if quick else TIMESTEPS:
            xml, init = build(dt, integrator, tmp)
            try:
                m = mujoco.MjModel.from_xml_string(xml)
            except ValueError as exc:
                raise Unsupported(f"MuJoCo cannot compile the scene: {first_line(exc)}") from exc
            errors, penetration, values = measure(mujoco, m, init, score)
            finite = [v for v in values if math.isfinite(v)]
            mean = statistics.fmean(errors) if all(map(math.isfinite, errors)) else math.nan
            what = (f"mean error {mean:+.2e} over {PHASES} phases" if math.isfinite(mean)
                    else "unstable or never left the contact in some phase")
            if finite:
                what += f", {value_name} {min(finite):.4f}–{max(finite):.4f}"
            settings.append(Setting(f"MuJoCo {version} {integrator}, dt={dt:g} s",
                                     partial(lambda m, init: timed_run(mujoco, m, init, scene.duration)[0], m, init),
                                     errors, penetration, what))
    return settings


def _rows(case: str, mbimpact: list[Setting], mujoco: list[Setting]) -> list[BenchRow]:
    reference = next(s for s in mbimpact if s.label.startswith(f"mbimpact rtol={REFERENCE_RTOL:g} ")).wall
    return [BenchRow("mujoco", case, f"{s.label}: {s.what}", s.penetration, s.worst, s.wall, s.wall / reference)
            for s in mbimpact + mujoco]


def _mbimpact_settings(scene: Scene, reference: Trajectory, quick: bool,
                       score: Callable[[Trajectory], tuple[float, str]]) -> list[Setting]:
    settings = []
    for rtol in sorted(set(QUICK_RTOLS if quick else RTOLS) | {REFERENCE_RTOL}):
        sc = replace(scene, rtol=rtol)
        tr = reference if rtol == scene.rtol else simulate(sc)
        error, what = score(tr)
        settings.append(Setting(f"mbimpact rtol={rtol:g} ({tr.status})", partial(simulate_wall, sc), [error],
                                 max(0.0, -tr.min_gap), what))
    return settings


def scene_rows(mujoco: Any, name: str, quick: bool) -> list[BenchRow]:
    """Accuracy rows of one shipped scene (see :mod:`~mbimpact.apps.bench.mujoco`)."""
    scene = replace(load_scene(name), rtol=REFERENCE_RTOL)
    try:
        e, _ = impact_law(scene)
    except Unsupported as exc:
        return [_skipped(f"{name} ({scene.duration:g} s)", str(exc))]
    k, b = contact_solref(e)
    case = f"{name} ({scene.duration:g} s; e = {e:g}: solref ({k:.3g}, {b:.4g}))"
    reference = simulate(scene)  # untimed: the process's first run loads the compiled kernels
    measure_ = Measure(scene, reference)
    mbi = _mbimpact_settings(scene, reference, quick, measure_.mbimpact)
    ball = measure_.kind == "ball"

    def build(dt: float, integrator: str, tmp: Path) -> tuple[str, Init]:
        if ball:
            return ball_xml(scene, dt, integrator, STIFFNESS)
        return robot_xml(mujoco, scene, dt, integrator, STIFFNESS, tmp), partial(initial_state, scene=scene)

    with tempfile.TemporaryDirectory(prefix="mbimpact-mujoco-") as tmp:
        try:
            mjc = _mujoco_settings(mujoco, scene, quick, build, measure_.mujoco,
                                   "restitution" if ball else "κ (worst object)", Path(tmp))
        except Unsupported as exc:
            timings(mbi, QUICK_REPEATS if quick else REPEATS)
            return _rows(case, mbi, []) + [_skipped(case, str(exc))]
    timings(mbi + mjc, QUICK_REPEATS if quick else REPEATS)
    return _rows(case, mbi, mjc)


def oblique_scene(tmp: Path) -> tuple[Scene, float]:
    """The oblique sphere as an mbimpact scene (a TOML in ``tmp``), and its radius [m] (``models/sphere.urdf``)."""
    radius = 0.05
    vn = OBLIQUE_SPEED
    path = tmp / "oblique_sphere.toml"
    path.write_text(f"""name = "oblique_sphere"
[mechanism]
model = "sphere"
floating = true
[initial]
q = [0.0, 0.0, {radius + _GAP!r}, 0.0, 0.0, 0.0, 1.0]
v = [{OBLIQUE_RATIO * vn!r}, 0.0, {-vn!r}, 0.0, 0.0, 0.0]
[[contacts]]
frame = "bottom"
law = "coulomb"
e = {OBLIQUE_E!r}
mu = {OBLIQUE_MU!r}
friction = {OBLIQUE_MU!r}
[forces]
gravity = false
[simulation]
duration = 0.01
""")
    return load_scene(path), radius


def _oblique_error(vx: float, vz: float, vt: float, vn: float) -> tuple[float, float, float]:
    """(the larger relative error, v_t⁺/v_t⁻, v_n⁺/v_n⁻) against the rigid sticking prediction 5/7 and −e."""
    tangential, normal = vx / vt, vz / vn
    return max(tangential / (5 / 7) - 1.0, normal / -OBLIQUE_E - 1.0, key=abs), tangential, normal


def oblique_rows(mujoco: Any, quick: bool) -> list[BenchRow]:
    """Accuracy rows of the oblique sphere against the rigid prediction (see :mod:`~mbimpact.apps.bench.mujoco`)."""
    vn, vt = OBLIQUE_SPEED, OBLIQUE_RATIO * OBLIQUE_SPEED
    k, b = contact_solref(OBLIQUE_E)
    case = (f"{OBLIQUE} (e = {OBLIQUE_E:g}, μ = {OBLIQUE_MU:g}, v_t/v_n = {OBLIQUE_RATIO:g}, no gravity; "
            f"solref ({k:.3g}, {b:.4g}))")
    with tempfile.TemporaryDirectory(prefix="mbimpact-mujoco-") as tmp:
        scene, radius = oblique_scene(Path(tmp))
        scene = replace(scene, rtol=REFERENCE_RTOL)
        reference = simulate(scene)
        t_touch = first_impact_time(reference)

        def score_mbimpact(tr: Trajectory) -> tuple[float, str]:
            i = int(np.searchsorted(tr.t, first_impact_time(tr), side="right"))
            x, y, z, w = tr.q[i, 3:7]
            R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                          [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                          [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
            v = R @ tr.v[i, :3]
            error, tangential, normal = _oblique_error(float(v[0]), float(v[2]), vt, -vn)
            return error, f"v_t⁺/v_t⁻ = {tangential:.6f} (rigid 5/7 = {5 / 7:.6f}), v_n⁺/v_n⁻ = {normal:.6f}"

        def score_mujoco(mujoco: Any, m: Any, init: Init, phase: float) -> tuple[float, float, float]:
            c = through_contact(mujoco, m, init, t_touch, phase, t_touch + 0.1)
            if c is None:
                return math.nan, math.nan, math.nan
            error, tangential, _ = _oblique_error(float(c.qvel_after[0]), float(c.qvel_after[2]), vt, -vn)
            return error, c.penetration, tangential

        mbi = _mbimpact_settings(scene, reference, quick, score_mbimpact)
        mjc = _mujoco_settings(mujoco, scene, quick, lambda dt, integrator, _: sphere_xml(scene, radius, dt, integrator, STIFFNESS),
                               score_mujoco, "v_t⁺/v_t⁻", Path(tmp))
    timings(mbi + mjc, QUICK_REPEATS if quick else REPEATS)
    return _rows(case, mbi, mjc)


def equal_accuracy_rows(rows: list[BenchRow]) -> list[BenchRow]:
    """Per scene with a rigid prediction and tolerance: the cheapest setting of each simulator within it."""
    out = []
    for case in dict.fromkeys(r.case for r in rows if r.part == "mujoco"):
        if not case.startswith((SCENES[0], SCENES[1], OBLIQUE)):
            continue  # Solo12's outcome is compared with mbimpact's own, not with a rigid prediction
        mine = [r for r in rows if r.case == case and "skipped" not in r.method and math.isfinite(r.error)]
        for tol in TOLERANCES:
            best = {}
            for simulator in ("mbimpact", "MuJoCo"):
                within = [r for r in mine if r.method.startswith(simulator) and abs(r.error) <= tol]
                best[simulator] = min(within, key=lambda r: r.seconds) if within else None
            mbi, mjc = best["mbimpact"], best["MuJoCo"]
            names = [r.method.split(":")[0] if r else f"{s}: none within it" for s, r in best.items()]
            out.append(BenchRow("mujoco", case, f"at equal accuracy {tol:.0e}: {names[1]} against {names[0]}", tol,
                                mjc.error if mjc else math.nan, mjc.seconds if mjc else math.nan,
                                mjc.seconds / mbi.seconds if mjc and mbi else math.nan))
    return out

"""The shipped scenes MuJoCo can express, simulated by MuJoCo in the same run as mbimpact.

Optional: needs the ``mujoco`` package (``pip install mbimpact[bench]``); without it the part is
skipped (:data:`UNAVAILABLE` says so).

Three scenes, one progress step each:

* ``ball_drop`` — mbimpact's point mass dropped from h onto a smooth plane (Newton, e); in MuJoCo
  a sphere of the same mass, radius :data:`BALL_RADIUS`, its lowest point at h, frictionless
  contact (condim 1). The outcome is the apex after the first bounce, exactly e²h.
* ``ur5_forearm_box`` — the UR5 of example-robot-data falling on the box (joint damping, Newton
  e, friction μ), and
* ``solo12_geometry_landing`` — Solo12 landing on the ground, its joints held by PD torques
  (MuJoCo: affine position actuators with the same kp, kd).

  Both robots are MuJoCo's own import of the same URDF with its STL collision meshes
  (``package://`` paths made absolute in a temporary copy, visuals discarded). Both simulators
  collide the convex hulls of those meshes, and only the pairs of mbimpact's scene (the moving
  objects against the obstacle; no self-collision: contype/conaffinity). Joint ranges are dropped
  (mbimpact has no joint limits). The outcome is the restitution κ = −u_n⁺/u_n⁻ of the first
  impact against the declared e, for each object that struck: mbimpact's from its event log,
  MuJoCo's at the deepest point of the object's first contact (fixed in its body), u_n⁻ before
  the step that made that contact and u_n⁺ after the last step in which the object still
  touched (how it left the contact; at the end of the run if it never does). Every object
  touching before the first one leaves counts as striking with it.

MuJoCo's contacts are tuned from e, per time step dt: negative ``solref = (−k, −b)`` is the
stiffness and damping of the contact's own acceleration (mass-normalised), so a linear
spring-damper with ω₀ = √k, ζ = b / (2ω₀) has restitution e = exp(−ζπ/√(1−ζ²)) whatever the
mass it stops. ζ is set from e and ω₀ so that one contact lasts :data:`CONTACT_STEPS` time steps
(a shorter contact is not resolved by the integrator, a longer one penetrates deeper). Default
``solimp``, elliptic friction cones, Euler integrator. The restitution MuJoCo achieves with it is
measured and reported.

MuJoCo's wall time is that of one bare ``mj_step(m, d, nstep)`` over the scene's duration; the
outcome and the penetration are measured in a second, identical run stepped from Python (not
timed). mbimpact's wall time is that of :func:`mbimpact.simulate` (which also records its
samples and events). MuJoCo runs single-threaded (no thread pool is made).

Rows (``part == "mujoco"``), one per scene and simulator setting:

* ``case`` — the scene and its simulated seconds;
* ``method`` — the simulator, its setting and what it measured (the apex, the restitution);
* ``param`` — the deepest penetration of any contact over the run [m];
* ``error`` — relative error of the impact outcome: apex/(e²h) − 1 for the ball, κ/e − 1 for the
  robots (signed; the worst object for the robots);
* ``seconds`` — wall time of the whole scene;
* ``ratio`` — that wall time over mbimpact's on the same scene, in the same run (mbimpact: 1).

A scene MuJoCo cannot load or express gives one row whose ``method`` is
``"MuJoCo: skipped (<reason>)"``, with NaN numbers.
"""

from __future__ import annotations

import math
import re
import tempfile
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...geometry.shapes import Box, HalfSpace
from ...laws import NewtonLaw
from ...mechanism.robots import robots_share_dir
from ...simulation import Scene, SceneCollision, SceneContact, Trajectory, load_scene, simulate
from ..progress import Progress
from .common import BenchRow

__all__ = ["available", "mujoco_rows", "format_rows", "damping_ratio", "contact_solref", "UNAVAILABLE",
           "SCENES", "CONTACT_STEPS", "BALL_RADIUS", "QUICK_TIMESTEPS", "TIMESTEPS"]

#: The line printed instead of the part when ``mujoco`` cannot be imported.
UNAVAILABLE = "mujoco: part skipped, the optional mujoco package is not installed (pip install 'mbimpact[bench]')"

#: The shipped scenes compared, in order.
SCENES = ("ball_drop", "ur5_forearm_box", "solo12_geometry_landing")

#: Time steps one MuJoCo contact lasts (sets the contact stiffness from the time step).
CONTACT_STEPS = 10

#: Radius of MuJoCo's ball [m] (mbimpact's is a point: only its lowest point matters).
BALL_RADIUS = 0.05

#: MuJoCo time steps of ``--quick`` and of the full bench [s].
QUICK_TIMESTEPS = (1e-4,)
TIMESTEPS = (1e-3, 1e-4, 1e-5)


def available() -> bool:
    """Whether the ``mujoco`` package can be imported."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


def damping_ratio(e: float) -> float:
    """ζ of the linear spring-damper whose restitution is e: e = exp(−ζπ/√(1−ζ²))."""
    if not 0.0 < e <= 1.0:
        raise ValueError(f"a spring-damper's restitution is in (0, 1], got {e}")
    log = math.log(e)
    return -log / math.sqrt(math.pi**2 + log * log)


def contact_solref(e: float, dt: float, steps: int = CONTACT_STEPS) -> tuple[float, float]:
    """MuJoCo's negative ``solref`` (−k, −b): restitution e, one contact lasting ``steps`` time steps dt."""
    zeta = damping_ratio(e)
    omega0 = math.pi / (steps * dt) / math.sqrt(1.0 - zeta * zeta)  # damped half period = steps · dt
    return -omega0 * omega0, -2.0 * zeta * omega0


class _Unsupported(Exception):
    """The scene has no MuJoCo counterpart here (the message says why)."""


@dataclass(frozen=True)
class _Outcome:
    """What one simulator measured on one scene."""

    wall: float
    penetration: float
    kappa: tuple[float, ...]  # restitution of the first impact, per object that struck
    apex: float = math.nan  # ball: highest point of its lowest point after the first bounce [m]


# ---------------------------------------------------------------- mbimpact


def _mbimpact(scene: Scene) -> tuple[_Outcome, Trajectory]:
    tr = simulate(scene)
    impacts = [e for e in tr.events if e.kind == "impact"]
    first = [e for e in impacts if e.t <= impacts[0].t + 1e-12] if impacts else []
    apex = math.nan
    if impacts and isinstance(scene.contacts[0], SceneContact):
        # ballistic after the first impact: the apex of the flight from the first sample after it
        g = -float(scene.mechanism.model.gravity.linear[2])
        i = int(np.searchsorted(tr.t, impacts[0].t, side="right"))
        z, vz = float(tr.q[i, -1]), float(tr.v[i, -1])
        apex = z + vz * vz / (2 * g) if vz > 0 else math.nan
    return _Outcome(tr.wall_time, max(0.0, -tr.min_gap), tuple(e.kappa for e in first), apex), tr


# ---------------------------------------------------------------- MuJoCo models

_Init = Callable[[Any, Any], None]  # sets the initial state of MjData


def _newton(scene: Scene) -> tuple[float, float]:
    """(e, μ) shared by every contact of the scene; _Unsupported otherwise."""
    laws = {(c.law.e if isinstance(c.law, NewtonLaw) else None, c.friction) for c in scene.contacts}
    if any(e is None for e, _ in laws):
        raise _Unsupported("a rough or friction impact law has no MuJoCo counterpart")
    if len(laws) != 1:
        raise _Unsupported("contacts with different e or μ")
    (e, mu), = laws
    assert e is not None
    return e, mu


def _ball_model(mujoco: Any, scene: Scene, dt: float) -> tuple[str, Callable[[Any], float], _Init]:
    """MJCF of the ball drop, the height of the ball's lowest point, and its initial state."""
    e, mu = _newton(scene)
    contact = scene.contacts[0]
    assert isinstance(contact, SceneContact)
    if contact.surface.kind != "plane" or contact.surface.amplitude != 0.0 or mu != 0.0:
        raise _Unsupported("only a fixed smooth plane")
    mass = float(scene.mechanism.model.inertias[-1].mass)
    k, b = contact_solref(e, dt)
    g = scene.mechanism.model.gravity.linear
    h = float(scene.q0[-1])
    xml = f"""<mujoco model="{scene.name}">
  <option timestep="{dt!r}" gravity="{_vec(g)}" cone="elliptic"/>
  <default><geom condim="1" solref="{k!r} {b!r}"/></default>
  <worldbody>
    <geom name="plane" type="plane" size="0 0 1"/>
    <body name="ball" pos="0 0 {h + BALL_RADIUS!r}">
      <freejoint/><geom name="ball" type="sphere" size="{BALL_RADIUS!r}" mass="{mass!r}"/>
    </body>
  </worldbody>
</mujoco>"""

    def init(m: Any, d: Any) -> None:  # the point mass's x, y, z → the ball's centre
        d.qpos[:3] = scene.q0 + [0.0, 0.0, BALL_RADIUS]
        d.qvel[:3] = scene.v0
        mujoco.mj_forward(m, d)

    return xml, lambda d: float(d.qpos[2]) - BALL_RADIUS, init


def _import_urdf(mujoco: Any, source: Path, tmp: Path) -> ET.Element:
    """MuJoCo's own import of a URDF (mesh paths absolute, visuals discarded), as MJCF."""
    text = source.read_text()
    text = text.replace("package://", str(robots_share_dir()) + "/")
    text = re.sub(r'filename="(?!/)([^"]+)"', lambda m: f'filename="{(source.parent / m.group(1)).resolve()}"', text)
    compiler = '<compiler strippath="false" discardvisual="true" fusestatic="false"/>'
    if "<mujoco>" in text:
        text = text.replace("<mujoco>", "<mujoco>" + compiler, 1)
    else:
        text = re.sub(r"</robot>\s*$", f"<mujoco>{compiler}</mujoco></robot>", text)
    urdf, mjcf = tmp / "robot.urdf", tmp / "robot.xml"
    urdf.write_text(text)
    mujoco.mj_saveLastXML(str(mjcf), mujoco.MjModel.from_xml_path(str(urdf)))
    return ET.parse(mjcf).getroot()


def _first_line(exc: Exception) -> str:
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__


def _vec(x: NDArray[np.float64] | list[float]) -> str:
    return " ".join(repr(float(v)) for v in x)


def _robot_model(mujoco: Any, scene: Scene, dt: float, tmp: Path) -> str:
    """MJCF of a robot scene: its URDF, the obstacle, the contacts, damping and PD actuators."""
    e, mu = _newton(scene)
    mech = scene.mechanism
    if mech.source is None or mech.source.suffix.lower() != ".urdf":
        raise _Unsupported("the mechanism is not read from a URDF")
    if not all(isinstance(c, SceneCollision) and c.obstacle is not None for c in scene.contacts):
        raise _Unsupported("only collision objects against world obstacles")
    obstacles = list({id(c.obstacle): c.obstacle for c in scene.contacts
                      if isinstance(c, SceneCollision) and c.obstacle is not None}.values())
    try:
        root = _import_urdf(mujoco, mech.source, tmp)
    except Exception as exc:  # MuJoCo's compiler error: the row says why
        raise _Unsupported(f"MuJoCo cannot load {mech.source.name}: {_first_line(exc)}") from exc
    k, b = contact_solref(e, dt)
    g = mech.model.gravity.linear
    option = ET.Element("option", timestep=repr(dt), gravity=_vec(g), cone="elliptic")
    root.insert(0, option)
    contact_attrs = {"condim": "3" if mu > 0 else "1", "friction": f"{mu!r} 0 0", "solref": f"{k!r} {b!r}"}
    struck_links = {str(c.body).rsplit("_", 1)[0] for c in scene.contacts if isinstance(c, SceneCollision)}
    worldbody = root.find("worldbody")
    assert worldbody is not None
    for body in worldbody.iter("body"):
        for geom in body.findall("geom"):
            moving = body.get("name") in struck_links
            geom.attrib.update(contact_attrs, contype="1" if moving else "0", conaffinity="0")
    for joint in worldbody.iter("joint"):
        joint.attrib.pop("range", None)
        joint.set("damping", repr(scene.damping))
    for i, shape in enumerate(obstacles):
        attrs = dict(contact_attrs, name=f"obstacle{i}", contype="0", conaffinity="1")
        if isinstance(shape, HalfSpace):
            attrs.update(type="plane", size="0 0 1", pos=_vec(shape.normal * shape.offset), zaxis=_vec(shape.normal))
        elif isinstance(shape, Box):
            R = shape.rotation
            attrs.update(type="box", size=_vec(shape.size / 2), pos=_vec(shape.position),
                         xyaxes=_vec(np.concatenate([R[:, 0], R[:, 1]])))
        else:
            raise _Unsupported(f"obstacle kind {shape.kind} is not mapped to MuJoCo here")
        worldbody.insert(0, ET.Element("geom", attrs))
    if mech.model.joints[1].shortname() == "JointModelFreeFlyer":
        base = worldbody.find("body")
        assert base is not None
        base.insert(0, ET.Element("freejoint", name="root_joint"))
    if scene.pd is not None:
        kp, kd = scene.pd.kp, scene.pd.kd
        actuator = ET.SubElement(root, "actuator")
        for joint in worldbody.iter("joint"):
            ET.SubElement(actuator, "general", joint=joint.get("name", ""), gainprm=repr(kp), biastype="affine",
                          biasprm=f"0 {-kp!r} {-kd!r}", ctrllimited="false", forcelimited="false")
    return ET.tostring(root, encoding="unicode")


def _initial_state(mujoco: Any, m: Any, d: Any, *, scene: Scene) -> None:
    """The scene's q0, v0 (and PD references) in MuJoCo's coordinates, joint by joint name."""
    model = scene.mechanism.model
    for j in range(1, model.njoints):
        joint, name = model.joints[j], model.names[j]
        q, v = scene.q0[joint.idx_q:joint.idx_q + joint.nq], scene.v0[joint.idx_v:joint.idx_v + joint.nv]
        mj = m.joint(name) if joint.shortname() != "JointModelFreeFlyer" else m.joint("root_joint")
        qa, va = int(mj.qposadr[0]), int(mj.dofadr[0])
        if joint.shortname() == "JointModelFreeFlyer":
            x, y, z, w = q[3:7]
            d.qpos[qa:qa + 7] = [*q[:3], w, x, y, z]
            R = np.zeros(9)
            mujoco.mju_quat2Mat(R, np.array([w, x, y, z]))
            d.qvel[va:va + 6] = [*(R.reshape(3, 3) @ v[:3]), *v[3:]]  # linear: local → world
        elif joint.nq == 1 and joint.nv == 1:
            d.qpos[qa], d.qvel[va] = q[0], v[0]
            if scene.pd is not None:
                d.ctrl[_actuator(m, int(mj.id))] = scene.pd.q_ref[joint.idx_q]
        else:
            raise _Unsupported(f"joint {name} ({joint.shortname()}) is not mapped to MuJoCo here")
    if scene.torque is not None:
        for j in range(1, model.njoints):
            joint = model.joints[j]
            if joint.nv == 1:
                d.qfrc_applied[int(m.joint(model.names[j]).dofadr[0])] = scene.torque[joint.idx_v]
    mujoco.mj_forward(m, d)


def _actuator(m: Any, joint_id: int) -> int:
    """The actuator driving a joint."""
    for a in range(m.nu):
        if int(m.actuator_trnid[a, 0]) == joint_id:
            return a
    raise _Unsupported(f"no actuator on joint {joint_id}")  # pragma: no cover


# ---------------------------------------------------------------- MuJoCo runs


def _normal_velocity(mujoco: Any, m: Any, scratch: Any, qpos: NDArray[np.float64], qvel: NDArray[np.float64],
                     body: int, local: NDArray[np.float64], normal: NDArray[np.float64]) -> float:
    """Velocity along ``normal`` of a point fixed in ``body`` (body coordinates ``local``) at (qpos, qvel)."""
    scratch.qpos[:] = qpos
    mujoco.mj_kinematics(m, scratch)
    mujoco.mj_comPos(m, scratch)
    point = scratch.xpos[body] + scratch.xmat[body].reshape(3, 3) @ local
    jacp = np.zeros((3, m.nv))
    mujoco.mj_jac(m, scratch, jacp, None, point, body)
    return float(normal @ (jacp @ qvel))


def _run_mujoco(mujoco: Any, m: Any, scene: Scene, init: _Init, height: Callable[[Any], float] | None
                ) -> _Outcome:
    """One timed bare run of the scene, then one stepped run measuring penetration and the first impact."""
    steps = int(round(scene.duration / m.opt.timestep))
    d = mujoco.MjData(m)
    init(m, d)
    start = time.perf_counter()
    try:
        mujoco.mj_step(m, d, nstep=steps)
    except TypeError:  # bindings without nstep: a Python loop (its overhead is then in the time)
        for _ in range(steps):
            mujoco.mj_step(m, d)
    wall = time.perf_counter() - start

    d = mujoco.MjData(m)
    init(m, d)
    scratch = mujoco.MjData(m)
    obstacle = {g for g in range(m.ngeom) if int(m.geom_bodyid[g]) == 0}  # the world's geoms
    penetration = 0.0
    struck: dict[int, tuple[int, NDArray[np.float64], NDArray[np.float64], float]] = {}
    leaving: dict[int, float] = {}
    kappa: dict[int, float] = {}
    phase = 0  # 0: before the first contact, 1: in it, 2: after it (ball: flying to its apex), 3: done
    apex = -math.inf
    qpos, qvel = d.qpos.copy(), d.qvel.copy()
    for _ in range(steps):
        qpos[:], qvel[:] = d.qpos, d.qvel
        mujoco.mj_step(m, d)
        touching: dict[int, tuple[float, NDArray[np.float64], NDArray[np.float64]]] = {}
        if d.ncon:
            con = d.contact
            penetration = max(penetration, -float(np.min(con.dist)))
            if phase < 3:
                for c in range(d.ncon):
                    g1, g2 = int(con.geom1[c]), int(con.geom2[c])
                    robot, sign = (g2, 1.0) if g1 in obstacle else (g1, -1.0)  # normal: obstacle → robot
                    if robot not in touching or con.dist[c] < touching[robot][0]:
                        touching[robot] = (float(con.dist[c]), con.pos[c].copy(), sign * con.frame[c, :3])
        if phase == 1 or (phase == 0 and touching):
            phase = 1
            for g, (_, point, normal) in touching.items():
                if g not in struck:  # the point that struck, fixed in its body; its velocity before the step
                    b = int(m.geom_bodyid[g])
                    local = d.xmat[b].reshape(3, 3).T @ (point - d.xpos[b])
                    struck[g] = (b, local, normal, _normal_velocity(mujoco, m, scratch, qpos, qvel, b, local, normal))
            for g, (b, local, normal, u_minus) in struck.items():
                if g in kappa:
                    continue
                if g in touching:  # its velocity after each step it touched; the last one is how it left
                    leaving[g] = _normal_velocity(mujoco, m, scratch, d.qpos, d.qvel, b, local, normal)
                else:
                    kappa[g] = -leaving[g] / u_minus
            if len(kappa) == len(struck):
                phase = 2 if height is not None else 3
        elif phase == 2 and height is not None:
            if touching:
                phase = 3
            else:
                apex = max(apex, height(d))
    for g, (_, _, _, u_minus) in struck.items():  # never left its contact within the duration
        kappa.setdefault(g, -leaving[g] / u_minus)
    return _Outcome(wall, penetration, tuple(kappa.values()), apex if phase == 3 else math.nan)


# ---------------------------------------------------------------- rows


def _skipped(case: str, reason: str) -> BenchRow:
    return BenchRow("mujoco", case, f"MuJoCo: skipped ({reason})", math.nan, math.nan, math.nan, math.nan)


def _worst(kappa: tuple[float, ...], e: float) -> float:
    """The relative error κ/e − 1 of largest magnitude (NaN when nothing struck)."""
    errors = [k / e - 1.0 for k in kappa]
    return max(errors, key=abs) if errors else math.nan


def _scene_rows(mujoco: Any, name: str, timesteps: tuple[float, ...]) -> list[BenchRow]:
    scene = load_scene(name)
    case = f"{name} ({scene.duration:g} s)"
    ball = isinstance(scene.contacts[0], SceneContact)
    try:
        e, _ = _newton(scene)
    except _Unsupported as exc:
        return [_skipped(case, str(exc))]
    mbi, tr = _mbimpact(scene)
    exact = e * e * float(scene.q0[-1]) if ball else math.nan
    if ball:
        what, err = f"apex {mbi.apex:.6f} m (e²h = {exact:.6g} m)", mbi.apex / exact - 1.0
    else:
        what, err = f"first impact κ = {', '.join(f'{k:.3f}' for k in mbi.kappa)} (e = {e:g})", _worst(mbi.kappa, e)
    rows = [BenchRow("mujoco", case, f"mbimpact ({tr.status}): {what}", mbi.penetration, err, mbi.wall, 1.0)]
    version = getattr(mujoco, "__version__", "?")
    for dt in timesteps:
        with tempfile.TemporaryDirectory(prefix="mbimpact-mujoco-") as tmp:
            try:
                height: Callable[[Any], float] | None = None
                if ball:
                    xml, height, init = _ball_model(mujoco, scene, dt)
                else:
                    xml = _robot_model(mujoco, scene, dt, Path(tmp))
                    init = partial(_initial_state, mujoco, scene=scene)
                try:
                    m = mujoco.MjModel.from_xml_string(xml)
                except ValueError as exc:
                    raise _Unsupported(f"MuJoCo cannot compile the scene: {_first_line(exc)}") from exc
                out = _run_mujoco(mujoco, m, scene, init, height)
            except _Unsupported as exc:
                rows.append(_skipped(case, str(exc)))
                break
        k, b = contact_solref(e, dt)
        setting = f"MuJoCo {version}, dt={dt:g} s, solref=({k:.3g}, {b:.3g})"
        kappas = ", ".join(f"{x:.3f}" for x in out.kappa) or "none"
        if ball:
            what, err = f"apex {out.apex:.6f} m, restitution {kappas}", out.apex / exact - 1.0
        else:
            what, err = f"first impact κ = {kappas}", _worst(out.kappa, e)
        rows.append(BenchRow("mujoco", case, f"{setting}: {what}", out.penetration, err, out.wall, out.wall / mbi.wall))
    return rows


def mujoco_rows(quick: bool, progress: Progress) -> list[BenchRow]:
    """Rows of part ``"mujoco"`` (see the module docstring); one progress step per scene."""
    import mujoco

    rows: list[BenchRow] = []
    for name in SCENES:
        rows += _scene_rows(mujoco, name, QUICK_TIMESTEPS if quick else TIMESTEPS)
        progress.step(name)
    return rows


def format_rows(rows: list[BenchRow]) -> str:
    """The markdown table of these rows (what ``report.py`` should print for the part)."""
    def num(x: float, fmt: str) -> str:
        return "" if math.isnan(x) else format(x, fmt)

    lines = ["## Against MuJoCo on the same scenes, in one run (outcome: the apex after the first bounce "
             "against e²h for the ball, the restitution of the first impact against e for the robots)", "",
             "| scene | simulator, setting: outcome | rel. error of the outcome | deepest penetration [m] | wall s "
             "| wall s / mbimpact's |", "|---|---|---|---|---|---|"]
    lines += [f"| {r.case} | {r.method} | {num(r.error, '+.2e')} | {num(r.param, '.2g')} | {num(r.seconds, '.3g')} "
              f"| {num(r.ratio, '.3g')} |" for r in rows if r.part == "mujoco"]
    return "\n".join(lines)

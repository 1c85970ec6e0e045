"""MJCF of the scenes compared with MuJoCo (:mod:`~mbimpact.apps.bench.mujoco`), and their initial states.

Every contact is an explicit ``<pair>`` (every geom has contype = conaffinity = 0): the pairs of
mbimpact's scene and no other, each with the same ``solref`` and ``solimp`` (and, under Coulomb's
impact law, ``solreffriction``; :mod:`~mbimpact.apps.bench.mujoco_contact`), ``condim`` 3 with
friction (elliptic cones) or 1 without.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...geometry.shapes import Box, HalfSpace
from ...laws import CoulombLaw, NewtonLaw
from ...mechanism.robots import robots_share_dir
from ...simulation import Scene, SceneCollision, SceneContact
from .mujoco_contact import SOLIMP, contact_solref, friction_solref

__all__ = ["Unsupported", "Init", "impact_law", "ball_xml", "sphere_xml", "robot_xml", "standing_xml",
           "point_heights", "initial_state", "first_line", "BALL_RADIUS", "FOOT_RADIUS"]

#: Radius of MuJoCo's ball [m] (mbimpact's is a point: only its lowest point matters).
BALL_RADIUS = 0.05

#: Radius of the spheres standing for point contacts (Solo12's feet, Talos's sole corners) in MuJoCo [m].
FOOT_RADIUS = 0.005

Init = Callable[[Any, Any], None]  # sets the initial state of MjData


class Unsupported(Exception):
    """The scene has no MuJoCo counterpart here (the message says why)."""


def first_line(exc: Exception) -> str:
    """The first line of an exception's message (MuJoCo's compiler errors run over several)."""
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__


def impact_law(scene: Scene) -> tuple[float, float]:
    """(e, μ) shared by every contact of the scene (Newton's or Coulomb's law); Unsupported otherwise."""
    laws = {(c.law.e if isinstance(c.law, (NewtonLaw, CoulombLaw)) else None, c.friction) for c in scene.contacts}
    if any(e is None for e, _ in laws):
        raise Unsupported("a rough impact law has no MuJoCo counterpart")
    if len(laws) != 1:
        raise Unsupported("contacts with different e or μ")
    (e, mu), = laws
    assert e is not None
    return e, mu


def _vec(x: NDArray[np.float64] | list[float] | tuple[float, ...]) -> str:
    return " ".join(repr(float(v)) for v in x)


def _pair_attrs(scene: Scene, stiffness: float) -> dict[str, str]:
    """A contact pair of the scene's law: its own ``solreffriction`` only under Coulomb's impact law.

    Newton's law has no friction in the impact (μ acts in the persistent contact only), so there
    MuJoCo's friction rows keep their default reference (the normal's damping), slow against the
    contact; Coulomb's law has friction throughout, and the rows resolve the slip within the contact.
    """
    e, mu = impact_law(scene)
    attrs = {"condim": "3" if mu > 0 else "1", "friction": f"{mu!r} {mu!r} 0 0 0",
             "solref": _vec(contact_solref(e, stiffness)), "solimp": _vec(SOLIMP)}
    if any(isinstance(c.law, CoulombLaw) for c in scene.contacts):
        attrs["solreffriction"] = _vec(friction_solref(stiffness))
    return attrs


def _option(dt: float, integrator: str, gravity: NDArray[np.float64] | list[float]) -> str:
    return f'<option timestep="{dt!r}" gravity="{_vec(gravity)}" cone="elliptic" integrator="{integrator}"/>'


def ball_xml(scene: Scene, dt: float, integrator: str, stiffness: float) -> tuple[str, Init]:
    """MJCF of the ball drop (a sphere whose lowest point starts where mbimpact's point mass does) and its
    initial state; ``d.qpos[2] − BALL_RADIUS`` is the height of its lowest point."""
    _, mu = impact_law(scene)
    contact = scene.contacts[0]
    assert isinstance(contact, SceneContact)
    if contact.surface.kind != "plane" or contact.surface.amplitude != 0.0 or mu != 0.0:
        raise Unsupported("only a fixed smooth plane")
    mass = float(scene.mechanism.model.inertias[-1].mass)
    pair = ET.tostring(ET.Element("pair", dict(_pair_attrs(scene, stiffness), geom1="plane", geom2="ball")),
                       encoding="unicode")
    xml = f"""<mujoco model="{scene.name}">
  {_option(dt, integrator, scene.mechanism.model.gravity.linear)}
  <default><geom contype="0" conaffinity="0"/></default>
  <worldbody>
    <geom name="plane" type="plane" size="0 0 1"/>
    <body name="ball"><freejoint/><geom name="ball" type="sphere" size="{BALL_RADIUS!r}" mass="{mass!r}"/></body>
  </worldbody>
  <contact>{pair}</contact>
</mujoco>"""

    def init(m: Any, d: Any) -> None:  # the point mass's x, y, z → the ball's centre
        import mujoco

        d.qpos[:3] = scene.q0 + [0.0, 0.0, BALL_RADIUS]
        d.qvel[:3] = scene.v0
        mujoco.mj_forward(m, d)

    return xml, init


def sphere_xml(scene: Scene, radius: float, dt: float, integrator: str, stiffness: float) -> tuple[str, Init]:
    """MJCF of a solid sphere (mbimpact's floating sphere: mass, inertia) on a plane, and its initial state."""
    inertia = scene.mechanism.model.inertias[1]
    pair = ET.tostring(ET.Element("pair", dict(_pair_attrs(scene, stiffness), geom1="plane", geom2="ball")),
                       encoding="unicode")
    xml = f"""<mujoco model="{scene.name}">
  {_option(dt, integrator, scene.mechanism.model.gravity.linear if scene.gravity else [0.0, 0.0, 0.0])}
  <default><geom contype="0" conaffinity="0"/></default>
  <worldbody>
    <geom name="plane" type="plane" size="0 0 1"/>
    <body name="ball"><freejoint/>
      <geom name="ball" type="sphere" size="{radius!r}"/>
      <inertial pos="0 0 0" mass="{float(inertia.mass)!r}" diaginertia="{_vec(np.diag(inertia.inertia))}"/>
    </body>
  </worldbody>
  <contact>{pair}</contact>
</mujoco>"""
    return xml, lambda m, d: initial_state(m, d, scene=scene)


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


def _robot_root(mujoco: Any, scene: Scene, dt: float, integrator: str, tmp: Path) -> tuple[ET.Element, ET.Element]:
    """The robot's MJCF (every geom out of automatic collisions, joint ranges dropped, joint damping,
    free base, PD position servos) and its worldbody."""
    mech = scene.mechanism
    if mech.source is None or mech.source.suffix.lower() != ".urdf":
        raise Unsupported("the mechanism is not read from a URDF")
    try:
        root = _import_urdf(mujoco, mech.source, tmp)
    except Exception as exc:  # MuJoCo's compiler error: the row says why
        raise Unsupported(f"MuJoCo cannot load {mech.source.name}: {first_line(exc)}") from exc
    root.insert(0, ET.fromstring(_option(dt, integrator, mech.model.gravity.linear)))
    worldbody = root.find("worldbody")
    assert worldbody is not None
    for geom in worldbody.iter("geom"):
        geom.attrib.update(contype="0", conaffinity="0")
    for joint in worldbody.iter("joint"):
        joint.attrib.pop("range", None)  # mbimpact has no joint limits
        joint.set("damping", repr(scene.damping))
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
    return root, worldbody


def robot_xml(mujoco: Any, scene: Scene, dt: float, integrator: str, stiffness: float, tmp: Path) -> str:
    """MJCF of a robot scene: its URDF with its collision meshes, the obstacles, one pair per mbimpact pair."""
    pair = _pair_attrs(scene, stiffness)
    if not all(isinstance(c, SceneCollision) and c.obstacle is not None for c in scene.contacts):
        raise Unsupported("only collision objects against world obstacles")
    root, worldbody = _robot_root(mujoco, scene, dt, integrator, tmp)
    obstacles = list({id(c.obstacle): c.obstacle for c in scene.contacts
                      if isinstance(c, SceneCollision) and c.obstacle is not None}.values())
    for i, shape in enumerate(obstacles):
        attrs = {"name": f"obstacle{i}"}
        if isinstance(shape, HalfSpace):
            attrs.update(type="plane", size="0 0 1", pos=_vec(shape.normal * shape.offset), zaxis=_vec(shape.normal))
        elif isinstance(shape, Box):
            R = shape.rotation
            attrs.update(type="box", size=_vec(shape.size / 2), pos=_vec(shape.position),
                         xyaxes=_vec(np.concatenate([R[:, 0], R[:, 1]])))
        else:
            raise Unsupported(f"obstacle kind {shape.kind} is not mapped to MuJoCo here")
        worldbody.insert(0, ET.Element("geom", dict(attrs, contype="0", conaffinity="0")))
    struck_links = {str(c.body).rsplit("_", 1)[0] for c in scene.contacts if isinstance(c, SceneCollision)}
    contact = ET.SubElement(root, "contact")
    n = 0
    for body in worldbody.iter("body"):
        if body.get("name") not in struck_links:
            continue
        for geom in body.findall("geom"):
            if geom.get("name") is None:
                geom.set("name", f"robot_geom{n}")
                n += 1
            for i in range(len(obstacles)):
                ET.SubElement(contact, "pair", dict(pair, geom1=f"obstacle{i}", geom2=geom.get("name", "")))
    return ET.tostring(root, encoding="unicode")


def standing_xml(mujoco: Any, scene: Scene, dt: float, integrator: str, tmp: Path) -> str:
    """MJCF of a robot on point contacts: a sphere of :data:`FOOT_RADIUS` centred at each contact point
    (geom ``point<i>`` of the scene's contact i, in the body of its frame), each fixed plane of the scene
    (geom ``plane<k>``) moved back along its normal by that radius (a sphere touches when its centre,
    mbimpact's contact point, is on mbimpact's plane).

    The contact is MuJoCo's own choice for this step: ``solref = (2 dt, 1)``, critically damped at the
    shortest time constant MuJoCo accepts for dt (its ``refsafe`` limit), flat :data:`SOLIMP`."""
    _, mu = impact_law(scene)
    contacts = [c for c in scene.contacts if isinstance(c, SceneContact)]
    if len(contacts) != len(scene.contacts):
        raise Unsupported("only point contacts")
    if any(c.surface.kind != "plane" or c.surface.amplitude != 0.0 for c in contacts):
        raise Unsupported("only fixed planes")
    root, worldbody = _robot_root(mujoco, scene, dt, integrator, tmp)
    planes: dict[tuple[float, ...], str] = {}
    for c in contacts:
        key = (*c.surface.normal, float(c.surface.normal @ c.surface.origin))
        if key not in planes:
            planes[key] = f"plane{len(planes)}"
            worldbody.insert(0, ET.Element("geom", name=planes[key], type="plane", size="0 0 1",
                                           pos=_vec(c.surface.origin - FOOT_RADIUS * c.surface.normal),
                                           zaxis=_vec(c.surface.normal), contype="0", conaffinity="0"))
    bodies = {b.get("name"): b for b in worldbody.iter("body")}
    contact = ET.SubElement(root, "contact")
    for i, c in enumerate(contacts):
        if c.frame not in bodies:
            raise Unsupported(f"no body {c.frame} in MuJoCo's import")
        ET.SubElement(bodies[c.frame], "geom", name=f"point{i}", type="sphere", size=repr(FOOT_RADIUS),
                      pos=_vec(c.point), mass="0", contype="0", conaffinity="0")
        plane = planes[(*c.surface.normal, float(c.surface.normal @ c.surface.origin))]
        ET.SubElement(contact, "pair", geom1=plane, geom2=f"point{i}", condim="3",
                      friction=f"{mu!r} {mu!r} 0 0 0", solref=f"{2 * dt!r} 1", solimp=_vec(SOLIMP))
    return ET.tostring(root, encoding="unicode")


def point_heights(m: Any, d: Any, scene: Scene) -> NDArray[np.float64]:
    """Heights above their planes of the centres of :func:`standing_xml`'s spheres (mbimpact's gaps)."""
    contacts = [c for c in scene.contacts if isinstance(c, SceneContact)]
    return np.array([float(c.surface.normal @ (d.geom_xpos[m.geom(f"point{i}").id] - c.surface.origin))
                     for i, c in enumerate(contacts)])


def initial_state(m: Any, d: Any, *, scene: Scene) -> None:
    """The scene's q0, v0 (and PD references) in MuJoCo's coordinates, joint by joint name."""
    import mujoco

    model = scene.mechanism.model
    for j in range(1, model.njoints):
        joint, name = model.joints[j], model.names[j]
        q, v = scene.q0[joint.idx_q:joint.idx_q + joint.nq], scene.v0[joint.idx_v:joint.idx_v + joint.nv]
        free = joint.shortname() == "JointModelFreeFlyer"
        if free:
            qa, va = 0, 0  # the free base is MuJoCo's first joint
            if m.njnt == 0 or int(m.jnt_type[0]) != int(mujoco.mjtJoint.mjJNT_FREE):
                raise Unsupported("no free joint in MuJoCo's model")  # pragma: no cover
        else:
            mj = m.joint(name)
            qa, va = int(mj.qposadr[0]), int(mj.dofadr[0])
        if free:
            x, y, z, w = q[3:7]
            d.qpos[qa:qa + 7] = [*q[:3], w, x, y, z]
            R = np.zeros(9)
            mujoco.mju_quat2Mat(R, np.array([w, x, y, z]))
            d.qvel[va:va + 6] = [*(R.reshape(3, 3) @ v[:3]), *v[3:]]  # linear: local → world
        elif joint.nq == 1 and joint.nv == 1:
            d.qpos[qa], d.qvel[va] = q[0], v[0]
            if scene.pd is not None:
                d.ctrl[_actuator(m, int(m.joint(name).id))] = scene.pd.q_ref[joint.idx_q]
        else:
            raise Unsupported(f"joint {name} ({joint.shortname()}) is not mapped to MuJoCo here")
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
    raise Unsupported(f"no actuator on joint {joint_id}")  # pragma: no cover

"""The robots of the contact-phase rows besides Solo12 (:mod:`~mbimpact.apps.bench.mujoco_standing`).

* Talos (example-robot-data's ``talos``, 90.3 kg, 32 actuated joints) in its SRDF posture
  ``half_sitting``, its joints held there by PD torques (:data:`TALOS_PD`), standing on 8 points: the
  4 corners of each sole (:data:`SOLE_CORNERS`, in the frames ``left_sole_link`` and
  ``right_sole_link``), lowered until its lowest corner is ``drop`` above the ground.
* A UR5 (fixed base) held by PD torques (:data:`UR5_PD`) at the posture :data:`UR5_POSTURE` of
  ``models/scenes/ur5_strikes_table.toml``, its tool point (frame ``tool0``) ``drop`` above a table:
  gravity bends the held arm until the tool rests on the table and presses on it.

Every contact follows Newton's law, e = :data:`E`, with friction μ = :data:`MU`, as Solo12's feet do.
The gains keep MuJoCo's explicit integration of the servos stable at a 1 ms step: kd·dt/I < 2 and
√(kp/I)·dt < 2 for the lightest joint inertia I (1.2e-3 kg m² for Talos's grippers).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
from numpy.typing import NDArray

from ...laws import NewtonLaw
from ...mechanism import Mechanism
from ...mechanism.robots import robots_dir
from ...simulation import PD, Scene, SceneContact, Surface

__all__ = ["E", "MU", "SOLE_CORNERS", "SOLES", "TALOS_PD", "UR5_PD", "UR5_POSTURE", "TABLE_FRAME",
           "srdf_state", "talos_scene", "ur5_scene"]

#: Newton's restitution and the friction coefficient of every contact.
E, MU = 0.2, 0.8

#: The sole frames of Talos.
SOLES = ("left_sole_link", "right_sole_link")

#: The corners of a Talos sole in its sole frame [m]: the bounding box of the foot's collision mesh
#: (``talos_data/meshes/v2/ankle_X_collision.stl``: x ∈ [−0.1163, 0.1045], y ∈ [−0.0672, 0.0672], its
#: bottom 0.4 mm below the sole frame), on the sole plane z = 0.
SOLE_CORNERS = tuple((x, y, 0.0) for x in (0.1045, -0.1163) for y in (0.0672, -0.0672))

#: Talos's PD gains (kp [N m/rad], kd [N m s/rad]).
TALOS_PD = (3000.0, 2.0)

#: The UR5's PD gains, its posture [rad], and the frame of its tool point.
UR5_PD = (500.0, 5.0)
UR5_POSTURE = (0.0, -1.2, 1.6, -1.97, -1.57, 0.0)
TABLE_FRAME = "tool0"


def srdf_state(mech: Mechanism, srdf: str, state: str) -> NDArray[np.float64]:
    """The configuration of a named ``group_state`` of an example-robot-data SRDF.

    Parameters
    ----------
    mech : Mechanism
    srdf : str
        The SRDF's path below example-robot-data's robots folder.
    state : str
        The ``group_state`` name.

    Returns
    -------
    ndarray, shape (nq,)
        The state's joint values, the neutral value for a joint it does not name.
    """
    root = ET.parse(robots_dir() / srdf).getroot()
    group = next(g for g in root.iter("group_state") if g.get("name") == state)
    values = {j.get("name"): [float(x) for x in j.get("value", "").split()] for j in group.iter("joint")}
    model = mech.model
    q = mech.neutral().copy()
    for j in range(1, model.njoints):
        if model.names[j] in values:
            joint = model.joints[j]
            q[joint.idx_q:joint.idx_q + joint.nq] = values[model.names[j]]
    return q


def talos_scene(seconds: float, drop: float, step: float) -> Scene:
    """Talos standing on its 8 sole corners (see the module docstring).

    Parameters
    ----------
    seconds : float
        Simulated duration [s].
    drop : float
        Height of the lowest corner above the ground at the start [m].
    step : float
        mbimpact's contact step [s].

    Returns
    -------
    Scene
    """
    mech = Mechanism.from_robot("talos")
    q0 = srdf_state(mech, "talos_data/srdf/talos.srdf", "half_sitting")
    contacts = tuple(SceneContact(frame, NewtonLaw(E), point=np.array(p), friction=MU)
                     for frame in SOLES for p in SOLE_CORNERS)
    q0[2] -= min(float(mech.frame_position(q0, c.frame, c.point)[2]) for c in contacts) - drop
    kp, kd = TALOS_PD
    return Scene(mechanism=mech, q0=q0, v0=np.zeros(mech.nv), contacts=contacts, pd=PD(kp, kd, q0.copy()),
                 duration=seconds, contact_step=step, name="talos_standing")


def ur5_scene(seconds: float, drop: float, step: float) -> Scene:
    """A UR5 held by PD torques, its tool resting on a table (see the module docstring).

    Parameters
    ----------
    seconds : float
        Simulated duration [s].
    drop : float
        Height of the tool point above the table at the start [m].
    step : float
        mbimpact's contact step [s].

    Returns
    -------
    Scene
    """
    mech = Mechanism.from_robot("ur5")
    q0 = np.array(UR5_POSTURE)
    tool = mech.frame_position(q0, TABLE_FRAME)
    table = Surface(origin=np.array([0.0, 0.0, float(tool[2]) - drop]))
    contact = SceneContact(TABLE_FRAME, NewtonLaw(E), surface=table, friction=MU)
    kp, kd = UR5_PD
    return Scene(mechanism=mech, q0=q0, v0=np.zeros(mech.nv), contacts=(contact,), pd=PD(kp, kd, q0.copy()),
                 duration=seconds, contact_step=step, name="ur5_resting")

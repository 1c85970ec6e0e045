"""The compiled contact step is a backend of Moreau's step: a run takes the same steps and events on
either route, and its states agree to rounding (and the cone solver's tolerance)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.mechanism import front
from mbimpact.simulation.compiled_steps import compiled_steps
from mbimpact.simulation.run import RunState

pytestmark = pytest.mark.skipif(not front.available(), reason=f"compiled front end {front.status()}")


def _both(scene: mbi.Scene) -> tuple[mbi.Trajectory, mbi.Trajectory]:
    compiled = mbi.simulate(scene)
    with front.disabled():
        python = mbi.simulate(scene)
    return compiled, python


def _standing(seconds: float) -> mbi.Scene:
    from mbimpact.apps.bench.mujoco_standing import standing_scene

    return standing_scene(seconds)


def _limp_solo(seconds: float) -> mbi.Scene:
    """Solo12 without torques dropped 2 cm on four Newton feet: it lands, its legs fold, and it rests."""
    landing = mbi.load_scene("solo12_landing")
    mech = landing.mechanism
    q0 = landing.q0.copy()
    q0[2] += 0.02 - min(float(mech.frame_position(q0, c.frame)[2]) for c in landing.contacts)
    contacts = tuple(mbi.SceneContact(c.frame, mbi.NewtonLaw(0.3), friction=0.8) for c in landing.contacts)
    return replace(landing, q0=q0, contacts=contacts, pd=None, duration=seconds, name="limp_solo12")


def _sliding_pendulum(seconds: float) -> mbi.Scene:
    """A double pendulum's tip sliding on a frictionless floor (a fixed base, curved tip paths)."""
    mech = mbi.Mechanism.from_model("double_pendulum")
    q = np.array([0.6, -1.2])
    Jn = mech.frame_jacobian(q, mech.frame_id("tip"), np.zeros(3))[2]
    v = 2.0 * np.array([-Jn[1], Jn[0]]) / np.linalg.norm(Jn)
    floor = float(mech.frame_position(q, "tip")[2])
    return mbi.Scene(mechanism=mech, q=q, v=v, duration=seconds, name="sliding_pendulum",
                     contacts=[mbi.SceneContact(frame="tip", law="newton", e=0.0, friction=0.0,
                                                normal=[0.0, 0.0, 1.0], origin=[0.0, 0.0, floor])])


SCENES = {
    "solo12 standing, PD": lambda: _standing(1.0),
    "solo12 limp": lambda: _limp_solo(0.25),  # before its mirror-image feet lift off together (a coin toss)
    "box landing": lambda: replace(mbi.load_scene("box_landing"), duration=1.0),
    "sliding pendulum": lambda: _sliding_pendulum(0.5),
}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_compiled_steps_take_the_python_route_steps_to_rounding(name):
    scene = SCENES[name]()
    compiled, python = _both(scene)
    assert compiled.status == python.status == "completed", (compiled.message, python.message)
    assert compiled.work["compiled_contact_steps"] > 0
    assert "compiled_contact_steps" not in python.work
    work = {k: n for k, n in compiled.work.items() if k != "compiled_contact_steps"}
    assert work == dict(python.work)
    assert [(e.kind, e.contact) for e in compiled.events] == [(e.kind, e.contact) for e in python.events]
    np.testing.assert_allclose([e.t for e in compiled.events], [e.t for e in python.events], rtol=0, atol=1e-12)
    assert compiled.t.shape == python.t.shape
    np.testing.assert_array_equal(compiled.t, python.t)
    scale_q = 1.0 + float(np.abs(python.q).max())
    scale_v = 1.0 + float(np.abs(python.v).max())
    assert float(np.abs(compiled.q - python.q).max()) <= 1e-9 * scale_q
    assert float(np.abs(compiled.v - python.v).max()) <= 1e-7 * scale_v
    assert float(np.abs(compiled.gaps - python.gaps).max()) <= 1e-9
    assert float(np.abs(compiled.energy - python.energy).max()) <= 1e-8 * (1.0 + float(np.abs(python.energy).max()))
    assert compiled.gaps.min() >= -scene.tolerance


def test_the_standing_robot_stands_on_its_four_feet():
    """Solo12 held by its PD lands from 1 mm and stands: every foot on the ground (within the tolerance,
    never above the band), carrying together its weight, with no further impact."""
    scene = _standing(2.0)
    tr = mbi.simulate(scene)
    assert tr.completed
    late = tr.t > 1.0
    assert tr.active[late].all()
    assert np.abs(tr.gaps[late]).max() <= scene.tolerance
    weight = float(scene.mechanism.model.gravity.linear[2] * -sum(i.mass for i in scene.mechanism.model.inertias))
    np.testing.assert_allclose(tr.forces[late, :, 2].sum(axis=1), weight, rtol=1e-3)
    assert not [e for e in tr.events if e.kind == "impact" and e.t > 0.05]


def test_only_frame_contacts_on_fixed_planes_take_the_compiled_step():
    assert compiled_steps(RunState(_standing(0.1), 2, None)) is not None
    vibrating = mbi.load_scene("ball_on_vibrating_plate")  # a moving surface
    assert compiled_steps(RunState(vibrating, 2, None)) is None
    pairs = mbi.load_scene("box_tumbling")  # a collision pair
    assert compiled_steps(RunState(pairs, 2, None)) is None
    with front.disabled():
        assert compiled_steps(RunState(_standing(0.1), 2, None)) is None

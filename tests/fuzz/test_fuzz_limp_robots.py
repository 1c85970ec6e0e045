"""Fuzzing legged robots dropped on their feet: limp or PD-held, many contacts, impacts that drive the other
feet back into the ground.

Each example draws a legged robot of example-robot-data (Solo12, ANYmal, HyQ, A1, Go1), a posture (its
standing one, or neutral, plus a small random tilt of the base and of the joints), a drop height of
1–30 cm above its lowest foot, a foot law (rough on a cone, Coulomb, Newton), a restitution, and a PD on
its posture or none. Asserted, through :func:`tests.fuzz.test_fuzz_scenes.simulate_checked`: the run ends
within its time limit with a status of :data:`mbimpact.simulation.trajectory.STATUSES` — "completed", as
this class must — a completed run never reports a gap below −tolerance, and a passive scene
(:func:`mbimpact.simulation.run.passive`) never stops as ``energy_growth`` nor gains energy beyond its
flight's integration error.

The default run takes a small derandomised sample; ``pytest -m slow`` runs 1000 examples.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mbimpact.simulation import Scene, SceneContact
from mbimpact.simulation.trajectory import STATUSES
from tests.fuzz.test_fuzz_scenes import simulate_checked
from tests.helpers import mechanism
from tests.simulation.test_contact_robustness import FEET, feet_heights

DURATION = 0.6  # simulated seconds: the first rounds of impacts, where the other feet are driven back in


@st.composite
def drops(draw: st.DrawFn) -> Scene:
    robot = draw(st.sampled_from(sorted(FEET)))
    mech = mechanism(robot)
    refs = mech.model.referenceConfigurations
    q0 = refs["standing"].copy() if "standing" in refs else pin.neutral(mech.model)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    tilt = draw(st.sampled_from([0.0, 0.05, 0.2]))
    q0[3:7] = (pin.Quaternion(q0[3:7]) * pin.Quaternion(pin.exp3(rng.normal(size=3) * tilt))).coeffs()
    q0[7:] += rng.normal(size=mech.nq - 7) * draw(st.sampled_from([0.0, 0.05]))
    q0 = pin.normalize(mech.model, q0)
    data = mech.model.createData()
    pin.framesForwardKinematics(mech.model, data, q0)
    lowest = min(data.oMf[mech.model.getFrameId(f)].translation[2] for f in FEET[robot])
    q0[2] += draw(st.floats(0.01, 0.3)) - lowest
    kind = draw(st.sampled_from(["rough", "coulomb", "newton"]))
    e = draw(st.sampled_from([0.0, 0.3, 0.8]))
    friction = draw(st.sampled_from([0.3, 0.6, 1.0]))
    if kind == "rough":
        contacts = [SceneContact(frame=f, roughness={"kind": "cone", "alpha": draw(st.sampled_from([0.1, 0.2, 0.4]))},
                                 e=e, friction=friction) for f in FEET[robot]]
    elif kind == "coulomb":
        contacts = [SceneContact(frame=f, law="coulomb", e=e, mu=friction, friction=friction) for f in FEET[robot]]
    else:
        contacts = [SceneContact(frame=f, law="newton", e=e, friction=friction) for f in FEET[robot]]
    kw = {"pd": {"kp": 20.0, "kd": 0.5, "q": "initial"}} if draw(st.booleans()) else {}
    return Scene(mechanism=mech, q=q0, contacts=contacts, duration=DURATION, name=f"fuzz_{robot}_drop",
                 max_wall_time=30.0, samples=200, **kw)


def check(scene: Scene) -> None:
    tr = simulate_checked(scene)
    assert tr.status in STATUSES
    if tr.status == "energy_growth":
        from mbimpact.simulation.run import passive

        assert not passive(scene), tr.message
    assert tr.status == "completed", (tr.status, tr.message)
    assert tr.gaps.min() >= -scene.tolerance
    assert feet_heights(scene, tr).min() >= -scene.tolerance


@settings(max_examples=12, deadline=None, derandomize=True)
@given(drops())
def test_dropped_legged_robots_complete_above_the_ground(scene):
    check(scene)


@pytest.mark.slow
@settings(max_examples=1000, deadline=None, derandomize=True)
@given(drops())
def test_dropped_legged_robots_complete_above_the_ground_slow(scene):
    check(scene)

"""The contact step follows a point on a curved path: J̇v in the gap rate, against the constrained dynamics.

A double pendulum (q = [0.6, −1.2]) has its tip on a floor at the tip's height, sliding along it at 2 m/s
(frictionless, plastic). The tip's path is an arc: with the velocity-level constraint of the step's start
alone it leaves the floor by O(h) a step and strikes it again. The reference is independent of the
simulator: the index-1 constrained dynamics

    A(q) q̈ + nle(q, q̇) = Jₙᵀ λ,   Jₙ q̈ + (J̇ q̇)ₙ = 0,

from Pinocchio's crba, nonLinearEffects, frame Jacobian and classical frame acceleration, integrated by
scipy's solve_ivp until the normal force λ crosses 0: the physical lift-off.

Known defect, kept as strict expected failures: the contact step has no J̇v term. With h n·J̇v in the gap
rate these tests pass, but a HyQ dropped limp gained 4 % of its energy and the cone problems of feet on
stretched legs (a singular G) had no solution; with h n·J̇v / 2 the tip rises 5e-8 m at 1 ms.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import mbimpact as mbi
from mbimpact.simulation import Scene, SceneContact, Surface
from mbimpact.simulation.trajectory import STATUSES
from tests.helpers import time_limit

Q0 = np.array([0.6, -1.2])
SPEED = 2.0
#: The gap a persistent contact may open before its lift-off [m] (the contact band, BAND_MAX).
BAND = 1e-8


def start() -> tuple[mbi.Mechanism, np.ndarray, float]:
    """The pendulum, the joint velocity moving the tip along the floor at SPEED, and the floor's height."""
    mech = mbi.Mechanism.from_model("double_pendulum")
    model, data = mech.model, mech.model.createData()
    fid = model.getFrameId("tip")
    pin.computeJointJacobians(model, data, Q0)
    pin.framesForwardKinematics(model, data, Q0)
    Jn = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[2]
    v0 = np.array([-Jn[1], Jn[0]])
    return mech, SPEED * v0 / np.linalg.norm(v0), float(data.oMf[fid].translation[2])


def reference():
    """The constrained dynamics from the start: (lift-off time where λ = 0, the normal force λ(t) before it,
    the tip's largest height drift before it — the integration's check of the constraint)."""
    mech, v0, floor = start()
    model, data = mech.model, mech.model.createData()
    fid = model.getFrameId("tip")

    def solve(y):
        q, v = y[:2], y[2:]
        A = pin.crba(model, data, q)
        A = np.triu(A) + np.triu(A, 1).T
        nle = pin.nonLinearEffects(model, data, q, v)
        pin.forwardKinematics(model, data, q, v, np.zeros(2))
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        Jn = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[2]
        drift = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear[2]
        K = np.block([[A, -Jn[:, None]], [Jn[None, :], np.zeros((1, 1))]])
        x = np.linalg.solve(K, np.r_[-nle, -drift])
        return x[:2], x[2]

    def rhs(t, y):
        return np.r_[y[2:], solve(y)[0]]

    def lift(t, y):
        return solve(y)[1]

    lift.terminal, lift.direction = True, -1.0
    y0 = np.r_[Q0, v0]
    assert solve(y0)[1] > 0.0  # pressed at the start
    out = solve_ivp(rhs, (0.0, 1.0), y0, method="DOP853", rtol=1e-12, atol=1e-12, events=lift, dense_output=True)
    assert out.t_events[0].size == 1, "no lift-off within 1 s"
    t_lift = float(out.t_events[0][0])
    heights = []
    for t in np.linspace(0.0, t_lift, 200):
        pin.framesForwardKinematics(model, data, out.sol(t)[:2])
        heights.append(data.oMf[fid].translation[2] - floor)
    return t_lift, (lambda t: solve(out.sol(t))[1]), float(np.abs(heights).max())


@pytest.fixture(scope="module")
def ref():
    t_lift, force, drift = reference()
    assert drift < 1e-9  # the reference keeps the tip on the floor
    return t_lift, force


def arc(step: float, duration: float = 0.5) -> tuple[Scene, mbi.Trajectory]:
    mech, v0, floor = start()
    surface = Surface(normal=[0, 0, 1.0], origin=[0, 0, floor])
    scene = Scene(mech, Q0, v0, (SceneContact("tip", mbi.NewtonLaw(0.0), surface, friction=0.0),), duration=duration,
                  contact_step=step, name="arc")
    with time_limit(30.0):
        tr = mbi.simulate(scene, samples=1000)
    assert tr.status in STATUSES
    assert tr.status == "completed", tr.message
    return scene, tr


NO_JDOT = pytest.mark.xfail(strict=True, reason="the contact step's gap rate has no J̇v term (issue 39)")


@NO_JDOT
@pytest.mark.parametrize("step, bound", [(1e-3, BAND), (4e-3, 2 * BAND)])
def test_a_point_sliding_on_an_arc_stays_on_its_surface_until_the_physical_lift_off(ref, step, bound):
    """Held within the band at 1 ms (the step's second-order residue grows as h²: 1.2e-8 m at 4 ms; without
    J̇v the tip rises by 6e-6 m at 1 ms and 9e-5 m at 4 ms)."""
    t_lift = ref[0]
    scene, tr = arc(step)
    lifts = [e for e in tr.events if e.kind == "lift"]
    assert lifts, [(e.t, e.kind) for e in tr.events]
    # one lift-off, at the reference's, within a few contact steps; no re-strikes before it
    assert lifts[0].t == pytest.approx(t_lift, abs=3 * step)
    assert not [e for e in tr.events if e.kind == "impact" and e.t < lifts[0].t]
    before = tr.t < lifts[0].t - step
    assert before.sum() > 40
    assert tr.gaps[before].max() < bound, tr.gaps[before].max()
    assert tr.gaps[before].min() >= -scene.tolerance
    assert np.all(tr.active[before, 0])


@NO_JDOT
def test_the_contact_force_follows_the_constrained_dynamics(ref):
    """The step's mean normal force against λ(t) of the reference, from the first step to a few steps
    before the lift-off: first order in the step."""
    t_lift, force = ref
    step = 1e-3
    _, tr = arc(step, duration=0.3)
    pick = (tr.t > 2 * step) & (tr.t < t_lift - 5 * step)
    assert pick.sum() > 100
    f = tr.forces[pick, 0, 2]
    expected = np.array([force(t) for t in tr.t[pick]])
    assert expected.min() > 0.0
    scale = float(expected.max())
    np.testing.assert_allclose(f, expected, rtol=0, atol=0.02 * scale)

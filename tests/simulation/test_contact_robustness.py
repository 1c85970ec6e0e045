"""Contacts are never lost: limp and PD-held legged robots dropped on their feet, boxes thrown with spin
on their corners, a sphere spinning on a plane, and the Coulomb cone problem of a single sliding foot.

Asserted, scene by scene, through :func:`tests.fuzz.test_fuzz_scenes.simulate_checked` (named status,
finite state, a completed run above its surfaces and without an energy gain beyond its flight's
integration error when passive) and by independent checks: every foot's height recomputed from the
sampled configurations, output times that never run backwards, unit quaternions, the Coulomb
conditions of a cone solution checked from G and g, and the ``energy_growth`` status of a run whose
energy rises.

The default run takes a fast sample of scenes; ``pytest -m slow`` drops 1000 robots.
"""

from __future__ import annotations

import dataclasses
import math
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import mbimpact as mbi
from mbimpact.simulation import Scene, SceneContact, Surface
from mbimpact.simulation.trajectory import STATUSES
from tests.fuzz.test_fuzz_scenes import simulate_checked
from tests.helpers import mechanism, spd, time_limit

#: The foot frames of the legged robots of example-robot-data.
FEET = {"solo12": ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"],
        "anymal": ["LF_FOOT", "RF_FOOT", "LH_FOOT", "RH_FOOT"],
        "hyq": ["lf_foot", "rf_foot", "lh_foot", "rh_foot"],
        "a1": ["FL_foot", "FR_foot", "RL_foot", "RR_foot"],
        "go1": ["FL_foot", "FR_foot", "RL_foot", "RR_foot"]}
FOOT_LAWS = ("rough", "coulomb", "newton")
#: Energy a passive drop may gain [J per J of scale |E₀| + max |E| + 1]: rounding of the contact steps.
ENERGY_RTOL = 1e-9


def foot_contacts(frames: list[str], kind: str) -> list[SceneContact]:
    """Feet on the ground z = 0: rough (a cone of slopes, e = 0.3), Coulomb (e = 0.3, μ = 0.5) or Newton."""
    if kind == "rough":
        return [SceneContact(frame=f, roughness={"kind": "cone", "alpha": 0.2}, e=0.3, friction=0.8) for f in frames]
    if kind == "coulomb":
        return [SceneContact(frame=f, law="coulomb", e=0.3, mu=0.5, friction=0.5) for f in frames]
    return [SceneContact(frame=f, law="newton", e=0.3, friction=0.6) for f in frames]


def robot_drop(robot: str, height: float, kind: str, pd: bool, duration: float = 1.0) -> Scene:
    """``robot`` in its standing posture (else neutral), at rest, its lowest foot ``height`` above the
    ground, its feet under the law ``kind``; limp, or held by a PD (kp 20, kd 0.5) on that posture."""
    mech = mechanism(robot)
    refs = mech.model.referenceConfigurations
    q0 = refs["standing"].copy() if "standing" in refs else pin.neutral(mech.model)
    data = mech.model.createData()
    pin.framesForwardKinematics(mech.model, data, q0)
    q0[2] += height - min(data.oMf[mech.model.getFrameId(f)].translation[2] for f in FEET[robot])
    kw = {"pd": {"kp": 20.0, "kd": 0.5, "q": "initial"}} if pd else {}
    return Scene(mechanism=mech, q=q0, contacts=foot_contacts(FEET[robot], kind), duration=duration,
                 name=f"{robot}-drop", max_wall_time=60.0, **kw)


def seeded_drop(robot: str, seed: int) -> Scene:
    """The drop of ``seed``: height uniform in 1–30 cm, law ``FOOT_LAWS[seed % 3]``, PD on odd seeds."""
    height = float(np.random.default_rng(seed).uniform(0.01, 0.3))
    return robot_drop(robot, height, FOOT_LAWS[seed % 3], pd=seed % 2 == 1)


def feet_heights(scene: Scene, tr: mbi.Trajectory) -> np.ndarray:
    """Heights (samples, feet) of the contact frames above the ground z = 0, recomputed from tr.q."""
    model = scene.mechanism.model
    data = model.createData()
    ids = [model.getFrameId(c.frame) for c in scene.contacts]
    out = np.empty((len(tr.t), len(ids)))
    for k, q in enumerate(tr.q):
        pin.framesForwardKinematics(model, data, q)
        out[k] = [data.oMf[i].translation[2] for i in ids]
    return out


def check_drop(scene: Scene) -> mbi.Trajectory:
    """A drop completes with every foot above the ground and, limp, without gaining energy."""
    tr = simulate_checked(scene)
    assert tr.status == "completed", (scene.name, tr.status, tr.message)
    assert tr.gaps.min() >= -scene.tolerance, tr.gaps.min()
    assert feet_heights(scene, tr).min() >= -scene.tolerance
    assert np.all(np.diff(tr.t) >= 0.0)
    if scene.pd is None:
        scale = abs(tr.energy[0]) + float(np.abs(tr.energy).max()) + 1.0
        assert tr.energy.max() - tr.energy[0] <= ENERGY_RTOL * scale, (tr.energy.max() - tr.energy[0], scale)
    return tr


# ---------------------------------------------------------------- legged robots dropped on their feet

#: (robot, seed) of :func:`seeded_drop`, one for each way this class can lose a contact: a foot pushed below the
#: ground by an impact elsewhere or by the projection (1e-5 to 8e-4 m without the rearming and the projection of
#: open contacts), ADMM stalling on one sliding ANYmal foot, brentq given an interval without a sign change
#: (anymal 2); the last three held by a PD.
DROPS = [("anymal", 2), ("a1", 2), ("anymal", 4), ("a1", 4), ("solo12", 6), ("anymal", 8), ("solo12", 7),
         ("hyq", 1), ("go1", 7)]


@pytest.mark.parametrize("robot, seed", DROPS)
def test_dropped_legged_robot_keeps_its_feet_above_the_ground(robot, seed):
    check_drop(seeded_drop(robot, seed))


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(1000))
def test_dropped_legged_robots_keep_their_feet_above_the_ground_slow(seed):
    check_drop(seeded_drop(sorted(FEET)[seed % len(FEET)], seed))


# ---------------------------------------------------------------- boxes

def thrown_box(seed: int) -> Scene:
    """A box 0.3 m up at a random orientation, thrown (0.5 m/s) with spin (4 rad/s) on its 8 corners (Newton,
    e = 0.5, μ = 0.5)."""
    rng = np.random.default_rng(seed)
    quat = pin.Quaternion(pin.exp3(rng.normal(size=3) * 0.8)).coeffs()
    q = np.r_[0.0, 0.0, 0.3, quat]
    v = np.r_[rng.normal(size=3) * 0.5, rng.normal(size=3) * 4]
    contacts = [SceneContact(frame=f"corner{i}", law="newton", e=0.5, friction=0.5) for i in range(8)]
    return Scene(mechanism=mbi.Mechanism.from_model("box", floating=True), q=q, v=v, contacts=contacts, duration=1.0,
                 name=f"box-{seed}", max_wall_time=60.0)


#: Seeds exercising brentq on a start already below the surface (7, 20), a sub-step's gap/s velocity (a blow-up to
#: 2e6 J without the whole-step gap term: 9) and corners pushed in by the other corners' steps (4, 12).
BOXES = [4, 7, 9, 12, 20]


@pytest.mark.parametrize("seed", BOXES)
def test_box_thrown_with_spin_on_eight_corners_completes(seed):
    check_drop(thrown_box(seed))


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(200))
def test_boxes_thrown_with_spin_complete_slow(seed):
    check_drop(thrown_box(seed))


BOX_QUAT = [0.04972948160146045, 0.09970865087213879, -0.004989591229461981, 0.9937606691655043]


def test_box_dropped_on_four_corners_output_runs_forward_above_the_ground():
    """A box dropped tilted on four corners: impacts inside persistent-contact steps; the samples between a
    step's start and such an impact are never emitted afterwards (extrapolated backwards below the ground)."""
    contacts = [SceneContact(frame=f"corner{i}", law="newton", e=0.5, friction=0.5) for i in range(4)]
    scene = Scene(mechanism=mbi.Mechanism.from_model("box", floating=True), q=np.r_[0.0, 0.0, 0.3, BOX_QUAT],
                  contacts=contacts, duration=1.0, name="box-four-corners")
    tr = check_drop(scene)
    assert np.all(np.diff(tr.t) >= 0.0)
    assert tr.t[0] == 0.0 and tr.t[-1] == pytest.approx(1.0, rel=1e-12)
    assert sum(e.kind == "impact" for e in tr.events) >= 4


# ---------------------------------------------------------------- a sphere spinning on a plane

def test_sphere_spinning_on_a_plane_keeps_a_unit_quaternion_and_no_energy_gain():
    """A collision sphere resting on a half-space, spinning at 30 rad/s about the vertical: thousands of
    contact steps; its quaternion stays normalised and the spin, braked by friction, never gains energy."""
    text = """
name = "spinning_sphere"
[mechanism]
model = "sphere"
floating = true
[initial]
q = [0, 0, 0.05, 0, 0, 0, 1]
v = [0, 0, 0, 0, 0, 30]
[[obstacles]]
name = "ground"
shape = "halfspace"
[[contacts]]
body = "all"
obstacle = "ground"
law = "newton"
e = 0.5
friction = 0.3
[simulation]
duration = 0.2
"""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "spinning_sphere.toml"
        path.write_text(text)
        scene = mbi.load_scene(path)
    tr = simulate_checked(scene)
    assert tr.status == "completed", tr.message
    assert tr.work["contact_steps"] > 100
    np.testing.assert_allclose(np.linalg.norm(tr.q[:, 3:7], axis=1), 1.0, rtol=0, atol=1e-12)
    scale = abs(tr.energy[0]) + float(np.abs(tr.energy).max()) + 1.0
    assert tr.energy.max() - tr.energy[0] <= 1e-12 * scale
    assert tr.energy[-1] <= tr.energy[0]


# ---------------------------------------------------------------- the cone solver

#: A Coulomb cone problem of one sliding foot (cond G = 120) on which ADMM stalls.
STALL_G = np.array([[4.0237120679589005, -2.288879263131299, 3.846328347057078],
                    [-2.288879263131299, 1.7114600927717483, -2.2899894645874337],
                    [3.846328347057078, -2.2899894645874337, 3.8324144309734334]])
STALL_g = np.array([2.9654999092903216, 0.51542111403276, -0.10892068242778086])


def check_coulomb(G: np.ndarray, g: np.ndarray, mus: tuple[float, ...], lam: np.ndarray, tol: float = 1e-9) -> None:
    """λ solves the Coulomb cone complementarity problem (G, g, μ): for each contact (tangential, normal last),
    λn ≥ 0, |λt| ≤ μ λn, σ = Gλ + g with σn ≥ 0, λn σn = 0; a sticking contact has σt = 0, a sliding one λt
    antiparallel to σt — to ``tol`` of the problem's scales."""
    assert lam.shape == g.shape and np.all(np.isfinite(lam))
    sigma = G @ lam + g
    s_scale = float(np.abs(g).max())
    l_scale = s_scale / float(np.abs(np.diag(G)).max())
    for k, mu in enumerate(mus):
        lt, ln = lam[3 * k:3 * k + 2], lam[3 * k + 2]
        st, sn = sigma[3 * k:3 * k + 2], sigma[3 * k + 2]
        assert ln >= -tol * l_scale
        assert np.linalg.norm(lt) <= mu * ln * (1 + tol) + tol * l_scale
        assert sn >= -tol * s_scale
        assert abs(ln * sn) <= tol * l_scale * s_scale
        if mu == 0.0 or ln <= tol * l_scale:  # frictionless or open: no tangential condition left
            continue
        if np.linalg.norm(lt) < mu * ln * (1 - 1e-6):  # inside the cone: sticking
            assert np.linalg.norm(st) <= 1e-6 * s_scale
        elif np.linalg.norm(st) > 1e-6 * s_scale:  # on its boundary and sliding: friction opposes the slip
            cos = lt @ st / (np.linalg.norm(lt) * np.linalg.norm(st))
            assert cos == pytest.approx(-1.0, abs=1e-6)


def test_cone_solver_solves_the_sliding_contact_where_admm_stalls():
    from mbimpact.simulation.cones import ConeSolver

    with time_limit(20.0):
        lam = ConeSolver().solve(STALL_G, STALL_g, (0.5,))
    check_coulomb(STALL_G, STALL_g, (0.5,), lam)
    np.testing.assert_allclose(lam, [-0.02572127, -0.0037595, 0.05198913], rtol=0, atol=1e-7)
    assert np.linalg.norm(lam[:2]) == pytest.approx(0.5 * lam[2], rel=1e-9)  # sliding: on the cone's boundary


def test_cone_solver_results_satisfy_coulomb_on_random_problems(rng):
    """Random well-conditioned problems of 1–4 contacts, each checked from G and g."""
    from mbimpact.simulation.cones import ConeSolver

    solver = ConeSolver()
    for _ in range(30):
        k = int(rng.integers(1, 5))
        G = spd(rng, 3 * k, cond=float(rng.choice([1.0, 10.0, 120.0])))
        g = rng.normal(size=3 * k)
        mus = tuple(float(m) for m in rng.choice([0.0, 0.3, 0.5, 1.0], k))
        check_coulomb(G, g, mus, solver.solve(G, g, mus), tol=1e-6)


# ---------------------------------------------------------------- energy_growth and passive scenes

def point_sliding(friction: float = 0.0, **kw) -> Scene:
    """A point mass resting on the plane z = 0, sliding at 1 m/s."""
    return Scene(mbi.Mechanism.from_model("point_mass_3d"), np.zeros(3), np.array([1.0, 0.0, 0.0]),
                 (SceneContact("mass", mbi.NewtonLaw(0.0), Surface(), friction=friction),), duration=0.5, **kw)


def test_energy_growth_is_in_the_statuses():
    assert "energy_growth" in STATUSES


class GainingLaw(mbi.NewtonLaw):
    """Newton's law with a restitution above 1 (set past the constructor's check): each impact creates
    energy, while the scene is classified passive."""

    def __init__(self, e: float) -> None:
        super().__init__(0.5)
        self.e = e


def simulate_quietly(scene: Scene) -> mbi.Trajectory:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.ImpactWarning)
        with time_limit(30.0):
            return mbi.simulate(scene)


def test_a_passive_run_whose_impacts_create_energy_stops_as_energy_growth():
    point = mbi.Mechanism.from_model("point_mass_3d")
    scene = Scene(point, np.array([0.0, 0.0, 0.2]), np.zeros(3), (SceneContact("mass", GainingLaw(1.2), Surface()),),
                  duration=2.0)
    tr = simulate_quietly(scene)
    assert tr.status == "energy_growth", (tr.status, tr.message)
    assert "energy of a passive scene rose" in tr.message
    t1 = math.sqrt(2 * 0.2 / 9.81)
    assert tr.t[-1] == pytest.approx(t1, rel=1e-6)  # stopped at the first impact, where it grew
    assert tr.energy[-1] == pytest.approx(1.44 * tr.energy[0], rel=1e-6)  # the state recorded: (1.2)² the energy
    # the same drop with e = 1 (no gain) completes
    assert simulate_quietly(dataclasses.replace(scene, contacts=(SceneContact("mass", GainingLaw(1.0), Surface()),),
                                                duration=0.5)).status == "completed"


def test_a_passive_run_whose_contact_steps_create_energy_stops_as_energy_growth(monkeypatch):
    """A defect injected in the Python contact step (every step's velocity 1 % faster; the compiled route
    off) is stopped and named."""
    from mbimpact.simulation import persistent

    monkeypatch.setattr(persistent, "compiled_steps", lambda state: None, raising=False)
    step_velocity = persistent.Persistent.step_velocity

    def faster(self, *args, **kwargs):
        return 1.01 * step_velocity(self, *args, **kwargs)

    monkeypatch.setattr(persistent.Persistent, "step_velocity", faster)
    scene = point_sliding()
    tr = simulate_quietly(scene)
    assert tr.status == "energy_growth", (tr.status, tr.message)
    assert "energy" in tr.message and "passive" in tr.message
    assert tr.t[-1] < scene.duration
    assert tr.energy[-1] > tr.energy[0]  # the output ends where it grew, the state recorded
    monkeypatch.setattr(persistent.Persistent, "step_velocity", step_velocity)
    assert simulate_checked(scene).status == "completed"  # unharmed, the same scene completes


def test_check_energy_raises_on_growth_and_accepts_rounding():
    from mbimpact.simulation.run import ENERGY_SLACK, RunState, Stop

    scene = point_sliding()
    state = RunState(scene, 10, None)
    assert state.passive
    q, v = scene.q0, scene.v0
    state.check_energy(0.0, q, v)  # the start
    state.check_energy(0.1, q, v * (1 + 1e-12))  # rounding
    state.check_energy(0.1, q, 0.5 * v)  # dissipation
    e0 = state.energy(q, v)
    grown = v * math.sqrt(1 + 100 * ENERGY_SLACK * (abs(e0) + 1) / e0)
    with pytest.raises(Stop) as stop:
        state.check_energy(0.2, q, grown)
    assert stop.value.status == "energy_growth"
    assert "rose" in stop.value.message and "t = 0.2" in stop.value.message
    nan = RunState(scene, 10, None)
    nan.check_energy(0.0, q, v)
    with pytest.raises(Stop):
        nan.check_energy(0.1, q, np.full(3, np.nan))  # a NaN energy is growth too


def test_passive_classification():
    from mbimpact.simulation.run import passive

    assert passive(point_sliding())
    assert passive(point_sliding(friction=0.5))
    assert not passive(robot_drop("solo12", 0.05, "newton", pd=True))
    assert passive(robot_drop("solo12", 0.05, "newton", pd=False))
    assert passive(robot_drop("solo12", 0.05, "rough", pd=False))
    assert passive(robot_drop("solo12", 0.05, "coulomb", pd=False))  # energetic restitution
    point = mbi.Mechanism.from_model("point_mass_3d")
    vibrating = Surface(amplitude=0.01, frequency=5.0)
    assert not passive(Scene(point, np.array([0.0, 0.0, 0.1]), np.zeros(3),
                             (SceneContact("mass", mbi.NewtonLaw(0.5), vibrating),), duration=0.1))
    for restitution, expected in (("newton", False), ("poisson", True), ("energetic", True)):
        scene = Scene(point, np.array([0.0, 0.0, 0.1]), np.zeros(3),
                      (SceneContact("mass", mbi.CoulombLaw(0.5, 0.3, restitution), Surface(), friction=0.3),),
                      duration=0.1)
        assert passive(scene) is expected, restitution
    torque = Scene(point, np.array([0.0, 0.0, 0.1]), np.zeros(3), (SceneContact("mass", mbi.NewtonLaw(0.5), Surface()),),
                   torque=np.array([0.0, 0.0, 1.0]), duration=0.1)
    assert not passive(torque)


@pytest.mark.parametrize("name", [n for n in mbi.scene_names()])
def test_shipped_passive_scenes_never_stop_for_energy_growth(name):
    from mbimpact.simulation.run import passive

    scene = mbi.load_scene(name)
    if not passive(scene):
        pytest.skip("not passive")
    tr = simulate_checked(dataclasses.replace(scene, duration=min(scene.duration, 0.5)))
    assert tr.status == "completed", (tr.status, tr.message)

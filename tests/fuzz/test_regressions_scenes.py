"""Regressions of the scene simulator's reproducers, found by :mod:`tests.fuzz.test_fuzz_scenes` and its nightly runs.

One test per reproducer: the exact error class and a fragment of its message, or the physics, with
every warning turned into an error (no numpy RuntimeWarning may leak) and the calls that could hang
under :func:`tests.helpers.time_limit`.
"""

from __future__ import annotations

import math
import re
import time
import warnings

import numpy as np
import pinocchio as pin
import pytest

import mbimpact as mbi
from mbimpact.simulation import Surface
from mbimpact.simulation.scene import DAMPING_MAX
from tests.helpers import time_limit

LIMIT = 30.0  # seconds per call: generous on a busy 2-core machine
G = 9.81


@pytest.fixture(autouse=True)
def strict():
    """Every warning is an error, and every test is bounded in time as a whole."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with time_limit(2 * LIMIT):
            yield


def point_mass_scene(**kwargs) -> mbi.Scene:
    """A point mass 1 m above a plane (m = 1 kg), the settings overridden by ``kwargs``."""
    settings = {"mechanism": mbi.Mechanism.from_model("point_mass_3d"), "q0": [0.0, 0.0, 1.0], "v0": [0.0, 0.0, 0.0],
                "contacts": (mbi.SceneContact("mass", mbi.NewtonLaw(0.5)),), "duration": 0.1, "max_wall_time": 10.0}
    return mbi.Scene(**{**settings, **kwargs})


def raises_scene_error(call, match: str) -> mbi.SceneError:
    """``call()`` raises exactly a SceneError whose message contains ``match``."""
    with time_limit(LIMIT), pytest.raises(mbi.ImpactError, match=match) as info:
        call()
    assert type(info.value) is mbi.SceneError, type(info.value)
    return info.value


# ---------------------------------------------------------------- 1. load_scene(None)

@pytest.mark.parametrize("source", [None, 3, 1.5, ["ball_drop"], b"ball_drop", "x" * 5000])
def test_1_load_scene_of_something_else_than_a_name_or_path(source):
    raises_scene_error(lambda: mbi.load_scene(source), "shipped scene" if isinstance(source, str) else
                       "a scene is a shipped scene's name")


# ---------------------------------------------------------------- 2. contacts=None

@pytest.mark.parametrize("contacts", [None, 5, 1.0, "mass", b"mass"])
def test_2_contacts_that_are_not_a_sequence(contacts):
    raises_scene_error(lambda: point_mass_scene(contacts=contacts), "contacts must be a list or tuple")


def test_2_a_single_contact_says_how_to_write_one():
    one = mbi.SceneContact("mass", mbi.NewtonLaw(0.5))
    raises_scene_error(lambda: point_mass_scene(contacts=one), r"for one contact write \(contact,\)")
    assert point_mass_scene(contacts=[one]).contacts == (one,)  # a list is a sequence


# ---------------------------------------------------------------- 3. record=None | [1.0] | array

@pytest.mark.parametrize("record, match", [
    (None, "record must be a list or tuple of state names"),
    ("q2", "record must be a list or tuple of state names"),
    ([1.0], "record entry 1.0 is not a state name: use q0…q2 or v0…v2"),
    (np.array([1.0, 2.0]), "is not a state name"),
    (np.array([["q0"]]), "flat list"),
    (["q²"], "record entry 'q²': use q0…q2"),
    (["q3"], "record entry 'q3': use q0…q2"),
])
def test_3_record_entries_that_are_not_state_names(record, match):
    raises_scene_error(lambda: point_mass_scene(record=record), match)


def test_3_record_as_an_array_of_names_is_valid():
    scene = point_mass_scene(record=np.array(["q2", "v0"]))
    assert scene.record == ("q2", "v0") and all(type(name) is str for name in scene.record)


# ---------------------------------------------------------------- 4., 5. arrays in place of a choice

@pytest.mark.parametrize("rule", [np.array(["auto", "newton"]), np.array(["auto"]), None, 1, ["auto"]])
def test_4_simultaneous_that_is_not_a_rule_name(rule):
    raises_scene_error(lambda: point_mass_scene(simultaneous=rule),
                       "simultaneous must be one of auto, newton, rough, compliant, sequential")


@pytest.mark.parametrize("kind", [np.array(["plane", "paraboloid"]), np.array(["plane"]), None, ["plane"]])
def test_5_surface_kind_that_is_not_a_kind_name(kind):
    raises_scene_error(lambda: Surface(kind=kind), "surface kind must be 'plane' or 'paraboloid'")


# ---------------------------------------------------------------- 6. a huge tangent

@pytest.mark.parametrize("scale", [1e-300, 1e-160, 1.0, 1e160, 1e200, 1e300])
def test_6_tangents_of_any_size_are_normalised_without_overflow(scale):
    n = np.array([0.0, 0.6, 0.8])
    contact = mbi.SceneContact("mass", mbi.NewtonLaw(0.5), Surface(normal=n), tangent=scale * np.array([1.0, 2.0, 0.0]))
    expected = np.array([1.0, 2.0, 0.0]) - 1.2 * n  # the part across n, then normalised
    np.testing.assert_allclose(contact.tangent, expected / np.linalg.norm(expected), atol=1e-15)
    pair = mbi.SceneCollision("a", mbi.NewtonLaw(0.5), other="b", tangent=[scale, scale, 0.0])
    np.testing.assert_allclose(pair.tangent, [math.sqrt(0.5), math.sqrt(0.5), 0.0], atol=1e-15)
    raises_scene_error(lambda: mbi.SceneContact("mass", mbi.NewtonLaw(0.5), Surface(normal=n), tangent=scale * n),
                       "must not be parallel to its surface normal")
    raises_scene_error(lambda: mbi.SceneContact("mass", mbi.NewtonLaw(0.5), tangent=[0.0, 0.0, 0.0]),
                       "must not be the zero vector")


# ---------------------------------------------------------------- 7. damping=1e12 | 1e308

@pytest.mark.parametrize("damping", [1e12, 1e308, 10**12, 1.0000001e6, -1.0, -1e-300])
def test_7_damping_beyond_its_range(damping):
    raises_scene_error(lambda: point_mass_scene(damping=damping), re.escape(f"is outside [0, {DAMPING_MAX:g}]"))


@pytest.mark.parametrize("damping", [1e2, 1e5, DAMPING_MAX])
def test_7_stiff_damping_falls_at_its_terminal_speed(damping):
    """A point mass (m = 1) with damping c thrown from 1 m: z(t) = 1 − g t / c + (v₀ + g / c)(1 − e^(−ct)) / c,
    x(t) = u₀ (1 − e^(−ct)) / c; stiff (c ≥ 3e4 1/s) it is integrated by Radau, in far less than a second."""
    u0, v0 = 0.3, 0.5
    scene = point_mass_scene(v0=[u0, 0.0, v0], damping=damping, duration=0.5)
    with time_limit(LIMIT):
        tr = mbi.simulate(scene, samples=11)
    assert tr.status == "completed", tr.message
    t, c = tr.t, damping
    decay = -np.expm1(-c * t)
    np.testing.assert_allclose(tr.q[:, 2], 1.0 - G * t / c + (v0 + G / c) * decay / c, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tr.q[:, 0], u0 * decay / c, rtol=0, atol=1e-9)
    assert tr.work["stiff_flights"] == (c > 3e4)


def test_7_stiff_damping_in_persistent_contact_is_stable():
    """Sliding on a frictionless plane, x_∞ = u₀ / c; the explicit step grew by |1 − h c| = 9999 a step."""
    scene = point_mass_scene(q0=[0.0, 0.0, 0.0], v0=[1.0, 0.0, 0.0], damping=1e4, duration=0.05)
    with time_limit(LIMIT):
        tr = mbi.simulate(scene, samples=6)
    assert tr.status == "completed", tr.message
    assert tr.work["contact_steps"] > 0
    assert tr.q[-1, 0] == pytest.approx(1e-4, rel=1e-3) and abs(tr.v[-1, 0]) < 1e-30


def test_7_damping_on_a_light_floating_sphere_completes():
    """The reproducer's body: inertia 1e-3 kg m², so damping 1e6 decays its spin at 1e9 1/s."""
    mech = mbi.Mechanism.from_model("sphere")
    q0 = mech.neutral()
    q0[2] = 0.05
    scene = mbi.Scene(mech, q0, np.full(mech.nv, 0.3), (mbi.SceneContact("bottom", mbi.NewtonLaw(0.5)),),
                      damping=DAMPING_MAX, duration=0.3, max_wall_time=10.0)
    start = time.perf_counter()
    with time_limit(LIMIT):
        tr = mbi.simulate(scene, samples=16)
    assert tr.status == "completed", tr.message
    assert time.perf_counter() - start < 10.0
    assert np.abs(tr.v[-1]).max() < 1e-4  # locked: the terminal speed g m / c = 1e-5 m/s


@pytest.mark.parametrize("case", ["dop853", "vibrating"])
def test_7_every_run_ends_within_max_wall_time(case):
    """A run that cannot finish stops with status "wall_time" at max_wall_time, set-up included."""
    if case == "dop853":  # stiff, just below the switch to Radau: tiny explicit steps over 100 s
        scene = point_mass_scene(damping=2.9e4, duration=100.0, max_wall_time=1.0)
    else:  # a surface vibrating at 1 THz: steps of 1/16 of its period
        surface = Surface(amplitude=1e-3, frequency=1e12)
        scene = point_mass_scene(contacts=(mbi.SceneContact("mass", mbi.NewtonLaw(0.5), surface),),
                                 max_wall_time=1.0)
    start = time.perf_counter()
    with time_limit(LIMIT):
        tr = mbi.simulate(scene, samples=8)
    elapsed = time.perf_counter() - start
    assert tr.status == "wall_time" and "max_wall_time = 1 s" in tr.message, (tr.status, tr.message)
    assert elapsed < 1.5, elapsed


# ---------------------------------------------------------------- 8. Python scenes raise SceneError

@pytest.mark.parametrize("build, match, cause", [
    (lambda: point_mass_scene(damping="x"), "damping must be a real number", mbi.ParameterError),
    (lambda: point_mass_scene(damping=math.nan), "damping must be finite", mbi.NonFiniteError),
    (lambda: point_mass_scene(rtol=0.5), r"rtol = 0.5 is outside", mbi.ParameterError),
    (lambda: point_mass_scene(duration="1"), "duration must be a real number", mbi.ParameterError),
    (lambda: point_mass_scene(max_impacts=0.5), "max_impacts must be an integer", mbi.ParameterError),
    (lambda: point_mass_scene(torque=[1.0]), "torque has shape", mbi.ShapeError),
    (lambda: point_mass_scene(q0=None), "initial state: q must be a numeric array", mbi.ShapeError),
    (lambda: point_mass_scene(contacts=(mbi.SceneContact("foot", mbi.NewtonLaw(0.5)),)),
     r"contacts\[0\] \(foot\): frame 'foot' not found", mbi.FrameNotFoundError),
    (lambda: mbi.SceneContact("mass", mbi.NewtonLaw(0.5), friction=-1.0), r"friction = -1 is outside",
     mbi.ParameterError),
    (lambda: mbi.SceneContact("mass", mbi.NewtonLaw(0.5), point=[0.0, math.inf, 0.0]), "point contains NaN",
     mbi.NonFiniteError),
    (lambda: mbi.SceneCollision("a", mbi.NewtonLaw(0.5), other="b", stiffness=0.0), r"stiffness = 0 is outside",
     mbi.ParameterError),
    (lambda: mbi.PD(-1.0, 0.0, [0.0]), r"pd: kp = -1 is outside", mbi.ParameterError),
    (lambda: Surface(normal=[0.0, 0.0, 0.0]), "surface normal is the zero vector", mbi.ShapeError),
    (lambda: Surface(amplitude=math.nan), "amplitude must be finite", mbi.NonFiniteError),
    (lambda: Surface("paraboloid", rho="x"), "rho must be a real number", mbi.ParameterError),
])
def test_8_python_scene_objects_raise_scene_errors(build, match, cause):
    exc = raises_scene_error(build, match)
    assert type(exc.__cause__) is cause  # the shared helper's error, kept as the cause


def test_8_a_file_and_python_raise_the_same_class_for_damping(tmp_path):
    text = (mbi.models_dir() / "scenes" / "ball_drop.toml").read_text()
    path = tmp_path / "ball_drop.toml"
    path.write_text(text.replace("[simulation]", "[forces]\ndamping = 1e7\n\n[simulation]"))
    exc = raises_scene_error(lambda: mbi.load_scene(path), r"forces\.damping \(line \d+\): damping = 1e\+07 is outside")
    assert "locked joint" in str(exc)
    raises_scene_error(lambda: point_mass_scene(damping=1e7), re.escape("damping = 1e+07 is outside"))


# ---------------------------------------------------------------- found on the way

@pytest.mark.parametrize("kwargs, match", [
    ({"amplitude": 0.01, "frequency": 1e308}, "finite peak velocity and acceleration"),
    ({"amplitude": 1e308, "frequency": 1.0}, "finite peak velocity and acceleration"),
    ({"kind": "paraboloid", "rho": 1e-320}, r"rho of a paraboloid must be ≥ 1e-06 m"),
    ({"kind": "paraboloid", "rho": -1e-7}, r"rho of a paraboloid must be ≥ 1e-06 m"),
])
def test_surfaces_whose_motion_or_curvature_overflow(kwargs, match):
    """Each ran into a RuntimeWarning (or math's ValueError from sin(inf)) in the run."""
    raises_scene_error(lambda: Surface(**kwargs), match)


def test_the_smallest_rtol_and_a_huge_velocity_leak_no_warning():
    """rtol = 1e-14 is below scipy's 100 ε (a UserWarning); |v| = 1e300 overflowed in its step-size control."""
    with time_limit(LIMIT):
        tr = mbi.simulate(point_mass_scene(rtol=1e-14, v0=[0.1, 0.0, 0.0]), samples=4)
        assert tr.status == "completed", tr.message
        tr = mbi.simulate(point_mass_scene(v0=[1e300, 0.0, -1e300]), samples=4)
    assert tr.status == "integration_error" and tr.message, (tr.status, tr.message)


# ---------------------------------------------------------------- 9. passive scenes that gained energy (nightly)

def energy_gain(tr: mbi.Trajectory) -> float:
    """The largest energy gain over the start, in the scale of the fuzzer's check (|E₀| + max |E| + 1)."""
    return float(tr.energy.max() - tr.energy[0]) / (abs(tr.energy[0]) + float(np.abs(tr.energy).max()) + 1.0)


def simulate_completed(scene: mbi.Scene) -> mbi.Trajectory:
    with time_limit(LIMIT):
        tr = mbi.simulate(scene)  # the fuzzer's 2000 samples
    assert tr.status == "completed", tr.message
    return tr


def test_9_a_contact_that_leaves_by_itself_after_a_plastic_impact_lifts_off_at_once():
    """The nightly bad-scene fuzzer's example (torque None): no gravity, the tip of the double pendulum
    strikes a tilted plane plastically at t = 0 and leaves it on its arc. It came to rest, and Moreau's
    first step pushed it off (its Jacobian at the step's start misses J̇v): two explicit steps before the
    lift-off gained 1.76e-6 J, 1.03e-6 of the scale (the fuzzer allowed 1e-6 then; its flight's error,
    :func:`tests.fuzz.test_fuzz_scenes.energy_slack`, is 2.7e-9 J); lifted off at t = 0, 7e-12."""
    mech = mbi.Mechanism.from_model("double_pendulum")
    plane = Surface("plane", [0.479425538604203, 0.0, 0.8775825618903728], [-0.03579773147547127, 0.0, -1.999286891731173])
    scene = mbi.Scene(mech, [0.03771906632801799, -0.039631458987390566], [0.6404226504432821, 0.10490011715303971],
                      (mbi.SceneContact("tip", mbi.NewtonLaw(0.0), plane),), gravity=False, duration=0.25, samples=16,
                      max_wall_time=10.0)
    tr = simulate_completed(scene)
    assert [(e.kind, e.t) for e in tr.events] == [("impact", 0.0), ("rest", 0.0), ("lift", 0.0)]
    assert tr.events[-1].rule == "free motion" and tr.work["contact_steps"] == 0
    assert energy_gain(tr) < 1e-10, energy_gain(tr)


def test_9_a_contact_that_leaves_slowly_lifts_off_at_once_too():
    """The nightly random-scene fuzzer's example (to 8 digits), found with the energy bound
    :func:`tests.fuzz.test_fuzz_scenes.energy_slack`: the same tip leaves the plane at 0.009 m/s², so that
    its free motion opens the gap by 5e-9 m in a step, less than the band (1e-8 m). It rested, was pushed
    off, and lifted off after two steps: 7.6e-9 J gained, 1.6 times the slack; lifted off at t = 0, 1e-16
    of the scale."""
    mech = mbi.Mechanism.from_model("double_pendulum")
    plane = Surface("plane", [0.479425538604203, 0.0, 0.8775825618903728], [1.1002846591565478, 0.0, -1.6363935086859387])
    scene = mbi.Scene(mech, [-0.42413833, -0.33562385], [0.17081375, 0.40648615],
                      (mbi.SceneContact("tip", mbi.NewtonLaw(0.0), plane),), gravity=False, duration=0.25, samples=16,
                      max_wall_time=10.0)
    tr = simulate_completed(scene)
    assert [(e.kind, e.t) for e in tr.events[:3]] == [("impact", 0.0), ("rest", 0.0), ("lift", 0.0)]
    assert energy_gain(tr) < 1e-10, energy_gain(tr)


def test_9_a_spinning_sphere_after_a_plastic_impact_lifts_off_at_once():
    """The nightly random-scene fuzzer's example: the floating sphere's body point "bottom" strikes a plane
    plastically while the sphere spins, and leaves it (no gravity). It stayed in persistent contact for
    the whole run and gained 2.2e-4 J, 1.9e-4 of the scale; lifted off at t = 0, 2e-13."""
    mech = mbi.Mechanism.from_model("sphere")
    q0 = [0.03771906632801799, -0.039631458987390566, 0.1921267951329846, 0.02239862887126437, -0.11437794172940895,
          0.07720900277724158, 0.9901791543759014]
    v0 = [0.2841242889387726, -0.21112057074209778, -0.37962644131381573, -0.18698233876120565, 0.01239779380417308,
          -0.6975092323916503]
    plane = Surface("plane", [0.0, 0.0, 1.0], [0.04887159411023343, -0.03653049276583364, 0.14348519634594148])
    scene = mbi.Scene(mech, q0, v0, (mbi.SceneContact("bottom", mbi.NewtonLaw(0.0), plane),), gravity=False,
                      duration=0.25, samples=16, max_wall_time=10.0)
    tr = simulate_completed(scene)
    assert [(e.kind, e.t) for e in tr.events] == [("impact", 0.0), ("rest", 0.0), ("lift", 0.0)]
    assert energy_gain(tr) < 1e-10, energy_gain(tr)


@pytest.mark.parametrize("gravity", [False, True])
def test_9_a_top_spinning_on_its_tip_slides_straight(gravity):
    """Found on the way: the sphere on its body point "bottom" (a top on its tip), sliding at 1 m/s on a
    frictionless plane while it spins at 10 rad/s about the vertical, in persistent contact. The step
    moved the origin along a straight line and kept its world velocity, but added Pinocchio's spatial
    acceleration (the rate of the body-axis components, −ω × v): the world velocity turned by −ω h a
    step and grew by O(h²) — after 0.1 s the sphere was at (0.084, −0.047) instead of (0.1, 0) and had
    gained 5e-3 J of 0.55 J."""
    mech = mbi.Mechanism.from_model("sphere")
    q0 = mech.neutral()
    plane = Surface(origin=mech.frame_position(q0, "bottom"))
    scene = mbi.Scene(mech, q0, [1.0, 0.0, 0.0, 0.0, 0.0, 10.0], (mbi.SceneContact("bottom", mbi.NewtonLaw(0.0), plane),),
                      gravity=gravity, duration=0.1, max_wall_time=10.0)
    with time_limit(LIMIT):
        tr = mbi.simulate(scene, samples=5)
    assert tr.status == "completed", tr.message
    assert all(tr.active[:, 0]) and tr.work["contact_steps"] == 100  # resting on its tip throughout
    np.testing.assert_allclose(tr.q[:, :3], np.outer(tr.t, [1.0, 0.0, 0.0]), rtol=0, atol=1e-12)
    world = np.array([pin.Quaternion(q[3:7]).matrix() @ v[:3] for q, v in zip(tr.q, tr.v)])  # v is in body axes
    np.testing.assert_allclose(world, np.tile([1.0, 0.0, 0.0], (len(tr.t), 1)), rtol=0, atol=1e-9)
    np.testing.assert_allclose(tr.v[:, 3:], np.tile([0.0, 0.0, 10.0], (len(tr.t), 1)), rtol=0, atol=1e-12)
    assert np.ptp(tr.energy) < 1e-9, np.ptp(tr.energy)


def test_9_a_huge_tolerance_bounds_penetration_only():
    """The nightly bad-scene fuzzer's first example (tolerance 1e308, valid): the double pendulum's tip
    starts on a tilted plane, gravity on. The tolerance was also the band above the surface within which
    a contact touches it: the tip rested at t = 0 and never lifted off (gap > 1e308), its flight
    integrated by first-order contact steps for the whole run — 4.7e-3 J gained in 0.1 s, 1.9e-4 of the
    scale. The band is now min(tolerance, BAND_MAX)."""
    mech = mbi.Mechanism.from_model("double_pendulum")
    plane = Surface("plane", [0.3331065186944532, 0.18197692054597692, 0.9251618494035868],
                    [-0.5459389426774706, 0.0, -1.9133053603107668], frequency=30.0)
    scene = mbi.Scene(mech, [0.17627146557755227, 0.20336075464012493], [0.9626572972538084, 3.791969386388186],
                      (mbi.SceneContact("tip", mbi.NewtonLaw(2.225073858507203e-309), plane),), duration=0.1,
                      tolerance=1e308, samples=16, max_wall_time=10.0)
    tr = simulate_completed(scene)
    assert [e.kind for e in tr.events] == ["rest", "lift"] and tr.work["contact_steps"] == 0
    assert energy_gain(tr) < 1e-10, energy_gain(tr)


def test_9_a_huge_tolerance_strikes_no_contact_at_a_distance():
    """With the tolerance as the band, a point mass starting 0.2 m above the plane and falling at 2 m/s
    struck it at t = 0, 0.2 m away; it strikes when it gets there, at √(v₀² + 2 g h) = 2.81 m/s."""
    with time_limit(LIMIT):
        tr = mbi.simulate(point_mass_scene(q0=[0.0, 0.0, 0.2], v0=[0.0, 0.0, -2.0], tolerance=1e308), samples=8)
    assert tr.status == "completed", tr.message
    first = tr.events[0]
    assert first.kind == "impact"
    assert first.t == pytest.approx((math.sqrt(4.0 + 2 * G * 0.2) - 2.0) / G, rel=1e-9)
    assert first.un_minus == pytest.approx(-math.sqrt(4.0 + 2 * G * 0.2), rel=1e-9)

"""The simulator against closed forms and independent references, and its guarantees."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.simulation import Scene, SceneContact, Surface

G = 9.81
POINT = mbi.Mechanism.from_model("point_mass_3d")


def point(law, surface=None, q=(0.0, 0.0, 0.3), v=(0.5, 0.0, 0.0), friction=0.0, **kw):
    return Scene(POINT, np.array(q, dtype=float), np.array(v, dtype=float),
                 (SceneContact("mass", law, surface or Surface(), friction=friction),), **kw)


@pytest.mark.parametrize("e, h", [(0.5, 0.3), (0.8, 1.0), (0.95, 0.05)])
def test_ball_drop_impact_times_rebounds_and_time_to_rest(e, h):
    t1 = math.sqrt(2 * h / G)
    rest = t1 * (1 + e) / (1 - e)
    tr = mbi.simulate(point(mbi.NewtonLaw(e), q=(0.0, 0.0, h), v=(0.0, 0.0, 0.0), duration=rest + 0.5), samples=200)
    assert tr.status == "completed"
    assert tr.first_rest_time() == pytest.approx(rest, rel=1e-9)
    impacts = [x for x in tr.events if x.kind == "impact"]
    k = np.arange(len(impacts))
    np.testing.assert_allclose([x.t for x in impacts], t1 + np.concatenate([[0], np.cumsum(2 * G * t1 * e ** k[1:] / G)]),
                               rtol=1e-11)
    np.testing.assert_allclose([x.un_plus for x in impacts], G * t1 * e ** (k + 1), rtol=1e-9)


@pytest.mark.parametrize("theta, mu", [(0.3, 0.5), (0.3, 0.2), (0.6, 0.1), (0.2, 0.0)])
def test_point_on_an_incline_sticks_or_slides_at_g_sin_minus_mu_cos(theta, mu):
    n = np.array([math.sin(theta), 0.0, math.cos(theta)])
    tr = mbi.simulate(point(mbi.NewtonLaw(0.0), Surface(normal=n), q=(0, 0, 0), v=(0, 0, 0), friction=mu, duration=1.0),
                      samples=50)
    a = max(0.0, G * (math.sin(theta) - mu * math.cos(theta)))
    np.testing.assert_allclose(np.linalg.norm(tr.v, axis=1), a * tr.t, atol=1e-9 * (1 + a))
    assert tr.resting == (True,) and np.abs(tr.gaps).max() < 1e-10
    assert (tr.work["friction_cone"] > 0) == (mu > 0)  # no friction declared: no cone


@pytest.mark.parametrize("theta, mu", [(0.3, 0.5), (0.4, 0.2)])
def test_box_on_an_incline_on_four_corners(theta, mu):
    """A box resting on its four bottom corners on a slope: stuck when tan θ < μ, else sliding at
    g (sin θ − μ cos θ) without turning (it does not tip: its centre is low)."""
    box = mbi.Mechanism.from_model("box", floating=True)
    n = np.array([math.sin(theta), 0.0, math.cos(theta)])
    # the box tilted with the slope, its bottom face on it
    quat = np.array([0.0, math.sin(theta / 2), 0.0, math.cos(theta / 2)])
    q = np.concatenate([0.05 * n, quat])
    contacts = tuple(SceneContact(f"corner{k}", mbi.NewtonLaw(0.0), Surface(normal=n), friction=mu) for k in range(4))
    tr = mbi.simulate(Scene(box, q, np.zeros(6), contacts, duration=0.5), samples=20)
    assert tr.status == "completed" and all(tr.resting)
    a = max(0.0, G * (math.sin(theta) - mu * math.cos(theta)))
    speed = np.linalg.norm(tr.v[:, :3], axis=1)
    np.testing.assert_allclose(speed, a * tr.t, atol=1e-6 * (1 + a))
    assert np.abs(tr.v[:, 3:]).max() < 1e-6  # no rotation
    np.testing.assert_allclose(tr.forces[-1].sum(axis=0) @ n, G * math.cos(theta), rtol=1e-6)  # the slope carries m g cos θ


def test_plate_vibrating_below_one_g_carries_the_ball():
    f = 5.0
    A = 0.5 * G / (2 * math.pi * f) ** 2  # Γ = 0.5
    tr = mbi.simulate(point(mbi.NewtonLaw(0.5), Surface(amplitude=A, frequency=f), q=(0, 0, 0), v=(0, 0, A * 2 * math.pi * f),
                            duration=2.0), samples=400)
    assert tr.status == "completed" and not tr.impact_times().size
    assert np.all(tr.active) and np.abs(tr.gaps).max() < 1e-9  # rides the plate, never below it
    np.testing.assert_allclose(tr.q[:, 2], A * np.sin(2 * math.pi * f * tr.t), atol=1e-9)


def test_plate_vibrating_above_one_g_throws_the_ball_when_it_decelerates_faster_than_gravity():
    f, gamma = 5.0, 1.3
    w = 2 * math.pi * f
    A = gamma * G / w**2
    tr = mbi.simulate(point(mbi.NewtonLaw(0.5), Surface(amplitude=A, frequency=f), q=(0, 0, 0), v=(0, 0, A * w),
                            duration=0.3), samples=100)
    lift = [x for x in tr.events if x.kind == "lift"][0]
    # riding, the ball leaves when the plate's acceleration −A ω² sin ωt falls below −g: sin ωt = 1/Γ
    assert lift.t == pytest.approx(math.asin(1 / gamma) / w, abs=2e-3)  # one contact step
    assert tr.impact_times().size > 0 and tr.min_gap >= -tr.tolerance


def test_bouncing_ball_period_doubling():
    """Above Γ₂ = sqrt(Γ₁² + (2(1+e²)/(1+e)²)²) the period-1 orbit of a ball on a vibrating table is
    unstable and a period-2 orbit takes over: flights alternate between two durations that add up to
    two periods of the table."""
    f, e = 5.0, 0.5
    w, T = 2 * math.pi * f, 1 / f
    g1 = math.pi * (1 - e) / (1 + e)
    g2 = math.hypot(g1, 2 * (1 + e * e) / (1 + e) ** 2)
    V, adot = G * T / 2, G * T / 2 * (1 - e) / (1 + e)
    for gamma, doubled in ((0.5 * (g1 + g2), False), (1.05 * g2, True)):
        A = gamma * G / w**2
        phase = math.acos(adot / (A * w))
        scene = point(mbi.NewtonLaw(e), Surface(amplitude=A, frequency=f, phase=phase), q=(0, 0, A * math.sin(phase)),
                      v=(0, 0, 1.01 * V), duration=8.0)
        flights = np.diff(mbi.simulate(scene, samples=50).impact_times())[-6:]
        np.testing.assert_allclose(flights[:-1] + flights[1:], 2 * T, rtol=1e-8)
        assert (abs(flights[0] - flights[1]) > 0.02) == doubled
        if not doubled:
            np.testing.assert_allclose(flights, T, rtol=1e-8)


def test_moving_surface_uses_the_relative_velocity():
    tr = mbi.simulate(point(mbi.NewtonLaw(0.5), Surface(amplitude=0.01, frequency=5.0), duration=0.6))
    assert tr.work["surface_motion"] > 0 and tr.impact_times().size
    for x in tr.events:
        if x.kind == "impact":
            assert x.un_plus == pytest.approx(-0.5 * x.un_minus, rel=1e-9)  # Newton on the relative velocity
    assert tr.min_gap >= -tr.tolerance


def test_a_grazing_crossing_inside_one_step_is_found():
    """No gravity, the point at rest 1 µm below the crest of a vibrating plate: the plate touches it for
    a fraction of a millisecond, between the points where the step's gap is checked; the minimum of
    the gap is found all the same, and the plate strikes the point."""
    f, A = 5.0, 0.01
    scene = point(mbi.NewtonLaw(1.0), Surface(amplitude=A, frequency=f), q=(0, 0, A - 1e-6), v=(0, 0, 0),
                  gravity=False, duration=0.2, rtol=1e-6)
    tr = mbi.simulate(scene, samples=20)
    hit = [x for x in tr.events if x.kind == "impact"]
    assert len(hit) == 1 and tr.min_gap >= -tr.tolerance
    assert hit[0].t == pytest.approx((math.pi / 2 - math.acos(1 - 1e-4)) / (2 * math.pi * f), rel=1e-6)
    assert tr.v[-1, 2] > 0  # thrown up


def test_very_rough_surface_with_kappa_below_zero_comes_to_rest():
    tr = mbi.simulate(point(mbi.RoughLaw(mbi.Cone(1.2), 0.0), duration=1.0))
    assert tr.status == "completed" and tr.resting == (True,)
    assert tr.min_gap >= -tr.tolerance


def test_undeclared_effects_cost_nothing():
    newton = mbi.simulate(point(mbi.RoughLaw(mbi.Smooth(), 0.5), duration=0.5))
    assert newton.work["facet_average"] == 0 and newton.work["newton_impact"] > 0  # no roughness: Newton path
    for effect in ("surface_motion", "damping", "pd", "friction_cone"):
        assert newton.work[effect] == 0, effect
    free = mbi.simulate(point(mbi.NewtonLaw(0.5), gravity=False, duration=0.5))
    assert free.work["gravity"] == 0 and free.work["dynamics"] > 0 and not free.events
    np.testing.assert_allclose(free.q[-1], [0.25, 0.0, 0.3], atol=1e-9)
    rough = mbi.simulate(point(mbi.RoughLaw(mbi.Cone(0.2), 0.5), friction=0.2, duration=2.0))
    assert rough.work["facet_average"] > 0 and rough.work["gravity"] == rough.work["dynamics"]
    assert rough.work["friction_cone"] > 0


@pytest.mark.parametrize("rule", ["newton", "compliant", "sequential", "rough"])
def test_two_ends_striking_together(rule):
    """A rod falling flat: both ends strike at once. Newton's law at both (and the compliant one with
    equal stiffnesses) sends it back up flat; one end after the other makes it turn."""
    rod = mbi.Mechanism.from_model("planar_rod")
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.8) if rule == "rough" else mbi.NewtonLaw(0.8)
    contacts = tuple(SceneContact(f, law, Surface(), stiffness=1e4) for f in ("end_a", "end_b"))
    scene = Scene(rod, np.array([0.0, 0.2, 1.0, 0.0]), np.array([0.0, -1.0, 0.0]), contacts, gravity=False, duration=0.3,
                  simultaneous=rule, samples=2000)
    tr = mbi.simulate(scene, samples=20)
    first = [x for x in tr.events if x.kind == "impact"][:2]
    assert {x.contact for x in first} == {0, 1} and first[0].t == first[1].t and first[0].group == 2
    if rule == "newton":
        assert tr.v[-1, 2] == pytest.approx(0.0, abs=1e-9) and tr.v[-1, 1] == pytest.approx(0.8, rel=1e-9)
    elif rule == "compliant":  # coupled through the rod, the two springs restitute otherwise than one
        assert tr.v[-1, 2] == pytest.approx(0.0, abs=1e-6) and tr.v[-1, 1] > 0.5
    elif rule == "sequential":
        assert abs(tr.v[-1, 2]) > 1e-3  # one end first: the rod turns
    else:  # the rough rule: facet realisations at both ends, averaged; symmetric only on average
        assert tr.v[-1, 1] > 0 and abs(tr.v[-1, 2]) < 0.2 and abs(tr.v[-1, 0]) < 0.2
    assert tr.work[f"simultaneous_{rule}"] == 1


def test_floating_base_stays_on_the_manifold():
    solo = mbi.Mechanism.from_robot("solo12")
    q = solo.neutral()
    q[2] = 0.4
    scene = Scene(solo, q, np.zeros(solo.nv), (SceneContact("HR_FOOT", mbi.NewtonLaw(0.3), friction=0.5),),
                  duration=0.4)
    tr = mbi.simulate(scene, samples=50)
    assert tr.status == "completed" and tr.impact_times().size
    np.testing.assert_allclose(np.linalg.norm(tr.q[:, 3:7], axis=1), 1.0, atol=1e-9)
    assert tr.min_gap >= -tr.tolerance


@pytest.mark.parametrize("limit, status", [({"max_impacts": 5}, "max_impacts"), ({"max_wall_time": 1e-3}, "wall_time"),
                                           ({"rest_velocity": 0.0, "chatter_time": 0.0, "max_events_per_second": 1e3},
                                            "event_limit")])
def test_limits_stop_the_run_with_a_named_status(limit, status):
    """Never resting, the bounces accumulate without end (Zeno): the event limit stops it."""
    tr = mbi.simulate(point(mbi.NewtonLaw(0.9), q=(0, 0, 1.0), v=(0, 0, 0), duration=20.0, **limit), samples=50)
    assert tr.status == status and not tr.completed and tr.message
    assert tr.t[-1] < 20.0 and tr.min_gap >= -tr.tolerance

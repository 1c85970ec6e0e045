"""Every shipped scene does what its comment says, checked by its physics."""

from __future__ import annotations

import functools
import math

import numpy as np
import pinocchio as pin
import pytest

import mbimpact as mbi

G = 9.81


@functools.lru_cache(maxsize=None)
def run(name: str, samples: int = 2000) -> mbi.Trajectory:
    return mbi.simulate(mbi.load_scene(name), samples=samples)


def test_every_shipped_scene_completes_above_its_surfaces():
    names = mbi.scene_names()
    assert {"ball_drop", "ball_on_rough_plane", "ball_on_vibrating_plate", "particle_vibrating_surface", "box_landing",
            "rimless_wheel_slope", "solo12_landing", "ur5_strikes_table", "double_pendulum_wall"} <= set(names)
    for name in names:
        tr = run(name)
        assert tr.status == "completed", (name, tr.message)
        assert tr.min_gap >= -tr.tolerance, name
        assert abs(tr.t[-1] - mbi.load_scene(name).duration) < 1e-12


def test_ball_drop_rests_at_the_zeno_limit():
    tr = run("ball_drop")
    h, e = 1.0, 0.8
    t1 = math.sqrt(2 * h / G)
    assert tr.first_rest_time() == pytest.approx(t1 * (1 + e) / (1 - e), rel=1e-9)
    impacts = [x for x in tr.events if x.kind == "impact"]
    v0 = G * t1
    times = t1 + np.concatenate([[0.0], np.cumsum(2 * v0 * e ** np.arange(1, len(impacts)) / G)])
    np.testing.assert_allclose([x.t for x in impacts], times, rtol=1e-11, atol=1e-12)
    # rebound k leaves at e^k √(2gh): the apex heights are e^{2k} h
    rebounds = np.array([x.un_plus for x in impacts])
    np.testing.assert_allclose(rebounds ** 2 / (2 * G), h * e ** (2 * np.arange(1, len(impacts) + 1)), rtol=1e-9)
    after = tr.t > tr.first_rest_time()
    assert np.abs(tr.q[after, 2]).max() < 1e-12 and np.abs(tr.v[after]).max() < 1e-9


def test_ball_on_rough_plane_rests_then_slides_to_a_stop_at_mu_g():
    tr = run("ball_on_rough_plane")
    rest = tr.first_rest_time()
    assert rest is not None
    impacts = [x for x in tr.events if x.kind == "impact"]
    assert all(x.mu > 0 for x in impacts)  # every bounce takes horizontal speed
    assert np.all(np.diff([x.ut_plus for x in impacts]) < 0)
    # persistent from its last impact on (its remaining bounces, summed as the Zeno tail, are below
    # what the scene resolves): it slides with Coulomb friction
    sliding = tr.active[:, 0] & (tr.t > impacts[-1].t) & (np.abs(tr.v[:, 0]) > 1e-3)
    decel = -np.diff(tr.v[sliding, 0]) / np.diff(tr.t[sliding])
    assert sliding.sum() > 10 and np.allclose(decel, 0.3 * G, rtol=1e-6)  # Coulomb: μ g
    assert rest > impacts[-1].t
    assert abs(tr.v[-1, 0]) < 1e-9 and abs(tr.q[-1, 2]) < 1e-9  # stopped, on the plane
    assert np.all(np.diff(tr.energy) <= 1e-9)


def test_ball_on_vibrating_plate_stays_on_the_period_one_orbit():
    tr = run("ball_on_vibrating_plate")
    impacts = [x for x in tr.events if x.kind == "impact"]
    # at t = 0.2 k, k = 1 … 19, and the one at k = 20 if rounding puts it before the end (t = 4)
    assert len([x for x in impacts if x.t < 4.0 - 1e-9]) == 19 and len(impacts) in (19, 20)
    np.testing.assert_allclose(np.diff([x.t for x in impacts]), 0.2, rtol=1e-8)
    np.testing.assert_allclose([x.un_plus for x in impacts], 0.981 * (1 - 1 / 3), rtol=1e-7)  # V − ȧ, ȧ = V(1−e)/(1+e)


def test_particle_on_vibrating_paraboloid_decays_as_section_4_says():
    tr = run("particle_vibrating_surface")
    st = mbi.section4.stability(mbi.Cone(0.3), 0.8, 1)
    w = 2 * math.pi * 5.0
    x = np.interp(tr.impact_times(), tr.t, tr.q[:, 0])
    assert len(x) == 30 and abs(x[-1]) < 0.1 * 1e-3
    assert mbi.section4.growth_rate(x) == pytest.approx(st.growth((G / w**2) / 0.3, 1), rel=1e-4)
    assert math.exp(st.growth((G / w**2) / 0.3, 1)) == pytest.approx(math.sqrt(1 - st.lam), rel=1e-9)  # complex pair


def test_box_lands_flat_on_four_corners_and_rests_with_a_quarter_of_its_weight_each():
    tr = run("box_landing")
    first = [x for x in tr.events if x.kind == "impact"][:4]
    assert {x.contact for x in first} == {0, 1, 2, 3} and all(x.group == 4 and x.rule == "newton" for x in first)
    assert len({x.t for x in first}) == 1
    np.testing.assert_allclose([x.kappa for x in first], 0.5, rtol=1e-9)  # back up flat, e = 0.5
    assert np.abs(tr.q[:, 3:6]).max() < 1e-9  # the quaternion never leaves the identity: no tipping
    assert all(tr.resting) and tr.q[-1, 2] == pytest.approx(0.05, abs=1e-9)
    np.testing.assert_allclose(tr.forces[-1, :, 2], G / 4, rtol=1e-6)
    np.testing.assert_allclose(tr.forces[-1, :, :2], 0.0, atol=1e-9)


def mcgeer(N: int = 10, L: float = 0.5, I: float = 0.01, m: float = 1.0, gamma: float = 0.1) -> tuple[float, float]:
    a = math.pi / N
    eta = (I + m * L * L * math.cos(2 * a)) / (I + m * L * L)
    K = 4 * m * G * L * math.sin(a) * math.sin(gamma) / (I + m * L * L)
    return eta, K


def test_rimless_wheel_settles_into_mcgeers_limit_cycle():
    """Before each impact the hub turns at ω₋; the stance conserves energy, ω₋²(k+1) = ω₊²(k) + K, and the
    plastic sticking impact keeps the angular momentum about the new foot, ω₊ = η ω₋: the fixed point is
    ω₋ = √(K / (1 − η²))."""
    tr = run("rimless_wheel_slope")
    eta, K = mcgeer()
    fixed = math.sqrt(K / (1 - eta**2))
    impacts = [x for x in tr.events if x.kind == "impact"]
    w_minus = np.array([tr.v[tr.before(x.t), 2] for x in impacts])
    assert len(w_minus) >= 14
    # the map of McGeer, step by step (first-order contact stepping: a few 1e-3)
    np.testing.assert_allclose(w_minus[1:] ** 2, eta**2 * w_minus[:-1] ** 2 + K, rtol=5e-3)
    assert abs(w_minus[0] - fixed) > 0.05 * fixed  # started well away from it
    assert w_minus[-1] == pytest.approx(fixed, rel=3e-3)
    assert all(x.kappa == pytest.approx(0.0, abs=1e-9) and x.ut_plus < 1e-9 for x in impacts)  # plastic, sticking


def test_solo12_lands_on_four_rough_feet_together_and_stands():
    tr = run("solo12_landing")
    first = [x for x in tr.events if x.kind == "impact"][:4]
    assert {x.contact for x in first} == {0, 1, 2, 3} and all(x.group == 4 and x.rule.startswith("rough") for x in first)
    assert all(tr.resting)
    assert np.abs(tr.v[-1]).max() < 1e-3  # at rest
    assert tr.q[-1, 2] > 0.15  # standing: the base well above the ground
    mass = pin.computeTotalMass(mbi.load_scene("solo12_landing").mechanism.model)
    assert tr.forces[-1, :, 2].sum() == pytest.approx(mass * G, rel=1e-2)  # the feet carry its weight


def test_ur5_strikes_the_table_and_comes_to_rest_on_it():
    tr = run("ur5_strikes_table")
    impacts = [x for x in tr.events if x.kind == "impact"]
    assert impacts and impacts[0].rule.startswith("RoughLaw") and impacts[0].un_minus < -0.3
    assert tr.resting == (True,)
    assert abs(tr.gaps[-1, 0]) < 1e-8
    # the damped joints settle: the motion left at the end is small and still dying out
    one_second_before = np.searchsorted(tr.t, tr.t[-1] - 1.0)
    assert np.abs(tr.v[-1]).max() < 5e-3 < np.abs(tr.v[one_second_before]).max()
    assert tr.forces[-1, 0, 2] > 0.0  # pressing on the table


def test_double_pendulum_loses_energy_only_at_its_strikes():
    tr = run("double_pendulum_wall")
    impacts = tr.impact_times()
    assert len(impacts) >= 1
    segments = np.split(np.arange(len(tr.t)), [tr.before(t) + 1 for t in impacts])  # between pre and post
    for seg in segments:
        if len(seg) > 2:
            assert np.ptp(tr.energy[seg]) < 1e-8 * abs(tr.energy[0])  # no damping: constant in flight
    for t in impacts:
        k = tr.before(t)
        assert tr.energy[k + 1] < tr.energy[k]

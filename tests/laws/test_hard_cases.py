"""Hard cases stay finite and obey the invariants, or fail with a named error."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mbimpact as mbi

from tests.helpers import ROBOTS, approaching, last_frame, mechanism, seeds, spd

I2, I3 = np.eye(2), np.eye(3)


def sound(res, cond=1.0):
    """Finite, energy not created, (1.1) satisfied to the accuracy cond(A) allows."""
    assert np.all(np.isfinite(res.v_plus)) and np.all(np.isfinite(res.P))
    assert res.energy_loss >= -1e-10 * max(res.T_minus, 1e-300)
    assert res.residual < max(1e-9, 1e-14 * cond)


LAWS3 = [mbi.NewtonLaw(0.5), mbi.RoughLaw(mbi.Cone(0.5), 0.5), mbi.RoughLaw(mbi.GaussianSlopes(0.4), 0.5),
         mbi.RoughLaw(mbi.Cone(0.5), 0.5, flux="physical")]


@pytest.mark.parametrize("ratio", [1e-3, 1e-6, 1e-9, 1e-12])
@pytest.mark.parametrize("law", LAWS3, ids=repr)
def test_grazing_incidence(law, ratio):
    v = np.array([1.0, 0.0, -ratio])
    res = law.apply(I3, I3, v, [0, 0, 1])
    sound(res)
    assert res.P_n > 0


@pytest.mark.parametrize("alpha", [0.1, 0.5, 1.2])
def test_continuity_across_the_switch_on_a_mechanism(alpha, rng):
    mech = mechanism("ur5")
    q = mech.random_configuration(rng)
    A, J = mech.mass_matrix(q), mech.point_jacobian(q, "tool0")
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5)
    out = []
    for eps in (-1e-10, 0.0, 1e-10):
        beta = math.pi / 2 - alpha + eps
        u = np.array([math.sin(beta), 0.0, -math.cos(beta)])
        out.append(law.apply(A, J, np.linalg.lstsq(J, u, rcond=None)[0], [0, 0, 1]).v_plus)
    scale = np.linalg.norm(out[1])  # a 1e-10 step in β moves v₊ by O(1e-10): continuity to 1e-9
    assert np.linalg.norm(out[0] - out[1]) <= 1e-9 * scale
    assert np.linalg.norm(out[2] - out[1]) <= 1e-9 * scale


def test_tilt_limits():
    v = np.array([0.6, 0.2, -1.0])
    newton = mbi.NewtonLaw(0.5).apply(I3, I3, v, [0, 0, 1])
    tiny = mbi.RoughLaw(mbi.Cone(1e-9), 0.5).apply(I3, I3, v, [0, 0, 1])
    np.testing.assert_allclose(tiny.v_plus, newton.v_plus, atol=1e-8)
    for alpha in (math.pi / 2 - 1e-6, math.pi / 2 - 1e-12):
        for law in (mbi.RoughLaw(mbi.Cone(alpha), 0.5), mbi.RoughLaw(mbi.Sawtooth(alpha), 0.5)):
            d = law.dim
            res = law.apply(np.eye(d), np.eye(d), v[-d:] if d == 3 else v[[0, 2]], np.eye(d)[-1])
            sound(res)


@pytest.mark.parametrize("law", [mbi.RoughLaw(mbi.Cone(0.4), 0.0), mbi.RoughLaw(mbi.Cone(0.4), 1.0),
                                 mbi.RoughLaw(mbi.Cone(0.4), k=1.0), mbi.RoughLaw(mbi.Cone(0.4), k=1 - 1e-12),
                                 mbi.NewtonLaw(0.0), mbi.NewtonLaw(1.0)], ids=repr)
def test_restitution_limits(law):
    res = law.apply(I3, I3, [0.3, 0.0, -1.0], [0, 0, 1])
    sound(res)
    if law.e == 1.0 and isinstance(law, mbi.NewtonLaw):
        assert res.energy_loss == pytest.approx(0.0, abs=1e-15)
    if law.e == 0.0 and isinstance(law, mbi.NewtonLaw):
        assert res.kappa == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("scale", [1e-8, 1e-4, 1.0, 1e4, 1e8])
@pytest.mark.parametrize("law", LAWS3, ids=repr)
def test_velocity_scales(law, scale):
    v = np.array([0.7, -0.2, -1.0])
    base = law.apply(I3, I3, v, [0, 0, 1])
    res = law.apply(I3, I3, scale * v, [0, 0, 1])
    sound(res)
    np.testing.assert_allclose(res.dv, scale * base.dv, rtol=1e-11)


def sound_or_flagged(law, *args, cond):
    """Sound; a quadrature that could not reach rtol must say so (AccuracyWarning)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", mbi.AccuracyWarning)
        res = law.apply_metric(*args) if isinstance(args[0], mbi.ContactMetric) else mbi.impact(*args, law)
    sound(res, cond)
    flagged = any(issubclass(w.category, mbi.AccuracyWarning) for w in caught)
    if not isinstance(law, mbi.RoughLaw):
        assert not flagged
    elif flagged:
        assert res.error_estimate > law.rtol
    else:  # rtol, or the documented rounding floor 100 ε √K of a sum of K ≤ 10⁶ facets
        assert res.error_estimate <= max(law.rtol, 100 * np.finfo(float).eps * 1e3)
    return res


@pytest.mark.parametrize("cond", [1e6, 1e9, 1e12])
def test_ill_conditioned_mass_matrix(cond, rng):
    A = spd(rng, 7, cond)
    J = rng.normal(size=(3, 7))
    v = approaching(J, rng.normal(size=7), np.array([0, 0, 1.0]))
    metric = mbi.ContactMetric.from_arrays(A, J)
    for law in LAWS3:
        sound_or_flagged(law, metric, v, mbi.local_basis([0, 0, 1], 3), cond=cond)


def test_tiny_link_masses_on_a_robot():
    mech = mbi.Mechanism.from_robot("ur5")
    model = mech.model.copy()
    for inertia in model.inertias[1:]:
        inertia.mass *= 1e-6
        inertia.inertia *= 1e-6
    model.inertias[-1].mass = 1e-12
    tiny = mbi.Mechanism(model, "ur5-light")
    q = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
    J = tiny.point_jacobian(q, "tool0")
    res = mbi.impact(tiny, q, -J[2], mbi.PointContact("tool0"), mbi.RoughLaw(mbi.Cone(0.3), 0.5))
    sound(res)


def test_near_singular_arm_posture():
    mech = mechanism("ur5")
    q = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])  # upright, elbow straight: J nearly loses rank
    J = mech.point_jacobian(q, "tool0")
    assert np.linalg.svd(J, compute_uv=False)[-1] < 1e-3 * np.linalg.svd(J, compute_uv=False)[0]
    v = np.linalg.lstsq(J, [0.2, 0.1, -1.0], rcond=None)[0]
    for law in LAWS3:
        # W has eigenvalues spread over 1e7: the averages converge slowly and say so
        sound_or_flagged(law, mech, q, v, mbi.PointContact("tool0"), cond=1e8)


@pytest.mark.parametrize("law", LAWS3[1:], ids=repr)
def test_rank_deficient_contact_jacobian(law):
    """A planar mechanism with a spatial contact: W has rank 2."""
    mech = mbi.Mechanism.from_model("double_pendulum")
    q = np.array([0.4, 0.9])
    J = mech.point_jacobian(q, "tip")
    v = approaching(J, np.array([1.0, -2.0]), np.array([0, 0, 1.0]))
    res = mbi.impact(mech, q, v, mbi.PointContact("tip"), law)
    sound(res)
    assert abs(res.P[1]) < 1e-12 * np.linalg.norm(res.P)  # no impulse out of the plane of motion


def test_huge_facet_set():
    rng = np.random.default_rng(8)
    k = 100_000
    phi = rng.uniform(0, 2 * np.pi, k)
    tilt = 0.4
    m = np.column_stack([np.sin(tilt) * np.cos(phi), np.sin(tilt) * np.sin(phi), np.full(k, np.cos(tilt))])
    v = [0.5, 0.1, -1.0]
    res = mbi.RoughLaw(mbi.Facets(m), 0.5).apply(I3, I3, v, [0, 0, 1])
    sound(res)
    cone = mbi.RoughLaw(mbi.Cone(tilt), 0.5).apply(I3, I3, v, [0, 0, 1])
    np.testing.assert_allclose(res.dv, cone.dv, rtol=2e-2, atol=1e-2)


def _random_rough(rng, d):
    kind = int(rng.integers(4))
    if kind == 0:
        return mbi.Cone(rng.uniform(0, 1.5)) if d == 3 else mbi.Sawtooth(rng.uniform(0, 1.5))
    if kind == 1:
        return mbi.GaussianSlopes(rng.uniform(0.01, 1.0), dim=d)
    if kind == 2:
        return mbi.Smooth()
    tilt = rng.uniform(0, 1.4, 6)
    az = rng.uniform(0, 2 * np.pi, 6)
    m = np.column_stack([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)])
    return mbi.Facets(m, rng.uniform(0.1, 1, 6))


def _robot_case(name, seed):
    mech = mechanism(name)
    rng = np.random.default_rng(seed)
    q = mech.random_configuration(rng)
    n0 = rng.normal(size=3)
    contact = mbi.PointContact(last_frame(mech), normal=n0)
    J = mech.point_jacobian(q, contact.frame)
    v = approaching(J, rng.normal(size=mech.nv) * 10 ** rng.uniform(-4, 4), contact.normal)
    law = mbi.RoughLaw(_random_rough(rng, 3), float(rng.uniform(0, 1)),
                       flux=str(rng.choice(["configuration", "physical"])))  # type: ignore[arg-type]
    try:
        with warnings.catch_warnings():  # a nearly singular W may stop the quadrature early: flagged, still sound
            warnings.simplefilter("ignore", mbi.AccuracyWarning)
            res = mbi.impact(mech, q, v, contact, law)
    except mbi.NoFacingFacetError:
        return
    except mbi.NoImpactError:
        assert abs(contact.normal @ J @ v) <= 1e-12 * np.linalg.norm(J @ v) + 1e-300
        return
    sound(res, 1e8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)
        scaled = mbi.impact(mech, q, 3.0 * v, contact, law)
    np.testing.assert_allclose(scaled.dv, 3.0 * res.dv, rtol=1e-9, atol=1e-12 * np.abs(res.dv).max())


@given(st.sampled_from(ROBOTS), seeds)
def test_random_robots_configurations_velocities_roughness(name, seed):
    _robot_case(name, seed)


@pytest.mark.slow
@settings(max_examples=10_000, deadline=None)
@given(st.sampled_from(ROBOTS), seeds)
def test_random_robots_nightly(name, seed):
    """The same property over ≥ 1e4 cases: ``pytest -m slow``."""
    _robot_case(name, seed)

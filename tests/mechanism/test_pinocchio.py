"""mbimpact on Pinocchio mechanisms: Newton's law is pin.impulseDynamics."""

import math
import warnings

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi

from tests.helpers import ROBOTS, approaching, last_frame, mechanism, seeds


def random_state(mech, seed):
    rng = np.random.default_rng(seed)
    q = mech.random_configuration(rng)
    return rng, q, rng.normal(size=mech.nv)


@given(st.sampled_from(ROBOTS), seeds, st.floats(0.0, 1.0))
def test_newton_law_is_pinocchio_impulse_dynamics(name, seed, e):
    """NewtonLaw(e) and RoughLaw(Smooth(), e) equal pin.impulseDynamics to 1e-12."""
    mech = mechanism(name)
    rng, q, v = random_state(mech, seed)
    n0 = rng.normal(size=3)
    n0 /= np.linalg.norm(n0)
    contact = mbi.PointContact(last_frame(mech), normal=n0)
    J = mech.point_jacobian(q, contact.frame)
    if np.linalg.norm(n0 @ J) < 1e-6:
        return  # the point cannot move along n0 in this posture
    v = approaching(J, v, n0)
    data = mech.model.createData()
    expected = pin.impulseDynamics(mech.model, data, q, v, (n0 @ J)[None, :], e, 0.0).copy()
    scale = np.abs(expected).max() + np.abs(v).max()
    for law in (mbi.NewtonLaw(e), mbi.RoughLaw(mbi.Smooth(), e)):
        res = mbi.impact(mech, q, v, contact, law)
        np.testing.assert_allclose(res.v_plus, expected, rtol=0, atol=1e-12 * scale)
        assert res.kappa == pytest.approx(e, abs=1e-9)


@given(st.sampled_from(ROBOTS), seeds, st.floats(0.0, 1.3), st.floats(0.0, 1.0))
def test_rough_impacts_on_robots_dissipate_and_reach_the_surface(name, seed, alpha, e):
    mech = mechanism(name)
    rng, q, v = random_state(mech, seed)
    contact = mbi.PointContact(last_frame(mech), normal=rng.normal(size=3))
    J = mech.point_jacobian(q, contact.frame)
    if abs(contact.normal @ J @ v) < 1e-6 * np.linalg.norm(J @ v):
        return  # grazing or immobile along n0: covered by the hard-case tests
    v = approaching(J, v, contact.normal)
    law = mbi.RoughLaw(mbi.Cone(alpha), e)
    with warnings.catch_warnings(record=True) as caught:
        # a planar mechanism (double_pendulum) with a spatial contact has a rank-deficient W: the
        # quadrature may stop at rounding above rtol, and then says so
        warnings.simplefilter("always", mbi.AccuracyWarning)
        res = mbi.impact(mech, q, v, contact, law)
    assert not caught or res.error_estimate > law.rtol
    assert np.all(np.isfinite(res.v_plus))
    assert res.energy_loss >= -1e-10 * res.T_minus
    assert res.residual < 1e-9
    assert res.P_n > 0
    np.testing.assert_allclose(res.I, mech.mass_matrix(q) @ res.dv, rtol=1e-8, atol=1e-10 * np.abs(res.I).max())


@pytest.mark.parametrize("name", ["solo12", "talos"])
def test_floating_base_models(name):
    """nq ≠ nv: quaternions in q, angular velocity in v."""
    mech = mechanism(name)
    assert mech.nq == mech.nv + 1
    q = mech.random_configuration(np.random.default_rng(3))
    contact = mbi.PointContact(last_frame(mech))
    v = -mech.point_jacobian(q, contact.frame)[2] * 0.5  # along -∇f: approaches
    res = mbi.impact(mech, q, v, contact, mbi.NewtonLaw(0.0))
    assert res.u_plus[2] == pytest.approx(0.0, abs=1e-12)
    expected = pin.impulseDynamics(mech.model, mech.model.createData(), q, v,
                                   mech.point_jacobian(q, contact.frame)[2:3], 0.0, 0.0)
    np.testing.assert_allclose(res.v_plus, expected, atol=1e-12 * np.abs(v).max())


def test_unnormalised_quaternion_is_rejected():
    mech = mechanism("solo12")
    q = mech.neutral()
    q[3:7] = [0.5, 0.5, 0.5, 0.6]
    with pytest.raises(mbi.ParameterError, match="normalis"):
        mbi.impact(mech, q, np.ones(mech.nv), mbi.PointContact("HR_FOOT"), mbi.NewtonLaw(0.5))


def test_point_masses_have_identity_mass_matrix():
    for name, n in (("point_mass_2d", 2), ("point_mass_3d", 3)):
        mech = mbi.Mechanism.from_model(name)
        q = mech.neutral()
        np.testing.assert_allclose(mech.mass_matrix(q), np.eye(n), atol=1e-15)


def test_planar_point_mass_through_impact_equals_sawtooth_formula():
    """The planar contact space (t, n⁰) of a planar mechanism with the paper's sawtooth."""
    mech = mbi.Mechanism.from_model("point_mass_2d")
    contact = mbi.PointContact("mass", normal=(0, 0, 1), tangent=(1, 0, 0))
    law = mbi.RoughLaw(mbi.Sawtooth(0.3), 0.5)
    v = np.array([0.4, -1.0])
    res = mbi.impact(mech, mech.neutral(), v, contact, law)
    ref = law.apply(np.eye(2), np.eye(2), v, [0, 1])
    np.testing.assert_allclose(res.v_plus, ref.v_plus, atol=1e-15)


def test_spatial_point_mass_through_impact_equals_cone_on_arrays():
    mech = mbi.Mechanism.from_model("point_mass_3d")
    law = mbi.RoughLaw(mbi.Cone(0.4), 0.5)
    v = np.array([0.4, -0.2, -1.0])
    res = mbi.impact(mech, mech.neutral(), v, mbi.PointContact("mass"), law)
    np.testing.assert_allclose(res.v_plus, law.apply(np.eye(3), np.eye(3), v, [0, 0, 1]).v_plus, atol=1e-14)


def test_contact_point_offset_equals_frame_at_that_point():
    mech = mbi.Mechanism.from_model("planar_rod")
    q = np.array([0.1, 0.6, 0.0, 0.0])
    q[2:4] = [math.cos(0.4), math.sin(0.4)]  # continuous joint: (cos θ, sin θ)
    J_end = mech.point_jacobian(q, "end_b")
    J_off = mech.point_jacobian(q, "rod", np.array([0.5, 0.0, 0.0]))
    np.testing.assert_allclose(J_off, J_end, atol=1e-14)
    np.testing.assert_allclose(mech.frame_position(q, "rod", np.array([0.5, 0, 0])),
                               mech.frame_position(q, "end_b"), atol=1e-14)


def test_rod_falling_on_one_end_newton_closed_form():
    """Planar rod (m = 1, l = 1) hitting with one end: W_nn = 1/m + r_x²/I."""
    mech = mbi.Mechanism.from_model("planar_rod")
    th = 0.5
    q = np.array([0.0, 1.0, math.cos(th), math.sin(th)])
    v = np.array([0.0, -2.0, 0.0])
    res = mbi.impact(mech, q, v, mbi.PointContact("end_a"), mbi.NewtonLaw(1.0))
    # end_a at -0.5 along the rod's x axis; rotation about +y
    pos = mech.frame_position(q, "end_a") - mech.frame_position(q, "rod")
    w_nn = 1.0 + pos[0] ** 2 / (1.0 / 12.0)
    assert res.P_n == pytest.approx(2 * 2.0 / w_nn, rel=1e-12)
    assert res.kappa == pytest.approx(1.0, abs=1e-12)
    assert res.energy_loss == pytest.approx(0.0, abs=1e-12)


def test_double_pendulum_model_matches_example_robot_data_structure():
    mech = mbi.Mechanism.from_model("double_pendulum")
    q = np.array([0.3, -0.7])
    A = mech.mass_matrix(q)
    # two uniform rods, m = l = 1: A₂₂ = 1/3, A₁₂ = 1/3 + ½ cos q₂, A₁₁ = 5/3 + cos q₂
    np.testing.assert_allclose(A, [[5 / 3 + math.cos(-0.7), 1 / 3 + 0.5 * math.cos(-0.7)],
                                   [1 / 3 + 0.5 * math.cos(-0.7), 1 / 3]], atol=1e-12)


@pytest.mark.parametrize("name", mbi.robot_names())
def test_every_registered_robot_loads_without_meshes(name):
    mech = mbi.Mechanism.from_robot(name)
    q = mech.neutral()
    A = mech.mass_matrix(q)
    assert A.shape == (mech.nv, mech.nv)
    assert np.allclose(A, A.T)


def test_metric_route_is_as_accurate_as_impulse_dynamics_on_an_ill_conditioned_robot():
    """Talos, cond(A) ≈ 1e5: A⁻¹Jᵀ by the Cholesky factor (not the explicit inverse, whose error
    is ~ε cond A in every entry) keeps the general route within 1e-13 of pin.impulseDynamics."""
    mech = mechanism("talos")
    rng, q, v = random_state(mech, 539799)
    n0 = rng.normal(size=3)
    n0 /= np.linalg.norm(n0)
    contact = mbi.PointContact(last_frame(mech), normal=n0)
    J = mech.point_jacobian(q, contact.frame)
    v = approaching(J, v, n0)
    assert np.linalg.cond(mech.mass_matrix(q)) > 1e4
    expected = pin.impulseDynamics(mech.model, mech.model.createData(), q, v, (n0 @ J)[None, :], 0.0, 0.0).copy()
    res = mbi.impact(mech, q, v, contact, mbi.RoughLaw(mbi.Smooth(), 0.0))  # the general (metric) route
    assert np.abs(res.v_plus - expected).max() < 1e-13 * (np.abs(expected).max() + np.abs(v).max())


def _one_joint_mechanism():
    """The double pendulum with its first joint locked: nv = 1 (Pinocchio hands back a (6,) Jacobian)."""
    full = mechanism("double_pendulum").model
    return mbi.Mechanism(pin.buildReducedModel(full, [1], pin.neutral(full)), "one_joint")


@given(st.sampled_from(ROBOTS + ["one joint"]), seeds)
def test_stack_fillers_are_the_single_calls_to_the_bit(name, seed):
    """What impact_batch gathers in its lean loops (PointContact.fill_jacobians, Mechanism.fill_factors) is,
    row by row, what the single impact reads: the contact's jacobian, at the frame origin or an offset, in
    3-D and 2-D, and A(q) with Pinocchio's factor, to the bit."""
    mech = _one_joint_mechanism() if name == "one joint" else mechanism(name)
    rng = np.random.default_rng(seed)
    Q = np.stack([mech.random_configuration(rng) for _ in range(4)])
    B, n = Q.shape[0], mech.nv
    for point in ([0.0, 0.0, 0.0], [0.1, -0.05, 0.2]):
        contact = mbi.PointContact(last_frame(mech), point=point)
        for d in (3, 2):
            J, R = np.empty((B, d, n)), np.empty((B, d, d))
            assert contact.fill_jacobians(mech, Q, d, J, R) == B
            for i, q in enumerate(Q):
                J1, R1 = contact.jacobian(mech, q, d)
                assert np.array_equal(J[i], J1) and np.array_equal(R[i], R1)
    A, U, D, A_only = np.empty((B, n, n)), np.empty((B, n, n)), np.empty((B, n)), np.empty((B, n, n))
    mech.fill_factors(Q, A, U, D)
    mech.fill_factors(Q, A_only)
    for i, q in enumerate(Q):
        A1, U1, D1 = mech.factor_arrays(q)
        assert np.array_equal(A[i], A1) and np.array_equal(U[i], U1) and np.array_equal(D[i], D1)
        assert np.array_equal(A_only[i], A1)

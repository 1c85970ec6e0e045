"""The axiomatic impact with Coulomb friction (Routh/Keller/Stronge) in impulse space."""

import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi

from tests.helpers import approaching, seeds, spd

RESTITUTIONS = ["newton", "poisson", "energetic"]


@given(st.floats(0.0, 2.0), st.floats(0.0, 1.0), st.floats(-5.0, 5.0), st.sampled_from(RESTITUTIONS),
       st.floats(0.5, 4.0))
def test_point_mass_slide_or_stick_closed_form(mu, e, ut, restitution, mass):
    """W = I/m: the slip direction never changes; sliding if |u_t| > μ(1+e)|u_n|, else sticking."""
    law = mbi.CoulombLaw(e, mu, restitution)
    res = law.apply(mass * np.eye(2), np.eye(2), [ut, -1.0], [0, 1])
    assert res.u_plus[1] == pytest.approx(e, abs=1e-8)
    slide = abs(ut) - mu * (1 + e)
    expect_t = math.copysign(slide, ut) if slide > 0 else 0.0
    assert res.u_plus[0] == pytest.approx(expect_t, abs=1e-8)
    if slide > 1e-6:
        assert res.mu == pytest.approx(mu, rel=1e-8, abs=1e-12)


def test_spatial_point_mass_slides_against_the_slip():
    res = mbi.CoulombLaw(0.5, 0.3).apply(np.eye(3), np.eye(3), [1.0, 0.5, -1.0], [0, 0, 1])
    ut = np.array([1.0, 0.5])
    expect = ut * (1 - 0.3 * 1.5 / np.linalg.norm(ut))
    np.testing.assert_allclose(res.u_plus[:2], expect, atol=1e-8)


def rod(theta):
    """Uniform rod (m = 1, l = 1) striking with one end at angle θ: A, J (2×3)."""
    rx, rz = 0.5 * math.cos(theta), -0.5 * math.sin(theta)
    return np.diag([1.0, 1.0, 1.0 / 12.0]), np.array([[1.0, 0.0, -rz], [0.0, 1.0, rx]])


def test_newton_restitution_creates_energy_with_slip_reversal_energetic_does_not():
    """Stronge's paradox: kinematic restitution + Coulomb friction can create energy."""
    worst = {r: math.inf for r in RESTITUTIONS}
    for th, mu, ut, e in itertools.product(np.linspace(0.1, 1.5, 8), [0.2, 0.8], [-0.3, 0.3, 1.0], [0.9, 1.0]):
        A, J = rod(th)
        v = np.linalg.lstsq(J, [ut, -1.0], rcond=None)[0]
        for r in RESTITUTIONS:
            res = mbi.CoulombLaw(e, mu, r).apply(A, J, v, [0, 1])
            worst[r] = min(worst[r], res.energy_loss / res.T_minus)
    assert worst["newton"] < -1e-3
    assert worst["energetic"] >= -1e-9 and worst["poisson"] >= -1e-9


def test_slip_reversal_on_the_rod():
    """Slip stops mid-impact and, sticking being impossible, reverses."""
    A, J = rod(0.8)
    W = J @ np.linalg.solve(A, J.T)
    ratio = W[0, 1] / W[0, 0]
    mu = 0.5 * ratio  # too little friction to stick
    v = np.linalg.lstsq(J, [-0.2, -1.0], rcond=None)[0]  # slips against the sense W pushes it
    res = mbi.CoulombLaw(0.5, mu, "energetic").apply(A, J, v, [0, 1])
    assert res.u_minus[0] < 0 < res.u_plus[0]
    assert res.mu < mu  # friction impulse partly cancelled by the reversal


def test_sticking_keeps_the_tangential_velocity_zero():
    A, J = rod(0.8)
    W = J @ np.linalg.solve(A, J.T)
    mu = 2.0 * abs(W[0, 1] / W[0, 0])
    v = np.linalg.lstsq(J, [0.1, -1.0], rcond=None)[0]
    res = mbi.CoulombLaw(0.5, mu).apply(A, J, v, [0, 1])
    assert res.u_plus[0] == pytest.approx(0.0, abs=1e-8)


def test_slip_direction_curves_for_anisotropic_delassus():
    rng = np.random.default_rng(2)
    A = spd(rng, 5, 50)
    J = rng.normal(size=(3, 5))
    v = approaching(J, rng.normal(size=5), np.array([0, 0, 1.0]))
    res = mbi.CoulombLaw(0.4, 0.2).apply(A, J, v, [0, 0, 1])
    ut0 = res.u_minus[:2]
    Pt = res.P[:2]
    cosang = -(Pt @ ut0) / (np.linalg.norm(Pt) * np.linalg.norm(ut0))
    assert cosang < 1 - 1e-4  # the friction impulse is not along the initial slip
    assert np.linalg.norm(Pt) <= 0.2 * res.P_n * (1 + 1e-8)  # on or inside the cone


@given(seeds, st.sampled_from(RESTITUTIONS[1:]), st.floats(0.0, 1.5), st.floats(0.0, 1.0))
def test_poisson_and_energetic_never_create_energy(seed, restitution, mu, e):
    rng = np.random.default_rng(seed)
    d = int(rng.choice([2, 3]))
    n = int(rng.integers(d, 7))
    A = spd(rng, n, 100)
    J = rng.normal(size=(d, n))
    v = approaching(J, rng.normal(size=n), np.eye(d)[-1])
    res = mbi.CoulombLaw(e, mu, restitution).apply(A, J, v, np.eye(d)[-1])
    assert res.energy_loss >= -1e-8 * res.T_minus
    assert res.mu <= mu * (1 + 1e-7) + 1e-12
    assert res.P_n > 0


def test_frictionless_coulomb_is_newton():
    rng = np.random.default_rng(3)
    A = spd(rng, 4, 10)
    J = rng.normal(size=(3, 4))
    v = approaching(J, rng.normal(size=4), np.array([0, 0, 1.0]))
    for r in RESTITUTIONS:
        res = mbi.CoulombLaw(0.6, 0.0, r).apply(A, J, v, [0, 0, 1])
        np.testing.assert_allclose(res.v_plus, mbi.NewtonLaw(0.6).apply(A, J, v, [0, 0, 1]).v_plus, atol=1e-8)


def test_coulomb_errors():
    with pytest.raises(mbi.ParameterError, match="restitution"):
        mbi.CoulombLaw(0.5, 0.3, "kinetic")
    with pytest.raises(mbi.ParameterError, match="mu"):
        mbi.CoulombLaw(0.5, -0.1)
    with pytest.raises(mbi.ParameterError, match="exactly one"):
        mbi.CoulombLaw(mu=0.3)


@pytest.mark.parametrize("name", ["ur5", "panda", "solo12"])
def test_plastic_sticking_impact_equals_pinocchio_three_row_impulse_dynamics(name):
    """e = 0 with enough friction to stick: the contact point stops, u₊ = 0 — the problem
    pin.impulseDynamics solves with the full translational Jacobian as constraint."""
    import pinocchio as pin

    from tests.helpers import last_frame, mechanism

    mech = mechanism(name)
    frame = last_frame(mech)
    for seed in range(50):  # a state whose stopping impulse pushes (P_n > 0): sticking is admissible
        rng = np.random.default_rng(seed)
        q = mech.random_configuration(rng)
        J = mech.point_jacobian(q, frame)
        v = approaching(J, rng.normal(size=mech.nv), np.array([0, 0, 1.0]))
        u = J @ v
        W = J @ np.linalg.solve(mech.mass_matrix(q), J.T)
        P_stick = -np.linalg.solve(W, u)
        if P_stick[2] > 0:
            break
    mu = 2.0 * np.linalg.norm(P_stick[:2]) / P_stick[2] + 1.0  # comfortably inside the cone
    res = mbi.impact(mech, q, v, mbi.PointContact(frame), mbi.CoulombLaw(0.0, mu))
    expected = pin.impulseDynamics(mech.model, mech.model.createData(), q, v, J, 0.0, 0.0)
    np.testing.assert_allclose(res.v_plus, expected, atol=1e-7 * np.abs(v).max())
    np.testing.assert_allclose(res.u_plus, 0.0, atol=1e-7 * np.linalg.norm(u))


def admm_impulse(mech, q, v, frame, mu):
    """Pinocchio's conic solver: plastic impact with a Coulomb cone at a point (world-aligned)."""
    import pinocchio as pin

    from mbimpact.apps.bench.speed import conic_problem

    cm, models, datas, settings, result, solver = conic_problem(mech, q, frame, mu, "admm")
    model, data = mech.model, mech.model.createData()
    cdata = cm.createData()
    pin.computeJointJacobians(model, data, q)
    cm.calc(model, data, cdata)
    Jc = cm.jacobian(model, data, cdata)
    W = Jc @ np.linalg.solve(pin.crba(model, data, q), Jc.T)
    assert solver.solve(pin.DelassusOperatorDense(W), Jc @ v, models, datas, settings, result)
    return Jc, result.retrieveConstraintImpulses()


@pytest.mark.parametrize("name, frame", [("ur5", "tool0"), ("panda", "panda_hand_tcp")])
def test_sticking_plastic_impact_against_pinocchio_admm_coulomb_cone(name, frame):
    """e = 0 and enough friction to stick: the integrated Coulomb impact and Pinocchio's
    ADMMConstraintSolver on a CoulombFrictionCone solve the same problem."""
    mech = mbi.Mechanism.from_robot(name)
    q = mech.neutral() + 0.3
    J = mech.point_jacobian(q, frame)
    v = np.linalg.lstsq(J, [0.2, 0.1, -1.0], rcond=None)[0]
    Jc, lam = admm_impulse(mech, q, v, frame, 3.0)
    np.testing.assert_allclose(Jc, J, atol=1e-12)
    res = mbi.impact(mech, q, v, mbi.PointContact(frame), mbi.CoulombLaw(0.0, 3.0))
    assert np.linalg.norm(res.P[:2]) < 3.0 * res.P[2]  # inside the cone: sticking
    np.testing.assert_allclose(res.P, lam, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("restitution", RESTITUTIONS)
@pytest.mark.parametrize("e", [1e-10, 1e-6, 0.3])
def test_tiny_restitution_is_reached_to_rounding(restitution, e):
    """u_n⁺ = e |u_n⁻| also for e = 1e-10: the energetic criterion W_r = −e² W_c is located on the
    work of restitution alone (on the total work it was only good to ~sqrt(ε) ≈ 1e-8)."""
    res = mbi.CoulombLaw(e, 1.5, restitution).apply(np.eye(2), np.eye(2), [2.0, -1.0], [0, 1])
    np.testing.assert_allclose(res.u_plus, [2.0 - 1.5 * (1 + e), e], rtol=0, atol=1e-13)


def test_sticking_at_a_nearly_singular_delassus_matrix_ends_compression():
    """Sticking, u_n grows only at the Schur complement W_nn − W_nt²/W_tt (here 1e-4 of W_nn):
    the integration horizon must allow for it (it used to end before compression did)."""
    W = np.array([[46.74282839, 5.42633264], [5.42633264, 0.63001083]])
    L = np.linalg.cholesky(np.linalg.inv(W))  # A = W⁻¹ with J = I gives this Delassus matrix
    res = mbi.CoulombLaw(0.0, 1.0, "poisson").apply(L @ L.T, np.eye(2), [0.29733802, -0.00430435], [0, 1])
    assert res.u_plus[1] == pytest.approx(0.0, abs=1e-9)
    assert res.energy_loss >= 0.0 and res.mu <= 1.0 + 1e-9


def test_a_3d_slip_that_stops_switches_to_sticking_without_chattering():
    """Slip stops during restitution (μ = 1.5 allows sticking): the stop is detected above the
    integrator's resolution and the residual slip removed; the integrator used to chatter about
    u_t = 0 for millions of steps (tens of seconds). ``nodes`` counts the integration steps."""
    W = np.array([[0.50314836, 1.15271262, -0.27604205], [1.15271262, 5.10958421, -2.40727164],
                  [-0.27604205, -2.40727164, 1.55898575]])
    L = np.linalg.cholesky(np.linalg.inv(W))
    res = mbi.CoulombLaw(1.0, 1.5, "energetic").apply(L @ L.T, np.eye(3), [0.29384942, 0.82099915, -0.56966659],
                                                       [0, 0, 1])
    assert res.nodes < 200
    assert np.linalg.norm(res.u_plus[:2]) < 1e-9  # it sticks to the end
    assert res.energy_loss >= 0.0 and res.mu <= 1.5 * (1 + 1e-7)

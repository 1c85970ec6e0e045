"""NewtonLaw on a mechanism runs Pinocchio's own impulseDynamics; the result completes Δv, P and u±
on first access, and each of them equals the arrays route (our own metric and closed form)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi

from tests.helpers import ROBOTS, approaching, last_frame, mechanism, seeds

FIELDS = ("v_plus", "dv", "P", "u_minus", "u_plus")


def state(name, seed):
    mech = mechanism(name)
    rng = np.random.default_rng(seed)
    q = mech.random_configuration(rng)
    n0 = rng.normal(size=3)
    n0 /= np.linalg.norm(n0)
    contact = mbi.PointContact(last_frame(mech), normal=n0)
    J = mech.point_jacobian(q, contact.frame)
    return mech, q, approaching(J, rng.normal(size=mech.nv), n0), contact, J, n0


@given(st.sampled_from(ROBOTS), seeds, st.floats(0.0, 1.0))
def test_every_field_equals_the_arrays_route(name, seed, e):
    """Δv, v₊, P and u± of the Pinocchio route equal NewtonLaw.apply on A(q), J(q) (our closed form
    through the Cholesky factor) to 1e-12 relative; so do κ = e and the energy loss."""
    mech, q, v, contact, J, n0 = state(name, seed)
    if np.linalg.norm(n0 @ J) < 1e-3 * np.linalg.norm(J):
        return  # n0 nearly out of reach: the general route (tested elsewhere) takes it
    law = mbi.NewtonLaw(e)
    res = mbi.impact(mech, q, v, contact, law)
    assert isinstance(res, mbi.results.NormalImpactResult)
    ref = law.apply(mech.mass_matrix(q), J, v, n0)
    for name_ in FIELDS:
        got, want = getattr(res, name_), getattr(ref, name_)
        scale = np.abs(want).max() + np.abs(ref.v_minus).max() * (name_ != "P")
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * scale, err_msg=name_)
    np.testing.assert_allclose(res.A, ref.A, rtol=0, atol=1e-14 * np.abs(ref.A).max())
    assert res.P_n == pytest.approx(ref.P_n, rel=1e-12)
    assert res.kappa == pytest.approx(e, abs=1e-9)
    assert res.energy_loss == pytest.approx(ref.energy_loss, rel=1e-9, abs=1e-12 * ref.T_minus)
    assert res.residual < 1e-12


def test_fields_are_computed_once_and_read_only():
    mech, q, v, contact, J, n0 = state("ur5", 3)
    res = mbi.impact(mech, q, v, contact, mbi.NewtonLaw(0.5))
    assert "dv" not in vars(res)  # completed on demand only
    dv = res.dv
    assert res.dv is dv  # then kept
    for name in FIELDS + ("v_minus", "n0"):
        with pytest.raises(ValueError):
            getattr(res, name)[0] = 1.0


def test_fields_survive_a_reuse_of_the_workspace():
    """Δv read after other impacts at other configurations (the workspace's factor reused) is still
    the one at the result's own q."""
    mech, q, v, contact, J, n0 = state("panda", 5)
    res = mbi.impact(mech, q, v, contact, mbi.NewtonLaw(0.2))
    mech2, q2, v2, *_ = state("panda", 6)
    mbi.impact(mech, q2, v2, contact, mbi.NewtonLaw(0.7))
    mbi.impact(mech, q2, v2, contact, mbi.RoughLaw(mbi.Cone(0.3), 0.7))
    ref = mbi.NewtonLaw(0.2).apply(mech.mass_matrix(q), J, v, n0)
    np.testing.assert_allclose(res.dv, ref.dv, rtol=0, atol=1e-12 * np.abs(ref.dv).max())


def test_degenerate_and_extreme_inputs_keep_the_general_route():
    """Not approaching: NoImpactError as before. Velocities beyond the route's safe magnitudes (1e150)
    take the general route: the same post-impact velocity, scaled, and no RuntimeWarning."""
    mech, q, v, contact, J, n0 = state("ur5", 8)
    law = mbi.NewtonLaw(0.5)
    with pytest.raises(mbi.NoImpactError):
        mbi.impact(mech, q, -v, contact, law)
    small = mbi.impact(mech, q, v, contact, law)
    with np.errstate(all="raise"):
        big = mbi.impact(mech, q, v * 1e150, contact, law)
    assert not isinstance(big, mbi.results.NormalImpactResult)
    np.testing.assert_allclose(big.v_plus / 1e150, small.v_plus, rtol=1e-12, atol=1e-12 * np.abs(v).max())


def test_singular_mass_matrix_is_named():
    """A(q) not positive definite: NotPositiveDefiniteError from the general route, not a NaN result."""
    import pinocchio as pin

    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "x")
    model.appendBodyToJoint(joint, pin.Inertia.Zero(), pin.SE3.Identity())
    model.addFrame(pin.Frame("tip", joint, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    mech = mbi.Mechanism(model, "massless")
    with pytest.raises(mbi.NotPositiveDefiniteError):
        mbi.impact(mech, np.zeros(1), np.array([-1.0]), mbi.PointContact("tip", normal=[1.0, 0, 0]),
                   mbi.NewtonLaw(0.5))

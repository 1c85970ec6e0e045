"""NewtonLaw on a mechanism (NewtonLaw.compiled_impact): one compiled call on Pinocchio's factor, one
solve along n⁰ᵀJ, no Delassus matrix; the same closed form as the arrays route, to rounding."""

import pickle

import numpy as np
import pinocchio as pin
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
    """Δv, v₊, P and u± equal NewtonLaw.apply on A(q), J(q) to 1e-12 relative (the factors differ:
    Pinocchio's sparse one here, LAPACK's there); v₊ equals pin.impulseDynamics; κ = e."""
    mech, q, v, contact, J, n0 = state(name, seed)
    if np.linalg.norm(n0 @ J) < 1e-3 * np.linalg.norm(J):
        return  # n0 nearly out of reach: the general route (tested elsewhere) takes it
    law = mbi.NewtonLaw(e)
    res = mbi.impact(mech, q, v, contact, law)
    ref = law.apply(mech.mass_matrix(q), J, v, n0)
    for name_ in FIELDS:
        got, want = getattr(res, name_), getattr(ref, name_)
        scale = np.abs(want).max() + np.abs(ref.v_minus).max() * (name_ != "P")
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * scale, err_msg=name_)
    expected = pin.impulseDynamics(mech.model, mech.model.createData(), q, v, (n0 @ J)[None, :], e, 0.0)
    np.testing.assert_allclose(res.v_plus, expected, rtol=0, atol=1e-12 * (np.abs(expected).max() + np.abs(v).max()))
    assert res.P_n == pytest.approx(ref.P_n, rel=1e-12)
    assert res.kappa == pytest.approx(e, abs=1e-9)
    assert res.residual < 1e-12


def test_the_result_is_frozen_whole():
    """Every array of the result is read-only, A and J included (nothing the result derives from can
    be changed under it)."""
    mech, q, v, contact, J, n0 = state("ur5", 3)
    res = mbi.impact(mech, q, v, contact, mbi.NewtonLaw(0.5))
    for name in FIELDS + ("v_minus", "n0", "A", "J"):
        with pytest.raises(ValueError):
            getattr(res, name)[0] = 1.0


def test_results_do_not_depend_on_the_workspace_afterwards():
    """A result read after the mechanism's own workspace has been used for other impacts, and for
    Pinocchio calls made on it directly (``mech.data``), is the one at its own q; a pickled result
    is small (no mechanism inside) and equal."""
    mech, q, v, contact, J, n0 = state("panda", 5)
    res = mbi.impact(mech, q, v, contact, mbi.NewtonLaw(0.2))
    _, q2, v2, *_ = state("panda", 6)
    mbi.impact(mech, q2, v2, contact, mbi.NewtonLaw(0.7))
    mbi.impact(mech, q2, v2, contact, mbi.RoughLaw(mbi.Cone(0.3), 0.7))
    J2 = mech.point_jacobian(q2, contact.frame)
    pin.impulseDynamics(mech.model, mech.data, q2, v2, J2[2:3], 0.5, 0.0)
    ref = mbi.NewtonLaw(0.2).apply(mech.mass_matrix(q), J, v, n0)
    np.testing.assert_allclose(res.dv, ref.dv, rtol=0, atol=1e-12 * np.abs(ref.dv).max())
    blob = pickle.dumps(res)
    assert len(blob) < 5_000
    again = pickle.loads(blob)
    for name in FIELDS:
        assert np.array_equal(getattr(again, name), getattr(res, name))


def test_pickled_factors_refactorise_in_the_loading_process():
    """A MassFactor carries a token saying whether its thread's workspace still holds it; unpickled
    (possibly in another process, whose counter restarted), it gets a token of its own, so its first
    solve re-factorises at its q instead of reading another configuration's factor."""
    mech, q, v, contact, J, n0 = state("ur5", 9)
    A, factor = mech.factorise(q)
    b = np.arange(1.0, mech.nv + 1)
    expected = np.linalg.solve(A, b)
    clone = pickle.loads(pickle.dumps(factor))
    assert clone.token != factor.token
    _, q2, *_ = state("ur5", 10)
    mech.factorise(q2)  # the workspace now holds another factor
    np.testing.assert_allclose(clone.solve(b), expected, rtol=1e-12)
    np.testing.assert_allclose(factor.solve(b), expected, rtol=1e-12)


def test_degenerate_and_extreme_inputs_keep_the_general_route():
    """Not approaching: NoImpactError as before. Velocities beyond the route's safe magnitudes
    take the general route: the same post-impact velocity, scaled, and no RuntimeWarning."""
    mech, q, v, contact, J, n0 = state("ur5", 8)
    law = mbi.NewtonLaw(0.5)
    with pytest.raises(mbi.NoImpactError):
        mbi.impact(mech, q, -v, contact, law)
    small = mbi.impact(mech, q, v, contact, law)
    with np.errstate(all="raise"):
        big = mbi.impact(mech, q, v * 1e150, contact, law)
    np.testing.assert_allclose(big.v_plus / 1e150, small.v_plus, rtol=1e-12, atol=1e-12 * np.abs(v).max())


def test_a_subclass_overriding_apply_metric_is_still_called():
    calls = []

    class Logged(mbi.NewtonLaw):
        def apply_metric(self, metric, v, R):
            calls.append(1)
            return super().apply_metric(metric, v, R)

    mech, q, v, contact, J, n0 = state("ur5", 2)
    res = mbi.impact(mech, q, v, contact, Logged(0.5))
    assert calls == [1] and res.kappa == pytest.approx(0.5, abs=1e-9)


def test_singular_mass_matrix_is_named():
    """A(q) not positive definite: NotPositiveDefiniteError from the general route, not a NaN result."""
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "x")
    model.appendBodyToJoint(joint, pin.Inertia.Zero(), pin.SE3.Identity())
    model.addFrame(pin.Frame("tip", joint, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    mech = mbi.Mechanism(model, "massless")
    with pytest.raises(mbi.NotPositiveDefiniteError):
        mbi.impact(mech, np.zeros(1), np.array([-1.0]), mbi.PointContact("tip", normal=[1.0, 0, 0]),
                   mbi.NewtonLaw(0.5))


@pytest.mark.parametrize("name", ["ur5", "solo12", "talos"])
def test_the_compiled_impact_is_the_closed_form_of_apply_metric_to_rounding(name):
    """Without the metric, the same closed form on the same factor: equal to apply_metric on
    ContactMetric.from_mechanism to a few ulps of each field's scale."""
    mech, q, v, contact, J, n0 = state(name, 11)
    law = mbi.NewtonLaw(0.3)
    Jc, R = contact.jacobian(mech, q, 3)
    if Jc.dot(v) @ R[:, -1] >= 0:
        v = -v
    A, U, D = mech.factor_arrays(q)
    res = law.compiled_impact().run(law, A, U.copy(), D.copy(), Jc, v, R, False)
    assert res.method == "closed-form" and res.J.shape == (3, mech.nv) and not res.P.flags.writeable
    ref = law.apply_metric(mbi.ContactMetric.from_mechanism(mech, q, Jc.copy()), v, R)
    for name_ in FIELDS + ("v_minus", "n0"):
        got, want = getattr(res, name_), getattr(ref, name_)
        scale = np.abs(want).max() + np.abs(v).max() * (name_ in ("v_plus", "dv"))
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-14 * scale, err_msg=name_)
    np.testing.assert_array_equal(res.A, ref.A)

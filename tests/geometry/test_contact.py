"""GeometryContact in mbi.impact: Newton's law is pin.impulseDynamics at the witness point; rough laws
act about the gap normal; self-collision impulses are equal and opposite."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import mbimpact as mbi
from mbimpact import geometry as G

from tests.geometry.helpers import floating_q, model, two_balls, unit

R_SPHERE = 0.05


def approaching(g: G.Gap, v: np.ndarray) -> np.ndarray:
    return v if g.gradient @ v < 0 else -v


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("e", [0.0, 0.6])
def test_sphere_on_a_halfspace_newton_is_impulse_dynamics(seed, e):
    rng = np.random.default_rng(seed)
    mech = model("sphere")
    n = unit(rng.normal(size=3) + [0, 0, 2])
    ground = G.HalfSpace(n, 0.0)
    q = floating_q(mech, rng, height=0.1)
    contact = G.GeometryContact(body="sphere_0", obstacle=ground)
    g = contact.gap(mech, q)
    v = approaching(g, rng.normal(size=6))
    res = mbi.impact(mech, q, v, contact, mbi.NewtonLaw(e))
    row = (g.normal @ g.jacobian)[None, :]
    expected = pin.impulseDynamics(mech.model, mech.model.createData(), q, v, row, e, 0.0).copy()
    np.testing.assert_allclose(res.v_plus, expected, atol=1e-12 * (1 + np.abs(v).max()))
    np.testing.assert_allclose(res.J, g.jacobian, atol=1e-15)
    assert res.u_plus @ n == pytest.approx(-e * (res.u_minus @ n), abs=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_spinning_sphere_witness_velocity_includes_omega_cross_r(seed):
    """Free-flyer velocities are in the body frame: v_p = R v_lin + (R ω) × (p − c)."""
    rng = np.random.default_rng(20 + seed)
    mech = model("sphere")
    q = floating_q(mech, rng, height=0.2)
    R = pin.Quaternion(q[3:7]).matrix()
    v = rng.normal(size=6)
    g = G.GeometryContact(body="sphere_0", obstacle=G.HalfSpace()).gap(mech, q)
    c = q[:3]
    np.testing.assert_allclose(g.point, c - [0, 0, R_SPHERE], atol=1e-12)
    expected = R @ v[:3] + np.cross(R @ v[3:], g.point - c)
    np.testing.assert_allclose(g.velocity(v), expected, atol=1e-12)
    # pure spin about a horizontal axis: the bottom point slides at |ω| R, its normal speed is 0
    spin = np.zeros(6)
    spin[3:] = R.T @ [0.0, 3.0, 0.0]
    np.testing.assert_allclose(g.velocity(spin), [-3.0 * R_SPHERE, 0.0, 0.0], atol=1e-12)
    assert g.normal_velocity(spin) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_rough_law_acts_about_the_gap_normal(seed):
    """GeometryContact ≡ PointContact at the witness point with the gap normal (same frame, same result)."""
    rng = np.random.default_rng(40 + seed)
    mech = model("box")
    slope = G.HalfSpace(unit(rng.normal(size=3) + [0, 0, 2.5]), 0.0)
    q = floating_q(mech, rng, height=0.25)
    contact = G.GeometryContact(body="box_0", obstacle=slope)
    g = contact.gap(mech, q)
    J, R = contact.jacobian(mech, q)
    np.testing.assert_allclose(R[:, 2], g.normal, atol=1e-15)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    M = pin.SE3(pin.Quaternion(q[3:7]).matrix(), q[:3])
    point = mbi.PointContact("box", normal=g.normal, point=M.actInv(g.point))
    v = approaching(g, rng.normal(size=6))
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    res = mbi.impact(mech, q, v, contact, law)
    ref = mbi.impact(mech, q, v, point, law)
    np.testing.assert_allclose(res.v_plus, ref.v_plus, atol=1e-10 * (1 + np.abs(v).max()))
    assert res.P_n > 0 and res.energy_loss >= -1e-12 * res.T_minus


def test_planar_law_uses_the_tangent():
    mech = model("sphere")
    q = mech.neutral()
    q[2] = 0.05
    v = np.array([0.5, 0.0, -1.0, 0.0, 0.0, 0.0])
    law = mbi.RoughLaw(mbi.Sawtooth(0.3), 0.5)
    res = mbi.impact(mech, q, v, G.GeometryContact(body="sphere_0", obstacle=G.HalfSpace(), tangent=(1, 0, 0)), law)
    ref = mbi.impact(mech, q, v, mbi.PointContact("bottom", tangent=(1, 0, 0)), law)
    np.testing.assert_allclose(res.v_plus, ref.v_plus, atol=1e-12)


@pytest.mark.parametrize("e", [0.0, 0.8])
def test_self_collision_impulses_are_equal_and_opposite(e):
    mech = two_balls(0.1, 0.2)
    q = mech.neutral()
    q[7:10] = unit(np.array([1.0, 0.5, -0.2])) * 0.3  # touching
    contact = G.GeometryContact(body="ball_a", other="ball_b")
    g = contact.gap(mech, q)
    assert g.distance == pytest.approx(0.0, abs=1e-12)
    v = np.zeros(12)
    v[:3] = [1.0, 0.2, 0.0]      # a moves towards b
    v[6:9] = [-0.5, 0.0, 0.3]
    res = mbi.impact(mech, q, v, contact, mbi.NewtonLaw(e))
    momentum = lambda w: 1.0 * w[:3] + 2.0 * w[6:9]  # noqa: E731 (identity attitudes: body = world axes)
    np.testing.assert_allclose(momentum(res.v_plus), momentum(v), atol=1e-12)
    assert g.normal @ g.velocity(res.v_plus) == pytest.approx(-e * (g.normal @ g.velocity(v)), abs=1e-12)
    rough = mbi.impact(mech, q, v, contact, mbi.RoughLaw(mbi.Cone(0.3), 0.5))
    np.testing.assert_allclose(momentum(rough.v_plus), momentum(v), atol=1e-10)


def test_contact_follows_attached_shapes_and_caches_its_model():
    mech = mbi.Mechanism.from_model("sphere")
    contact = G.GeometryContact(body="sphere_0", obstacle=G.HalfSpace())
    assert contact.model(mech) is contact.model(mech)
    before = contact.model(mech)
    mech.collision_model().add("extra", "bottom", G.Sphere(0.01))
    assert contact.model(mech) is not before  # rebuilt after the collision model changed


def test_bad_contacts_are_named_errors():
    with pytest.raises(mbi.ParameterError, match="exactly one"):
        G.GeometryContact(body="a")
    with pytest.raises(mbi.ParameterError, match="exactly one"):
        G.GeometryContact(body="a", obstacle=G.HalfSpace(), other="b")
    with pytest.raises(mbi.ParameterError, match="itself"):
        G.GeometryContact(body="a", other="a")
    with pytest.raises(mbi.ParameterError, match="shape"):
        G.GeometryContact(body="a", obstacle="ground")  # type: ignore[arg-type]
    with pytest.raises(mbi.ParameterError, match="str"):
        G.GeometryContact(body=3)  # type: ignore[arg-type]
    with pytest.raises(mbi.ShapeError, match="zero"):
        G.GeometryContact(body="a", obstacle=G.HalfSpace(), tangent=(0, 0, 0))
    with pytest.raises(mbi.NonFiniteError, match="tangent"):
        G.GeometryContact(body="a", obstacle=G.HalfSpace(), tangent=(np.nan, 0, 0))
    mech = model("sphere")
    c = G.GeometryContact(body="sphere_0", obstacle=G.HalfSpace(), tangent=(0, 0, 1))
    with pytest.raises(mbi.ShapeError, match="parallel"):
        c.jacobian(mech, mech.neutral())
    with pytest.raises(mbi.ShapeError, match="2 or 3"):
        G.GeometryContact(body="sphere_0", obstacle=G.HalfSpace()).jacobian(mech, mech.neutral(), 4)

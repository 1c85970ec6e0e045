"""The shared contact geometry against brute force."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from mbimpact.common import (
    facing_half_width,
    facing_half_width_scalar,
    incidence_split,
    offset_point_jacobian,
    ring_quadratic_form,
)
from tests.helpers import mechanism


@pytest.mark.parametrize("alpha", [0.05, 0.4, 1.2])
@pytest.mark.parametrize("beta", [0.0, 0.3, 1.0, 1.4, 1.5707])
def test_facing_arc_is_the_set_of_facets_facing_the_velocity(alpha, beta):
    """Brute force on 200 001 azimuths: the facing set is ψ + π ± h."""
    psi = 0.7
    u = np.array([math.sin(beta) * math.cos(psi), math.sin(beta) * math.sin(psi), -math.cos(beta)])
    phi = np.linspace(-math.pi, math.pi, 200_001)
    m = np.column_stack([math.sin(alpha) * np.cos(phi), math.sin(alpha) * np.sin(phi), np.full(phi.size, math.cos(alpha))])
    facing = (m @ u) < 0
    h = float(facing_half_width(math.sin(alpha), math.cos(alpha), math.hypot(u[0], u[1]), -u[2]))
    # the scalar form is the array form's arithmetic in floats (libm's acos, or numpy's): equal to rounding
    assert h == pytest.approx(facing_half_width_scalar(math.sin(alpha), math.cos(alpha), math.hypot(u[0], u[1]),
                                                       -u[2]), rel=4 * np.finfo(float).eps)
    assert facing.mean() * math.pi == pytest.approx(h, abs=4 * math.pi / phi.size)
    dist = np.abs(np.angle(np.exp(1j * (phi - psi - math.pi))))
    inside = dist < h - 1e-4
    assert np.all(facing[inside])
    assert not np.any(facing[dist > h + 1e-4])


def test_incidence_split_is_the_tilt_at_which_rings_start_to_be_cut():
    U = np.array([[0.6, 0.0, -0.8], [0.0, 0.0, -1.0], [1.0, 0.0, -1e-9]])
    alpha_star = incidence_split(U)
    np.testing.assert_allclose(alpha_star, [math.atan(0.8 / 0.6), math.pi / 2, 1e-9], rtol=1e-12)
    for a, u in zip(alpha_star[:1], U[:1]):
        ut, un = math.hypot(u[0], u[1]), -u[2]
        assert facing_half_width_scalar(math.sin(a - 1e-9), math.cos(a - 1e-9), ut, un) == math.pi
        assert facing_half_width_scalar(math.sin(a + 1e-6), math.cos(a + 1e-6), ut, un) < math.pi


def test_ring_quadratic_form_reproduces_m_w_m():
    rng = np.random.default_rng(0)
    B = rng.normal(size=(3, 3))
    W = B @ B.T
    alpha, phi = 0.7, rng.uniform(0, 2 * math.pi, 9)
    q0, a1, b1, a2, b2 = ring_quadratic_form(math.sin(alpha), math.cos(alpha), W)
    m = np.column_stack([math.sin(alpha) * np.cos(phi), math.sin(alpha) * np.sin(phi), np.full(9, math.cos(alpha))])
    q = q0 + a1 * np.cos(phi) + b1 * np.sin(phi) + a2 * np.cos(2 * phi) + b2 * np.sin(2 * phi)
    np.testing.assert_allclose(q, np.einsum("ki,ij,kj->k", m, W, m), rtol=1e-13)


def test_offset_point_jacobian_matches_a_finite_difference_of_the_point():
    mech = mechanism("ur5")
    rng = np.random.default_rng(2)
    q = mech.random_configuration(rng)
    point = np.array([0.05, -0.02, 0.1])
    J = mech.point_jacobian(q, "tool0", point)
    fid = mech.frame_id("tool0")
    J6 = pin.computeFrameJacobian(mech.model, mech.data, q, fid, pin.LOCAL_WORLD_ALIGNED)
    r = mech.data.oMf[fid].rotation @ point
    np.testing.assert_allclose(offset_point_jacobian(J6, r), J6[:3] - pin.skew(r) @ J6[3:], atol=1e-15)
    dq = rng.normal(size=mech.nv) * 1e-7
    fd = (mech.frame_position(q + dq, "tool0", point) - mech.frame_position(q - dq, "tool0", point)) / 2
    np.testing.assert_allclose(J @ dq, fd, rtol=1e-6, atol=1e-15)
    np.testing.assert_array_equal(offset_point_jacobian(J6, None), J6[:3])

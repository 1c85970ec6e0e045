"""The Kelvin–Voigt process resolved in time converges to the closed laws."""

import math

import numpy as np
import pytest

import mbimpact as mbi

from tests.helpers import mechanism

UR5_Q = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
FACET = np.array([math.sin(0.3), 0.0, math.cos(0.3)])


def ur5_case():
    mech = mechanism("ur5")
    contact = mbi.PointContact("tool0")
    J = mech.point_jacobian(UR5_Q, "tool0")
    v = np.linalg.lstsq(J, [0.3, 0.0, -1.0], rcond=None)[0]
    return mech, contact, v


def facet_newton(mech, q, v, contact, m_local, e):
    """Per-facet Newton impact −(1+e)(N, v)N, the M → ∞ limit of one resolved facet."""
    return mbi.NewtonLaw(e).apply(mech.mass_matrix(q), mech.point_jacobian(q, contact.frame),
                                  v, contact.basis() @ mbi.local_basis(m_local, 3)).dv


@pytest.mark.parametrize("M", [1e2, 1e4, 1e6])
def test_frozen_dynamics_gives_the_facet_law_for_every_M(M):
    """(2.4): with A, J frozen the jump is −(1+e)(N,v)N whatever M, after τ = π/(M√(1−k²))."""
    mech, contact, v = ur5_case()
    res = mbi.resolve(mech, UR5_Q, v, contact, FACET, M=M, e=0.6, dynamics="impact")
    assert res.status == "separated"
    np.testing.assert_allclose(res.dv, facet_newton(mech, UR5_Q, v, contact, FACET, 0.6), rtol=1e-6, atol=1e-8)
    assert res.duration == pytest.approx(res.tau[0], rel=1e-5)
    np.testing.assert_allclose(res.impulse, mech.mass_matrix(UR5_Q) @ res.dv, rtol=1e-6, atol=1e-8)


def test_full_dynamics_converges_to_the_facet_law_first_order_in_one_over_M():
    mech, contact, v = ur5_case()
    target = facet_newton(mech, UR5_Q, v, contact, FACET, 0.6)
    Ms = np.array([1e2, 1e3, 1e4, 1e5])
    err = [np.linalg.norm(mbi.resolve(mech, UR5_Q, v, contact, FACET, M=M, e=0.6).dv - target) for M in Ms]
    order = -np.polyfit(np.log(Ms), np.log(err), 1)[0]
    assert order == pytest.approx(1.0, abs=0.1)  # observed order in M: 1
    assert err[-1] < 1e-3 * np.linalg.norm(target)


def test_stiff_contact_does_not_blow_up():
    mech, contact, v = ur5_case()
    res = mbi.resolve(mech, UR5_Q, v, contact, FACET, M=1e7, e=0.6)
    assert res.status == "separated" and res.duration == pytest.approx(res.tau[0], rel=1e-3)
    target = facet_newton(mech, UR5_Q, v, contact, FACET, 0.6)
    assert np.linalg.norm(res.dv - target) < 1e-5 * np.linalg.norm(target)  # O(1/M) with M = 1e7


def test_critical_damping_never_separates_and_says_so():
    mech, contact, v = ur5_case()
    res = mbi.resolve(mech, UR5_Q, v, contact, M=1e3, k=1.0, dynamics="impact")
    assert res.status == "no_separation"
    assert np.all(np.isfinite(res.v_plus))


def test_resolve_rough_converges_to_the_rough_law():
    mech, contact, v = ur5_case()
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.6)
    closed = mbi.impact(mech, UR5_Q, v, contact, law).dv
    sampled = mbi.resolve_rough(mech, UR5_Q, v, contact, mbi.Cone(0.3), samples=300, seed=2, M=1e3, e=0.6,
                                dynamics="impact")
    assert np.all(np.abs(sampled.dv - closed) <= 3 * sampled.ci95 + 1e-9)
    assert np.all(sampled.ci95 < 0.05 * np.abs(closed).max())


def test_rod_falling_flat_on_two_points_depends_on_the_stiffness_ratio():
    """[7]: simultaneous impacts have no unique outcome; contact-by-contact Newton disagrees."""
    rod = mbi.Mechanism.from_model("planar_rod")
    q = np.array([0.0, 0.5, 1.0, 0.0])
    v = np.array([0.0, -1.0, 0.0])
    ends = [mbi.PointContact("end_a"), mbi.PointContact("end_b")]
    omega = {}
    for ratio in (1.0, 2.0, 10.0):
        res = mbi.resolve(rod, q, v, ends, M=[1e3, 1e3 * ratio], e=0.8, gravity=False, t_max=3.0)
        assert res.status == "separated"
        T = lambda w: 0.5 * w @ rod.mass_matrix(q) @ w  # noqa: E731
        assert T(res.v_plus) <= T(v) * (1 + 1e-9)
        omega[ratio] = res.v_plus[2]
    assert omega[1.0] == pytest.approx(0.0, abs=1e-9)  # symmetric stiffness: no rotation
    assert abs(omega[2.0]) > 0.1 and abs(omega[10.0] - omega[2.0]) > 0.1
    # a single-contact law applied contact by contact
    vv = v.copy()
    for contact in ends * 4:
        if rod.point_jacobian(q, contact.frame)[2] @ vv < 0:
            vv = mbi.impact(rod, q, vv, contact, mbi.NewtonLaw(0.8)).v_plus
    assert all(abs(vv[2] - w) > 1e-2 for w in omega.values())


def test_quadruped_lands_on_four_feet_with_a_floating_base():
    solo = mechanism("solo12")
    q = solo.neutral()
    v = np.zeros(solo.nv)
    v[2] = -1.0
    feet = [mbi.PointContact(f) for f in ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")]
    res = mbi.resolve(solo, q, v, feet, M=1e5, e=0.5, gravity=False)
    assert res.status == "separated"
    assert res.q_plus.shape == (solo.nq,) and abs(np.linalg.norm(res.q_plus[3:7]) - 1) < 1e-12
    A = solo.mass_matrix(q)
    assert res.v_plus @ A @ res.v_plus <= v @ A @ v
    assert res.v_plus[2] > 0 and np.all(res.contact_impulse > 0)


def test_double_pendulum_striking_two_walls():
    mech = mbi.Mechanism.from_model("double_pendulum")
    q = np.array([0.4, -0.9])
    walls = [mbi.PointContact("tip", normal=(1.0, 0.0, 0.0)), mbi.PointContact("link2", normal=(-1.0, 0.0, 0.0))]
    Jt, Je = (mech.point_jacobian(q, w.frame) for w in walls)
    v = np.linalg.solve(np.array([Jt[0], -Je[0]]), [-1.0, -0.5])  # both points move into their walls
    res = mbi.resolve(mech, q, v, walls, M=[1e4, 3e4], e=0.7)
    assert res.status == "separated"
    A = mech.mass_matrix(q)
    assert res.v_plus @ A @ res.v_plus <= v @ A @ v * (1 + 1e-9)


def test_resolve_errors():
    mech, contact, v = ur5_case()
    with pytest.raises(mbi.ParameterError, match="M"):
        mbi.resolve(mech, UR5_Q, v, contact, M=0.0)
    with pytest.raises(mbi.ParameterError, match="k"):
        mbi.resolve(mech, UR5_Q, v, contact, k=1.5)
    with pytest.raises(mbi.ParameterError, match="at most one"):
        mbi.resolve(mech, UR5_Q, v, contact, k=0.1, e=0.5)
    with pytest.raises(mbi.NoImpactError):
        mbi.resolve(mech, UR5_Q, -v, contact)
    steep = np.array([math.sin(1.4), 0.0, math.cos(1.4)])  # tilted with the motion: not met
    J = mech.point_jacobian(UR5_Q, "tool0")
    v_grazing = np.linalg.lstsq(J, [1.0, 0.0, -0.05], rcond=None)[0]
    with pytest.raises(mbi.NoFacingFacetError):
        mbi.resolve(mech, UR5_Q, v_grazing, contact, steep)
    p = mech.frame_position(UR5_Q, "tool0")
    with pytest.raises(mbi.NoImpactError, match="not on its surface"):
        mbi.resolve(mech, UR5_Q, v, contact, surface_points=[p + [0, 0, 0.01]])
    res = mbi.resolve(mech, UR5_Q, v, contact, surface_points=[p], M=1e3)
    assert res.status == "separated"


def test_resolve_rough_full_dynamics_approaches_the_rough_law():
    mech, contact, v = ur5_case()
    closed = mbi.impact(mech, UR5_Q, v, contact, mbi.RoughLaw(mbi.Cone(0.3), 0.6)).dv
    sampled = mbi.resolve_rough(mech, UR5_Q, v, contact, mbi.Cone(0.3), samples=150, seed=4, M=1e4, e=0.6)
    bias = 5e-3 * np.abs(closed).max()  # O(1/M) of the full dynamics at M = 1e4
    assert np.all(np.abs(sampled.dv - closed) <= 3 * sampled.ci95 + bias)


def test_rocking_block_corner_strike_with_the_other_corner_on_the_ground():
    """Both corners on the ground, the block turning about one of them: only the other strikes."""
    rod = mbi.Mechanism.from_model("planar_rod")
    q = np.array([0.0, 0.0, 1.0, 0.0])
    omega = 1.0
    # rotation about end_a (x = -0.5): end_a still, end_b moving down
    J_a = rod.point_jacobian(q, "end_a")
    v = np.linalg.lstsq(np.vstack([J_a[[0, 2]], [0, 0, 1.0]]), [0.0, 0.0, omega], rcond=None)[0]
    assert rod.point_jacobian(q, "end_b")[2] @ v < 0
    ends = [mbi.PointContact("end_a"), mbi.PointContact("end_b")]
    res = mbi.resolve(rod, q, v, ends, M=1e4, e=0.5, gravity=False)
    assert res.status == "separated"
    A = rod.mass_matrix(q)
    assert res.v_plus @ A @ res.v_plus <= v @ A @ v
    assert res.contact_impulse[1] > 0  # the striking corner pushes
    u_a = rod.point_jacobian(q, "end_a")[2] @ res.v_plus
    assert u_a >= -1e-9  # the pivot corner is not driven into the ground


def test_flag_where_contact_by_contact_disagrees():
    rod = mbi.Mechanism.from_model("planar_rod")
    q = np.array([0.0, 0.5, 1.0, 0.0])
    v = np.array([0.0, -1.0, 0.0])
    ends = [mbi.PointContact("end_a"), mbi.PointContact("end_b")]
    flat = mbi.compare_simultaneous(rod, q, v, ends, mbi.NewtonLaw(0.8), M=[1e3, 1e4], e=0.8, gravity=False, t_max=3.0)
    assert flat.disagree and flat.difference > 0.05
    # one contact only: the two routes agree up to O(1/M)
    single = mbi.compare_simultaneous(rod, np.array([0.0, 0.5, math.cos(0.4), math.sin(0.4)]), v, ends[:1],
                                      mbi.NewtonLaw(0.8), M=1e6, e=0.8, gravity=False)
    assert not single.disagree and single.difference < 1e-3


def test_a_contact_that_reopens_and_closes_during_the_impact():
    """Stiffness ratio 2 on the flat rod: the stiff end leaves and strikes again (chattering)."""
    rod = mbi.Mechanism.from_model("planar_rod")
    ends = [mbi.PointContact("end_a"), mbi.PointContact("end_b")]
    res = mbi.resolve(rod, np.array([0.0, 0.5, 1.0, 0.0]), np.array([0.0, -1.0, 0.0]), ends, M=[1e3, 2e3], e=0.8,
                      gravity=False, t_max=3.0)
    f = res.f[1][np.abs(res.f[1]) > 1e-12]
    entries = int(np.sum(np.diff(np.sign(f)) < 0)) + int(f[0] < 0)
    assert res.status == "separated" and entries == 2


@pytest.mark.parametrize("ratio", [1e-3, 1e-6])
def test_grazing_touch_down(ratio):
    mech, contact, _ = ur5_case()
    J = mech.point_jacobian(UR5_Q, "tool0")
    v = np.linalg.lstsq(J, [1.0, 0.0, -ratio], rcond=None)[0]
    res = mbi.resolve(mech, UR5_Q, v, contact, M=1e4, e=0.5, dynamics="impact")
    assert res.status == "separated" and np.all(np.isfinite(res.v_plus))
    np.testing.assert_allclose(res.dv, mbi.impact(mech, UR5_Q, v, contact, mbi.NewtonLaw(0.5)).dv, rtol=1e-5,
                               atol=1e-6 * ratio)

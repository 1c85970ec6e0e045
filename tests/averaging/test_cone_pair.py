"""One velocity on a Cone: the compiled two-level shortcut against the general two-level quadrature."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging import Adaptive, ConePair
from mbimpact.averaging.cone_pair import KERNELS
from mbimpact.averaging.kernels import relative_change, rule_average

from tests.helpers import impulses, mechanism, relative_du, spd, unit_velocities

EPS = np.finfo(float).eps


@pytest.fixture(autouse=True, scope="module")
def _compiled() -> None:
    """Load (or, with a cold numba cache, compile: ~2 s) the kernel before the tests."""
    KERNELS.compile()


@given(st.integers(0, 2**32 - 1), st.floats(0.01, 1.55), st.sampled_from(["configuration", "physical"]),
       st.floats(1.0, 30.0))
def test_single_velocity_shortcut_equals_the_general_rule(seed, alpha, flux, cond):
    """Same nodes (periodic trapezoid on the full ring, Gauss–Legendre on the arc), same result, same
    error estimate and the same decision as the general rule's first pass; across both regimes of
    incidence."""
    rng = np.random.default_rng(seed)
    W = spd(rng, 3, cond)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux=flux)
    for u in unit_velocities(rng, 9):
        pair = ConePair().average(law.spec, W, u[None])
        coarse, fine = rule_average(law.spec, W, u[None], (32, 64))[0]
        err = relative_change(fine, coarse, W)[0]
        tol = max(law.rtol, 100 * EPS * math.sqrt(64))
        if pair is None:  # declined: the general pass does not settle it either (no facet is degenerate here)
            assert not err <= tol * (1 + 1e-6)
        else:  # the same sums in another order: rounding, which grows with cond W
            assert pair.nodes == 64 and pair.method == "cone-pair"
            assert relative_du(pair.P, fine, W)[0] < 2e-14 * cond
            assert pair.error[0] <= tol and abs(pair.error[0] - err) < 2e-14 * cond
        fast = impulses(law, W, u[None])
        slow = Adaptive().average(law.spec, W, u[None])
        assert relative_du(fast[0], slow.P, W)[0] < 2e-14 * cond
        # the same first pass: it settles the row (or the general route refines it), never more loosely
        assert fast[1][0] <= law.rtol and fast[2] <= slow.nodes


def test_switch_between_full_ring_and_arc_is_continuous():
    """At |u_t| tan α = |u_n| the arc has half-width π: both rules integrate the same circle."""
    alpha = 0.5
    W = spd(np.random.default_rng(3), 3, 10.0)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5)
    beta = math.pi / 2 - alpha
    P = [impulses(law, W, np.array([[math.sin(b) * 0.6, math.sin(b) * 0.8, -math.cos(b)]]))[0][0]
         for b in (beta - 1e-12, beta, beta + 1e-12)]
    assert relative_du(np.array(P[1:]), np.array(P[:2]), W).max() < 1e-9


def test_a_degenerate_facet_or_a_tight_rtol_takes_the_general_route():
    # a facet the mechanism cannot push (mᵀWm = 0 at φ = 0): the shortcut declines, the general rule masks it
    alpha = 0.4
    m = np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    W = np.eye(3) - np.outer(m, m)
    u = np.array([0.0, 0.0, -1.0])
    assert ConePair().average(mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux="configuration").spec, W, u[None]) is None
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)  # 1/mᵀWm is not integrable there: it says so
        P, err, nodes = impulses(law, W, u[None])
        ref = Adaptive().average(law.spec, W, u[None])
    np.testing.assert_array_equal(P, ref.P)
    assert nodes == ref.nodes > 64
    # rtol below rounding: the shortcut's pair does not settle it, the general route refines to the
    # documented rounding floor 100 ε √K
    W = spd(np.random.default_rng(4), 3, 30.0)
    law = mbi.RoughLaw(mbi.Cone(1.2), 0.5, rtol=1e-20)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", mbi.AccuracyWarning)
        _, err, nodes = impulses(law, W, np.array([[0.6, 0.0, -0.8]]))
    assert nodes > 64 and not caught
    assert err[0] <= 100 * np.finfo(float).eps * math.sqrt(nodes)


def test_single_impacts_on_robots_agree_with_the_batch_ring_path():
    """The shortcut (one velocity) and the ring expansion (a batch) are independent routes."""
    for name in ("ur5", "solo12", "talos"):
        mech = mechanism(name)
        rng = np.random.default_rng(11)
        q = mech.random_configuration(rng)
        J, A = mech.point_jacobian(q, mech.frame_names[-1]), mech.mass_matrix(q)
        if np.linalg.norm(J) < 1e-6:
            continue
        V = np.linalg.lstsq(J, unit_velocities(rng, 40).T, rcond=None)[0].T
        law = mbi.RoughLaw(mbi.Cone(0.35), 0.6)
        batch = law.apply_batch(A, J, V, [0, 0, 1])
        for i in (0, 17, 39):
            one = law.apply(A, J, V[i], [0, 0, 1])
            assert one.nodes == 2 * mbi.Cone.initial_nodes  # the first pass settled it
            np.testing.assert_allclose(one.P, batch.P[i], rtol=1e-11, atol=1e-11 * np.abs(batch.P[i]).max())

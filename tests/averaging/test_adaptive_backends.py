"""One velocity on a Cone: the adaptive rule's compiled backend (every level in one call) against its numpy
form (Adaptive.reference), and the decisions of "auto" that depend on it."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging import AUTO_ORDER, Adaptive, backends
from mbimpact.averaging.compiled import CONE
from mbimpact.averaging.compiled.codes import CAPPED, SETTLED
from mbimpact.averaging.integrand import relative_change, rule_average

from tests.helpers import impulses, mechanism, relative_du, seeds, spd, unit_velocities

EPS = np.finfo(float).eps


@pytest.fixture(autouse=True, scope="module")
def _compiled() -> None:
    """Load (or, with a cold numba cache, compile: ~2 s) the kernel before the tests."""
    CONE.compile()


@given(seeds, st.floats(0.01, 1.55), st.sampled_from(["configuration", "physical"]), st.floats(1.0, 3e3))
def test_every_level_equals_the_adaptive_rule(seed, alpha, flux, cond):
    """The same levels (n, 2n, … azimuth nodes: the periodic trapezoid rule on the full ring, Gauss–Legendre
    on the arc), the same result to rounding, the same final node count and error estimate; up to W's that
    need a hundred and more nodes (cond W up to 3e3), across both regimes of incidence. Where it does not
    settle, the numpy rule warns (it stopped short of rtol) or its last difference sat at the bound."""
    rng = np.random.default_rng(seed)
    W = spd(rng, 3, cond)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux=flux)
    for u in unit_velocities(rng, 7):
        status, fast = backends.adaptive(law.spec, W, u[None])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            slow = Adaptive().reference(law.spec, W, u[None])
        stop = max(law.rtol, 100 * EPS * np.sqrt(slow.nodes))  # the stopping test's bound
        if fast is None:
            assert any(issubclass(w.category, mbi.AccuracyWarning) for w in caught) or slow.error[0] > 0.1 * stop
            continue
        assert status == SETTLED and fast.method == "adaptive[compiled]"
        assert fast.error[0] <= max(law.rtol, 100 * EPS * np.sqrt(fast.nodes))
        if fast.nodes == slow.nodes:  # the same sums in another order
            assert relative_du(fast.P, slow.P, W)[0] < 1e-14 * cond
            assert abs(fast.error[0] - slow.error[0]) < 1e-13 * cond
        else:  # a difference at the bound, decided otherwise by rounding: one level apart, both converged; the
            # rule that settled first did so on a difference at the bound (the other found it just above)
            assert fast.nodes in (2 * slow.nodes, slow.nodes // 2)
            assert (fast if fast.nodes < slow.nodes else slow).error[0] > 0.1 * stop
            assert relative_du(fast.P, slow.P, W)[0] < 10 * stop


@given(st.integers(0, 2**32 - 1), st.floats(0.01, 1.55), st.sampled_from(["configuration", "physical"]),
       st.floats(1.0, 30.0))
def test_the_first_pass_decides_as_the_numpy_rule(seed, alpha, flux, cond):
    """Where the numpy rule's first pass (32 and 64 nodes) settles a velocity, so does the compiled one, at
    64 nodes, with the same result and error estimate to rounding; and the law's answer is never looser."""
    rng = np.random.default_rng(seed)
    W = spd(rng, 3, cond)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux=flux)
    for u in unit_velocities(rng, 9):
        status, fast = backends.adaptive(law.spec, W, u[None])
        coarse, fine = rule_average(law.spec, W, u[None], (32, 64))[0]
        err = relative_change(fine, coarse, W)[0]
        tol = max(law.rtol, 100 * EPS * math.sqrt(64))
        if err <= tol * (1 - 1e-6):
            assert status == SETTLED and fast.nodes == 64
            assert relative_du(fast.P, fine, W)[0] < 2e-14 * cond
            assert fast.error[0] <= tol and abs(fast.error[0] - err) < 2e-14 * cond
        elif err > tol * (1 + 1e-6):
            assert fast is None or fast.nodes > 64
        P, error, nodes = impulses(law, W, u[None])
        assert error[0] <= law.rtol  # the law's answer: settled to rtol, by the first pass or later levels
        if err <= tol:
            assert relative_du(P, fine, W)[0] < max(10 * tol, 2e-14 * cond)


def test_switch_between_full_ring_and_arc_is_continuous():
    """At |u_t| tan α = |u_n| the arc has half-width π: both rules integrate the same circle."""
    alpha = 0.5
    W = spd(np.random.default_rng(3), 3, 10.0)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5)
    beta = math.pi / 2 - alpha
    P = [impulses(law, W, np.array([[math.sin(b) * 0.6, math.sin(b) * 0.8, -math.cos(b)]]))[0][0]
         for b in (beta - 1e-12, beta, beta + 1e-12)]
    assert relative_du(np.array(P[1:]), np.array(P[:2]), W).max() < 1e-9


def test_a_degenerate_facet_or_a_tight_rtol_takes_the_numpy_rule():
    # a facet the mechanism cannot push (mᵀWm = 0 at φ = 0): the backend leaves it, the numpy rule masks it
    alpha = 0.4
    m = np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    W = np.eye(3) - np.outer(m, m)
    u = np.array([0.0, 0.0, -1.0])
    assert backends.adaptive(mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux="configuration").spec, W, u[None])[1] is None
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)  # 1/mᵀWm is not integrable there: it says so
        P, err, nodes = impulses(law, W, u[None])
        ref = Adaptive().reference(law.spec, W, u[None])
    np.testing.assert_array_equal(P, ref.P)  # the same numpy computation
    assert nodes == ref.nodes > 64
    # rtol below rounding: the compiled rule settles at the rounding floor 100 ε √K, as the numpy rule does
    W = spd(np.random.default_rng(4), 3, 30.0)
    law = mbi.RoughLaw(mbi.Cone(1.2), 0.5, rtol=1e-20)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", mbi.AccuracyWarning)
        _, err, nodes = impulses(law, W, np.array([[0.6, 0.0, -0.8]]))
    assert nodes > 64 and not caught
    assert err[0] <= 100 * EPS * math.sqrt(nodes)


def test_an_anisotropic_foot_needs_more_levels_than_the_first_pass():
    """The Solo12's foot on the ground (W's eigenvalues 30× apart): the first pair does not settle it, the
    compiled rule's further levels do, at the numpy rule's node count and impulse."""
    solo = mbi.Mechanism.from_robot("solo12")
    q = solo.neutral()
    q[2] = 0.336
    v = np.zeros(solo.nv)
    v[[0, 2]] = 0.3, -1.0
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    A, J = solo.mass_matrix(q), solo.point_jacobian(q, "FL_FOOT")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        res = mbi.impact(solo, q, v, mbi.PointContact("FL_FOOT"), law)
        numpy = law.replace(method="adaptive").apply_batch(A, J, np.vstack([v, v]), [0, 0, 1])  # two rows: numpy
    assert res.method == "adaptive[compiled]" and res.nodes == numpy.nodes >= 128 and numpy.method == "adaptive"
    np.testing.assert_allclose(res.P, numpy.P[0], rtol=1e-12)
    assert AUTO_ORDER.index("graded") < AUTO_ORDER.index("adaptive")


def test_it_leaves_to_the_numpy_rule_what_it_cannot_settle_and_that_warns():
    """max_nodes below what the case needs: the compiled rule is CAPPED, the numpy rule runs and reports the
    error reached."""
    W = np.array([[0.643, 6.4e-5, 3.3e-5], [6.4e-5, 0.328, 0.0493], [3.3e-5, 0.0493, 0.029]])  # a Solo12 foot's
    u = np.array([[0.28734789, 0.0, -0.95782629]])  # it needs 128 nodes
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5, max_nodes=64)
    assert backends.adaptive(law.spec, W, u) == (CAPPED, None)
    with pytest.warns(mbi.AccuracyWarning, match="64 nodes"):
        assert law.contact_impulses(W, u).method == "adaptive"
    assert not backends.one_velocity(law.spec, W, np.vstack([u, u]))  # one velocity only


def test_single_impacts_on_robots_agree_with_the_batch_ring_path():
    """The compiled rule (one velocity) and the ring expansion (a batch) are independent routes."""
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
        assert batch.method == "ring"
        for i in (0, 17, 39):
            one = law.apply(A, J, V[i], [0, 0, 1])
            assert one.nodes == 2 * mbi.Cone.initial_nodes  # the first pass settled it
            np.testing.assert_allclose(one.P, batch.P[i], rtol=1e-11, atol=1e-11 * np.abs(batch.P[i]).max())

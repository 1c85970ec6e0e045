"""One velocity on a Cone: the compiled adaptive rule (every level in one call) against the adaptive rule in numpy."""

import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging import AUTO_ORDER, Adaptive, ConePass

from tests.helpers import relative_du, seeds, spd, unit_velocities


@given(seeds, st.floats(0.01, 1.55), st.sampled_from(["configuration", "physical"]), st.floats(1.0, 3e3))
def test_every_level_equals_the_adaptive_rule(seed, alpha, flux, cond):
    """The same levels (n, 2n, … azimuth nodes), the same result to rounding, the same final node count
    and error estimate; up to W's that need a hundred and more nodes (cond W up to 3e3), across both
    regimes of incidence. Where it declines, the adaptive rule warns (it stopped short of rtol)."""
    rng = np.random.default_rng(seed)
    W = spd(rng, 3, cond)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux=flux)
    for u in unit_velocities(rng, 7):
        fast = ConePass().average(law.spec, W, u[None])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            slow = Adaptive().average(law.spec, W, u[None])
        stop = max(law.rtol, 100 * np.finfo(float).eps * np.sqrt(slow.nodes))  # the stopping test's bound
        if fast is None:  # the adaptive rule warned, or its last difference was itself at the bound
            assert any(issubclass(w.category, mbi.AccuracyWarning) for w in caught) or slow.error[0] > 0.1 * stop
            continue
        assert fast.method == "cone-pass"
        assert fast.error[0] <= max(law.rtol, 100 * np.finfo(float).eps * np.sqrt(fast.nodes))
        if fast.nodes == slow.nodes:  # the same sums in another order
            assert relative_du(fast.P, slow.P, W)[0] < 1e-14 * cond
            assert abs(fast.error[0] - slow.error[0]) < 1e-13 * cond
        else:  # a difference at the bound, decided otherwise by rounding: one level apart, both converged; the
            # rule that settled first did so on a difference at the bound (the other found it just above)
            assert fast.nodes in (2 * slow.nodes, slow.nodes // 2)
            assert (fast if fast.nodes < slow.nodes else slow).error[0] > 0.1 * stop
            assert relative_du(fast.P, slow.P, W)[0] < 10 * stop


def test_an_anisotropic_foot_takes_the_compiled_rule_where_the_pair_does_not_settle():
    """The Solo12's foot on the ground (W's eigenvalues 30× apart): the first pair does not settle it,
    the compiled rule does, at the adaptive rule's node count and impulse."""
    solo = mbi.Mechanism.from_robot("solo12")
    q = solo.neutral()
    q[2] = 0.336
    v = np.zeros(solo.nv)
    v[[0, 2]] = 0.3, -1.0
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        res = mbi.impact(solo, q, v, mbi.PointContact("FL_FOOT"), law)
        ref = mbi.impact(solo, q, v, mbi.PointContact("FL_FOOT"), law.replace(method="adaptive"))
    assert res.method == "cone-pass" and res.nodes == ref.nodes >= 128
    np.testing.assert_allclose(res.P, ref.P, rtol=1e-12)
    assert AUTO_ORDER.index("cone-pair") < AUTO_ORDER.index("cone-pass") < AUTO_ORDER.index("adaptive")


def test_it_declines_where_the_adaptive_rule_would_warn_and_auto_then_warns():
    """max_nodes below what the case needs: the compiled rule declines (CAPPED), "auto" runs the adaptive
    rule, which reports the error reached; naming "cone-pass" is then a ParameterError with the reason."""
    W = np.array([[0.643, 6.4e-5, 3.3e-5], [6.4e-5, 0.328, 0.0493], [3.3e-5, 0.0493, 0.029]])  # a Solo12 foot's
    u = np.array([[0.28734789, 0.0, -0.95782629]])  # it needs 128 nodes
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5, max_nodes=64)
    assert ConePass().average(law.spec, W, u) is None
    with pytest.warns(mbi.AccuracyWarning, match="64 nodes"):
        assert law.contact_impulses(W, u).method == "adaptive"
    with pytest.raises(mbi.ParameterError, match="stops short of rtol"):
        law.replace(method="cone-pass").contact_impulses(W, u)
    assert ConePass().average(law.spec, W, np.vstack([u, u])) is None  # one velocity only

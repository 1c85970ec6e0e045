"""One velocity on a Cone with a nearly singular W: the compiled graded rule against the graded rule in numpy."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging import AUTO_ORDER, GradedPass

from tests.helpers import (UPRIGHT_UR5, anisotropic_delassus, check_against_graded, mechanism, seeds,
                           unit_velocities, upright_ur5_delassus)


@given(seeds, st.floats(0.05, 1.5), st.sampled_from(["configuration", "physical"]), st.floats(3.0, 7.0),
       st.booleans())
def test_every_level_equals_the_graded_rule(seed, alpha, flux, log_cond, ur5):
    """The same minima, pieces, levels (n, 2n, … nodes a piece) and stopping rule: the same result to rounding
    at the same node count, on W with cond 1e3 … 1e7 (random, or the UR5's near-singular posture turned
    about the normal), across both regimes of incidence. It is worthwhile exactly where Graded is, declines
    exactly where Graded declines, and otherwise only where Graded warns or rounding decides: on such W the
    difference of two levels is itself rounding amplified by |W| |P| / |W P| (up to ~1e-8 for the UR5), so
    whether it falls below rtol = 1e-12 at this level or the next is rounding's decision, numpy's or the kernel's."""
    rng = np.random.default_rng(seed)
    W = anisotropic_delassus(rng, log_cond, ur5)
    cond = np.linalg.cond(W)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux=flux)
    for u in unit_velocities(rng, 7):
        check_against_graded(GradedPass(), law, W, u, cond)


def test_a_near_singular_arm_takes_the_compiled_graded_rule():
    """The UR5 upright with the elbow straight (W's eigenvalues 1e7 apart): the graded rule in one compiled
    call, at the numpy graded rule's node count and impulse ("auto" takes the poles out first, and grades the
    rule where that does not settle: test_pole_pass)."""
    mech = mechanism("ur5")
    v = np.linalg.lstsq(mech.point_jacobian(UPRIGHT_UR5, "tool0"), [0.3, 0.1, -1.0], rcond=None)[0]
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    contact = mbi.PointContact("tool0")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)  # further micro-impacts follow: not the point here
        res = mbi.impact(mech, UPRIGHT_UR5, v, contact, law.replace(method="graded-pass"))
        ref = mbi.impact(mech, UPRIGHT_UR5, v, contact, law.replace(method="graded"))
    assert res.method == "graded-pass" and ref.method == "graded" and res.nodes == ref.nodes
    np.testing.assert_allclose(res.P, ref.P, rtol=1e-12)
    assert AUTO_ORDER.index("graded-pass") + 1 == AUTO_ORDER.index("graded")
    # several velocities or a fixed node count: the numpy rule's (worthwhile says so, and it declines)
    W, u = upright_ur5_delassus(), np.array([[0.3, 0.1, -1.0]]) / math.sqrt(1.1)
    assert GradedPass().worthwhile(law.spec, W, u)
    for spec, U in ((law.spec, np.vstack([u, u])), (law.replace(nodes=32).spec, u)):
        assert not GradedPass().worthwhile(spec, W, U) and GradedPass().average(spec, W, U) is None
    assert law.contact_impulses(W, np.vstack([u, u])).method == "graded"


def test_it_declines_where_the_graded_rule_would_warn_and_naming_it_then_fails():
    """max_nodes below what the case needs (32 and 64 nodes a piece agree; max_nodes = 32 leaves the pair 16,
    32, which differ by ~1e-5): the compiled rule declines (CAPPED), "auto" runs the numpy graded rule, which
    reports the error reached; naming "graded-pass" is a ParameterError with the reason. On a W without a
    narrow peak it declines too."""
    W = upright_ur5_delassus()
    u = np.array([[math.sin(0.5), 0.0, -math.cos(0.5)]])
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5, flux="configuration")
    settled = GradedPass().average(law.spec, W, u)
    assert settled is not None and settled.nodes == 64
    capped = law.replace(max_nodes=32)
    assert GradedPass().average(capped.spec, W, u) is None
    with pytest.warns(mbi.AccuracyWarning, match="32 nodes"):
        assert capped.contact_impulses(W, u).method == "graded"
    with pytest.raises(mbi.ParameterError, match="stops short of rtol"):
        capped.replace(method="graded-pass").contact_impulses(W, u)
    with pytest.raises(mbi.ParameterError, match="no narrow peak"):
        law.replace(method="graded-pass").contact_impulses(np.eye(3), u)


def test_compile_kernels_covers_the_graded_kernels():
    out = mbi.compile_kernels()
    assert "mbimpact.averaging.graded_kernels" in out
    assert all(t >= 0.0 for t in out["mbimpact.averaging.graded_kernels"])


def test_auto_screens_a_single_velocity_once(monkeypatch):
    """"auto" reuses the compiled twin's screen for "graded" on one velocity (the same decision, tested
    above): the cone's twin screens in compiled code, the tilt density's with Graded's own screen, once
    an impact; a batch is still screened by "graded" itself."""
    from mbimpact.averaging import Graded

    calls = []
    screen = Graded.worthwhile

    def counted(self, spec, W, U):
        calls.append(len(U))
        return screen(self, spec, W, U)

    monkeypatch.setattr(Graded, "worthwhile", counted)
    foot = np.array([[0.643, 6.4e-5, 3.3e-5], [6.4e-5, 0.328, 0.0493], [3.3e-5, 0.0493, 0.029]])  # no narrow peak
    u = np.array([[0.28734789, 0.0, -0.95782629]])
    for law in (mbi.RoughLaw(mbi.Cone(0.3), 0.5), mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5)):
        for W in (foot, upright_ur5_delassus()):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", mbi.AccuracyWarning)
                law.contact_impulses(W, u)
    assert calls == [1, 1]  # the two impacts on the tilt density, once each; none for the cone
    mbi.RoughLaw(mbi.Cone(0.3), 0.5).contact_impulses(foot, np.vstack([u, u]))
    assert calls == [1, 1, 2]

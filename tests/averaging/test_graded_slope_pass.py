"""One velocity on a tilt density with a nearly singular W: the compiled graded rule against numpy's."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging import AUTO_ORDER, Graded, GradedSlopePass

from tests.helpers import (UPRIGHT_UR5, anisotropic_delassus, check_against_graded, mechanism, relative_du,
                           seeds, spd, unit_velocities, upright_ur5_delassus, upright_ur5_velocity)


@given(seeds, st.floats(0.05, 1.0), st.sampled_from(["configuration", "physical"]), st.floats(3.0, 6.0),
       st.booleans())
def test_every_level_equals_the_graded_rule(seed, sigma, flux, log_cond, ur5):
    """The same tilt and azimuth pieces, levels (n, 2n, … nodes a piece) and stopping rule: the same result
    to rounding at the same node count, on W with cond 1e3 … 1e6 (random, or the UR5's near-singular
    posture turned about the normal), across both regimes of incidence (rings whole and cut). It is
    worthwhile exactly where Graded is, declines where Graded declines, and otherwise only where Graded
    warns or rounding decides whether the last difference falls below rtol at this level or the next."""
    rng = np.random.default_rng(seed)
    W = anisotropic_delassus(rng, log_cond, ur5)
    cond = np.linalg.cond(W)
    law = mbi.RoughLaw(mbi.GaussianSlopes(sigma), 0.5, flux=flux)
    for u in np.vstack([unit_velocities(rng, 2, beta_max=0.3), unit_velocities(rng, 2)]):  # grazing and steep
        check_against_graded(GradedSlopePass(), law, W, u, cond, same_error=False)


def test_a_near_singular_arm_takes_the_compiled_graded_rule():
    """The UR5 upright with the elbow straight on Gaussian slopes with the configuration flux (the physical
    one goes to "laplace"): "auto" grades the rule in one compiled call, at the numpy graded rule's node
    count and impulse."""
    mech = mechanism("ur5")
    v = upright_ur5_velocity()
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, flux="configuration")
    contact = mbi.PointContact("tool0")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        res = mbi.impact(mech, UPRIGHT_UR5, v, contact, law)
        ref = mbi.impact(mech, UPRIGHT_UR5, v, contact, law.replace(method="graded"))
    assert res.method == "graded-slope-pass" and ref.method == "graded" and res.nodes == ref.nodes
    np.testing.assert_allclose(res.P, ref.P, rtol=1e-10)
    assert AUTO_ORDER.index("graded-slope-pass") + 1 == AUTO_ORDER.index("pole-pass")


def test_it_is_worthwhile_for_one_velocity_without_fixed_nodes_only():
    W, u = upright_ur5_delassus(), np.array([[0.3, 0.1, -1.0]]) / math.sqrt(1.1)
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5)
    assert GradedSlopePass().worthwhile(law.spec, W, u)
    for spec, U in ((law.spec, np.vstack([u, u])), (law.replace(nodes=16).spec, u)):
        assert not GradedSlopePass().worthwhile(spec, W, U) and GradedSlopePass().average(spec, W, U) is None
    configuration = law.replace(flux="configuration")  # the physical flux's batches go to "laplace"
    assert configuration.contact_impulses(W, np.vstack([u, u])).method == "graded"
    planar = mbi.RoughLaw(mbi.GaussianSlopes(0.3, dim=2), 0.5)
    assert not GradedSlopePass().supports(planar.spec)


def test_it_declines_where_the_graded_rule_would_warn_and_naming_it_then_fails():
    """max_nodes below what the case needs: the compiled rule declines (CAPPED), "auto" runs the numpy graded
    rule, which warns; naming "graded-slope-pass" is a ParameterError with the reason. On a W without a
    narrow peak it declines too."""
    W = upright_ur5_delassus()
    u = np.array([[math.sin(0.5), 0.0, -math.cos(0.5)]])
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, flux="configuration")
    settled = GradedSlopePass().average(law.spec, W, u)
    assert settled is not None and settled.nodes > 16
    capped = law.replace(max_nodes=16)
    assert GradedSlopePass().average(capped.spec, W, u) is None
    with pytest.warns(mbi.AccuracyWarning, match="16 nodes"):
        assert capped.contact_impulses(W, u).method == "graded"
    with pytest.raises(mbi.ParameterError, match="stops short of rtol"):
        capped.replace(method="graded-slope-pass").contact_impulses(W, u)
    mild = spd(np.random.default_rng(1), 3, 3.0)  # no narrow peak: Graded has no rule, nor has this
    assert Graded().average(law.spec, mild, u) is None and GradedSlopePass().average(law.spec, mild, u) is None


def test_compile_kernels_covers_the_graded_slope_kernels():
    out = mbi.compile_kernels()
    assert "mbimpact.averaging.graded_slope_kernels" in out
    assert all(t >= 0.0 for t in out["mbimpact.averaging.graded_slope_kernels"])


def test_levels_beyond_the_first_call_and_any_tilt_density(monkeypatch):
    """A velocity that needs more levels than the first call's tilts is run again with all of them, to the
    same result; a tilt density given as a Python callable takes the same route as the Gaussian one."""
    from mbimpact.averaging import graded_slope_pass

    W = upright_ur5_delassus()
    u = np.array([[math.sin(0.5), 0.0, -math.cos(0.5)]])
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, flux="configuration")
    first = GradedSlopePass().average(law.spec, W, u)
    monkeypatch.setattr(graded_slope_pass, "FIRST_LEVELS", 2)
    again = GradedSlopePass().average(law.spec, W, u)
    assert first is not None and again is not None and again.nodes == first.nodes > 16
    np.testing.assert_array_equal(again.P, first.P)
    bump = mbi.RoughLaw(mbi.IsotropicSlopes(lambda a: np.exp(-(((a - 0.3) / 0.1) ** 2)), support=(0.0, 0.8)), 0.5)
    for beta in (0.3, 1.2):
        v = np.array([[math.sin(beta), 0.0, -math.cos(beta)]])
        fast, slow = GradedSlopePass().average(bump.spec, W, v), Graded().average(bump.spec, W, v)
        assert fast is not None and slow is not None and fast.nodes == slow.nodes
        assert relative_du(fast.P, slow.P, W)[0] < 1e-14 * np.linalg.cond(W)

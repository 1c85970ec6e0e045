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
                           unit_velocities, upright_ur5_delassus, upright_ur5_velocity)


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
    v = upright_ur5_velocity()
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
    an impact; a batch is still screened by "graded" itself. (The tilt density's law has the
    configuration flux: with the physical one, Gaussian slopes go to "laplace", which needs no screen.)"""
    from mbimpact.averaging import Graded

    calls = []
    screen = Graded.worthwhile

    def counted(self, spec, W, U):
        calls.append(len(U))
        return screen(self, spec, W, U)

    monkeypatch.setattr(Graded, "worthwhile", counted)
    foot = np.array([[0.643, 6.4e-5, 3.3e-5], [6.4e-5, 0.328, 0.0493], [3.3e-5, 0.0493, 0.029]])  # no narrow peak
    u = np.array([[0.28734789, 0.0, -0.95782629]])
    for law in (mbi.RoughLaw(mbi.Cone(0.3), 0.5), mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, flux="configuration")):
        for W in (foot, upright_ur5_delassus()):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", mbi.AccuracyWarning)
                law.contact_impulses(W, u)
    assert calls == [1, 1]  # the two impacts on the tilt density, once each; none for the cone
    mbi.RoughLaw(mbi.Cone(0.3), 0.5).contact_impulses(foot, np.vstack([u, u]))
    assert calls == [1, 1, 2]


# Cones on nearly singular W where the graded rule's levels agree while all are off (q rounds alike at every
# level's nodes near its minima, or W nearly annihilates P): alpha, e, W (upper triangle), u, and P from an
# independent 36-digit evaluation of (2.8) (mpmath, adaptive quadrature split at the peaks).
ROUNDING_CASES = [
    (0.18971850649206928, 0.5,
     (1.8616055731825478, -0.20262876023033122, 0.30547405098144886, 0.02205646254037986, -0.0332496243190691,
      0.050125905241934644), (-0.5783237943814468, 0.17879304254290992, -0.7959740176604355),
     ("-2736.29302656572243927053632086613807", "136.996372459761661521993336463438506",
      "16771.8364542358138568568858077415976")),
    (0.7576663373528144, 0.0,
     (0.3354837579284305, -0.008159884781055244, -0.00027217216561346716, 0.00020049359531579681,
      6.042693331593098e-06, 4.196062417412844e-07), (-0.0017830057098334423, -0.1080716453761957, -0.9941415092210568),
     ("18.2230425760089061215208464028510249", "697.158405475605361687316615952468904",
      "1566.97120591784206404220684028401698")),
    (0.9360861984231083, 0.5,
     (0.07093006100372927, 0.015023636302568264, 0.09799979273761858, 0.06704069729018981, 0.04198085937253557,
      0.14245477802388087), (0.703560389273315, 0.5475829139142239, -0.4529412004165543),
     ("-6764.68423372064391638325159659174789", "-1727.41333246329448781124545413812896",
      "5150.02726835846257624726342756996405")),
    (0.8038694963286357, 1.0,
     (19.650919492851298, 1.6503655942473388, 8.395008298127625, 2.153192129623951, 2.6732413515574773,
      5.509276321177519), (-0.09833343073562785, -0.38067655435440506, -0.9194650060576635),
     ("-8.38840550655981588637536365787649279", "-23.5885723044251927287096762149862105",
      "24.3211485403329029323632508153546429")),
]


def _exact_error(P, W, ref):
    """|W (P − ref)| / |W ref| in exact rational arithmetic: rounding ref to float64 alone would move it by
    up to ε tr(W) |ref| / |W ref|, more than the errors measured here."""
    from fractions import Fraction

    Pf, rf = [Fraction(float(x)) for x in P], [Fraction(x) for x in ref]
    Wf = [[Fraction(float(x)) for x in row] for row in W]
    diff = [sum(Wf[i][k] * (Pf[k] - rf[k]) for k in range(3)) for i in range(3)]
    size = [sum(Wf[i][k] * rf[k] for k in range(3)) for i in range(3)]
    return math.sqrt(float(sum(d * d for d in diff) / sum(s * s for s in size)))


@pytest.mark.parametrize("case", range(len(ROUNDING_CASES)))
def test_its_error_estimate_holds_what_rounding_does_to_agreeing_levels(case):
    """Where successive levels agree to rtol while all of them are off (graded-pass erred by 3.8e-12 …
    1.5e-11 here with a level difference of 2.4e-13 … 6.8e-13), the estimate of graded-pass and graded
    holds the two rounding bounds that explain it: that of q at its minima (minima_sensitivity) and that of
    P where W nearly annihilates it (rounding_floor). It bounds the error against a 36-digit reference, and
    exceeds rtol there: the estimate says so, without a warning, as it does where two levels agree to the
    rounding floor 100 ε √K."""
    from mbimpact.averaging import Graded
    from mbimpact.averaging.refinement import rounding_floor
    from mbimpact.quadrature.graded import minima_sensitivity, ring_minima

    alpha, e, (w00, w01, w02, w11, w12, w22), u, ref = ROUNDING_CASES[case]
    W = np.array([[w00, w01, w02], [w01, w11, w12], [w02, w12, w22]])
    law, U = mbi.RoughLaw(mbi.Cone(alpha), e), np.array([u])
    bound = max(minima_sensitivity(alpha, W, ring_minima(alpha, W)[0], 0.5), 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)  # where rounding stalls numpy's levels, it says so
        results = [GradedPass().average(law.spec, W, U), Graded().average(law.spec, W, U)]
    assert results[1] is not None
    for out in results:
        if out is None:  # graded-pass declines where the numpy rule stalls at rounding
            continue
        floor = rounding_floor(out.P, W)[0]
        assert out.error[0] >= max(bound, floor)
        assert max(bound, floor) > law.rtol
        assert _exact_error(out.P[0], W, ref) <= out.error[0]

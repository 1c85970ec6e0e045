"""One velocity on a Cone with a nearly singular W: the graded rule's compiled backend against its numpy form."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging import AUTO_ORDER, Graded, backends
from mbimpact.averaging.compiled.codes import CAPPED, NOT_PEAKED, SETTLED

from tests.helpers import (UPRIGHT_UR5, anisotropic_delassus, check_against_graded, compiled_graded, mechanism,
                           seeds, unit_velocities, upright_ur5_delassus, upright_ur5_velocity)


@given(seeds, st.floats(0.05, 1.5), st.sampled_from(["configuration", "physical"]), st.floats(3.0, 7.0),
       st.booleans())
def test_every_level_equals_the_graded_rule(seed, alpha, flux, log_cond, ur5):
    """The same minima, pieces, levels (n, 2n, … nodes a piece) and stopping rule: the same result to rounding
    at the same node count, on W with cond 1e3 … 1e7 (random, or the UR5's near-singular posture turned
    about the normal), across both regimes of incidence. It declines exactly where the numpy rule has no
    graded rule, and otherwise differs only where that warns or rounding decides: on such W the
    difference of two levels is itself rounding amplified by |W| |P| / |W P| (up to ~1e-8 for the UR5), so
    whether it falls below rtol = 1e-12 at this level or the next is rounding's decision, numpy's or the kernel's."""
    rng = np.random.default_rng(seed)
    W = anisotropic_delassus(rng, log_cond, ur5)
    cond = np.linalg.cond(W)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux=flux)
    for u in unit_velocities(rng, 7):
        check_against_graded(compiled_graded, law, W, u, cond)


def test_a_near_singular_arm_takes_the_compiled_graded_rule():
    """The UR5 upright with the elbow straight (W's eigenvalues 1e7 apart): the graded rule in one compiled
    call, at the numpy graded rule's node count and impulse ("auto" takes the poles out first, and grades the
    rule where that does not settle: test_poles)."""
    mech = mechanism("ur5")
    v = upright_ur5_velocity()
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5, method="graded")
    contact = mbi.PointContact("tool0")
    A, J = mech.mass_matrix(UPRIGHT_UR5), mech.point_jacobian(UPRIGHT_UR5, "tool0")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)  # further micro-impacts follow: not the point here
        res = mbi.impact(mech, UPRIGHT_UR5, v, contact, law)
        ref = law.apply_batch(A, J, np.vstack([v, v]), [0, 0, 1])  # two rows: the numpy rule
    assert res.method == "graded[compiled]" and ref.method == "graded" and res.nodes == ref.nodes
    np.testing.assert_allclose(res.P, ref.P[0], rtol=1e-12)
    assert AUTO_ORDER.index("poles") + 1 == AUTO_ORDER.index("graded")
    # several velocities or a fixed node count: the numpy rule's
    W, u = upright_ur5_delassus(), np.array([[0.3, 0.1, -1.0]]) / math.sqrt(1.1)
    assert Graded().worthwhile(law.spec, W, u) and backends.one_velocity(law.spec, W, u)
    for spec, U in ((law.spec, np.vstack([u, u])), (law.replace(nodes=32).spec, u)):
        assert not backends.one_velocity(spec, W, U)
        assert Graded().average(spec, W, U).method == "graded"


def test_what_it_does_not_settle_goes_to_the_numpy_rule_which_warns():
    """max_nodes below what the case needs (32 and 64 nodes a piece agree; max_nodes = 32 leaves the pair 16,
    32, which differ by ~1e-5): the compiled rule is CAPPED, the numpy graded rule runs and reports the error
    reached. On a W without a narrow peak the rule declines, and naming it is a ParameterError."""
    W = upright_ur5_delassus()
    u = np.array([[math.sin(0.5), 0.0, -math.cos(0.5)]])
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5, flux="configuration")
    status, settled = backends.graded(law.spec, W, u, Graded.peaked)
    assert status == SETTLED and settled.nodes == 64
    capped = law.replace(max_nodes=32)
    assert backends.graded(capped.spec, W, u, Graded.peaked) == (CAPPED, None)
    with pytest.warns(mbi.AccuracyWarning, match="32 nodes"):
        assert capped.contact_impulses(W, u).method == "graded"
    assert backends.graded(law.spec, np.eye(3) / 3, u, Graded.peaked) == (NOT_PEAKED, None)
    with pytest.raises(mbi.ParameterError, match="no narrow peak"):
        law.replace(method="graded").contact_impulses(np.eye(3) / 3, u)


def test_compile_kernels_covers_the_graded_kernels():
    out = mbi.compile_kernels()
    assert "mbimpact.averaging.compiled.graded_cone" in out
    assert all(t >= 0.0 for t in out["mbimpact.averaging.compiled.graded_cone"])


def test_the_closed_form_screens_rule_out_only_what_the_compiled_peak_test_rules_out():
    """For one velocity on a cone, "auto" asks the closed-form screens of W (refinement.screened) before the
    graded and pole rules' compiled peak test: wherever the screens rule a W out, that test finds no peak
    narrower than Graded.peaked, on W from isotropic to cond 1e8."""
    from mbimpact.averaging.compiled import GRADED_CONE
    from mbimpact.averaging.refinement import screened

    ring_peaks = GRADED_CONE.get().ring_peaks
    rng = np.random.default_rng(21)
    ruled_out = 0
    for _ in range(400):
        W = anisotropic_delassus(rng, rng.uniform(0.0, 8.0), bool(rng.integers(2)))
        W = W / np.trace(W)
        if not screened(W, Graded.peaked):
            ruled_out += 1
            for alpha in np.linspace(0.02, 1.55, 12):
                assert ring_peaks(alpha, W, Graded.peaked) == 0
    assert ruled_out > 25


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
    """Where successive levels agree to rtol while all of them are off (the compiled rule erred by 3.8e-12 …
    1.5e-11 here with a level difference of 2.4e-13 … 6.8e-13), the estimate of the graded rule, compiled
    and in numpy, holds the two rounding bounds that explain it: that of q at its minima (minima_sensitivity) and that of
    P where W nearly annihilates it (rounding_floor). It bounds the error against a 36-digit reference, and
    exceeds rtol there: the estimate says so, without a warning, as it does where two levels agree to the
    rounding floor 100 ε √K."""
    from mbimpact.averaging.refinement import rounding_floor
    from mbimpact.quadrature.graded import minima_sensitivity, ring_minima

    alpha, e, (w00, w01, w02, w11, w12, w22), u, ref = ROUNDING_CASES[case]
    W = np.array([[w00, w01, w02], [w01, w11, w12], [w02, w12, w22]])
    law, U = mbi.RoughLaw(mbi.Cone(alpha), e), np.array([u])
    bound = max(minima_sensitivity(alpha, W, ring_minima(alpha, W)[0], 0.5), 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)  # where rounding stalls numpy's levels, it says so
        results = [compiled_graded(law.spec, W, U), Graded().reference(law.spec, W, U)]
    assert results[1] is not None
    for out in results:
        if out is None:  # the compiled rule leaves to numpy what stalls at rounding
            continue
        floor = rounding_floor(out.P, W)[0]
        # the compiled rule computes both bounds in its own arithmetic: equal to rounding
        assert out.error[0] >= max(bound, floor) * (1 - 1e-9)
        assert max(bound, floor) > law.rtol
        assert _exact_error(out.P[0], W, ref) <= out.error[0]

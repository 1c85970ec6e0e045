"""One velocity on a tilt density with a nearly singular W: the graded rule's compiled backend against its numpy form."""

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
                           relative_du, seeds, spd, unit_velocities, upright_ur5_delassus, upright_ur5_velocity)


@given(seeds, st.floats(0.05, 1.0), st.sampled_from(["configuration", "physical"]), st.floats(3.0, 6.0),
       st.booleans())
def test_every_level_equals_the_graded_rule(seed, sigma, flux, log_cond, ur5):
    """The same tilt and azimuth pieces, levels (n, 2n, … nodes a piece) and stopping rule: the same result
    to rounding at the same node count, on W with cond 1e3 … 1e6 (random, or the UR5's near-singular
    posture turned about the normal), across both regimes of incidence (rings whole and cut). It declines
    where the numpy rule has no graded rule, and otherwise differs only where that warns or rounding decides
    whether the last difference falls below rtol at this level or the next."""
    rng = np.random.default_rng(seed)
    W = anisotropic_delassus(rng, log_cond, ur5)
    cond = np.linalg.cond(W)
    law = mbi.RoughLaw(mbi.GaussianSlopes(sigma), 0.5, flux=flux)
    for u in np.vstack([unit_velocities(rng, 2, beta_max=0.3), unit_velocities(rng, 2)]):  # grazing and steep
        check_against_graded(compiled_graded, law, W, u, cond, same_error=False)


def test_a_near_singular_arm_takes_the_compiled_graded_rule():
    """The UR5 upright with the elbow straight on Gaussian slopes with the configuration flux (the physical
    one goes to "laplace"): "auto" grades the rule in one compiled call, at the numpy graded rule's node
    count and impulse."""
    mech = mechanism("ur5")
    v = upright_ur5_velocity()
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, flux="configuration")
    contact = mbi.PointContact("tool0")
    A, J = mech.mass_matrix(UPRIGHT_UR5), mech.point_jacobian(UPRIGHT_UR5, "tool0")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        warnings.simplefilter("ignore", mbi.AccuracyWarning)  # where numpy stalls at rounding it says so
        res = mbi.impact(mech, UPRIGHT_UR5, v, contact, law)
        ref = law.replace(method="graded").apply_batch(A, J, np.vstack([v, v]), [0, 0, 1])  # two rows: numpy
    assert res.method == "graded[compiled]" and ref.method == "graded"
    # the compiled level sums are compensated: where two levels differ by rounding the rules may settle one
    # level apart (check_against_graded), both within their estimates
    assert res.nodes in (ref.nodes, 2 * ref.nodes, ref.nodes // 2)
    W = J @ np.linalg.solve(A, J.T)
    assert relative_du(res.P[None], ref.P[:1], W)[0] <= 10 * max(1e-12, res.error_estimate, ref.error_estimate[0])
    assert AUTO_ORDER.index("laplace") < AUTO_ORDER.index("graded") < AUTO_ORDER.index("adaptive")


def test_it_runs_for_one_velocity_without_fixed_nodes_only():
    W, u = upright_ur5_delassus(), np.array([[0.3, 0.1, -1.0]]) / math.sqrt(1.1)
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5)
    assert backends.one_velocity(law.spec, W, u) and Graded().worthwhile(law.spec, W, u)
    for spec, U in ((law.spec, np.vstack([u, u])), (law.replace(nodes=16).spec, u)):
        assert not backends.one_velocity(spec, W, U)
    configuration = law.replace(flux="configuration")  # the physical flux's batches go to "laplace"
    assert configuration.contact_impulses(W, np.vstack([u, u])).method == "graded"
    planar = mbi.RoughLaw(mbi.GaussianSlopes(0.3, dim=2), 0.5)
    assert backends.graded(planar.spec, np.eye(2) / 2, np.array([[0.6, -0.8]]), Graded.peaked) == \
        (backends.NO_BACKEND, None)


def test_what_it_does_not_settle_goes_to_the_numpy_rule_which_warns():
    """max_nodes below what the case needs: the compiled rule is CAPPED, the numpy graded rule runs and warns.
    On a W without a narrow peak the rule declines, compiled and in numpy."""
    W = upright_ur5_delassus()
    u = np.array([[math.sin(0.5), 0.0, -math.cos(0.5)]])
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, flux="configuration")
    status, settled = backends.graded(law.spec, W, u, Graded.peaked)
    assert status == SETTLED and settled.nodes > 16
    capped = law.replace(max_nodes=16)
    assert backends.graded(capped.spec, W, u, Graded.peaked) == (CAPPED, None)
    with pytest.warns(mbi.AccuracyWarning, match="16 nodes"):
        assert capped.contact_impulses(W, u).method == "graded"
    mild = spd(np.random.default_rng(1), 3, 3.0)  # no narrow peak: Graded has no rule, compiled or in numpy
    assert Graded().reference(law.spec, mild, u) is None
    assert backends.graded(law.spec, mild, u, Graded.peaked) == (NOT_PEAKED, None)


def test_compile_kernels_covers_the_graded_slope_kernels():
    out = mbi.compile_kernels()
    assert "mbimpact.averaging.compiled.graded_slopes" in out
    assert all(t >= 0.0 for t in out["mbimpact.averaging.compiled.graded_slopes"])


def test_levels_beyond_the_first_call_and_any_tilt_density(monkeypatch):
    """A velocity that needs more levels than the first call's tilts is run again with all of them, to the
    same result; a tilt density given as a Python callable takes the same route as the Gaussian one."""
    W = upright_ur5_delassus()
    u = np.array([[math.sin(0.5), 0.0, -math.cos(0.5)]])
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, flux="configuration")
    first = compiled_graded(law.spec, W, u)
    monkeypatch.setattr(backends, "FIRST_LEVELS", 2)
    again = compiled_graded(law.spec, W, u)
    assert first is not None and again is not None and again.nodes == first.nodes > 16
    np.testing.assert_array_equal(again.P, first.P)  # the same computation, run again from the start
    bump = mbi.RoughLaw(mbi.IsotropicSlopes(lambda a: np.exp(-(((a - 0.3) / 0.1) ** 2)), support=(0.0, 0.8)), 0.5)
    for beta in (0.3, 1.2):
        v = np.array([[math.sin(beta), 0.0, -math.cos(beta)]])
        fast, slow = compiled_graded(bump.spec, W, v), Graded().reference(bump.spec, W, v)
        assert fast is not None and slow is not None and fast.nodes == slow.nodes
        assert relative_du(fast.P, slow.P, W)[0] < 1e-14 * np.linalg.cond(W)

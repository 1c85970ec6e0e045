"""One rough impact on a cone of a mechanism in one compiled call (RoughLaw.compiled_impact,
mbimpact.laws.compiled_cone.cone_impact).

Reference: the same law through the pipeline — a subclass of RoughLaw, which has no compiled impact (the
metric kernel, "auto" in Python with the rules' compiled backends, the outcome kernel). The compiled call
runs the steps of "auto" with the same kernels, so the two make the same decisions (method, node count,
warnings) and agree to rounding.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.laws.cone_plan import KERNELS

EPS = np.finfo(float).eps

from ..helpers import ROBOTS, last_frame, mechanism

FIELDS = ("v_minus", "v_plus", "dv", "P", "u_minus", "u_plus", "n0")


class Stepwise(mbi.RoughLaw):
    """RoughLaw through the three steps: a subclass does not take the compiled single impact."""


def _stepwise(law: mbi.RoughLaw) -> Stepwise:
    return Stepwise(law.roughness, law.e, flux=law.flux, rtol=law.rtol, max_nodes=law.max_nodes, repeat=law.repeat)


def _run(law: mbi.ImpactLaw, mech: mbi.Mechanism, q: np.ndarray, v: np.ndarray, contact: mbi.Contact):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = mbi.impact(mech, q, v, contact, law)
        except mbi.ImpactError as exc:
            return type(exc), str(exc).replace("Stepwise", "RoughLaw"), []
    return result, None, [(w.category, str(w.message).replace("Stepwise", "RoughLaw")) for w in caught]


def _assert_same(law: mbi.RoughLaw, mech: mbi.Mechanism, q: np.ndarray, v: np.ndarray, contact: mbi.Contact) -> str:
    """The compiled call and the pipeline make the same decisions and agree to rounding; returns the method."""
    got, got_error, got_warnings = _run(law, mech, q, v, contact)
    want, want_error, want_warnings = _run(_stepwise(law), mech, q, v, contact)
    assert (got_error, got_warnings) == (want_error, want_warnings)
    if got_error is not None:
        assert got == want  # the same exception class
        return "error"
    assert (got.method, got.nodes) == (want.method, want.nodes)
    assert abs(got.error_estimate - want.error_estimate) <= 64 * EPS + 1e-6 * want.error_estimate
    for f in FIELDS:
        g, w = getattr(got, f), getattr(want, f)
        np.testing.assert_allclose(g, w, rtol=0, atol=64 * EPS * max(np.abs(w).max(), np.abs(got.v_minus).max()),
                                   err_msg=f)
    assert got.law is law
    return got.method


@pytest.fixture(scope="module")
def stretched_ur5():
    """The UR5 with its elbow straight: W's eigenvalues 1e7 apart, the cone's kernels peak on the ring."""
    mech = mechanism("ur5")
    q = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])
    v = np.linalg.lstsq(mech.point_jacobian(q, "tool0"), [0.3, 0.1, -1.0], rcond=None)[0]
    return mech, q, v, mbi.PointContact("tool0")


@pytest.fixture(scope="module")
def solo_foot():
    """A Solo12 foot on the ground (W's eigenvalues 30× apart): the cone's rule needs 128 nodes."""
    mech = mechanism("solo12")
    q = mech.neutral()
    q[2] = 0.336
    v = np.zeros(mech.nv)
    v[[0, 2]] = 0.3, -1.0
    return mech, q, v, mbi.PointContact("FL_FOOT")


@pytest.mark.parametrize("flux", ["physical", "configuration"])
def test_each_compiled_method_and_the_declined_cases_match_the_pipeline(flux, stretched_ur5, solo_foot):
    cone = mbi.RoughLaw(mbi.Cone(0.3), 0.5, flux=flux)
    ur5 = mechanism("ur5")
    q = np.array([0.3, -1.0, 1.2, 0.4, -0.7, 0.2])
    J = ur5.point_jacobian(q, "tool0")
    generic = (ur5, q, -J[2] + 0.1 * J[0], mbi.PointContact("tool0"))
    assert _assert_same(cone, *generic) == "adaptive[compiled]"
    assert _assert_same(cone, *solo_foot) == "adaptive[compiled]"
    # W passes the rank screen on its eigenvalues; the physical flux's poles are taken out, the other's graded
    assert _assert_same(cone, *stretched_ur5) == ("poles" if flux == "physical" else "graded[compiled]")
    # declined: max_nodes stops the cone's levels short of rtol (AccuracyWarning, "adaptive" goes on)
    assert _assert_same(cone.replace(max_nodes=64), *solo_foot) == "adaptive"
    # not prepared: the contact point leaves the surface
    mech, q, v, contact = solo_foot
    assert _assert_same(cone, mech, q, -v, contact) == "error"


@settings(max_examples=60, deadline=None)
@given(robot=st.sampled_from(ROBOTS), seed=st.integers(0, 2**32 - 1), alpha=st.floats(0.05, 1.2),
       e=st.floats(0.0, 1.0), flux=st.sampled_from(["physical", "configuration"]), tilted=st.booleans())
def test_random_impacts_match_the_pipeline(robot, seed, alpha, e, flux, tilted):
    mech = mechanism(robot)
    rng = np.random.default_rng(seed)
    q = mech.random_configuration(rng)
    normal = rng.normal(size=3) * 0.4 + [0.0, 0.0, 1.0] if tilted else [0.0, 0.0, 1.0]
    contact = mbi.PointContact(last_frame(mech), normal=normal)
    J, R = contact.jacobian(mech, q, 3)
    v = -J.T @ R[:, -1] + rng.normal(size=mech.nv) * rng.uniform(0.0, 2.0)
    _assert_same(mbi.RoughLaw(mbi.Cone(alpha), e, flux=flux), mech, q, v, contact)


def test_a_cone_impact_loads_the_compiled_call_and_a_pickled_law_leaves_its_tables_behind():
    import pickle

    mech = mechanism("ur5")
    q = mech.neutral() + 0.3
    contact = mbi.PointContact("tool0")
    law = mbi.RoughLaw(mbi.Cone(0.4), 0.5)
    with KERNELS.unloaded():
        assert not KERNELS.ready
        mbi.impact(mech, q, -mech.point_jacobian(q, "tool0")[2], contact, law)
        assert KERNELS.ready
    # the law's node tables (tens of kB) are a cache: rebuilt after unpickling, not carried
    assert len(pickle.dumps(law)) < 2_000
    clone = pickle.loads(pickle.dumps(law))
    v = -mech.point_jacobian(q, "tool0")[2]
    assert np.array_equal(mbi.impact(mech, q, v, contact, clone).v_plus, mbi.impact(mech, q, v, contact, law).v_plus)


def test_settings_changed_after_the_first_impact_are_honoured(solo_foot):
    # the compiled route's plan is remade when what it was made of changes (here: repeat, set on the
    # law after an impact; and Graded.peaked, a class setting of "auto")
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        once = mbi.impact(*solo_foot[:3], solo_foot[3], law)
    assert not once.separates  # a foot pressed on the ground: one application still approaches
    law.repeat = True
    assert _assert_same(law, *solo_foot) == once.method
    assert mbi.impact(*solo_foot[:3], solo_foot[3], law).separates


def test_a_velocity_beyond_the_compiled_tables_goes_on_with_every_level():
    # the UR5 near a stretched posture: its cone needs 256 nodes; the compiled call's tables stop at 128,
    # it declines, and the adaptive rule goes on in Python with the tables up to max_nodes
    mech = mechanism("ur5")
    q = np.array([0.0, -1.2, 0.0, -1.57, 0.0, 0.0])
    v = np.linalg.lstsq(mech.point_jacobian(q, "tool0"), [0.3, 0.1, -1.0], rcond=None)[0]
    contact = mbi.PointContact("tool0")
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    assert _assert_same(law, mech, q, v, contact) == "adaptive[compiled]"
    assert mbi.impact(mech, q, v, contact, law).nodes == 256


def _kernel_states(count, seed):
    """Random states of the UR5 and the Solo12 at a random contact frame, as the compiled call takes them."""
    rng = np.random.default_rng(seed)
    for robot, frame in (("ur5", "tool0"), ("solo12", "FL_FOOT")):
        mech = mechanism(robot)
        for _ in range(count):
            q = mech.random_configuration(rng)
            _A, U, D = mech.factor_arrays(q)
            J = mech.point_jacobian(q, frame)
            R = np.linalg.qr(rng.normal(size=(3, 3)))[0] if rng.random() < 0.5 else np.eye(3)
            yield U, D, J, -J.T @ R[:, 2] + rng.normal(size=mech.nv) * rng.uniform(0.0, 2.0), R


def test_the_call_without_the_peaked_rules_is_the_same_arithmetic_and_hands_a_peak_on(stretched_ur5):
    from mbimpact.common.geometry import DEGENERATE
    from mbimpact.laws.compiled import PEAKED, RANK_FLOOR

    kernels = KERNELS.get()
    for flux in ("physical", "configuration"):
        compiled = mbi.RoughLaw(mbi.Cone(0.3), 0.5, flux=flux).compiled_impact()
        assert (compiled.single, compiled.whole) == ("cone_unpeaked", "cone_impact")
        for U, D, J, v, R in _kernel_states(40, 5):
            got, want = np.full(6 * len(v) + 33, 7.0), np.full(6 * len(v) + 33, 7.0)
            a = kernels.cone_unpeaked(U, D, J, v, R, DEGENERATE, RANK_FLOOR, *compiled.args, got)
            b = kernels.cone_impact(U, D, J, v, R, DEGENERATE, RANK_FLOOR, *compiled.args, want)
            assert a[0] != PEAKED  # no narrow peak at these states
            assert a == b and np.array_equal(got, want, equal_nan=True)  # to the bit
        mech, q, v, contact = stretched_ur5
        _A, U, D = mech.factor_arrays(q)
        J, R = contact.jacobian(mech, q, 3)
        buffer = np.empty(6 * mech.nv + 33)
        assert kernels.cone_unpeaked(U, D, J, v, R, DEGENERATE, RANK_FLOOR, *compiled.args, buffer)[0] == PEAKED
        status = kernels.cone_impact(U, D, J, v, R, DEGENERATE, RANK_FLOOR, *compiled.args, buffer)[0]
        assert compiled.methods[status] == ("poles" if flux == "physical" else "graded[compiled]")


def test_a_compiled_impact_runs_every_step_once_a_velocity_needs_them(stretched_ur5):
    ur5 = mechanism("ur5")
    q = np.array([0.3, -1.0, 1.2, 0.4, -0.7, 0.2])
    J = ur5.point_jacobian(q, "tool0")
    generic = (ur5, q, -J[2] + 0.1 * J[0], mbi.PointContact("tool0"))
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.4375)  # a restitution of its own: a compiled impact of its own
    compiled = law.compiled_impact()
    assert compiled._in_use == ["cone_unpeaked"]
    before = mbi.impact(*generic, law)
    assert compiled._in_use == ["cone_unpeaked"]
    assert _assert_same(law, *stretched_ur5) == "poles"  # the first peak: cone_impact from now on
    assert compiled._in_use == ["cone_impact"]
    after = mbi.impact(*generic, law)
    assert before.method == after.method == "adaptive[compiled]"
    for f in FIELDS:
        assert np.array_equal(getattr(before, f), getattr(after, f)), f  # the same result, to the bit


def test_an_impact_without_a_narrow_peak_compiles_neither_peaked_rule():
    # in a fresh interpreter, as `mbimpact demo` runs: the kernels it does not reach are not compiled, nor
    # loaded from numba's cache
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent("""
        import numpy as np
        import mbimpact as mbi
        from mbimpact.averaging.compiled import GRADED_CONE, POLES
        from mbimpact.laws.cone_plan import KERNELS
        from mbimpact.metric.delassus import KERNELS as METRIC

        mech = mbi.Mechanism.from_robot("ur5")
        q = np.array([0.3, -1.0, 1.2, 0.4, -0.7, 0.2])
        J = mech.point_jacobian(q, "tool0")
        result = mbi.impact(mech, q, -J[2] + 0.1 * J[0], mbi.PointContact("tool0"), mbi.RoughLaw(mbi.Cone(0.3), 0.5))
        cone, metric = KERNELS.get(), METRIC.get()
        print(result.method)
        print(*(len(f.signatures) for f in (cone.cone_unpeaked, cone.cone_impact, cone.cone_batch, POLES.get().poles,
                                             GRADED_CONE.get().graded_cone, GRADED_CONE.get().ring_peaks,
                                             metric.prepare_factor, metric.finish, metric.delassus)))
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    method, counts = done.stdout.splitlines()[-2:]
    assert method == "adaptive[compiled]"
    assert counts == "1 0 0 0 0 0 0 0 0"  # (the adaptive rule's kernel is compiled into the first, or loaded with it)

"""The compiled front end (mbimpact.mechanism.front): built by this install, and the Python route's results
to rounding for every law that takes it, with the same decisions and the same errors for what it hands
back."""

import os
import pickle
import subprocess
import sys
import threading
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.mechanism import front

from tests.helpers import ROBOTS, mechanism, seeds

FIELDS = ("v_minus", "v_plus", "dv", "P", "u_minus", "u_plus", "n0", "A", "J", "error_estimate", "nodes", "method")
LAWS = [mbi.NewtonLaw(0.0), mbi.NewtonLaw(0.6), mbi.RoughLaw(mbi.Cone(alpha=0.3), e=0.8), mbi.CoulombLaw(0.4, 0.5),
        mbi.RoughLaw(mbi.GaussianSlopes(0.2), e=0.5), mbi.RoughLaw(mbi.Sawtooth(0.3), e=0.5)]


def outcome(mech, q, v, contact, law):
    """The result, or the class and text of the error it raises (warnings ignored)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return mbi.impact(mech, q, v, contact, law)
        except mbi.ImpactError as exc:
            return type(exc), str(exc)


def assert_same(got, want, exact: bool = False):
    """The same result (to rounding; to the bit with ``exact``: one route on one machine) or the same error.
    Where a stopping test decided otherwise on a difference at rounding, both results are still converged:
    within 1e-9 of each other."""
    if isinstance(want, tuple):
        assert got == want
        return
    assert not isinstance(got, tuple), got
    same = (got.method, got.nodes) == (want.method, want.nodes)
    assert same or not exact
    tol = 0.0 if exact else 1e-11 * max(1.0, np.linalg.cond(want.A) * 1e-4) if same else 1e-9
    scale = max(np.abs(want.v_minus).max(), np.abs(want.u_minus).max(), 1e-300)
    for name in FIELDS:
        a, b = getattr(got, name), getattr(want, name)
        if isinstance(a, np.ndarray):
            assert a.shape == b.shape and not a.flags.writeable, name
            np.testing.assert_allclose(a, b, rtol=0, atol=tol * max(np.abs(b).max(), scale), err_msg=name)
        elif name == "error_estimate":
            assert abs(a - b) <= (0.0 if exact else 1e-9 + 1e-6 * abs(b)), name
        elif same:
            assert a == b, name


def assert_close(got, want):
    """Two builds of the same arithmetic (the front end's C++ and Pinocchio's bindings or the kernels):
    equal to rounding, scaled to the largest entry."""
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-14 * max(np.abs(want).max(), 1e-300))


def test_this_install_built_it():
    """CI and a fresh `pip install` compile the front end; off only where the environment says so."""
    if os.environ.get("MBIMPACT_NATIVE") == "0":
        assert not front.available() and front.status() == "off: MBIMPACT_NATIVE=0"
        return
    assert front.available(), front.status()
    assert front.status().startswith("on: built for Pinocchio")
    with front.disabled():
        assert not front.available() and front.status() == "off: disabled()"
    assert front.available()


@pytest.mark.skipif(not front.available(), reason="compiled front end not in use")
@given(st.sampled_from(ROBOTS), seeds, st.sampled_from(range(len(LAWS))), st.booleans())
def test_the_python_routes_results(name, seed, which, offset):
    """Every field of every law's result, or the error it raises, equals the Python route's to rounding:
    random robots, frames, normals, offsets, configurations and velocities (half of them approaching)."""
    mech = mechanism(name)
    rng = np.random.default_rng(seed)
    frames = [f.name for f in mech.model.frames if f.parentJoint > 0]
    point = rng.normal(size=3) * 0.2 if offset else np.zeros(3)
    contact = mbi.PointContact(frames[rng.integers(len(frames))], normal=rng.normal(size=3), point=point)
    q = mech.random_configuration(rng)
    v = rng.normal(size=mech.nv)
    J = mech.point_jacobian(q, contact.frame, point)
    if seed % 2 and np.any(contact.normal @ J):  # make it approach
        jn = contact.normal @ J
        v -= (jn @ v + 1.0) * jn / (jn @ jn)
    law = LAWS[which]
    got = outcome(mech, q, v, contact, law)
    with front.disabled():
        want = outcome(mech, q, v, contact, law)
    assert_same(got, want)


@pytest.mark.skipif(not front.available(), reason="compiled front end not in use")
@pytest.mark.parametrize("law", LAWS[:3], ids=repr)
def test_inputs_it_hands_back_get_the_same_answer(law):
    """Lists, other dtypes, strided views, NaN, wrong lengths and unnormalised quaternions go to the
    Python route's checks: the same result or the same named error."""
    mech = mechanism("solo12")
    rng = np.random.default_rng(4)
    contact = mbi.PointContact("FL_FOOT")
    q = mech.random_configuration(rng)
    J = mech.point_jacobian(q, "FL_FOOT")
    v = -J[2] / (J[2] @ J[2])
    wide = np.zeros((len(q), 2))
    wide[:, 0] = q
    cases = [(q.tolist(), v), (q, v.astype(np.float32)), (wide[:, 0], v), (q, v.tolist()),
             (np.where(np.arange(len(q)) == 3, np.nan, q), v), (q[:-1], v), (q, np.append(v, 0.0)),
             (np.where(np.arange(len(q)) == 6, 2.0, q), v), (q.astype(np.int64), v)]
    for qi, vi in cases:
        got = outcome(mech, qi, vi, contact, law)
        with front.disabled():
            want = outcome(mech, qi, vi, contact, law)
        assert_same(got, want)
    assert isinstance(outcome(mech, q[:-1], v, contact, law), tuple)  # the cases above include errors


def test_a_contact_that_overrides_the_jacobian_keeps_its_own():
    """A PointContact subclass with its own jacobian is applied by the pipeline, not the front end."""

    class Doubled(mbi.PointContact):
        def jacobian(self, mech, q, d=3):
            J, R = super().jacobian(mech, q, d)
            return 2.0 * J, R

    mech = mechanism("ur5")
    q = mech.neutral() + 0.3
    plain, doubled = mbi.PointContact("tool0"), Doubled("tool0")
    J = mech.point_jacobian(q, "tool0")
    v = -J[2] / (J[2] @ J[2])
    for law in LAWS[:3]:
        res = mbi.impact(mech, q, v, doubled, law)
        np.testing.assert_array_equal(res.J, 2.0 * mbi.impact(mech, q, v, plain, law).J)


def test_a_contact_that_overrides_the_basis_is_applied_as_the_pipeline_applies_it():
    """A PointContact subclass with its own basis() is applied by the pipeline (the front end hands its
    frame to compiled kernels unchecked), which takes that basis as the contact frame: the same result with
    the front end on and off."""

    class Turned(mbi.PointContact):
        def basis(self):
            return super().basis()[:, [1, 0, 2]] * [1.0, -1.0, 1.0]

    mech = mechanism("ur5")
    q = mech.neutral() + 0.3
    contact = Turned("tool0")
    J = mech.point_jacobian(q, "tool0")
    v = -J[2] / (J[2] @ J[2]) + 0.2 * J[0]
    assert np.array_equal(contact.jacobian(mech, q)[1], contact.basis())
    for law in LAWS[:3] + LAWS[4:5]:
        got = outcome(mech, q, v, contact, law)
        with front.disabled():
            want = outcome(mech, q, v, contact, law)
        assert_same(got, want)


def test_factors_kept_for_later_solves_stay_right():
    """A call through the front end re-factorises the workspace: a metric made before still solves
    with its own A(q)."""
    mech = mechanism("ur5")
    rng = np.random.default_rng(2)
    q1, q2 = mech.random_configuration(rng), mech.random_configuration(rng)
    metric = mbi.ContactMetric.from_mechanism(mech, q1, mech.point_jacobian(q1, "tool0"))
    b = rng.normal(size=mech.nv)
    before = metric.solve(b)
    J2 = mech.point_jacobian(q2, "tool0")
    mbi.impact(mech, q2, -J2[2] / (J2[2] @ J2[2]), mbi.PointContact("tool0"), mbi.NewtonLaw(0.5))
    np.testing.assert_array_equal(metric.solve(b), before)
    np.testing.assert_allclose(mech.mass_matrix(q1) @ before, b, rtol=0, atol=1e-12 * np.abs(b).max() * 1e3)


def test_threads_each_get_their_own_workspace():
    """Impacts on one mechanism from two threads give each thread's single-threaded results."""
    mech = mechanism("panda")
    contact, law = mbi.PointContact("panda_hand"), mbi.RoughLaw(mbi.Cone(alpha=0.3), e=0.5)
    rng = np.random.default_rng(7)
    states = []
    for _ in range(40):
        q = mech.random_configuration(rng)
        J = mech.point_jacobian(q, "panda_hand")
        states.append((q, -J[2] / (J[2] @ J[2]) + 0.1 * rng.normal(size=mech.nv)))
    alone = [outcome(mech, q, v, contact, law) for q, v in states]
    got: dict[int, list] = {}

    def work(k):
        got[k] = [outcome(mech, q, v, contact, law) for _ in range(5) for q, v in states][-len(states):]

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in range(2):
        for a, b in zip(got[k], alone):
            assert_same(a, b, exact=True)


@pytest.mark.skipif(not front.available(), reason="compiled front end not in use")
def test_its_calls_check_their_own_arguments():
    """The extension's own errors: not a model and data, a Data of another model, a short buffer."""
    native = front.NATIVE
    ur5, panda = mechanism("ur5"), mechanism("panda")
    with pytest.raises(TypeError, match="pinocchio.Model and a pinocchio.Data"):
        native.bind(1, 2)
    with pytest.raises(ValueError, match="not made by this model"):
        native.bind(ur5.model, panda.model.createData())
    bound = native.bind(ur5.model, ur5.model.createData())
    q, v = ur5.neutral(), -np.ones(ur5.nv)
    with pytest.raises(ValueError, match="at least"):
        native.newton(bound, q, v, 1, np.zeros(3), np.eye(3), 0.5, np.empty(10))
    with pytest.raises(TypeError, match="takes 8 arguments"):
        native.newton(bound, q, v)
    n = ur5.nv
    A, J = np.empty((n, n)), np.empty((3, n))
    assert native.stage_one(bound, q, v, 10 ** 6, np.zeros(3), A, J) == native.CHECKS  # no such frame
    assert native.stage_one(bound, q, v, ur5.frame_id("tool0"), np.zeros(3), A, J) == native.DONE
    assert_close(A, ur5.mass_matrix(q))


def test_results_it_packs_pickle_and_read_back():
    """A Newton result made of one packed buffer (ImpactResult.from_packed) pickles to equal arrays,
    and its A and J are the mechanism's."""
    mech = mechanism("talos")
    rng = np.random.default_rng(5)
    q = mech.random_configuration(rng)
    J = mech.point_jacobian(q, "left_sole_link")
    res = mbi.impact(mech, q, -J[2] / (J[2] @ J[2]), mbi.PointContact("left_sole_link"), mbi.NewtonLaw(0.3))
    back = pickle.loads(pickle.dumps(res))
    assert_same(back, res, exact=True)
    assert_close(res.A, mech.mass_matrix(q))
    assert_close(res.J, J)
    assert res.kappa == pytest.approx(0.3, abs=1e-9)


def test_the_environment_can_turn_it_off():
    """MBIMPACT_NATIVE=0: the front end is off, and impacts still run (the Python route)."""
    code = ("import numpy as np, mbimpact as mbi; from mbimpact.mechanism import front; "
            "m = mbi.Mechanism.from_robot('ur5'); q = m.neutral() + 0.3; J = m.point_jacobian(q, 'tool0'); "
            "r = mbi.impact(m, q, -J[2] / (J[2] @ J[2]), mbi.PointContact('tool0'), mbi.NewtonLaw(0.5)); "
            "print(front.status(), round(r.kappa, 6))")
    out = subprocess.run([sys.executable, "-c", code], env={**os.environ, "MBIMPACT_NATIVE": "0"},
                         capture_output=True, text=True, check=True).stdout.strip()
    assert out == "off: MBIMPACT_NATIVE=0 0.5"


def test_the_build_backend_finds_the_headers_it_compiles_against():
    """The backend's extension looks for Pinocchio's, Boost's and Eigen's headers and Pinocchio's library in
    the cmeel wheels on sys.path (here: the runtime's, which carry them as the build environment's do),
    and builds it optional: an install without a compiler goes on without it."""
    from pathlib import Path

    pytest.importorskip("setuptools")
    from mbimpact.mechanism import native_build

    ext = native_build.extension()
    assert ext.name == "mbimpact.mechanism.native" and ext.optional
    found = {h: any((Path(d) / h).is_file() for d in ext.include_dirs)
             for h in ("pinocchio/config.hpp", "boost/python.hpp", "Eigen/Core")}
    assert found["pinocchio/config.hpp"] and found["boost/python.hpp"], found
    assert any(Path(d, "libpinocchio_default.so").exists() for d in ext.library_dirs)
    assert Path(ext.sources[0]).name == "native.cpp"


@pytest.mark.parametrize("law", [LAWS[1], LAWS[2], LAWS[3]], ids=repr)
def test_batches_gathered_by_it_equal_single_impacts(law):
    """impact_batch's rows gathered by the front end (offset point, free flyer) are the Python route's to
    rounding, and impact()'s (the same compiled code on one machine: to the bit); a row with an unnormalised
    quaternion raises its error in row order."""
    mech = mechanism("solo12")
    rng = np.random.default_rng(9)
    contact = mbi.PointContact("HR_FOOT", normal=[0.1, 0.0, 1.0], point=[0.01, -0.02, 0.0])
    Q = np.array([mech.random_configuration(rng) for _ in range(24)])
    V = np.empty((24, mech.nv))
    for i, q in enumerate(Q):
        J = mech.point_jacobian(q, "HR_FOOT", contact.point)
        jn = contact.normal @ J
        V[i] = -jn / (jn @ jn) + 0.05 * rng.normal(size=mech.nv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        batch = mbi.impact_batch(mech, Q, V, contact, law)
        with front.disabled():
            python = mbi.impact_batch(mech, Q, V, contact, law)
        for i in range(0, 24, 5):
            single = mbi.impact(mech, Q[i], V[i], contact, law)
            assert_close(batch.V_plus[i], single.v_plus)
            assert_close(batch.J[i], single.J)
    scale = np.abs(V).max()
    np.testing.assert_allclose(batch.V_plus, python.V_plus, rtol=0, atol=1e-11 * scale)
    assert_close(batch.A, python.A)
    Q[7, 3] = 2.0  # the base quaternion, not normalised
    with pytest.raises(mbi.ParameterError, match="not normalised"):
        mbi.impact_batch(mech, Q, V, contact, law)

"""The compiled route of a mechanism's spatial impact (ImpactLaw.apply_metric on a FactoredMetric): the metric and the
state from Pinocchio's factor of A(q) in one call, the law, the outcome (1.1) in another, and the
result made of their buffer (ImpactResult.from_buffer).

References: the arrays route on A(q) from ``pin.crba`` and LAPACK (no kernel, no Pinocchio factor),
and the declined cases' own errors.
"""

from __future__ import annotations

import copy
import dataclasses
import pickle
import warnings

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.metric.delassus import ContactMetric

from ..helpers import ROBOTS, last_frame, mechanism, seeds

LAWS = {
    "cone": mbi.RoughLaw(mbi.Cone(0.4), e=0.5),
    "gaussian": mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5),
    "coulomb sticking": mbi.CoulombLaw(0.0, 3.0),
    "coulomb sliding": mbi.CoulombLaw(0.5, 0.2),
    "newton": mbi.NewtonLaw(0.7),
}
FIELDS = ("v_minus", "v_plus", "dv", "P", "u_minus", "u_plus", "n0")


def _state(name: str, seed: int, tilted: bool):
    mech = mechanism(name)
    rng = np.random.default_rng(seed)
    q = mech.random_configuration(rng)
    normal = rng.normal(size=3) * 0.3 + [0.0, 0.0, 1.0] if tilted else [0.0, 0.0, 1.0]
    contact = mbi.PointContact(last_frame(mech), normal=normal)
    J, R = contact.jacobian(mech, q, 3)
    n0 = R[:, -1]
    v = -J.T @ n0 / max(np.linalg.norm(J.T @ n0), 1e-300) + 0.5 * rng.normal(size=mech.nv)
    if (J @ v) @ n0 >= 0:
        v = -J.T @ n0
    return mech, q, v, contact, J.copy(), R


def _compare(name: str, seed: int, law_name: str, tilted: bool) -> tuple[str, str] | None:
    """mbi.impact on a mechanism (Pinocchio's factor, compiled) against law.apply on A(q) = pin.crba and
    J (LAPACK's factor, numpy): the same impact to the accuracy the conditioning of A allows, and the
    same separation. Returns the two methods, or None when nothing was compared."""
    mech, q, v, contact, J, R = _state(name, seed, tilted)
    n0 = R[:, -1]
    if np.linalg.norm(n0 @ J) < 1e-3 * np.linalg.norm(J):
        return None  # n⁰ (nearly) out of reach: the declined cases are tested below
    law = LAWS[law_name]
    A = mech.mass_matrix(q)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        warnings.simplefilter("ignore", mbi.AccuracyWarning)
        try:
            ref = law.apply(A, J, v, R)
        except mbi.ImpactError as exc:  # e.g. a Coulomb impact that jams on a near-singular W
            with pytest.raises(type(exc)):
                mbi.impact(mech, q, v, contact, law)
            return None
        res = mbi.impact(mech, q, v, contact, law)
    tol = 1e-12 * max(1.0, np.linalg.cond(A) * 1e-4)  # the two factors of A differ by ~ε cond(A)
    if (res.method, res.nodes) != (ref.method, ref.nodes):  # a screen or a stopping test decided otherwise
        tol = max(tol, 1e-9)  # on W's equal to rounding: both are still converged to rtol (1e-12)
    if isinstance(law, mbi.CoulombLaw):
        tol = max(tol, 10 * law.rtol)  # a turning slip, integrated to rtol
    for f in ("P", "u_plus", "dv"):
        got, want = getattr(res, f), getattr(ref, f)
        scale = np.abs(want).max() + (np.abs(ref.u_minus).max() if f == "u_plus" else 0.0)
        scale += np.abs(v).max() if f == "dv" else 0.0
        np.testing.assert_allclose(got, want, rtol=0, atol=tol * scale, err_msg=f)
    assert np.array_equal(res.v_minus, v) and np.array_equal(res.n0, ref.n0)
    assert res.energy_loss >= -1e-9 * res.T_minus
    if abs(ref.kappa) > 1e-6:
        assert res.separates == ref.separates
    return res.method, ref.method


@given(st.sampled_from(ROBOTS), seeds, st.sampled_from(sorted(LAWS)), st.booleans())
def test_the_compiled_route_equals_the_arrays_route(name, seed, law_name, tilted):
    _compare(name, seed, law_name, tilted)


def test_the_routes_compare_real_impacts_and_choose_alike():
    """On a fixed grid of robots, seeds, laws and frames, most cases are compared (not declined) and
    both routes choose the same averaging method."""
    pairs = [_compare(name, seed, law_name, seed % 2 == 0) for name in ROBOTS[:6] for seed in range(3)
             for law_name in sorted(LAWS)]
    compared = [p for p in pairs if p is not None]
    assert len(compared) >= 0.8 * len(pairs)
    assert sum(a == b for a, b in compared) >= 0.95 * len(compared)


@pytest.mark.parametrize("law_name", sorted(LAWS))
def test_results_of_the_compiled_route_are_frozen_self_contained_and_pickle(law_name):
    mech, q, v, contact, J, R = _state("panda", 3, True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        res = mbi.impact(mech, q, v, contact, LAWS[law_name])
    kept = {f: getattr(res, f).copy() for f in FIELDS}
    _, q2, v2, *_ = _state("panda", 4, False)
    mbi.impact(mech, q2, v2, contact, LAWS[law_name])  # the workspace and its factor are reused
    pin.crba(mech.model, mech.data, q2)
    for f in FIELDS + ("A", "J"):
        with pytest.raises(ValueError):
            getattr(res, f)[0] = 1.0
    for f in FIELDS:
        assert np.array_equal(getattr(res, f), kept[f]), f
    for clone in (pickle.loads(pickle.dumps(res)), copy.deepcopy(res), dataclasses.replace(res, nodes=7)):
        for f in FIELDS:
            assert np.array_equal(getattr(clone, f), kept[f]), f
    assert len(pickle.dumps(res)) < 6_000
    assert res.residual < 1e-10


def test_from_buffer_reads_the_documented_layout():
    """v₋, v₊, Δv (n each), P, u₋, u₊, n⁰ (d each), then anything; read-only views taken on first
    access; an unknown attribute is still an AttributeError."""
    n, d = 4, 2
    buffer = np.arange(3 * n + 4 * d + 5, dtype=float)
    A, J = np.eye(n), np.ones((d, n))
    res = mbi.ImpactResult.from_buffer(buffer, A, J, mbi.NewtonLaw(0.5), 0.1, 3, "ring")
    expected = np.split(buffer[: 3 * n + 4 * d], np.cumsum([n, n, n, d, d, d]))
    for f, want in zip(FIELDS, expected):
        got = getattr(res, f)
        assert np.array_equal(got, want) and np.shares_memory(got, buffer) and not got.flags.writeable, f
    assert (res.error_estimate, res.nodes, res.method) == (0.1, 3, "ring")
    assert not buffer.flags.writeable
    direct = mbi.ImpactResult(*(getattr(res, f).copy() for f in FIELDS), A=A, J=J, law=res.law)
    assert res.P_n == direct.P_n and res.energy_loss == direct.energy_loss
    with pytest.raises(AttributeError, match="no attribute 'speed'"):
        res.speed  # noqa: B018
    assert not hasattr(res, "_missing")


def test_factor_arrays_are_views_of_pinocchios_factor():
    """A(q) from crba (the caller's copy), and U, D with U D Uᵀ = A: views of the workspace, which
    follow every later factorisation in it."""
    mech = mechanism("talos")
    rng = np.random.default_rng(2)
    q1, q2 = mech.random_configuration(rng), mech.random_configuration(rng)
    A, U, D = mech.factor_arrays(q1)
    np.testing.assert_allclose(U @ np.diag(D) @ U.T, A, rtol=0, atol=1e-12 * np.abs(A).max())
    assert np.array_equal(np.triu(U), U) and np.all(np.diag(U) == 1.0) and np.all(D > 0)
    A2, U2, D2 = mech.factor_arrays(q2)
    assert np.shares_memory(U, U2) and np.array_equal(U, U2) and np.array_equal(D, D2)
    assert np.array_equal(A, mech.mass_matrix(q1)) and not np.shares_memory(A, A2)


def test_declined_cases_are_named_or_treated_by_the_general_route():
    """No approach: NoImpactError. A singular A(q): NotPositiveDefiniteError. A rank-deficient W (a
    planar mechanism struck in 3-D): the minimum-norm impulse of the general route. An overflowing
    W: NonFiniteError naming it."""
    mech, q, v, contact, J, R = _state("ur5", 5, False)
    law = LAWS["cone"]
    with pytest.raises(mbi.NoImpactError):
        mbi.impact(mech, q, -v, contact, law)
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "x")
    model.appendBodyToJoint(joint, pin.Inertia.Zero(), pin.SE3.Identity())
    model.addFrame(pin.Frame("tip", joint, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    massless = mbi.Mechanism(model, "massless")
    for law_ in (LAWS["cone"], LAWS["coulomb sliding"]):
        with pytest.raises(mbi.NotPositiveDefiniteError):
            mbi.impact(massless, np.zeros(1), np.array([-1.0]), mbi.PointContact("tip", normal=[1.0, 0, 0]), law_)
    pend = mechanism("double_pendulum")  # moves in a plane: J (3, 2) has rank 2
    q = np.array([0.4, 0.9])
    tip = mbi.PointContact(last_frame(pend), normal=[0.0, 0.3, -1.0])
    Jp, Rp = tip.jacobian(pend, q, 3)
    vp = np.linalg.lstsq(Jp, Rp @ [0.2, 0.1, -1.0], rcond=None)[0]
    if (Jp @ vp) @ Rp[:, -1] >= 0:
        vp = -vp
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        res = mbi.impact(pend, q, vp, tip, law)
        ref = law.apply_metric(ContactMetric.from_arrays(pend.mass_matrix(q), Jp), vp, Rp)
    np.testing.assert_allclose(res.P, ref.P, rtol=1e-9, atol=1e-12 * np.abs(ref.P).max())
    crank = pin.Model()  # a lever 1e150 long on an axis of inertia 1e-20: W ~ 1e320 overflows
    joint = crank.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "z")
    crank.appendBodyToJoint(joint, pin.Inertia(1.0, np.zeros(3), np.diag([1.0, 1.0, 1e-20])), pin.SE3.Identity())
    crank.addFrame(pin.Frame("tip", joint, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    lever = mbi.PointContact("tip", normal=[0.0, 1.0, 0.0], point=[1e150, 0.0, 0.0])
    with pytest.raises(mbi.NonFiniteError, match="Delassus"):
        mbi.impact(mbi.Mechanism(crank, "crank"), np.zeros(1), np.array([-1.0]), lever, law)


def test_a_subclass_overriding_apply_metric_keeps_its_route():
    """A law whose apply_metric is overridden is still called by mbi.impact (the compiled route is only
    taken while apply_metric is the class's own)."""
    calls = []

    class LoggedRough(mbi.RoughLaw):
        def apply_metric(self, metric, v, R):
            calls.append("rough")
            return super().apply_metric(metric, v, R)

    class LoggedCoulomb(mbi.CoulombLaw):
        def apply_metric(self, metric, v, R):
            calls.append("coulomb")
            return super().apply_metric(metric, v, R)

    mech, q, v, contact, J, R = _state("ur5", 2, False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        mbi.impact(mech, q, v, contact, LoggedRough(mbi.Cone(0.3), 0.5))
        mbi.impact(mech, q, v, contact, LoggedCoulomb(0.5, 0.3))
    assert calls == ["rough", "coulomb"]


def test_a_contact_that_keeps_approaching_warns_on_the_compiled_route():
    """NoSeparationWarning from the compiled route exactly when the result says it does not separate."""
    mech, q, v, contact, J, R = _state("solo12", 1, False)
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.6), 0.0)
    found = False
    for seed in range(30):
        mech, q, v, contact, J, R = _state("solo12", seed, seed % 2 == 1)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = mbi.impact(mech, q, v, contact, law)
        warned = any(issubclass(w.category, mbi.NoSeparationWarning) for w in caught)
        assert warned == (not res.separates)
        found |= warned
    assert found



def test_factor_arrays_follow_a_workspace_whose_data_was_replaced():
    """The cached views of the factor belong to one Pinocchio Data: after the workspace's Data is
    replaced, they are taken of the new one (the old memory may be freed)."""
    mech = mbi.Mechanism.from_robot("ur5")  # its own workspace, not the session's shared mechanism
    rng = np.random.default_rng(8)
    q1, q2 = mech.random_configuration(rng), mech.random_configuration(rng)
    mech.factor_arrays(q1)
    mech.workspace().data = mech.model.createData()
    A, U, D = mech.factor_arrays(q2)
    np.testing.assert_allclose(U @ np.diag(D) @ U.T, A, rtol=0, atol=1e-12 * np.abs(A).max())
    assert np.shares_memory(U, mech.data.U)
    J = mech.point_jacobian(q2, "tool0")
    v = np.linalg.lstsq(J, [0.3, 0.1, -1.0], rcond=None)[0]
    law = LAWS["cone"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        res = mbi.impact(mech, q2, v, mbi.PointContact("tool0"), law)
        ref = law.apply(mech.mass_matrix(q2), J, v, [0.0, 0.0, 1.0])
    np.testing.assert_allclose(res.P, ref.P, rtol=1e-9)


@pytest.mark.parametrize("law_name", ["newton", "cone", "coulomb sliding"])
@pytest.mark.parametrize("bad", ["column short", "two rows"])
def test_a_contact_returning_wrong_shapes_is_named(law_name, bad):
    """A user's Contact whose jacobian returns J or R of the wrong shape: ShapeError naming both shapes,
    before any compiled code reads them (impact and impact_batch)."""

    class Broken(mbi.PointContact):
        def jacobian(self, mech, q, d=3):
            J, R = super().jacobian(mech, q, d)
            return (J[:, :-1], R) if bad == "column short" else (J[:2], R)

    mech, q, v, contact, J, R = _state("ur5", 2, False)
    broken = Broken(contact.frame)
    with pytest.raises(mbi.ShapeError, match=r"Broken.jacobian must return J of shape \(3, 6\)"):
        mbi.impact(mech, q, v, broken, LAWS[law_name])
    with pytest.raises(mbi.ShapeError, match="Broken.jacobian"):
        mbi.impact_batch(mech, np.stack([q, q]), np.stack([v, v]), broken, LAWS[law_name])


def test_a_nearly_singular_but_full_rank_delassus_matrix_stays_on_the_compiled_route(monkeypatch):
    """The UR5 upright (W's eigenvalues 1e7 apart): det W / (tr W)³ is below the rank screen, but every
    eigenvalue is kept by the range projector, which is then the identity: the compiled route goes on
    (no ContactMetric is built) and equals the batch pipeline, projector included. A truly planar
    mechanism (rank 2) still takes the general route."""
    mech = mechanism("ur5")
    q = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])
    J = mech.point_jacobian(q, "tool0")
    v = np.linalg.lstsq(J, [0.3, 0.1, -1.0], rcond=None)[0]
    metric = ContactMetric.from_mechanism(mech, q, J.copy())
    assert metric.range_projector is not None  # the screen fires: the general route would project
    calls = []
    real = ContactMetric.from_mechanism.__func__

    def counted(cls, *args):
        calls.append(1)
        return real(cls, *args)

    monkeypatch.setattr(ContactMetric, "from_mechanism", classmethod(counted))
    for law in (LAWS["cone"], LAWS["coulomb sliding"]):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mbi.NoSeparationWarning)
            res = mbi.impact(mech, q, v, mbi.PointContact("tool0"), law)
            ref = law.impulses(metric, res.u_minus[None], np.eye(3))
        W = metric.W
        tol = 1e-12 if isinstance(law, mbi.RoughLaw) else 10 * law.rtol
        assert np.linalg.norm(W @ (res.P - ref.P[0])) <= tol * np.linalg.norm(W @ ref.P[0])
    assert not calls
    pend = mechanism("double_pendulum")
    tip = mbi.PointContact(last_frame(pend), normal=[0.0, 0.3, -1.0])
    Jp, Rp = tip.jacobian(pend, np.array([0.4, 0.9]), 3)
    vp = np.linalg.lstsq(Jp, Rp @ [0.2, 0.1, -1.0], rcond=None)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        mbi.impact(pend, np.array([0.4, 0.9]), vp if (Jp @ vp) @ Rp[:, -1] < 0 else -vp, tip, LAWS["cone"])
    assert calls  # rank 2: the general route, which projects


def test_compiled_results_freeze_their_arrays_when_read(rng):
    """A compiled route's result stores its buffer, A and J as they came; each becomes read-only
    before the first read hands it out, and the views of the buffer are read-only too."""
    mech = mbi.Mechanism.from_robot("ur5")
    q = mech.random_configuration(rng)
    J = mech.point_jacobian(q, "tool0")
    contact = mbi.PointContact("tool0")
    for law in (mbi.NewtonLaw(0.5), mbi.RoughLaw(mbi.Cone(0.3), 0.5)):
        res = mbi.impact(mech, q, -J[2], contact, law)
        assert not {"A", "J", "v_plus", "P"} & set(vars(res))
        for name in ("A", "J", "v_plus", "P"):
            array = getattr(res, name)
            assert not array.flags.writeable, name
            with pytest.raises(ValueError):
                array[0] = 1.0
        np.testing.assert_allclose(res.A, mech.mass_matrix(q), rtol=1e-14)
        np.testing.assert_allclose(res.J, J, rtol=1e-14, atol=1e-15)

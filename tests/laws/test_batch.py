"""Batch evaluation equals one-by-one evaluation."""

import warnings

import numpy as np
import pytest

import mbimpact as mbi

from tests.helpers import mechanism


@pytest.fixture(params=[1, 3], ids=["one-thread", "three-threads"])
def kernel_threads(request, small_blocks):
    """impact_batch's compiled calls on the calling thread only, or on three threads with blocks of a few
    rows (so that small batches exercise the hand-over of filled blocks)."""
    mbi.set_kernel_threads(request.param)
    return request.param


@pytest.mark.parametrize(
    "law",
    [mbi.NewtonLaw(0.3), mbi.RoughLaw(mbi.Cone(0.4), 0.6), mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.2),
     mbi.RoughLaw(mbi.Cone(0.4), 0.6, method="monte-carlo", samples=500), mbi.RoughLaw(mbi.Cone(0.4), 0.6, flux="configuration")],
    ids=repr,
)
def test_apply_batch_rows_equal_apply(law, rng, monkeypatch):
    monkeypatch.setattr(mbi.averaging.integrand, "BLOCK_ROWS", 400)  # several blocks of rows, cheaply
    mech = mechanism("ur5")
    q = mech.random_configuration(rng)
    A, J = mech.mass_matrix(q), mech.point_jacobian(q, "tool0")
    V = rng.normal(size=(1000, 6))
    V[V @ J[2] > 0] *= -1
    batch = law.apply_batch(A, J, V, [0, 0, 1])
    assert len(batch) == 1000
    for i in (0, 567, 999):
        one = law.apply(A, J, V[i], [0, 0, 1])
        np.testing.assert_allclose(batch.V_plus[i], one.v_plus, rtol=1e-12, atol=1e-12)
        assert batch.kappa[i] == pytest.approx(one.kappa, rel=1e-12)
        assert batch.mu[i] == pytest.approx(one.mu, rel=1e-10, abs=1e-14)
        assert batch.energy_loss[i] == pytest.approx(one.energy_loss, rel=1e-10)
        assert batch[i].kappa == pytest.approx(one.kappa, rel=1e-12)
    assert np.all(batch.energy_loss >= -1e-12)


def test_apply_batch_names_the_rows_that_do_not_approach():
    V = np.array([[0.0, -1.0], [0.0, 1.0], [1.0, -1.0]])
    with pytest.raises(mbi.NoImpactError, match=r"rows \[1\]"):
        mbi.RoughLaw(mbi.Sawtooth(0.2), 0.5).apply_batch(np.eye(2), np.eye(2), V, [0, 1])


def test_impact_batch_over_configurations(rng):
    mech = mechanism("solo12")
    contact = mbi.PointContact("HR_FOOT")
    Q = np.stack([mech.random_configuration(rng) for _ in range(5)])
    V = np.stack([-mech.point_jacobian(q, "HR_FOOT")[2] for q in Q])
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    batch = mbi.impact_batch(mech, Q, V, contact, law)
    assert batch.A.shape == (5, mech.nv, mech.nv) and batch.J.shape == (5, 3, mech.nv)
    for i in range(5):
        one = mbi.impact(mech, Q[i], V[i], contact, law)
        np.testing.assert_allclose(batch.V_plus[i], one.v_plus, rtol=1e-13, atol=1e-13)
        assert batch[i].residual < 1e-10
    with pytest.raises(mbi.ShapeError):
        mbi.impact_batch(mech, Q, V[:4], contact, law)


@pytest.mark.parametrize("robot, frame", [("ur5", "tool0"), ("solo12", "HR_FOOT"), ("panda", "panda_hand")])
def test_newton_impact_batch_over_configurations_is_the_vectorised_closed_form(rng, robot, frame):
    """Newton's law across configurations runs vectorised (one batched Cholesky and solve): every row
    equals :func:`mbimpact.impact` at its configuration (Pinocchio's sparse factor there) to rounding."""
    mech = mechanism(robot)
    contact = mbi.PointContact(frame)
    Q = np.stack([mech.random_configuration(rng) for _ in range(40)])
    V = rng.normal(size=(40, mech.nv))
    for i, q in enumerate(Q):  # every row approaches the surface
        V[i] -= (1.0 + abs(mech.point_jacobian(q, frame)[2] @ V[i])) * mech.point_jacobian(q, frame)[2] / np.sum(
            mech.point_jacobian(q, frame)[2] ** 2)
    law = mbi.NewtonLaw(0.7)
    batch = mbi.impact_batch(mech, Q, V, contact, law)
    assert batch.A.shape == (40, mech.nv, mech.nv) and batch.n0.shape == (40, 3)
    for i in range(40):
        one = mbi.impact(mech, Q[i], V[i], contact, law)
        np.testing.assert_allclose(batch.V_plus[i], one.v_plus, rtol=1e-11, atol=1e-11 * np.abs(one.v_plus).max())
        np.testing.assert_allclose(batch.A[i], one.A, rtol=0, atol=0)
        assert batch[i].kappa == pytest.approx(0.7, rel=1e-10)  # Newton's restitution, row by row
    assert np.all(batch.energy_loss >= 0.0)


_SINGLE_FIELDS = (("V_minus", "v_minus"), ("V_plus", "v_plus"), ("dV", "dv"), ("P", "P"), ("U_minus", "u_minus"),
                  ("U_plus", "u_plus"), ("n0", "n0"), ("A", "A"), ("J", "J"), ("error_estimate", "error_estimate"))


def _approaching_rows(mech, Q, contact, rng):
    """Random velocities, each turned to approach the plane z = const at its configuration."""
    V = rng.normal(size=(len(Q), mech.nv))
    for i, q in enumerate(Q):
        jz = contact.jacobian(mech, q)[0][2]
        if jz @ V[i] >= 0.0:
            V[i] -= (1.0 + jz @ V[i]) * jz / float(jz @ jz)
    return V


def _assert_rows_are_single_impacts(batch, singles):
    """Every field of every row is the single impact's to rounding (the batch kernel compiles the same
    source in another loop, so the compiler may order a sum otherwise), scaled to the row's largest entry
    of that field; nodes and methods as BatchResult.stack."""
    for many, one in _SINGLE_FIELDS:
        rows, expected = getattr(batch, many), np.stack([getattr(r, one) for r in singles])
        assert rows.shape == expected.shape, many
        scale = np.abs(expected).reshape(len(expected), -1).max(axis=1)
        diff = np.abs(rows - expected).reshape(len(expected), -1).max(axis=1)
        if many == "error_estimate":  # a relative error itself, which rounding moves by ~ε Σ|terms|/|sum|
            scale = np.ones_like(scale)
        assert np.all(diff <= 1e-13 * np.maximum(scale, 1e-300)), (many, np.max(diff / np.maximum(scale, 1e-300)))
    assert batch.nodes == max(r.nodes for r in singles)
    assert batch.method == "+".join(sorted({r.method for r in singles}))


@pytest.mark.parametrize("robot, frame, hard", [
    ("ur5", "tool0", [0.0, -1.57, 0.0, -1.57, 0.0, 0.0]),  # elbow straight: the graded rule
    ("solo12", "FL_FOOT", None),  # a foot on the ground (W's eigenvalues 30× apart): the cone's third level
])
def test_rough_cone_impact_batch_is_the_single_impact_row_by_row(rng, robot, frame, hard, kernel_threads):
    """A rough cone across configurations runs the single impact's compiled call once for all rows
    (CompiledImpact.run_stack): each row is mbimpact.impact's result at its configuration (the same source:
    to rounding), on generic and on strongly anisotropic W, with the methods that settled
    each row reported."""
    mech = mechanism(robot)
    Q = np.stack([mech.random_configuration(rng) for _ in range(30)])
    if hard is None:
        hard = mech.neutral()
        hard[2] = 0.336
    Q[::7] = hard
    contact = mbi.PointContact(frame)
    V = _approaching_rows(mech, Q, contact, rng)
    law = mbi.RoughLaw(mbi.Cone(0.4), 0.5)
    assert law.compiled_impact() is not None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        batch = mbi.impact_batch(mech, Q, V, contact, law)
        singles = [mbi.impact(mech, q, v, contact, law) for q, v in zip(Q, V)]
    _assert_rows_are_single_impacts(batch, singles)
    expected = {"ur5": {"poles", "adaptive[compiled]"}, "solo12": {"adaptive[compiled]"}}[robot]
    assert expected <= set(batch.method.split("+"))
    assert np.all(batch.energy_loss >= 0.0)


@pytest.mark.parametrize("robot, frame", [("ur5", "tool0"), ("solo12", "FL_FOOT"), ("panda", "panda_hand")])
def test_coulomb_impact_batch_is_the_single_impact_row_by_row(rng, robot, frame, kernel_threads):
    """The Coulomb law across configurations runs its compiled single impact once for all rows
    (CompiledImpact.run_stack): every row, closed form or integrated turning slip, under each restitution
    hypothesis, is mbimpact.impact's result."""
    mech = mechanism(robot)
    contact = mbi.PointContact(frame)
    Q = np.stack([mech.random_configuration(rng) for _ in range(40)])
    V = _approaching_rows(mech, Q, contact, rng)
    for law in (mbi.CoulombLaw(0.5, 0.3), mbi.CoulombLaw(0.2, 0.8, restitution="poisson"),
                mbi.CoulombLaw(0.0, 0.1, restitution="newton")):
        assert law.compiled_impact() is not None
        batch = mbi.impact_batch(mech, Q, V, contact, law)
        singles = [mbi.impact(mech, q, v, contact, law) for q, v in zip(Q, V)]
        _assert_rows_are_single_impacts(batch, singles)
        assert batch.nodes > 1  # some slip turned and was integrated
        assert np.all(batch.energy_loss >= -1e-12 * np.abs(batch.V_minus).max() ** 2)


def test_rough_cone_impact_batch_hands_declined_rows_to_impact(rng, kernel_threads):
    """Rows the compiled call does not settle go through mbimpact.impact, for the rough cone and for the
    Coulomb law: a point that only two joints move (W of rank 2: the general route's range projector), and
    a row that does not approach (named)."""
    mech = mechanism("ur5")
    contact = mbi.PointContact("forearm_link", point=[0.2, 0.0, 0.0])
    Q = np.stack([mech.random_configuration(rng) for _ in range(6)])
    V = _approaching_rows(mech, Q, contact, rng)
    upper = mbi.PointContact("upper_arm_link", point=[0.0, 0.0, 0.3])  # joints 1 and 2: rank 2
    Vu = _approaching_rows(mech, Q, upper, rng)
    for law in (mbi.RoughLaw(mbi.Cone(0.3), 0.5), mbi.CoulombLaw(0.5, 0.3)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mbi.NoSeparationWarning)
            for c, VV in ((contact, V), (upper, Vu)):
                batch = mbi.impact_batch(mech, Q, VV, c, law)
                _assert_rows_are_single_impacts(batch, [mbi.impact(mech, q, v, c, law) for q, v in zip(Q, VV)])
        # the compiled call declines a W of rank 2 (prepare's rank screen): every row took the general route
        assert all(np.linalg.matrix_rank(J, tol=1e-9) == 2 for J in batch.J)
        bad = V.copy()
        bad[3] = -bad[3]
        with pytest.raises(mbi.NoImpactError, match="does not approach"):
            mbi.impact_batch(mech, Q, bad, contact, law)


def test_rough_cone_impact_batch_warns_once_for_the_rows_that_still_approach(rng, kernel_threads):
    """The compiled rows whose contact still approaches after the impact (κ < 0) make one
    NoSeparationWarning for the batch, with the single impact's text; a batch whose rows all separate, none."""
    mech = mechanism("ur5")
    elbow = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])
    Q = np.stack([elbow] * 4)
    J = mech.point_jacobian(elbow, "tool0")
    oblique = np.linalg.lstsq(J, [0.3, 0.1, -1.0], rcond=None)[0]
    V = np.stack([oblique * s for s in (1.0, 2.0, 3.0, 4.0)])
    law, contact = mbi.RoughLaw(mbi.Cone(0.4), 0.5), mbi.PointContact("tool0")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        batch = mbi.impact_batch(mech, Q, V, contact, law)
    assert not batch.separates.any() and batch.method == "poles"  # homogeneity: every row as the first
    assert [type(w.message) for w in caught] == [mbi.NoSeparationWarning]
    assert "kappa < 0" in str(caught[0].message) and caught[0].filename == __file__
    Q = np.stack([mech.random_configuration(rng) for _ in range(4)])  # generic postures, normal incidence
    V = np.stack([np.linalg.lstsq(mech.point_jacobian(q, "tool0"), [0.0, 0.0, -1.0], rcond=None)[0] for q in Q])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        batch = mbi.impact_batch(mech, Q, V, contact, law)
    assert batch.separates.all() and not caught


def test_rough_cone_impact_batch_takes_any_memory_layout(rng, kernel_threads):
    """V and Q as Fortran-ordered, strided, broadcast or read-only arrays: the same rows to the bit."""
    mech = mechanism("ur5")
    contact, law = mbi.PointContact("tool0"), mbi.RoughLaw(mbi.Cone(0.4), 0.5)
    Q = np.stack([mech.random_configuration(rng) for _ in range(4)])
    V = _approaching_rows(mech, Q, contact, rng)
    reference = mbi.impact_batch(mech, Q, V, contact, law)
    frozen = V.copy()
    frozen.setflags(write=False)
    expected = reference.V_plus
    for QQ, VV, rows in ((np.asfortranarray(Q), np.asfortranarray(V), expected), (Q, frozen, expected),
                         (Q, np.repeat(V, 2, axis=1)[:, ::2], expected), (Q[::-1], V[::-1], expected[::-1])):
        assert np.array_equal(mbi.impact_batch(mech, QQ, VV, contact, law).V_plus, rows)
    same = mbi.impact_batch(mech, np.broadcast_to(Q[0], Q.shape), np.broadcast_to(V[0], V.shape), contact, law)
    assert np.array_equal(same.V_plus, np.broadcast_to(reference.V_plus[0], V.shape))


def test_rough_cone_impact_batch_raises_and_warns_in_row_order(rng, kernel_threads):
    """As the row-by-row loop: an earlier row's error comes before a later row's bad quaternion, and a
    NoSeparationWarning of an earlier row before a later row's error (a filter that raises it sees it first)."""
    solo = mechanism("solo12")
    contact, law = mbi.PointContact("FL_FOOT"), mbi.RoughLaw(mbi.Cone(0.4), 0.5)
    Q = np.stack([solo.neutral()] * 2)
    Q[1, 3:7] *= 1.1  # not normalised
    V = np.zeros((2, solo.nv))
    V[:, 2] = 1.0  # the base moves up: row 0 does not approach
    with pytest.raises(mbi.NoImpactError, match="does not approach"):
        mbi.impact_batch(solo, Q, V, contact, law)
    ur5 = mechanism("ur5")
    elbow = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])
    oblique = np.linalg.lstsq(ur5.point_jacobian(elbow, "tool0"), [0.3, 0.1, -1.0], rcond=None)[0]
    Q, V = np.stack([elbow] * 3), np.stack([oblique, 2 * oblique, -oblique])  # the last row recedes
    with warnings.catch_warnings():
        warnings.simplefilter("error", mbi.NoSeparationWarning)
        with pytest.raises(mbi.NoSeparationWarning):
            mbi.impact_batch(ur5, Q, V, mbi.PointContact("tool0"), law)
    with warnings.catch_warnings(record=True) as caught, pytest.raises(mbi.NoImpactError):
        warnings.simplefilter("always")
        mbi.impact_batch(ur5, Q, V, mbi.PointContact("tool0"), law)
    assert [type(w.message) for w in caught] == [mbi.NoSeparationWarning]


class _Picky(mbi.PointContact):
    """A contact that finds no contact at configurations whose first joint is past 3 rad."""

    def jacobian(self, mech, q, d=3):
        if q[0] > 3.0:
            raise mbi.GeometryError(f"no contact at q[0] = {q[0]}")
        return super().jacobian(mech, q, d)


@pytest.mark.parametrize("law", [mbi.RoughLaw(mbi.Cone(0.4), 0.5), mbi.CoulombLaw(0.5, 0.3), mbi.NewtonLaw(0.5)],
                         ids=repr)
def test_impact_batch_names_a_later_rows_contact_error_in_row_order(rng, law, kernel_threads):
    """A contact that raises at a row of a later block (the compiled calls already under way on the rows
    before it): the batch raises as the row-by-row loop does, an earlier row's error first, and a
    subclass that overrides jacobian is asked at every row (not PointContact's lean loop)."""
    mech = mechanism("ur5")
    Q = np.stack([mech.random_configuration(rng) for _ in range(30)])
    Q[:, 0] = np.clip(Q[:, 0], -3.0, 3.0)
    contact = _Picky("tool0")
    V = _approaching_rows(mech, Q, contact, rng)
    batch = mbi.impact_batch(mech, Q, V, contact, law)
    singles = [mbi.impact(mech, q, v, contact, law) for q, v in zip(Q, V)]
    _assert_rows_are_single_impacts(batch, singles)
    Q[17, 0] = 3.1
    with pytest.raises(mbi.GeometryError, match="q\\[0\\] = 3.1"):
        mbi.impact_batch(mech, Q, V, contact, law)
    V[11] = -V[11]  # an earlier row does not approach: its error comes first
    with pytest.raises(mbi.NoImpactError, match="does not approach"):
        mbi.impact_batch(mech, Q, V, contact, law)


class _Buggy(mbi.PointContact):
    """A contact with a bug past q[0] = 3 rad: a ValueError (not an ImpactError), or a Jacobian of shape (nv,)
    that numpy would broadcast into a (3, nv) row."""

    kind = "raise"

    def jacobian(self, mech, q, d=3):
        J, R = super().jacobian(mech, q, d)
        if q[0] > 3.0:
            if self.kind == "raise":
                raise ValueError(f"bug at q[0] = {q[0]}")
            return J[2].copy(), R
        return J, R


@pytest.mark.parametrize("law", [mbi.RoughLaw(mbi.Cone(0.4), 0.5), mbi.CoulombLaw(0.5, 0.3), mbi.NewtonLaw(0.5)],
                         ids=repr)
def test_impact_batch_meets_a_buggy_contact_where_the_loop_does(rng, law, kernel_threads):
    """A contact's own error at a later row comes after an earlier row's NoImpactError, as in the loop of
    impact; a Jacobian of the wrong shape at a later row is named (ShapeError), never broadcast."""
    mech = mechanism("ur5")
    Q = np.stack([mech.random_configuration(rng) for _ in range(30)])
    Q[:, 0] = np.clip(Q[:, 0], -3.0, 3.0)
    V = _approaching_rows(mech, Q, mbi.PointContact("tool0"), rng)
    Q[20, 0] = 3.1
    raising, shaped = _Buggy("tool0"), _Buggy("tool0")
    object.__setattr__(shaped, "kind", "shape")
    with pytest.raises(ValueError, match="bug at q"):
        mbi.impact_batch(mech, Q, V, raising, law)
    with pytest.raises(mbi.ShapeError, match="must return J of shape"):
        mbi.impact_batch(mech, Q, V, shaped, law)
    V[6] = -V[6]
    for contact in (raising, shaped):
        with pytest.raises(mbi.NoImpactError, match="does not approach"):
            mbi.impact_batch(mech, Q, V, contact, law)


def test_impact_batch_reads_no_garbage_of_rows_the_kernel_leaves(rng, kernel_threads):
    """Rows the compiled call does not prepare (a contact point the mechanism cannot move: J = 0) leave
    their statistics unwritten; the batch raises their NoImpactError, with no RuntimeWarning from reading
    stale memory even under np.seterr(invalid="raise")."""
    mech = mechanism("ur5")
    contact = mbi.PointContact("shoulder_link")  # on joint 1's axis: J = 0
    Q = np.stack([mech.random_configuration(rng) for _ in range(300)])
    V = rng.normal(size=(300, mech.nv))
    signalling = np.array([0x7FF0000000000001], np.uint64).view(np.float64)[0]
    for law in (mbi.CoulombLaw(0.5, 0.3), mbi.RoughLaw(mbi.Cone(0.4), 0.5)):
        junk = np.full((300, 5), signalling)  # freed memory the batch's next allocation may reuse
        del junk
        with np.errstate(invalid="raise"), warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(mbi.NoImpactError, match="does not approach"):
                mbi.impact_batch(mech, Q, V, contact, law)


def test_a_law_declares_its_compiled_impact_and_a_subclass_takes_the_pipeline(rng):
    """Only a law whose compiled_impact() is not None runs its rows in one compiled call; a subclass, which may
    change any step, takes the pipeline, and impact_batch honours what it changed."""
    mech = mechanism("ur5")
    gaussian = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5)
    assert gaussian.compiled_impact() is None and mbi.NewtonLaw(0.5).compiled_impact() is not None
    assert mbi.RoughLaw(mbi.Cone(0.4), 0.5, method="adaptive").compiled_impact() is None

    class Frictionless(mbi.CoulombLaw):  # changes the law: impact and impact_batch must honour it
        def contact_impulses(self, W, U):
            out = super().contact_impulses(W, U)
            out.P[..., :2] = 0.0
            return out

    assert Frictionless(0.5, 0.7).compiled_impact() is None
    Q = np.stack([mech.random_configuration(rng) for _ in range(3)])
    contact = mbi.PointContact("tool0")
    VV = _approaching_rows(mech, Q, contact, rng)
    batch = mbi.impact_batch(mech, Q, VV, contact, Frictionless(0.5, 0.7))
    _assert_rows_are_single_impacts(batch, [mbi.impact(mech, q, v, contact, Frictionless(0.5, 0.7))
                                            for q, v in zip(Q, VV)])
    R = contact.basis()
    assert np.allclose(batch.P @ R[:, :2], 0.0, atol=1e-15 * np.abs(batch.P).max())


def test_impact_batch_names_a_bad_row_as_the_row_by_row_route_does(rng):
    """A row that does not approach, or a quaternion that is not normalised, leaves the vectorised route:
    the row-by-row route names it."""
    mech = mechanism("solo12")
    contact = mbi.PointContact("HR_FOOT")
    Q = np.stack([mech.random_configuration(rng) for _ in range(3)])
    V = np.stack([-mech.point_jacobian(q, "HR_FOOT")[2] for q in Q])
    V[1] *= -1.0
    with pytest.raises(mbi.NoImpactError, match="does not approach"):
        mbi.impact_batch(mech, Q, V, contact, mbi.NewtonLaw(0.5))
    V[1] *= -1.0
    Q[2, 3:7] *= 2.0
    with pytest.raises(mbi.ParameterError, match="not normalised"):
        mbi.impact_batch(mech, Q, V, contact, mbi.NewtonLaw(0.5))


def _eager_newton_batch(law, A, J, V, n0):
    """Newton's batch written out eagerly, with the arithmetic of BatchResult.along_normal."""
    jn = n0 @ J
    y = np.linalg.solve(A, jn)
    Pn = (-(1.0 + law.e) / float(jn @ y)) * (V @ jn)
    col = Pn[:, None]
    dV = col.dot(y[None, :])
    U = V.dot(J.T)
    return dict(V_minus=V, dV=dV, V_plus=V + dV, U_minus=U, U_plus=U + col.dot((J @ y)[None, :]),
                P=col.dot(n0[None, :]))


def test_newton_batch_forms_its_fields_on_access(rng):
    """Only V₋ and the normal impulses are stored; each field read later equals the eager batch's
    (to the solve's rounding; V₊ = V₋ + Δv exactly), whatever the order of reading, and is kept."""
    mech = mechanism("ur5")
    q = mech.random_configuration(rng)
    A, J, n0 = mech.mass_matrix(q), mech.point_jacobian(q, "tool0"), np.array([0.0, 0.0, 1.0])
    V = rng.normal(size=(300, 6))
    V[V @ J[2] > 0] *= -1
    law = mbi.NewtonLaw(0.4)
    eager = _eager_newton_batch(law, A, J, V, n0)
    for order in (["U_plus", "V_plus", "P", "dV", "U_minus"], ["dV", "P", "U_minus", "V_plus", "U_plus"]):
        batch = law.apply_batch(A, J, V, n0)
        assert not {"dV", "V_plus", "U_minus", "U_plus", "P", "error_estimate"} & set(vars(batch))
        for name in order:
            np.testing.assert_allclose(getattr(batch, name), eager[name], rtol=1e-12, atol=1e-14)
            assert getattr(batch, name) is getattr(batch, name)  # formed once
        np.testing.assert_array_equal(batch.V_plus, batch.V_minus + batch.dV)
        np.testing.assert_array_equal(batch.error_estimate, np.zeros(300))
    assert not np.shares_memory(batch.V_minus, V)  # the caller's V may change later
    V[:] = 0.0
    assert np.all(batch.V_minus @ J[2] < 0)
    np.testing.assert_allclose(batch.kappa, law.e, rtol=1e-12)


def test_newton_batch_at_huge_magnitudes_takes_the_general_route():
    """Velocities near 1e150 fail the lazy batch's bounds (its products could overflow): the general
    route treats the rows, with the same outcome as the single impacts, or names what overflows."""
    A, J, n0 = np.diag([2.0, 3.0]), np.eye(2), np.array([0.0, 1.0])
    law = mbi.NewtonLaw(0.5)
    V = np.array([[1e151, -1e151], [0.0, -1.0]])
    batch = law.apply_batch(A, J, V, n0)
    for i in range(2):
        np.testing.assert_allclose(batch.V_plus[i], law.apply(A, J, V[i], n0).v_plus, rtol=1e-14)
    with pytest.raises(mbi.NonFiniteError):
        law.apply_batch(A, J, np.array([[1e308, -1e308]]), n0)


def test_newton_batch_whose_contact_velocity_jump_overflows_is_named():
    """J y can overflow where y does not (A tiny along one axis, J large on it): the general route
    names it, as a single impact does, instead of a batch whose U₊ holds inf or NaN."""
    A, J, n0 = np.diag([1e-305, 1.0]), np.array([[1.4e4, 0.0], [1.0, 1.0]]), np.array([0.0, 1.0])
    V = np.array([[-1.0, -1.0], [-2.0, 0.5]])
    law = mbi.NewtonLaw(0.5)
    with pytest.raises(mbi.NonFiniteError) as single:
        law.apply(A, J, V[0], n0)
    with pytest.raises(mbi.NonFiniteError) as batch:
        law.apply_batch(A, J, V, n0)
    assert str(batch.value) == str(single.value)


def test_newton_batch_arrays_are_read_only(rng):
    """What a lazy batch forms its fields of cannot change under it, and the fields it forms are
    read-only too."""
    A, J = np.diag([1.0, 2.0, 3.0]), np.eye(3)
    V = -np.abs(rng.normal(size=(5, 3)))
    batch = mbi.NewtonLaw(0.5).apply_batch(A, J, V, [0, 0, 1])
    for name in ("V_minus", "n0", "U_minus", "V_plus", "dV", "U_plus", "P", "error_estimate"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(batch, name)[0] = 1.0

"""Batch evaluation equals one-by-one evaluation."""

import numpy as np
import pytest

import mbimpact as mbi

from tests.helpers import mechanism


@pytest.mark.parametrize(
    "law",
    [mbi.NewtonLaw(0.3), mbi.RoughLaw(mbi.Cone(0.4), 0.6), mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.2),
     mbi.RoughLaw(mbi.Cone(0.4), 0.6, method="monte-carlo", samples=500), mbi.RoughLaw(mbi.Cone(0.4), 0.6, flux="configuration")],
    ids=repr,
)
def test_apply_batch_rows_equal_apply(law, rng, monkeypatch):
    monkeypatch.setattr(law, "block_rows", 400)  # several blocks of rows, cheaply
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

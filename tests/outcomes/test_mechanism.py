"""The outcomes of a mechanism's impact (:func:`mbimpact.impact_outcomes`) and of batches of velocities."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbimpact as mbi
from tests.helpers import mechanism, random_facets


@pytest.fixture(scope="module")
def ur5_impact():
    mech = mechanism("ur5")
    rng = np.random.default_rng(40)
    q = mech.random_configuration(rng)
    contact = mbi.PointContact("tool0")
    J = contact.jacobian(mech, q, 3)[0]
    v = rng.normal(size=mech.nv)
    return mech, q, (v if J[2] @ v < 0 else -v), contact


@pytest.mark.parametrize("rough", [mbi.Cone(0.4), random_facets(np.random.default_rng(2), 3, 9, 1.0)], ids=repr)
def test_mechanism_outcomes_average_to_mbi_impact(ur5_impact, rough):
    mech, q, v, contact = ur5_impact
    law = mbi.RoughLaw(rough, 0.6)
    out = mbi.impact_outcomes(mech, q, v, contact, law)
    assert isinstance(out, mbi.ImpactOutcomes)
    mean = mbi.impact(mech, q, v, contact, law)
    np.testing.assert_allclose(out.mean.v_plus, mean.v_plus, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(out.support.A, mean.A, rtol=1e-14)
    scale = np.abs(out.support.V_plus).max()
    tol = 1e-12 if out.exact else 1e-7
    np.testing.assert_allclose(out.weights @ out.support.V_plus, mean.v_plus, rtol=0, atol=tol * scale)
    sample = out.sample(20_000, seed=1)
    se = sample.V_plus.std(axis=0) / math.sqrt(len(sample))
    assert np.all(np.abs(sample.V_plus.mean(axis=0) - mean.v_plus) <= 4 * se + 1e-14 * scale)
    # the same outcomes as the law on the arrays of the mechanism
    arrays = law.outcomes(mean.A, mean.J, v, contact.basis())
    np.testing.assert_allclose(arrays.weights, out.weights, rtol=1e-10)


def test_batch_rows_have_their_own_outcomes():
    rng = np.random.default_rng(6)
    law = mbi.RoughLaw(mbi.Sawtooth(0.5), 0.8)
    V = np.array([[0.1, -1.0], [2.0, -0.5], [-0.4, -1.0]])
    rows = law.outcomes_batch(np.eye(2), np.eye(2), V, [0.0, 1.0])
    assert len(rows) == 3 and [len(r.probabilities) for r in rows] == [2, 1, 2]
    for out, v in zip(rows, V):
        single = law.outcomes(np.eye(2), np.eye(2), v, [0.0, 1.0])
        np.testing.assert_array_equal(out.probabilities, single.probabilities)
        np.testing.assert_array_equal(out.results.V_minus, np.repeat(v[None], len(out.probabilities), 0))
    cone = mbi.RoughLaw(mbi.Cone(0.3), 0.8)
    W = rng.normal(size=(2, 3)) * 0.2 + [0.0, 0.0, -1.0]
    outs = cone.outcomes_batch(np.eye(3), np.eye(3), W, [0.0, 0.0, 1.0])
    for out, w in zip(outs, W):
        np.testing.assert_allclose(out.mean.P, cone.apply(np.eye(3), np.eye(3), w, [0.0, 0.0, 1.0]).P, rtol=1e-13)

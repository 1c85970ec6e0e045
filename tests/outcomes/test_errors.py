"""Every documented error of the outcomes."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.results.outcomes import ImpactOutcomes

LAW = mbi.RoughLaw(mbi.Sawtooth(0.4), 0.7)
CONE = mbi.RoughLaw(mbi.Cone(0.3), 0.7)
POINT = (np.eye(2), np.eye(2))


@pytest.fixture(scope="module")
def outcomes():
    return LAW.outcomes(*POINT, [0.3, -1.0], [0.0, 1.0]), CONE.outcomes(np.eye(3), np.eye(3), [0.3, 0.0, -1.0],
                                                                          [0.0, 0.0, 1.0])


def test_the_laws_own_errors():
    with pytest.raises(mbi.NoImpactError):
        LAW.outcomes(*POINT, [0.3, 1.0], [0.0, 1.0])
    steep = mbi.RoughLaw(mbi.Facets([[math.sin(1.2), math.cos(1.2)]]), 0.5)
    with pytest.raises(mbi.NoFacingFacetError):
        steep.outcomes(*POINT, [1.0, -0.1], [0.0, 1.0])
    with pytest.raises(mbi.RoughnessError):
        LAW.outcomes(np.eye(3), np.eye(3), [0.0, 0.0, -1.0], [0.0, 0.0, 1.0])
    with pytest.raises(mbi.ShapeError):
        LAW.outcomes(*POINT, [0.3, -1.0, 0.0], [0.0, 1.0])
    with pytest.raises(mbi.NotPositiveDefiniteError):
        LAW.outcomes(-np.eye(2), np.eye(2), [0.3, -1.0], [0.0, 1.0])
    with pytest.raises(mbi.ShapeError):
        LAW.outcomes_batch(*POINT, np.zeros((0, 2)), [0.0, 1.0])
    with pytest.raises(mbi.NoImpactError):
        LAW.outcomes_batch(*POINT, [[0.3, -1.0], [0.3, 1.0]], [0.0, 1.0])


@pytest.mark.parametrize("n", [0, -1, 1.5, True, "3", None, mbi.results.outcomes.MAX_SAMPLE + 1])
def test_a_bad_sample_size_is_a_parameter_error(outcomes, n):
    for out in outcomes:
        with pytest.raises(mbi.ParameterError, match=r"^n "):
            out.sample(n, seed=0)


@pytest.mark.parametrize("seed", [-1, 1.5, "seed", None, np.random.RandomState(0), 2**63])
def test_a_bad_seed_is_a_parameter_error(outcomes, seed):
    for out in outcomes:
        with pytest.raises(mbi.ParameterError, match="seed"):
            out.sample(10, seed=seed)


def test_unknown_quantities_and_probabilities(outcomes):
    for out in outcomes:
        with pytest.raises(mbi.ParameterError, match="unknown outcome quantity"):
            out.std("restitution")
        for p in (-0.1, 1.1, math.nan, "half", [0.5, 2.0]):
            with pytest.raises(mbi.ParameterError, match="p must"):
                out.quantile("kappa", p)


def test_repeated_micro_impacts_and_other_laws_are_refused():
    with pytest.raises(mbi.ParameterError, match="repeat"):
        LAW.replace(repeat=True).outcomes(*POINT, [0.3, -1.0], [0.0, 1.0])
    mech = mbi.Mechanism.from_robot("ur5")
    with pytest.raises(mbi.ParameterError, match="RoughLaw"):
        mbi.impact_outcomes(mech, mech.neutral(), np.ones(6), mbi.PointContact("tool0"), mbi.NewtonLaw(0.5))
    with pytest.raises(mbi.ParameterError):
        mbi.impact_outcomes(mech, mech.neutral(), np.ones(6), "tool0", CONE)


def test_the_value_object_validates_itself(outcomes):
    out = outcomes[0]
    with pytest.raises(mbi.ShapeError, match="sum to 1"):
        ImpactOutcomes(out.mean, out.weights * 0.5, out.support, out.normals, True)
    with pytest.raises(mbi.ShapeError, match="shape"):
        ImpactOutcomes(out.mean, out.weights[:1], out.support, out.normals, True)
    with pytest.raises(mbi.ShapeError, match="normals"):
        ImpactOutcomes(out.mean, out.weights, out.support, out.normals[:, :1], True)
    with pytest.raises(mbi.ShapeError, match="sampler"):
        ImpactOutcomes(out.mean, out.weights, out.support, out.normals, False)
    with pytest.raises(ValueError):
        out.weights[0] = 0.5  # read-only
    with pytest.raises(ValueError):
        out.results.P[0, 0] = 0.5
    with pytest.raises(AttributeError):
        out.weights = out.weights  # type: ignore[misc]  # frozen

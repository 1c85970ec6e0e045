"""Continuous measures: facets drawn from the measure with the flux weights, against (2.8) and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

import mbimpact as mbi
from mbimpact.results.outcomes import OUTCOME_QUANTITIES, outcome_values
from tests.helpers import spd

N0 = [0.0, 0.0, 1.0]


def point_mass_velocity(beta: float) -> np.ndarray:
    return np.array([math.sin(beta), 0.0, -math.cos(beta)])


def within_standard_errors(sample: np.ndarray, expected: np.ndarray, k: float = 4.0) -> bool:
    se = sample.std(axis=0) / math.sqrt(len(sample))
    return bool(np.all(np.abs(sample.mean(axis=0) - expected) <= k * se + 1e-14 * np.abs(expected).max()))


@pytest.mark.parametrize("rough, flux", [(mbi.Cone(0.35), "physical"), (mbi.Cone(0.35), "configuration"),
                                         (mbi.GaussianSlopes(0.3), "physical"),
                                         (mbi.GaussianSlopes(0.25, dim=2), "physical"),
                                         (mbi.GaussianSlopes(0.25, dim=2), "configuration")], ids=str)
def test_sample_mean_converges_to_the_law_on_a_mechanism(rough, flux):
    rng = np.random.default_rng(21)
    d = rough.dim
    A, J = spd(rng, 6, 30.0), rng.normal(size=(d, 6))
    v = rng.normal(size=6)
    n0 = np.eye(d)[-1]
    v = v if n0 @ J @ v < 0 else -v
    law = mbi.RoughLaw(rough, 0.7, flux=flux)
    out = law.outcomes(A, J, v, n0)
    assert out.probabilities is None and out.results is None and not out.exact
    mean = law.apply(A, J, v, n0)
    np.testing.assert_allclose(out.mean.P, mean.P, rtol=1e-13)
    # the statistics' quadrature nodes average to (2.8) too
    np.testing.assert_allclose(out.weights @ out.support.P, mean.P, rtol=1e-7, atol=1e-9 * np.abs(mean.P).max())
    sample = out.sample(40_000, seed=5)
    assert within_standard_errors(sample.P, mean.P)
    assert within_standard_errors(sample.V_plus, mean.v_plus)
    # every outcome is a Newton impact on a facet facing the motion: P ∥ m, mᵀu < 0
    m = sample.P / np.linalg.norm(sample.P, axis=1)[:, None]
    assert np.all(m @ (J @ v) < 0.0) and np.all(m @ n0 > 0.0)
    # the covariance of the nodes agrees with the sample covariance
    cov = out.impulse_covariance
    np.testing.assert_allclose(np.cov(sample.P.T, bias=True), cov, rtol=0.06, atol=0.03 * np.abs(cov).max())
    assert out.covariance.shape == (6, 6)
    for name in OUTCOME_QUANTITIES:
        x = outcome_values(sample, name)
        assert out.std(name) == pytest.approx(x.std(), rel=0.03)
        np.testing.assert_allclose(out.quantile(name, [0.1, 0.5, 0.9]), np.quantile(x, [0.1, 0.5, 0.9]),
                                   atol=0.03 * (x.max() - x.min()))


def test_cone_facets_are_drawn_on_the_cone_with_the_flux_weight_in_azimuth():
    """A point mass on a cone: every facet tilts by α; the azimuth φ of the facet met has the density
    ∝ cos α |u_n| − sin α |u_t| cos φ (the flux), so E[cos φ] = −tan α tan β / 2 (whole cone facing)."""
    alpha, beta, e = 0.4, 0.6, 0.9
    out = mbi.RoughLaw(mbi.Cone(alpha), e).outcomes(np.eye(3), np.eye(3), point_mass_velocity(beta), N0)
    sample = out.sample(60_000, seed=2)
    m = sample.P / np.linalg.norm(sample.P, axis=1)[:, None]
    np.testing.assert_allclose(m[:, 2], math.cos(alpha), rtol=1e-12)
    cos_phi = m[:, 0] / math.sin(alpha)
    expected = -math.tan(alpha) * math.tan(beta) / 2
    se = cos_phi.std() / math.sqrt(len(cos_phi))
    assert abs(cos_phi.mean() - expected) < 4 * se
    assert abs((m[:, 1] / math.sin(alpha)).mean()) < 4 * se  # symmetric about the plane of incidence


def test_gaussian_slopes_met_at_normal_incidence_are_the_base_plane_slopes():
    """At normal incidence the flux weight cos α cancels the true-area factor sec α: the slopes of the
    facets met are normal with RMS σ per component, as over the base plane."""
    sigma = 0.8
    out = mbi.RoughLaw(mbi.GaussianSlopes(sigma), 0.5).outcomes(np.eye(3), np.eye(3), [0.0, 0.0, -1.0], N0)
    sample = out.sample(20_000, seed=9)
    m = sample.P / np.linalg.norm(sample.P, axis=1)[:, None]
    slopes = -m[:, :2] / m[:, 2:]
    for k in range(2):
        assert stats.kstest(slopes[:, k] / sigma, "norm").pvalue > 1e-3
    # κ of a facet of tilt α at normal incidence: (1+e) cos²α − 1 (2.11); its mean is (4.2)
    kappa = 1.5 / (1.0 + np.sum(slopes**2, axis=1)) - 1.0
    np.testing.assert_allclose(sample.kappa, kappa, rtol=1e-10, atol=1e-12)


def test_samples_are_reproducible_per_seed():
    out = mbi.RoughLaw(mbi.Cone(0.3), 0.8).outcomes(np.eye(3), np.eye(3), point_mass_velocity(1.2), N0)
    a, b, c = out.sample(500, seed=1), out.sample(500, seed=1), out.sample(500, seed=2)
    np.testing.assert_array_equal(a.V_plus, b.V_plus)
    assert not np.array_equal(a.V_plus, c.V_plus)
    assert len(out.sample(1, seed=0)) == 1


def test_grazing_cone_samples_only_the_facing_arc_and_lose_no_energy():
    alpha, beta = 0.5, 1.4  # tan α tan β > 1: part of the cone faces away
    v = point_mass_velocity(beta)
    for flux in ("physical", "configuration"):
        law = mbi.RoughLaw(mbi.Cone(alpha), 1.0, flux=flux)
        out = law.outcomes(np.eye(3), np.eye(3), v, N0)
        sample = out.sample(20_000, seed=4)
        m = sample.P / np.linalg.norm(sample.P, axis=1)[:, None]
        assert np.all(m @ v < 0.0)
        assert np.all(sample.energy_loss >= -1e-12)
        assert within_standard_errors(sample.P, out.mean.P)


def test_coulomb_facets_on_a_cone():
    law = mbi.RoughLaw(mbi.Cone(0.3), facet=mbi.CoulombFacet(0.6, 0.3))
    v = point_mass_velocity(0.8)
    out = law.outcomes(np.eye(3), np.eye(3), v, N0)
    sample = out.sample(5_000, seed=3)
    assert within_standard_errors(sample.P, out.mean.P)
    np.testing.assert_allclose(out.weights @ out.support.P, out.mean.P, rtol=0, atol=1e-3 * np.abs(out.mean.P).max())

"""Finite measures: the outcomes of (2.6)–(2.7) against plain geometry and the closed forms of (2.11)–(2.13)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mbimpact as mbi
from tests.helpers import random_facets, seeds, spd

POINT = (np.eye(2), np.eye(2))


def sawtooth_velocity(alpha: float, beta: float) -> np.ndarray:
    """v = (v_l, v_n) of a point mass at incidence β from the normal, v_l > 0."""
    return np.array([math.sin(beta), -math.cos(beta)])


@pytest.mark.parametrize("alpha, beta", [(0.4, 0.3), (0.7, 0.1), (0.3, 1.0), (0.6, 1.2)])
def test_sawtooth_probabilities_are_the_flux_weights_of_plain_geometry(alpha, beta):
    e = 0.7
    v = sawtooth_velocity(alpha, beta)
    out = mbi.RoughLaw(mbi.Sawtooth(alpha), e).outcomes(*POINT, v, [0.0, 1.0])
    s, c = math.sin(alpha), math.cos(alpha)
    # the two facets (∓sin α, cos α), P = ½ each; the flux through each is ½ (−mᵀu) where positive
    facets = [np.array([-s, c]), np.array([s, c])]
    flux = [0.5 * max(0.0, -(m @ v)) for m in facets]
    expected = [(m, f / sum(flux)) for m, f in zip(facets, flux) if f > 0.0]
    assert len(out.probabilities) == len(expected) == (2 if beta < math.pi / 2 - alpha else 1)
    assert out.probabilities.sum() == pytest.approx(1.0, abs=1e-14)
    for (m, prob), got_m, got_p, P in zip(expected, out.normals, out.probabilities, out.results.P):
        np.testing.assert_allclose(got_m, m, atol=1e-15)
        assert got_p == pytest.approx(prob, rel=1e-13)
        # the outcome on that facet: Newton's impact along its normal (A = I), −(1+e)(mᵀv) m
        np.testing.assert_allclose(P, -(1 + e) * (m @ v) * m, rtol=1e-13, atol=1e-15)


def test_sawtooth_above_the_switch_meets_only_the_facet_facing_the_motion():
    """(2.13): β ≥ π/2 − α, Δv = (1+e)(|v_l| sin α + |v_n| cos α)(−sin α sgn v_l, cos α)."""
    alpha, e = 0.5, 0.6
    for sign in (1.0, -1.0):
        v = np.array([sign * 2.0, -0.5])  # tan β = 4 > cot α
        out = mbi.RoughLaw(mbi.Sawtooth(alpha), e).outcomes(*POINT, v, [0.0, 1.0])
        assert out.probabilities.tolist() == [1.0]
        dv = (1 + e) * (2.0 * math.sin(alpha) + 0.5 * math.cos(alpha)) * np.array([-math.sin(alpha) * sign,
                                                                                  math.cos(alpha)])
        np.testing.assert_allclose(out.results.dV[0], dv, rtol=1e-13)
        np.testing.assert_allclose(out.mean.dv, dv, rtol=1e-13)


def test_sawtooth_spread_of_kappa_and_mu_is_that_of_the_two_point_distribution():
    alpha, e, beta = 0.45, 0.8, 0.35
    v = sawtooth_velocity(alpha, beta)
    out = mbi.RoughLaw(mbi.Sawtooth(alpha), e).outcomes(*POINT, v, [0.0, 1.0])
    p1, p2 = out.probabilities
    k1, k2 = -out.results.U_plus[:, 1] / out.results.U_minus[:, 1]
    assert out.std("kappa") == pytest.approx(abs(k1 - k2) * math.sqrt(p1 * p2), rel=1e-12)
    assert out.std("mu") == pytest.approx(0.0, abs=1e-13)  # every facet impact has μ = tan α: P ∥ m
    np.testing.assert_allclose(out.values("mu"), math.tan(alpha), rtol=1e-13)
    low, high = sorted([(k1, p1), (k2, p2)])
    assert out.quantile("kappa", 0.0) == low[0]
    assert out.quantile("kappa", low[1] * 0.999) == low[0]
    assert out.quantile("kappa", low[1] * 1.001) == high[0]
    assert out.quantile("kappa", 1.0) == high[0]
    np.testing.assert_array_equal(out.quantile("kappa", [0.0, 1.0]), [low[0], high[0]])
    # the covariance of a two-point distribution: p₁ p₂ (x₁ − x₂)(x₁ − x₂)ᵀ
    dP = out.results.P[0] - out.results.P[1]
    np.testing.assert_allclose(out.impulse_covariance, p1 * p2 * np.outer(dP, dP), rtol=1e-12, atol=1e-16)
    dv = out.results.V_plus[0] - out.results.V_plus[1]
    np.testing.assert_allclose(out.covariance, p1 * p2 * np.outer(dv, dv), rtol=1e-12, atol=1e-16)


def test_tangential_restitution_and_rebound_angle_of_a_facet_outcome():
    alpha, e = 0.5, 1.0
    v = np.array([2.0, -0.5])  # one facet: the one facing the motion
    out = mbi.RoughLaw(mbi.Sawtooth(alpha), e).outcomes(*POINT, v, [0.0, 1.0])
    u_plus = out.results.U_plus[0]
    assert out.values("et_cp")[0] == pytest.approx(u_plus[0] / v[0], rel=1e-13)
    angle = math.degrees(math.atan2(abs(u_plus[0]), u_plus[1]))
    assert out.values("rebound_cp_deg")[0] == pytest.approx(angle if u_plus[0] > 0 else -angle, rel=1e-13)
    normal = mbi.RoughLaw(mbi.Sawtooth(alpha), e).outcomes(*POINT, [0.0, -1.0], [0.0, 1.0])
    assert math.isnan(normal.std("et_cp")) and math.isnan(normal.quantile("et_cp", 0.5))


def _mechanism_arrays(rng: np.random.Generator, d: int, n: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    A = spd(rng, n, 50.0)
    J = rng.normal(size=(d, n))
    v = rng.normal(size=n)
    n0 = np.eye(d)[-1]
    return A, J, (v if n0 @ J @ v < 0 else -v)


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("facet", [mbi.NewtonFacet(0.6), mbi.CoulombFacet(0.5, 0.4),
                                   mbi.HuntCrossleyFacet(0.3), mbi.CompliantFacet(0.5, 0.3, 0.8)],
                         ids=lambda f: f.name)
@pytest.mark.parametrize("flux", ["physical", "configuration"])
def test_the_probability_weighted_outcomes_are_the_law(d, facet, flux):
    rng = np.random.default_rng(17 + d)
    A, J, v = _mechanism_arrays(rng, d)
    law = mbi.RoughLaw(random_facets(rng, d, 12, 1.0), facet=facet, flux=flux)
    out = law.outcomes(A, J, v, np.eye(d)[-1])
    mean = law.apply(A, J, v, np.eye(d)[-1])
    np.testing.assert_allclose(out.mean.P, mean.P, rtol=1e-13)
    np.testing.assert_allclose(out.mean.v_plus, mean.v_plus, rtol=1e-13)
    assert out.probabilities.sum() == pytest.approx(1.0, abs=1e-14)
    assert np.all(out.probabilities > 0.0) and len(out.results) == len(out.probabilities)
    assert np.all(out.normals @ (J @ v) < 0.0)  # only facets facing the motion
    scale = np.abs(out.results.P).max()
    np.testing.assert_allclose(out.probabilities @ out.results.P, mean.P, rtol=0, atol=1e-12 * scale)
    v_scale = np.abs(out.results.V_plus).max()
    np.testing.assert_allclose(out.probabilities @ out.results.V_plus, mean.v_plus, rtol=0, atol=1e-12 * v_scale)
    # each row is a consistent impact, (1.1): A Δv = Jᵀ P
    np.testing.assert_allclose(out.results.dV @ A, out.results.P @ J, rtol=0, atol=1e-12 * v_scale * np.abs(A).max())


@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_newton_facet_outcomes_are_newton_impacts_along_the_facet_and_lose_energy(e):
    rng = np.random.default_rng(3)
    A, J, v = _mechanism_arrays(rng, 3, 6)
    out = mbi.RoughLaw(random_facets(rng, 3, 20, 1.2), e).outcomes(A, J, v, [0.0, 0.0, 1.0])
    res, m = out.results, out.normals
    along = np.einsum("kd,kd->k", res.P, m)
    np.testing.assert_allclose(res.P, along[:, None] * m, rtol=0, atol=1e-13 * np.abs(res.P).max())
    # the facet's own restitution: mᵀu₊ = −e mᵀu₋
    np.testing.assert_allclose(np.einsum("kd,kd->k", m, res.U_plus), -e * np.einsum("kd,kd->k", m, res.U_minus),
                               rtol=0, atol=1e-12 * np.abs(res.U_minus).max())
    T_minus = 0.5 * v @ A @ v
    T_plus = 0.5 * np.einsum("kn,nm,km->k", res.V_plus, A, res.V_plus)
    assert np.all(T_plus <= T_minus * (1 + 1e-12))
    assert np.all(res.energy_loss >= -1e-12 * T_minus)


def test_smooth_is_one_outcome_with_probability_one_and_newtons_law():
    rng = np.random.default_rng(5)
    A, J, v = _mechanism_arrays(rng, 3)
    out = mbi.RoughLaw(mbi.Smooth(), 0.4).outcomes(A, J, v, [0.0, 0.0, 1.0])
    newton = mbi.NewtonLaw(0.4).apply(A, J, v, [0.0, 0.0, 1.0])
    assert out.probabilities.tolist() == [1.0]
    np.testing.assert_allclose(out.results.V_plus[0], newton.v_plus, rtol=1e-12)
    np.testing.assert_allclose(out.normals[0], [0.0, 0.0, 1.0])
    assert np.all(out.covariance == 0.0) and out.std("kappa") == 0.0
    assert out.sample(3, seed=1).V_plus.shape == (3, 5)


def test_finite_samples_are_drawn_with_the_probabilities_and_reproducible():
    rng = np.random.default_rng(8)
    A, J, v = _mechanism_arrays(rng, 2)
    out = mbi.RoughLaw(random_facets(rng, 2, 6, 1.0), 0.7).outcomes(A, J, v, [0.0, 1.0])
    n = 40_000
    a, b, c = out.sample(n, seed=11), out.sample(n, seed=11), out.sample(n, seed=12)
    np.testing.assert_array_equal(a.P, b.P)
    assert not np.array_equal(a.P, c.P)
    rows = [int(np.flatnonzero((out.results.P == p).all(axis=1))[0]) for p in a.P[:200]]
    assert set(rows) <= set(range(len(out.probabilities)))
    # frequencies within 5 standard errors of the probabilities
    counts = np.array([np.sum((a.P == p).all(axis=1)) for p in out.results.P])
    pr = out.probabilities
    assert np.all(np.abs(counts / n - pr) <= 5 * np.sqrt(pr * (1 - pr) / n) + 1e-12)
    # the sample mean converges to (2.8); the sample covariance to the exact one
    se = a.P.std(axis=0) / math.sqrt(n)
    assert np.all(np.abs(a.P.mean(axis=0) - out.mean.P) <= 4 * se + 1e-15)
    np.testing.assert_allclose(np.cov(a.V_plus.T, bias=True), out.covariance, rtol=0.05,
                               atol=0.05 * np.abs(out.covariance).max())
    gen = out.sample(5, seed=np.random.default_rng(11))
    np.testing.assert_array_equal(gen.P, a.P[:5])  # a Generator is used as it is


@settings(max_examples=15, deadline=None, derandomize=True)
@given(seed=seeds, scale=st.floats(1e-3, 1e3))
def test_outcomes_are_positively_homogeneous_in_the_velocity(seed, scale):
    """Property 1°, outcome by outcome: λ v meets the same facets with the same probabilities, and each
    facet's impulse scales by λ (Newton facets)."""
    rng = np.random.default_rng(seed)
    A, J, v = _mechanism_arrays(rng, 3, 4)
    law = mbi.RoughLaw(random_facets(rng, 3, 8, 1.1), 0.5)
    a = law.outcomes(A, J, v, [0.0, 0.0, 1.0])
    b = law.outcomes(A, J, scale * v, [0.0, 0.0, 1.0])
    np.testing.assert_allclose(b.probabilities, a.probabilities, rtol=1e-12)
    np.testing.assert_allclose(b.results.P, scale * a.results.P, rtol=0, atol=1e-12 * scale * np.abs(a.results.P).max())
    assert b.std("kappa") == pytest.approx(a.std("kappa"), rel=1e-9, abs=1e-12)

"""Properties 1°–5° of the paper's section 3 and the invariants of (2.8)."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi

from tests.helpers import approaching, random_facets, seeds, spd


def random_problem(seed: int, d: int | None = None):
    """Random A (n×n, cond up to 1e4), J (d×n), approaching v, and a roughness."""
    rng = np.random.default_rng(seed)
    d = d or int(rng.choice([2, 3]))
    n = int(rng.integers(d, 9))
    A = spd(rng, n, cond=10 ** rng.uniform(0, 4))
    J = rng.normal(size=(d, n))
    n0 = np.eye(d)[-1]
    v = approaching(J, rng.normal(size=n), n0)
    kind = rng.integers(3)
    if kind == 0:
        rough = random_facets(rng, d, int(rng.integers(1, 12)))
    elif d == 2:
        rough = mbi.Sawtooth(rng.uniform(0, 1.5))
    else:
        rough = mbi.Cone(rng.uniform(0, 1.5))
    return rng, A, J, v, n0, rough


def rough_law(rough, rng, flux="physical"):
    return mbi.RoughLaw(rough, float(rng.uniform(0, 1)), flux=flux)


def apply(law, A, J, v, n0):
    """``law.apply``; a random contact may be ill-conditioned enough for the quadrature to stop at
    rounding above rtol: then, and only then, it warns (an honest AccuracyWarning)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", mbi.AccuracyWarning)
        res = law.apply(A, J, v, n0)
    if caught:
        assert res.error_estimate > law.rtol
    return res


@given(seeds, st.sampled_from(["configuration", "physical"]))
def test_energy_never_grows(seed, flux):
    rng, A, J, v, n0, rough = random_problem(seed)
    try:
        res = apply(rough_law(rough, rng, flux), A, J, v, n0)
    except mbi.NoFacingFacetError:
        return
    assert res.energy_loss >= -1e-12 * res.T_minus
    assert res.energy_loss == pytest.approx(res.T_minus - res.T_plus, rel=1e-7, abs=1e-9 * res.T_minus)
    assert res.residual < 1e-10


@given(seeds, st.floats(1e-6, 1e6))
def test_homogeneous_of_degree_one(seed, scale):
    """1°: Δv(s v) = s Δv for s > 0: the direction depends on the direction of v only."""
    rng, A, J, v, n0, rough = random_problem(seed)
    law = rough_law(rough, rng)
    try:
        base = apply(law, A, J, v, n0)
    except mbi.NoFacingFacetError:
        return
    scaled = apply(law, A, J, scale * v, n0)
    np.testing.assert_allclose(scaled.dv, scale * base.dv, rtol=1e-10, atol=1e-12 * scale * np.abs(base.dv).max())
    assert scaled.kappa == pytest.approx(base.kappa, rel=1e-9, abs=1e-12)
    assert scaled.mu == pytest.approx(base.mu, rel=1e-9, abs=1e-12)


@given(seeds, st.sampled_from(["configuration", "physical"]))
def test_independent_of_generalised_coordinates(seed, flux):
    """Coordinates x = T y: A' = TᵀAT, J' = JT, v' = T⁻¹v give the same motion, T v'₊ = v₊."""
    rng, A, J, v, n0, rough = random_problem(seed)
    n = A.shape[0]
    T = rng.normal(size=(n, n)) + 2 * np.eye(n)
    law = rough_law(rough, rng, flux)
    try:
        res = apply(law, A, J, v, n0)
    except mbi.NoFacingFacetError:
        return
    res_y = apply(law, T.T @ A @ T, J @ T, np.linalg.solve(T, v), n0)
    # the same W up to the rounding of forming T'AT and JT (amplified by cond(T)² cond(A)),
    # to which the impact is Lipschitz: the tolerance follows that discrepancy
    W, W_y = (mbi.ContactMetric.from_arrays(r.A, r.J).W for r in (res, res_y))
    rtol = max(1e-7, 10 * float(np.abs(W_y - W).max() / np.abs(W).max()))
    np.testing.assert_allclose(T @ res_y.v_plus, res.v_plus, rtol=rtol, atol=10 * rtol * np.abs(v).max())
    np.testing.assert_allclose(res_y.P, res.P, rtol=rtol, atol=1e-9 * np.abs(res.P).max())
    assert res_y.energy_loss == pytest.approx(res.energy_loss, rel=rtol, abs=1e-10)


@given(seeds)
def test_1_impulse_direction_fixed_by_velocity_direction(seed):
    """1°: the impulse direction is that of (2.8)'s mean normal and independent of |v|."""
    rng, A, J, v, n0, rough = random_problem(seed)
    law = rough_law(rough, rng)
    try:
        a, b = apply(law, A, J, v, n0), apply(law, A, J, 1e3 * v, n0)
    except mbi.NoFacingFacetError:
        return
    np.testing.assert_allclose(a.P / np.linalg.norm(a.P), b.P / np.linalg.norm(b.P), atol=1e-10)


@given(st.floats(0.01, 1.5), st.floats(0, 1), st.floats(0.0, 2 * math.pi), st.floats(0.01, 20.0))
def test_2_isotropic_friction_opposes_sliding(alpha, e, azimuth, tan_beta):
    """2°: Δv_l antiparallel to v_l, Δv in the plane of v and n⁰ (point mass, cone)."""
    v = np.array([tan_beta * math.cos(azimuth), tan_beta * math.sin(azimuth), -1.0])
    res = mbi.RoughLaw(mbi.Cone(alpha), e).apply(np.eye(3), np.eye(3), v, [0, 0, 1])
    dvl, vl = res.dv[:2], v[:2]
    assert abs(dvl[0] * vl[1] - dvl[1] * vl[0]) <= 1e-10 * np.linalg.norm(dvl) * np.linalg.norm(vl)
    assert dvl @ vl < 0
    assert abs(np.linalg.det(np.column_stack([v, [0, 0, 1], res.dv]))) <= 1e-10 * np.linalg.norm(v) * np.linalg.norm(res.dv)


@given(st.floats(0.0, 1.5), st.floats(0, 1))
def test_2_normal_incidence_has_no_tangential_impulse(alpha, e):
    for law, d in ((mbi.RoughLaw(mbi.Sawtooth(alpha), e), 2), (mbi.RoughLaw(mbi.Cone(alpha), e), 3)):
        v = -np.eye(d)[-1]
        res = law.apply(np.eye(d), np.eye(d), v, np.eye(d)[-1])
        assert np.abs(res.dv[:-1]).max() <= 1e-14
        assert res.mu <= 1e-14


@given(st.floats(0.0, 1.5), st.floats(0, 1), st.floats(1e-3, 1e3))
def test_3_normal_incidence_is_newton_with_kappa_4_2(alpha, e, speed):
    """3°: κ = (1+e) E[cos³α]/E[cos α] − 1 = (1+e) cos²α − 1 for one tilt, independent of |v_n|."""
    for law, d in ((mbi.RoughLaw(mbi.Sawtooth(alpha), e), 2), (mbi.RoughLaw(mbi.Cone(alpha), e), 3)):
        res = law.apply(np.eye(d), np.eye(d), -speed * np.eye(d)[-1], np.eye(d)[-1])
        assert res.kappa == pytest.approx((1 + e) * math.cos(alpha) ** 2 - 1, abs=1e-12)


def test_3_kappa_4_2_for_a_mixture_of_tilts():
    tilts, weights = np.array([0.0, 0.3, 0.7]), np.array([0.2, 0.5, 0.3])
    m = np.column_stack([np.sin(tilts), np.zeros(3), np.cos(tilts)])
    # symmetric set: each tilt at azimuth 0, π/2, π, 3π/2
    normals, w = [], []
    for ang in np.arange(4) * np.pi / 2:
        c, s = np.cos(ang), np.sin(ang)
        normals.append(m @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]))
        w.append(weights)
    facets = mbi.Facets(np.vstack(normals), np.concatenate(w))
    res = mbi.RoughLaw(facets, 0.7).apply(np.eye(3), np.eye(3), [0, 0, -2.0], [0, 0, 1])
    ec, ec3 = weights @ np.cos(tilts), weights @ np.cos(tilts) ** 3
    assert res.kappa == pytest.approx(1.7 * ec3 / ec - 1, rel=1e-12)


@pytest.mark.parametrize("alpha", [0.1, 0.4, 0.8])
def test_4_kappa_grows_with_sliding_and_exceeds_one(alpha):
    """4°: at fixed v_n, κ increases with |v_l| (first regime) and exceeds 1 at large β."""
    e = 0.9
    for law, d in ((mbi.RoughLaw(mbi.Sawtooth(alpha), e), 2), (mbi.RoughLaw(mbi.Cone(alpha), e), 3)):
        tb = np.linspace(0, 0.999 / math.tan(alpha), 40)
        kappas = []
        for t in tb:
            v = np.zeros(d)
            v[0], v[-1] = t, -1.0
            kappas.append(law.apply(np.eye(d), np.eye(d), v, np.eye(d)[-1]).kappa)
        assert np.all(np.diff(kappas) > 0)
    v = np.array([math.tan(1.55), -1.0])
    assert mbi.RoughLaw(mbi.Sawtooth(0.4), e).apply(np.eye(2), np.eye(2), v, [0, 1]).kappa > 1.0


@given(seeds)
def test_5_no_microrelief_is_newton(seed):
    """5°: g ≡ 0 (and zero tilt) gives the frictionless law with κ = e."""
    rng, A, J, v, n0, _ = random_problem(seed)
    d = J.shape[0]
    e = float(rng.uniform(0, 1))
    newton = mbi.NewtonLaw(e).apply(A, J, v, n0)
    flat = [mbi.Smooth(), mbi.Facets(np.eye(d)[-1:])] + ([mbi.Sawtooth(0.0)] if d == 2 else [mbi.Cone(0.0)])
    for rough in flat:
        res = apply(mbi.RoughLaw(rough, e), A, J, v, n0)
        np.testing.assert_allclose(res.v_plus, newton.v_plus, rtol=1e-13, atol=1e-13 * np.abs(v).max())
    assert newton.kappa == pytest.approx(e, abs=1e-12)
    assert newton.mu <= 1e-14  # P = P_n n⁰; what is left is the rounding of n⁰·n⁰ = 1


def test_flux_modes_agree_for_point_mass_and_differ_otherwise(rng):
    v = np.array([0.8, 0.3, -1.0])
    laws = [mbi.RoughLaw(mbi.Cone(0.5), 0.5, flux=f) for f in ("configuration", "physical")]
    a, b = (law.apply(2.0 * np.eye(3), np.eye(3), v, [0, 0, 1]) for law in laws)
    np.testing.assert_allclose(a.v_plus, b.v_plus, rtol=1e-13)
    A = np.diag([1.0, 1.0, 1.0 / 12.0])  # planar rod, contact at one end
    J = np.array([[1.0, 0.0, 0.3], [0.0, 1.0, 0.4]])  # tilted rod: W has off-diagonal terms
    laws = [mbi.RoughLaw(mbi.Sawtooth(0.5), 0.5, flux=f) for f in ("configuration", "physical")]
    a, b = (law.apply(A, J, [0.5, -1.0, 0.0], [0, 1]) for law in laws)
    assert np.linalg.norm(a.v_plus - b.v_plus) > 1e-3


def test_energy_loss_convexity_bound():
    """The averaged impact loses at least the flux-weighted mean of the facet losses."""
    alpha, e = 0.5, 0.3
    v = np.array([0.7, -1.0])
    res = mbi.RoughLaw(mbi.Sawtooth(alpha), e).apply(np.eye(2), np.eye(2), v, [0, 1])
    m = np.array([[-math.sin(alpha), math.cos(alpha)], [math.sin(alpha), math.cos(alpha)]])
    flux = np.maximum(-(m @ v), 0)
    facet_loss = 0.5 * (1 - e**2) * flux**2
    assert res.energy_loss >= flux @ facet_loss / flux.sum() - 1e-14

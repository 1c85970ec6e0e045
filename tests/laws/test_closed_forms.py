"""The paper's closed forms, in their corrected form (THEORY §6–§7), against (2.8).

The library never uses these formulas; it builds every result from (2.8).
"""

import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from scipy import integrate, optimize

import mbimpact as mbi

alphas = st.floats(0.0, 1.5)
es = st.floats(0.0, 1.0)
speeds = st.floats(1e-3, 1e3)
angles = st.floats(-1.55, 1.55)  # incidence β, signed: sign of v_l


def sawtooth_dv(alpha, e, vl, vn):
    """Corrected (2.11)–(2.13) for A = I, base x₂ = 0, v = (v_l, v_n), v_n < 0."""
    sa, ca = math.sin(alpha), math.cos(alpha)
    beta = math.atan2(abs(vl), abs(vn))
    if beta < math.pi / 2 - alpha:  # (2.12); (2.11) when v_l = 0
        return (1 + e) * np.array([-2 * vl * sa**2, vl**2 * sa**2 / abs(vn) + abs(vn) * ca**2])
    # (2.13): only the facet facing the motion is met
    return (1 + e) * (abs(vl) * sa + abs(vn) * ca) * np.array([-sa * math.copysign(1.0, vl), ca])


def sawtooth_mu(alpha, tan_beta):
    """Fig. 1 / (3.1): μ(tan β)."""
    ta = math.tan(alpha)
    if math.atan(tan_beta) < math.pi / 2 - alpha:
        return 2 * ta**2 * tan_beta / (ta**2 * tan_beta**2 + 1)
    return ta


@given(alphas, es, speeds, angles)
def test_sawtooth_2_11_to_2_13(alpha, e, speed, beta):
    vl, vn = speed * math.sin(beta), -speed * math.cos(beta)
    # stay off the regime switch by more than rounding (continuity is tested elsewhere)
    assume(abs(abs(beta) - (math.pi / 2 - alpha)) > 1e-9)
    res = mbi.RoughLaw(mbi.Sawtooth(alpha), e).apply(np.eye(2), np.eye(2), [vl, vn], [0.0, 1.0])
    np.testing.assert_allclose(res.dv, sawtooth_dv(alpha, e, vl, vn), rtol=1e-12, atol=1e-12 * speed)


@given(alphas, es, st.floats(0.0, 1e3))
def test_sawtooth_mu_is_fig1_formula(alpha, e, tan_beta):
    assume(alpha > 1e-6 and abs(math.atan(tan_beta) - (math.pi / 2 - alpha)) > 1e-9)
    res = mbi.RoughLaw(mbi.Sawtooth(alpha), e).apply(np.eye(2), np.eye(2), [tan_beta, -1.0], [0.0, 1.0])
    assert res.mu == pytest.approx(sawtooth_mu(alpha, tan_beta), rel=1e-11, abs=1e-14)
    # (3.1) for a point mass: μ = |Δv_l| / |Δv_n|
    assert res.mu == pytest.approx(abs(res.dv[0]) / abs(res.dv[1]), rel=1e-12, abs=1e-15)


@given(st.floats(0.01, 1.5), es, st.floats(0.0, 1.0))
def test_sawtooth_restitution_first_regime(alpha, e, frac):
    """κ = (1+e)(tan²β sin²α + cos²α) − 1 below the switch (THEORY §7)."""
    tan_beta = frac * math.tan(math.pi / 2 - alpha) * (1 - 1e-9)
    res = mbi.RoughLaw(mbi.Sawtooth(alpha), e).apply(np.eye(2), np.eye(2), [tan_beta, -1.0], [0.0, 1.0])
    expect = (1 + e) * (tan_beta**2 * math.sin(alpha) ** 2 + math.cos(alpha) ** 2) - 1
    assert res.kappa == pytest.approx(expect, rel=1e-11, abs=1e-12)


def isotropic_dv(alpha, e, v):
    """Corrected (2.10) for a cone of tilt α, A = I, n⁰ = e_z, valid while |v_l| tan α < |v_n|."""
    vl, vn = v[:2], abs(v[2])
    ca, s2c = math.cos(alpha), math.sin(alpha) ** 2 * math.cos(alpha)
    normal = vn * ca**3 + (vl @ vl) / vn * s2c / 2
    return (1 + e) / ca * np.array([-2 * vl[0] * s2c / 2, -2 * vl[1] * s2c / 2, normal])


@given(st.floats(0.0, 1.4), es, speeds, st.floats(0, 2 * math.pi), st.floats(0.0, 0.999))
def test_cone_matches_corrected_2_10(alpha, e, speed, azimuth, frac):
    tan_beta = min(frac / math.tan(alpha), 1e6) if alpha > 0 else 10 * frac
    vl = tan_beta * np.array([math.cos(azimuth), math.sin(azimuth)])
    v = speed * np.array([vl[0], vl[1], -1.0]) / math.hypot(tan_beta, 1.0)
    res = mbi.RoughLaw(mbi.Cone(alpha), e).apply(np.eye(3), np.eye(3), v, [0, 0, 1])
    np.testing.assert_allclose(res.dv, isotropic_dv(alpha, e, v), rtol=1e-10, atol=1e-12 * speed)


def cone_reference(alpha, e, W, u, flux="physical"):
    """(2.8) for a cone by adaptive scipy quadrature, boundaries of G* found by root finding."""
    sa, ca = math.sin(alpha), math.cos(alpha)

    def m(phi):
        return np.array([sa * math.cos(phi), sa * math.sin(phi), ca])

    def s(phi):
        return m(phi) @ u

    grid = np.linspace(0, 2 * math.pi, 721)
    vals = [s(p) for p in grid]
    cuts = [optimize.brentq(s, a, b, xtol=1e-15) for a, b, fa, fb in zip(grid, grid[1:], vals, vals[1:]) if fa * fb < 0]
    pts = sorted(set([0.0, 2 * math.pi] + cuts))

    def parts(phi):
        mm = m(phi)
        sv, qv = mm @ u, mm @ W @ mm
        if sv >= 0:
            return np.zeros(4)
        w = -sv / math.sqrt(qv) if flux == "configuration" else -sv
        return np.concatenate([[w], w * (-sv / qv) * mm])

    tot = np.zeros(4)
    with warnings.catch_warnings():  # quad's round-off notice on near-constant integrands
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        for a, b in zip(pts, pts[1:]):
            for i in range(4):
                tot[i] += integrate.quad(lambda p: parts(p)[i], a, b, epsabs=1e-15, epsrel=1e-12, limit=400)[0]
    return (1 + e) * tot[1:] / tot[0]


@pytest.mark.parametrize("flux", ["configuration", "physical"])
@pytest.mark.parametrize("alpha", [0.05, 0.4, 1.0, 1.45])
@pytest.mark.parametrize("beta", [0.0, 0.3, 1.0, 1.4, 1.5607])
def test_cone_accuracy_every_regime(alpha, beta, flux, rng):
    """≤ 1e-9 relative against adaptive quadrature, whole and truncated cone, anisotropic W."""
    A = np.diag([1.0, 3.0, 0.5])
    J = rng.normal(size=(3, 3))
    W = J @ np.linalg.solve(A, J.T)
    u = np.array([math.sin(beta) * math.cos(0.7), math.sin(beta) * math.sin(0.7), -math.cos(beta)])
    v = np.linalg.solve(J, u)
    res = mbi.RoughLaw(mbi.Cone(alpha), 0.6, flux=flux).apply(A, J, v, [0, 0, 1])
    ref = cone_reference(alpha, 0.6, W, u, flux)
    np.testing.assert_allclose(res.P, ref, rtol=1e-9, atol=1e-9 * np.linalg.norm(ref))


@given(st.floats(0.05, 1.45), es)
def test_continuity_at_regime_switch(alpha, e):
    """β crossing π/2 − α: (2.12) and (2.13), whole and truncated cone, agree to 1e-9."""
    for law, d in ((mbi.RoughLaw(mbi.Sawtooth(alpha), e), 2), (mbi.RoughLaw(mbi.Cone(alpha), e), 3)):
        results = []
        for eps in (-1e-11, 0.0, 1e-11):
            beta = math.pi / 2 - alpha + eps
            v = np.zeros(d)
            v[0], v[-1] = math.sin(beta), -math.cos(beta)
            results.append(law.apply(np.eye(d), np.eye(d), v, np.eye(d)[-1]).dv)
        np.testing.assert_allclose(results[0], results[1], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(results[2], results[1], rtol=1e-9, atol=1e-12)

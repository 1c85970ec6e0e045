"""Continuous (IsotropicSlopes, GaussianSlopes) and measured (Profile, HeightMap) roughness."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import integrate

import mbimpact as mbi

I2, I3 = np.eye(2), np.eye(3)

# scipy quad in the references notes round-off on near-constant integrands
pytestmark = pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")


def isotropic_reference(pdf, lo, hi, e, u):
    """(2.8) for a point mass on an isotropic spatial measure by nested scipy quadrature."""
    u = np.asarray(u, float)

    def inner(alpha):
        sa, ca = math.sin(alpha), math.cos(alpha)

        def parts(phi, i):
            m = np.array([sa * math.cos(phi), sa * math.sin(phi), ca])
            s = m @ u
            if s >= 0:
                return 0.0
            return (-s) if i == 3 else (-s) * (-s) * m[i]

        # kinks of the integrand where a facet stops facing u (u in the x-z plane here)
        c = ca * abs(u[2]) / (sa * abs(u[0])) if sa * abs(u[0]) > 0 else 2.0
        pts = [math.acos(c), 2 * math.pi - math.acos(c)] if c < 1 else None
        return [integrate.quad(parts, 0, 2 * math.pi, args=(i,), points=pts, limit=200, epsabs=1e-14)[0] / (2 * math.pi)
                for i in range(4)]

    tot = np.zeros(4)
    for i in range(4):
        # the outer integrand has a (α − α*)^{3/2} point where the cone starts to be cut
        star = math.atan2(abs(u[2]), math.hypot(u[0], u[1]))
        pts = [star] if lo < star < hi else None
        tot[i] = integrate.quad(lambda a: pdf(np.array([a]))[0] * inner(a)[i], lo, hi, points=pts, limit=100,
                                epsabs=1e-14, epsrel=1e-12)[0]
    return (1 + e) * tot[:3] / tot[3]


@pytest.mark.parametrize("beta", [0.0, 0.6, 1.3])
def test_isotropic_slopes_against_nested_quadrature(beta):
    pdf = lambda a: np.sin(2 * a) * (1 + np.cos(3 * a))  # noqa: E731 — any smooth density
    rough = mbi.IsotropicSlopes(pdf, support=(0.0, 1.0))
    u = [math.sin(beta), 0.0, -math.cos(beta)]
    res = mbi.RoughLaw(rough, 0.4).apply(I3, I3, u, [0, 0, 1])
    np.testing.assert_allclose(res.dv, isotropic_reference(pdf, 0.0, 1.0, 0.4, u), rtol=1e-8, atol=1e-10)


def test_gaussian_slopes_normal_incidence_is_4_2():
    """3°: 1 + κ = (1+e) E[cos³α] / E[cos α] under the true-area measure."""
    for dim in (2, 3):
        rough = mbi.GaussianSlopes(0.3, dim=dim)
        e = 0.6
        v = -np.eye(dim)[-1]
        res = mbi.RoughLaw(rough, e).apply(np.eye(dim), np.eye(dim), v, np.eye(dim)[-1])
        expect = (1 + e) * rough.moment(lambda a: np.cos(a) ** 3) / rough.moment(np.cos) - 1
        assert res.kappa == pytest.approx(expect, rel=1e-10)


def test_gaussian_slopes_measure_is_per_true_area():
    """In 2-D, E[cos α] over the true-length measure is 1 / E_base[sec α] (a direct average over x)."""
    sigma = 0.5
    rough = mbi.GaussianSlopes(sigma, dim=2)
    s = np.linspace(-12 * sigma, 12 * sigma, 200001)
    phi = np.exp(-0.5 * (s / sigma) ** 2)
    sec = np.sqrt(1 + s * s)
    expect = integrate.trapezoid(phi, s) / integrate.trapezoid(phi * sec, s)
    assert rough.moment(np.cos) == pytest.approx(expect, rel=1e-8)


@given(st.floats(0.05, 1.0), st.floats(0.0, 1.45), st.sampled_from([2, 3]))
def test_gaussian_slopes_monte_carlo_agrees_with_quadrature(sigma, beta, dim):
    rough = mbi.GaussianSlopes(sigma, dim=dim)
    v = np.zeros(dim)
    v[0], v[-1] = math.sin(beta), -math.cos(beta)
    exact = mbi.RoughLaw(rough, 0.5).apply(np.eye(dim), np.eye(dim), v, np.eye(dim)[-1])
    mc = mbi.RoughLaw(rough, 0.5, method="monte-carlo", samples=20_000, seed=3).apply(np.eye(dim), np.eye(dim), v, np.eye(dim)[-1])
    assert exact.error_estimate <= 1e-11  # rtol = 1e-12, or the rounding floor of the sum
    err = np.linalg.norm(mc.P - exact.P) / np.linalg.norm(exact.P)
    assert err <= 6 * mc.error_estimate + 1e-12  # within 6 standard errors


def test_monte_carlo_error_shrinks_like_one_over_sqrt_n():
    law = lambda n: mbi.RoughLaw(mbi.Cone(0.5), 0.5, method="monte-carlo", samples=n, seed=5)  # noqa: E731
    v = [1.0, 0.2, -1.0]
    se = [law(n).apply(I3, I3, v, [0, 0, 1]).error_estimate for n in (1_000, 100_000)]
    assert se[1] == pytest.approx(se[0] / 10, rel=0.2)


def test_exact_arc_quadrature_converges_with_64_nodes_in_every_regime():
    rng = np.random.default_rng(4)
    J = rng.normal(size=(3, 3))
    A = np.diag([2.0, 1.0, 0.3])
    for beta in np.linspace(0, 1.55, 12):
        u = np.array([math.sin(beta), 0.3 * math.sin(beta), -math.cos(beta)])
        v = np.linalg.solve(J, u)
        ref = mbi.RoughLaw(mbi.Cone(0.5), 0.5, nodes=1024).apply(A, J, v, [0, 0, 1]).P
        got = mbi.RoughLaw(mbi.Cone(0.5), 0.5, nodes=64).apply(A, J, v, [0, 0, 1]).P
        assert np.linalg.norm(got - ref) <= 1e-12 * np.linalg.norm(ref)


def test_fixed_nodes_reports_an_error_estimate():
    coarse = mbi.RoughLaw(mbi.Cone(0.5), 0.5, nodes=4).apply(I3, I3, [2.0, 0.0, -1.0], [0, 0, 1])
    fine = mbi.RoughLaw(mbi.Cone(0.5), 0.5).apply(I3, I3, [2.0, 0.0, -1.0], [0, 0, 1])
    true_err = np.linalg.norm(coarse.P - fine.P) / np.linalg.norm(fine.P)
    assert coarse.nodes == 4 and 1e-6 < true_err <= coarse.error_estimate * 10


def sawtooth_profile(alpha, teeth=10, per_tooth=20):
    x = np.arange(teeth * per_tooth + 1) / per_tooth
    return np.tan(alpha) * np.abs((x % 1.0) - 0.5), 1.0 / per_tooth


@given(st.floats(0.05, 1.4), st.floats(0.0, 0.999), st.booleans())
def test_sawtooth_profile_shadowing_changes_nothing_below_the_switch(alpha, frac, periodic):
    """tan α tan β < 1: every facet facing the motion is fully lit; Profile = Sawtooth."""
    h, dx = sawtooth_profile(alpha)
    tan_beta = frac / math.tan(alpha)
    v = [tan_beta, -1.0]
    plain = mbi.RoughLaw(mbi.Profile(h, dx), 0.5).apply(I2, I2, v, [0, 1])
    shadowed = mbi.RoughLaw(mbi.Profile(h, dx, shadowing=True, periodic=periodic), 0.5).apply(I2, I2, v, [0, 1])
    saw = mbi.RoughLaw(mbi.Sawtooth(alpha), 0.5).apply(I2, I2, v, [0, 1])
    np.testing.assert_allclose(plain.dv, saw.dv, rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(shadowed.dv, saw.dv, rtol=1e-11, atol=1e-13)


@given(st.floats(0.0, 30.0), st.sampled_from(["sine", "saw"]))
def test_periodic_shadowing_meets_every_ray_once(tan_beta, shape):
    """Lit facets' projected length across the rays equals the period's cross-section exactly."""
    x = np.linspace(0.0, 3.0, 601)
    h = 0.2 * np.sin(2 * np.pi * x) if shape == "sine" else sawtooth_profile(0.7, 3, 200)[0]
    prof = mbi.Profile(h, x[1], shadowing=True, periodic=True)
    u = np.array([tan_beta, -1.0]) / math.hypot(tan_beta, 1.0)
    flux = np.maximum(-(prof.normals @ u), 0.0)
    assert (prof.lit_fraction(u) * prof.lengths * flux).sum() == pytest.approx(3.0 * abs(u[1]), rel=1e-10)


def test_sinusoid_shadowing_makes_friction_fall_at_grazing_incidence():
    """The dashed curve of Fig. 1: with shadowing μ(tan β) has an interior maximum and falls."""
    x = np.linspace(0.0, 1.0, 801)
    h = 0.1 * np.sin(2 * np.pi * x)
    tb = np.geomspace(0.1, 50, 40)

    def mu(prof):
        return np.array([mbi.RoughLaw(prof, 0.5).apply(I2, I2, [t, -1.0], [0, 1]).mu for t in tb])

    shadowed, plain = mu(mbi.Profile(h, x[1], shadowing=True, periodic=True)), mu(mbi.Profile(h, x[1]))
    peak = int(np.argmax(shadowed))
    assert 0 < peak < len(tb) - 1 and shadowed[-1] < 0.8 * shadowed[peak]
    assert plain[-1] >= plain[peak] - 1e-12  # without shadowing the steepest facets keep μ up
    np.testing.assert_allclose(shadowed[:5], plain[:5], rtol=1e-12)  # steep incidence: nothing hidden


def test_height_map_of_a_ridge_profile_matches_the_profile():
    x = np.linspace(0.0, 2.0, 121)
    h = 0.1 * np.sin(2 * np.pi * x)
    z = np.tile(h[:, None], (1, 4))
    for shadowing in (False, True):
        hm = mbi.HeightMap(z, x[1], 0.1, shadowing=shadowing)
        pr = mbi.Profile(h, x[1], shadowing=shadowing)
        for tb in (0.5, 4.0, 15.0):
            a = mbi.RoughLaw(hm, 0.5).apply(I3, I3, [tb, 0.0, -1.0], [0, 0, 1]).dv
            b = mbi.RoughLaw(pr, 0.5).apply(I2, I2, [tb, -1.0], [0, 1]).dv
            np.testing.assert_allclose(a[[0, 2]], b, rtol=1e-12, atol=1e-12)
            assert abs(a[1]) < 1e-12


def first_hits(hm, u, n_rays, rng):
    """Ray casting: parallel rays along u from a horizontal plane above the map; the
    triangle each ray meets first from above (−1: none) and the beam area per ray."""
    z, (nx, ny) = hm.z, hm.z.shape
    X, Y = (nx - 1) * hm.dx, (ny - 1) * hm.dy
    top = z.max() + 0.1
    drift = (top - z.min()) / abs(u[2])
    xs, ys = [0, X, -drift * u[0], X - drift * u[0]], [0, Y, -drift * u[1], Y - drift * u[1]]
    box = (max(xs) - min(xs)) * (max(ys) - min(ys))
    O = np.column_stack([rng.uniform(min(xs), max(xs), n_rays), rng.uniform(min(ys), max(ys), n_rays),
                         np.full(n_rays, top)])
    I, J = (a.ravel() for a in np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij"))
    vertex = lambda i, j: np.column_stack([i * hm.dx, j * hm.dy, z[i, j]])  # noqa: E731
    corners = [np.concatenate(c) for c in zip((vertex(I, J), vertex(I + 1, J), vertex(I + 1, J + 1)),
                                              (vertex(I, J), vertex(I + 1, J + 1), vertex(I, J + 1)))]
    best, who = np.full(n_rays, np.inf), np.full(n_rays, -1)
    for k, (p0, p1, p2) in enumerate(zip(*corners)):  # Möller–Trumbore
        e1, e2 = p1 - p0, p2 - p0
        pv = np.cross(u, e2)
        det = e1 @ pv
        tv = O - p0
        a = tv @ pv / det
        qv = np.cross(tv, e1)
        b, t = qv @ u / det, qv @ e2 / det
        hit = (a >= 0) & (b >= 0) & (a + b <= 1) & (t > 0) & (t < best)
        best[hit], who[hit] = t[hit], k
    from_above = hm.normals[np.maximum(who, 0)] @ u < 0
    return np.where((who >= 0) & from_above, who, -1), box * abs(u[2]) / n_rays


@pytest.mark.parametrize("u", [[0.8, 0.5, -0.3], [-0.2, 0.9, -0.6]])
def test_height_map_shadowing_agrees_with_ray_casting(u):
    """Independent check of the exact lit areas: the beam each triangle intercepts first."""
    rng = np.random.default_rng(1)
    hm = mbi.HeightMap(rng.normal(size=(6, 5)) * 0.25, 0.3, 0.25, shadowing=True)
    u = np.array(u) / np.linalg.norm(u)
    who, per_ray = first_hits(hm, u, 400_000, rng)
    hits = np.bincount(who[who >= 0], minlength=len(hm.areas))
    exact = hm.lit_fraction(u) * hm.areas * np.abs(hm.normals @ u) / per_ray  # expected hits
    seen = hits > 100
    assert seen.sum() > 10
    z_scores = (hits[seen] - exact[seen]) / np.sqrt(exact[seen])
    assert np.max(np.abs(z_scores)) < 5
    assert np.all(exact[hits == 0] < 30)  # triangles in full shadow are dark in both
    unshadowed = hm.areas * np.abs(hm.normals @ u) / per_ray * (hm.normals @ u < 0)
    assert np.max(np.abs(unshadowed - hits)[seen] / np.sqrt(hits[seen])) > 20  # shadowing matters here


def test_height_map_shadowing_is_exact_against_a_fine_midpoint_rule():
    rng = np.random.default_rng(0)
    hm = mbi.HeightMap(rng.normal(size=(10, 10)) * 0.1, 0.1, 0.1, shadowing=True)
    u = np.array([0.7, 0.4, -0.5])
    ut = math.hypot(u[0], u[1])
    d = u[:2] / ut
    e = np.array([-d[1], d[0]])
    x, y = np.meshgrid(np.arange(10) * 0.1, np.arange(10) * 0.1, indexing="ij")
    s = (x * e[0] + y * e[1]).ravel()
    errors = []
    for planes in (10_000, 40_000):
        edges = np.linspace(s.min(), s.max(), planes + 1)
        tri, length = hm.lit_lengths(0.5 * (edges[1:] + edges[:-1]), d, e, abs(u[2]) / ut)
        ok = tri >= 0
        lit = np.bincount(tri[ok], weights=(length * (edges[1] - edges[0]))[ok], minlength=len(hm.areas))
        errors.append(np.abs(lit / 0.005 - hm.lit_fraction(u)).max())
    assert errors[1] < 2e-6 and errors[1] < errors[0] / 8  # the midpoint rule converges to it like h²


@pytest.mark.parametrize("tan_beta", [0.5, 1.5, 2.3, 6.0])
def test_sawtooth_height_map_shadows_exactly_the_closed_form(tan_beta):
    """Teeth of period 1 and slope tan α; below the switch (tan α tan β < 1) nothing facing the
    motion is shadowed; above it the rising face of every tooth after the first is lit from
    x* = tan α / (tan α + cot β) (the ray from the previous peak) onwards."""
    alpha, dx = 0.4, 0.05
    x = np.arange(41) * dx
    z = np.tile((np.tan(alpha) * np.abs((x % 1.0) - 0.5))[:, None], (1, 3))
    hm = mbi.HeightMap(z, dx, 0.1, shadowing=True)
    lit = hm.lit_fraction(np.array([tan_beta, 0.0, -1.0]))
    x_star = max(0.5, math.tan(alpha) / (math.tan(alpha) + 1 / tan_beta))
    cells = np.arange(30, 40)  # the rising face of the second tooth, x in [1.5, 2]
    a = np.clip((1 + x_star - cells * dx) / dx, 0.0, 1.0)  # shadow edge, in cell units
    lower = 2 * (a * (1 - a) + (1 - a) ** 2 / 2)  # triangle (00, 10, 11): x-fraction ≥ y-fraction
    upper = (1 - a) ** 2  # triangle (00, 11, 01)
    for j in (0, 1):
        np.testing.assert_allclose(lit[cells * 2 + j], lower, rtol=0, atol=1e-12)
        np.testing.assert_allclose(lit[40 * 2 + cells * 2 + j], upper, rtol=0, atol=1e-12)
    assert (tan_beta * math.tan(alpha) < 1) == np.all(lower == 1.0)
    plain = mbi.RoughLaw(mbi.HeightMap(z, dx, 0.1), 0.5).apply(I3, I3, [tan_beta, 0, -1.0], [0, 0, 1]).dv
    shadowed = mbi.RoughLaw(hm, 0.5).apply(I3, I3, [tan_beta, 0, -1.0], [0, 0, 1]).dv
    if tan_beta * math.tan(alpha) < 1:
        np.testing.assert_allclose(shadowed, plain, rtol=1e-13, atol=1e-13)


def test_height_map_facets_are_weighted_by_true_area():
    z = np.array([[0.0, 0.0], [1.0, 1.0]])  # one plane of slope 1 in x: both triangles tilted 45°
    hm = mbi.HeightMap(z, 1.0, 1.0)
    np.testing.assert_allclose(hm.areas, [math.sqrt(2) / 2] * 2)
    np.testing.assert_allclose(hm.normals, [[-1 / math.sqrt(2), 0, 1 / math.sqrt(2)]] * 2)


def test_measure_errors():
    with pytest.raises(mbi.RoughnessError, match="at least 2"):
        mbi.Profile([1.0], 0.1)
    with pytest.raises(mbi.RoughnessError, match="dx"):
        mbi.Profile([0.0, 1.0], 0.0)
    with pytest.raises(mbi.RoughnessError, match="2×2"):
        mbi.HeightMap(np.zeros((1, 3)), 1.0, 1.0)
    with pytest.raises(mbi.ParameterError, match="sigma"):
        mbi.GaussianSlopes(0.0)
    with pytest.raises(mbi.RoughnessError, match="non-negative"):
        mbi.IsotropicSlopes(lambda a: np.cos(a) - 0.5)
    with pytest.raises(mbi.RoughnessError, match="dim"):
        mbi.IsotropicSlopes(np.cos, dim=4)
    with pytest.raises(mbi.RoughnessError, match="support"):
        mbi.IsotropicSlopes(np.cos, support=(1.0, 0.5))
    with pytest.raises(mbi.RoughnessError, match="not supported"):
        mbi.RoughLaw(mbi.Profile([0.0, 1.0, 0.0], 1.0, shadowing=True), 0.5, method="monte-carlo")
    with pytest.raises(mbi.ParameterError, match="'monte-carlo' averaging cannot average Smooth"):
        mbi.RoughLaw(mbi.Smooth(), 0.5, method="monte-carlo")
    with pytest.raises(mbi.ParameterError, match="method"):
        mbi.RoughLaw(mbi.Cone(0.1), 0.5, method="exact")
    with pytest.raises(mbi.ParameterError, match="samples"):
        mbi.RoughLaw(mbi.Cone(0.1), 0.5, method="monte-carlo", samples=1)
    with pytest.raises(mbi.ParameterError, match="nodes"):
        mbi.RoughLaw(mbi.Cone(0.1), 0.5, nodes=0)

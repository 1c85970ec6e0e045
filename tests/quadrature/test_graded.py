"""Graded quadrature (azimuth; tilt and azimuth for tilt densities) for nearly singular Delassus
matrices (arms near singular postures)."""

import functools
import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

import mbimpact as mbi
from mbimpact.averaging.integrand import rule_average
from mbimpact.common import ring_quadratic_form
from mbimpact.quadrature import (
    gauss_legendre,
    graded_azimuth_rule,
    graded_tilt_rule,
    peak_tilts,
    peak_width_bound,
    ring_minima,
    ring_minima_many,
)
from tests.helpers import UPRIGHT_UR5 as UPRIGHT
from tests.helpers import impulses, mechanism, spd, upright_ur5_delassus


def upright_ur5():
    mech = mechanism("ur5")
    J = mech.point_jacobian(UPRIGHT, "tool0")
    return mech, J, mech.mass_matrix(UPRIGHT)


def reference(alpha, e, W, u, flux="physical"):
    """(2.8) by adaptive scipy.quad, told where the kernels peak."""
    s, c = math.sin(alpha), math.cos(alpha)
    gamma, delta = (1.5, 0.5) if flux == "configuration" else (1.0, 0.0)

    def kernel(phi, j):
        m = np.array([s * math.cos(phi), s * math.sin(phi), c])
        su, q = m @ u, m @ W @ m
        if su >= 0:
            return 0.0
        return su * su * m[j] / q**gamma if j < 3 else -su / q**delta

    peaks = list(ring_minima(alpha, W)[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        I = [integrate.quad(kernel, 0, 2 * math.pi, args=(j,), points=peaks, limit=2000, epsabs=0, epsrel=1e-13)[0]
             for j in range(4)]
    return (1 + e) * np.array(I[:3]) / I[3]


@pytest.mark.parametrize("alpha", [0.3, 1.0])
@pytest.mark.parametrize("u", [[0.2, 0.1, -1.0], [1.0, 0.3, -0.2], [0.0, 0.0, -1.0]])
def test_near_singular_posture_converges_with_few_nodes(alpha, u):
    mech, J, A = upright_ur5()
    metric = mbi.ContactMetric.from_arrays(A, J)
    W = metric.W  # local frame = world frame for n0 = z
    u = np.array(u) / np.linalg.norm(u)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)  # may be rounding-limited near 1e-11: it says so
        P, est, nodes = impulses(mbi.RoughLaw(mbi.Cone(alpha), 0.5), W, u[None])
    ref = reference(alpha, 0.5, W, u)  # scipy itself reports roundoff near 1e-11 here
    assert np.linalg.norm((P[0] - ref) @ W) < 1e-9 * np.linalg.norm(ref @ W)
    assert nodes <= 256  # where rounding (~1e-11 here) stops the refinement, not 1e5 nodes
    # the estimate is honest against the same graded rule with 8× more nodes (rounding scatter ~1e-11)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5)
    fine = rule_average(law.spec, W, u[None], (1024,), functools.partial(graded_azimuth_rule, alpha, ring_minima(alpha, W)))[0][0][0]
    assert np.linalg.norm((P[0] - fine) @ W) <= (10 * est[0] + 1e-11) * np.linalg.norm(fine @ W)
    # the whole pipeline on the robot stays sound there
    v = np.linalg.lstsq(J, u, rcond=None)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)
        res = mbi.impact(mech, UPRIGHT, v, mbi.PointContact("tool0"), mbi.RoughLaw(mbi.Cone(alpha), 0.5))
    # (its estimate holds the rounding of q at the ring's minima, up to 2.2e-9 here: cond W ~ 1e7)
    assert res.energy_loss >= 0 and res.error_estimate < 1e-8


def test_uniform_rule_needs_far_more_nodes_there():
    """What the grading buys: 20 000 plain nodes are still off by ~1e-6 with the configuration weight
    (whose kernels peak hardest, like q^(-3/2))."""
    mech, J, A = upright_ur5()
    metric = mbi.ContactMetric.from_arrays(A, J)
    W = metric.W
    u = np.array([0.2, 0.1, -1.0]) / np.linalg.norm([0.2, 0.1, -1.0])
    ref = reference(0.3, 0.5, W, u, "configuration")
    phi = 2 * math.pi * np.arange(20_000) / 20_000  # the whole cone faces u: the periodic trapezoid rule
    ring = mbi.Facets(np.column_stack([math.sin(0.3) * np.cos(phi), math.sin(0.3) * np.sin(phi),
                                       np.full(phi.size, math.cos(0.3))]))
    plain, _, _ = impulses(mbi.RoughLaw(ring, 0.5, flux="configuration"), W, u[None])
    assert np.linalg.norm((plain[0] - ref) @ W) > 1e-7 * np.linalg.norm(ref @ W)
    graded, _, _ = impulses(mbi.RoughLaw(mbi.Cone(0.3), 0.5, flux="configuration", nodes=64), W, u[None])
    assert np.linalg.norm((graded[0] - ref) @ W) < 1e-9 * np.linalg.norm(ref @ W)


def test_ring_minima_of_a_rank_one_delassus_matrix():
    """W = λ e eᵀ + δ I: q = λ (mᵀe)² + δ has its minima where the ring crosses e⊥, width ≈ sqrt(δ/λ)/|d(mᵀe)/dφ|."""
    alpha, lam, delta = 0.7, 1.0, 1e-8
    e = np.array([1.0, 0.5, 0.4])
    e /= np.linalg.norm(e)
    W = lam * np.outer(e, e) + delta * np.eye(3)
    phi, eps = ring_minima(alpha, W)
    s, c = math.sin(alpha), math.cos(alpha)
    assert len(phi) == 2
    for p, w in zip(phi, eps):
        m = np.array([s * math.cos(p), s * math.sin(p), c])
        dm = np.array([-s * math.sin(p), s * math.cos(p), 0.0])
        assert abs(m @ e) < 1e-12
        assert w == pytest.approx(math.sqrt(delta / lam) / abs(dm @ e), rel=1e-6)


@pytest.mark.parametrize("beta", [0.0, 0.5, 1.2, 1.5])
def test_graded_rule_integrates_the_measure_of_the_facing_arc(beta):
    alpha = 0.6
    W = np.diag([1.0, 1e-7, 1e-3])
    minima = ring_minima(alpha, W)
    U = np.array([[math.sin(beta) * math.cos(0.4), math.sin(beta) * math.sin(0.4), -math.cos(beta)]])
    m, w = graded_azimuth_rule(alpha, minima, U, 32)
    ratio = math.cos(alpha) * math.cos(beta) / (math.sin(alpha) * math.sin(beta)) if beta else math.inf
    facing = 1.0 if ratio >= 1 else (math.pi - math.acos(ratio)) / math.pi
    assert w.sum() == pytest.approx(facing, rel=1e-13)
    # every node faces u (up to the arc end points) and trig polynomials integrate exactly
    assert np.all(m[0] @ U[0] <= 1e-14)
    if facing == 1.0:
        assert abs(w[0] @ (m[0, :, 0] * m[0, :, 1])) < 1e-14


# ---------------------------------------------------------------- tilt densities


def composite_slopes_reference(measure, e, W, u, flux="physical", panels=3000):
    """(2.8) for a tilt density by brute force in the tilt: uniform Gauss–Legendre panels,
    no grading, no hints; each ring by the graded azimuth rule (checked against scipy above)."""
    lo, hi = measure.support
    x, gw = gauss_legendre(8)
    edges = np.linspace(lo, hi, panels + 1)
    tilt = (edges[:-1, None] + np.diff(edges)[:, None] * (x + 1) / 2).ravel()[None, :]
    dtilt = (np.diff(edges)[:, None] / 2 * gw).ravel() * measure.density(tilt[0])
    m, w = graded_azimuth_rule(tilt, ring_minima_many(tilt, W), u[None], 48)
    m, w = m[0], (w[0].reshape(tilt.shape[1], -1) * dtilt[:, None]).ravel()
    s, q = m @ u, np.einsum("ki,ij,kj->k", m, W, m)
    f = (s < 0) & (w > 0)
    g = np.sqrt(q[f]) if flux == "configuration" else np.ones(f.sum())  # the configuration weight divides by √q
    return (1 + e) * ((w[f] * s[f] ** 2 / (q[f] * g)) @ m[f]) / (w[f] @ (-s[f] / g))


def w_error(P, ref, W):
    """Relative error of the contact-velocity change W P (P itself is ill-determined along null W)."""
    return np.linalg.norm((P - ref) @ W) / np.linalg.norm(ref @ W)


@pytest.mark.parametrize("flux", ["physical", "configuration"])
@pytest.mark.parametrize("u", [[1.0, 0.3, -0.2], [0.0, 1.0, -0.3]], ids=["oblique", "along-valley"])
def test_gaussian_slopes_at_a_near_singular_posture(u, flux):
    """W spans 1e7: 1/mᵀWm has a valley across the sphere and a point peak; tilt and azimuth are graded."""
    W = upright_ur5_delassus()
    u = np.array(u) / np.linalg.norm(u)
    measure = mbi.GaussianSlopes(0.3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)  # rounding-limited near 1e-11: it says so
        P, est, nodes = impulses(mbi.RoughLaw(measure, 0.5, flux=flux, method="graded"), W, u[None])
        fine, _, _ = impulses(mbi.RoughLaw(measure, 0.5, flux=flux, nodes=256), W, u[None])
    assert nodes <= 128
    assert w_error(P[0], composite_slopes_reference(measure, 0.5, W, u, flux), W) < 1e-9
    assert w_error(P[0], fine[0], W) <= 10 * est[0] + 1e-10  # the estimate is honest
    # what the grading buys: the plain tilt × azimuth product rule is far off at 256 nodes
    # (O(1) for the configuration weight, whose kernels peak like q^(-3/2))
    plain = rule_average(mbi.RoughLaw(measure, 0.5, flux=flux).spec, W, u[None], (256,))[0][0][0]
    assert w_error(plain, fine[0], W) > (1e-3 if flux == "configuration" else 1e-6)


def test_ring_minima_many_matches_the_scalar_search(rng):
    for _ in range(20):
        B = rng.normal(size=(3, 3))
        W = B @ np.diag(10.0 ** rng.uniform(-8, 0, 3)) @ B.T
        alpha = rng.uniform(0.01, 1.5, 7)
        phi, eps = ring_minima_many(alpha, W)
        for a, p, e in zip(alpha, phi, eps):
            ref_p, ref_e = ring_minima(a, W)
            got = p[np.isfinite(p)]
            assert len(got) == len(ref_p)
            for x, w in zip(ref_p, ref_e):
                j = np.argmin(np.abs(np.angle(np.exp(1j * (got - x)))))
                assert abs(np.angle(np.exp(1j * (got[j] - x)))) < 1e-9
                assert e[np.isfinite(p)][j] <= w * (1 + 1e-9)  # capped by the quartic width, never wider


def test_ring_minima_stop_at_rounding_on_a_nearly_singular_w():
    """Newton on q' = 0 stops once its step is at the rounding of q'/q'' (issue #14: a fixed 1e-15 lay
    below it on a nearly singular W, so all 60 rounds ran on every call, and a ring with one minimum
    walked its unused second slot in clamped steps): the minima are still stationary to rounding,
    with q'' > 0, and agree with the scalar search."""
    W = np.array([[0.40738481, 0.43425876, 0.22864059], [0.43425876, 0.46427383, 0.24358853],
                  [0.22864059, 0.24358853, 0.12834136]])  # the local W of the hang, eigenvalues 5e-6 … 1
    alpha = np.linspace(0.001, 1.45, 400)
    phi, eps = ring_minima_many(alpha, W)
    q0, a1, b1, a2, b2 = (x[:, None] for x in ring_quadratic_form(np.sin(alpha), np.cos(alpha), W))
    dq = -a1 * np.sin(phi) + b1 * np.cos(phi) - 2 * a2 * np.sin(2 * phi) + 2 * b2 * np.cos(2 * phi)
    d2q = -a1 * np.cos(phi) - b1 * np.sin(phi) - 4 * a2 * np.cos(2 * phi) - 4 * b2 * np.sin(2 * phi)
    found = np.isfinite(phi)
    assert found[:, 0].all() and not found[:, 1].all()  # rings with one minimum and with two
    scale = np.abs(a1) + np.abs(b1) + 2 * np.abs(a2) + 2 * np.abs(b2)
    assert np.all(np.abs(dq[found]) <= 64 * np.finfo(float).eps * np.broadcast_to(scale, dq.shape)[found])
    assert np.all(d2q[found] > 0) and np.all(eps[found] > 0)
    for a, p in zip(alpha[::37], phi[::37]):
        ref, _ = ring_minima(a, W)
        got = p[np.isfinite(p)]
        assert len(got) == len(ref)
        assert np.abs(np.angle(np.exp(1j * (np.sort(got) - np.sort(ref))))).max() < 1e-9


@pytest.mark.parametrize("width", [1e-1, 1e-4, 1e-8])
@pytest.mark.parametrize("centre", [0.05, 0.3, 0.6, 1.2])
def test_graded_tilt_rule_resolves_a_narrow_peak(width, centre):
    """∫ ε / ((α − c)² + ε²) dα over [0, 1], a Lorentzian at a hinted tilt (also at α* = 0.3 and
    outside), to 1e-13 with 64 nodes per half-piece — 1e-10 for ε = 1e-8, where the rounding of α
    itself (1e-16 beside ε) limits; and (α − α*)^{3/2} above α* to rounding."""
    tilt, dtilt = graded_tilt_rule(0.0, 1.0, np.array([0.3]), (np.array([centre]), np.array([width])), 64)
    exact = math.atan2(width, width**2 + (1.0 - centre) * (0.0 - centre))  # atan((1−c)/ε) − atan(−c/ε)
    got = float(dtilt[0] @ (width / ((tilt[0] - centre) ** 2 + width**2)))
    assert got == pytest.approx(exact, rel=1e-10 if width < 1e-6 else 1e-13)
    assert dtilt.sum() == pytest.approx(1.0, rel=1e-14)
    onset = np.where(tilt > 0.3, np.abs(tilt - 0.3) ** 1.5, 0.0)[0]
    assert dtilt[0] @ onset == pytest.approx(0.7**2.5 / 2.5, rel=1e-13)
    assert np.all((tilt >= 0.0) & (tilt <= 1.0))


def test_peak_tilts_of_a_rank_one_delassus_matrix():
    """W = λ e eᵀ + δ I: a valley e ⊥ m, whose highest point has tilt asin|e_z|; it meets the
    boundary of G* at m ∥ u × e."""
    e = np.array([0.6, 0.0, 0.8])
    W = np.outer(e, e) + 1e-8 * np.eye(3)
    u = np.array([0.3, 0.4, -0.866])
    tilt, eps = peak_tilts(W, u[None], 0.15)
    assert tilt[0, 1] == pytest.approx(math.asin(0.8), rel=1e-12)
    p = np.cross(u, e)
    assert tilt[0, 2] == pytest.approx(math.acos(abs(p[2]) / np.linalg.norm(p)), rel=1e-12)
    np.testing.assert_allclose(eps[0, 1:], 1e-4, rtol=1e-6)  # sqrt(δ / λ)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-9.0, 0.0), st.floats(0.0, 1.0), st.booleans())
def test_peak_width_bound_is_below_the_widths_it_screens(seed, log_small, mid, aligned):
    """sqrt(λ₁/λ₃) bounds the widths of peak_tilts from below (the two u-independent ones above all), for
    eigenvalues from equal to 1e9 apart, in any axes and in the world's own (``aligned``: W's eigenvectors
    along the axes, n⁰ among them); so that IsotropicSlopes.graded_rule, which rules a W out by it first,
    decides as peak_tilts alone would."""
    rng = np.random.default_rng(seed)
    Q = np.eye(3)[rng.permutation(3)] if aligned else np.linalg.qr(rng.normal(size=(3, 3)))[0]
    small = 10.0**log_small
    W = (Q * [small, small + mid * (1.0 - small), 1.0]) @ Q.T * rng.uniform(1e-3, 1e3)
    W = (W + W.T) / 2
    widths = peak_tilts(W, np.array([[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]]), math.inf)[1]
    eps = widths[0, :2]
    bound = peak_width_bound(W)
    assert bound <= widths.min()  # the u-dependent width (the valley meeting G*'s boundary) too
    assert bound >= 0.99 * math.sqrt(small) - 1e-3  # the bound is not vacuous
    slopes = mbi.GaussianSlopes(0.3)
    for peaked in (0.05, 0.15, 0.3):
        assert (slopes.graded_rule(W, peaked) is None) == (not (eps < peaked).any())


@pytest.mark.parametrize("diagonal", [(1.0, 2.0, 3.0), (1.0, 1.0, 1.0), (20.0, 1.0, 0.5), (0.04, 1.0, 2.0)])
def test_the_valley_of_a_w_whose_stiffest_axis_is_the_normal_is_the_horizon(diagonal):
    """w₃ = n⁰: the valley w₃ᵀm = 0 is the horizon, every point of it at tilt π/2, the softest one w₁ with
    the width sqrt(λ₁/λ₃) (not width 0: peak_tilts once normalised the zero vector ez − w₃ᵀez w₃)."""
    W = np.diag(diagonal)
    lam = np.sort(np.asarray(diagonal))
    tilt, eps = peak_tilts(W, np.array([[0.3, 0.1, -1.0], [0.0, 0.0, -1.0]]), math.inf)
    assert np.all(eps >= peak_width_bound(W))  # every width, the one where the valley meets G*'s boundary too
    if diagonal[2] > max(diagonal[:2]):  # the stiffest axis is n⁰ itself
        np.testing.assert_allclose(eps[:, 1], math.sqrt(lam[0] / lam[2]), rtol=1e-14)
        np.testing.assert_allclose(tilt[:, 1], math.pi / 2, atol=1e-15)
        # u ∥ w₃: G*'s boundary is the valley, met everywhere; graded towards its highest point
        assert (tilt[1, 2], eps[1, 2]) == (tilt[1, 1], eps[1, 1])


def test_a_foot_on_the_ground_is_ruled_out_by_the_bound_alone(monkeypatch):
    """Solo12's foot on the ground (W's eigenvalues 30× apart): no peak narrower than Graded.peaked, and
    the closed-form bound says so without peak_tilts (150 µs in numpy)."""
    mech = mbi.Mechanism.from_robot("solo12")
    q = mech.neutral()
    q[2] = 0.336
    J = mech.point_jacobian(q, "FL_FOOT")
    W = J @ np.linalg.solve(mech.mass_matrix(q), J.T)
    eps = peak_tilts(W, np.array([[0.0, 0.0, -1.0]]), math.inf)[1][0, :2]
    assert peak_width_bound(W) >= mbi.averaging.Graded.peaked
    assert eps.min() >= mbi.averaging.Graded.peaked
    monkeypatch.setattr("mbimpact.roughness.slopes.peak_tilts", None)  # not called
    assert mbi.GaussianSlopes(0.3).graded_rule(W, mbi.averaging.Graded.peaked) is None


def planar_slopes_reference(measure, e, W, u, flux="physical"):
    """(2.8) for a planar tilt density by scipy.quad on each side, told where the kernels peak."""
    lo, hi = measure.support
    vec = np.linalg.eigh(W)[1]
    w1 = vec[:, 0] if vec[1, 0] >= 0 else -vec[:, 0]
    points = [p for p in (abs(math.atan2(w1[0], w1[1])), math.atan2(abs(u[1]), abs(u[0]))) if lo < p < hi]
    total = np.zeros(3)
    for side in (-1.0, 1.0):
        def kernel(a, j, side=side):
            m = np.array([side * math.sin(a), math.cos(a)])
            su, q = m @ u, m @ W @ m
            if su >= 0:
                return 0.0
            g = math.sqrt(q) if flux == "configuration" else 1.0  # the configuration weight divides by √q
            return (su * su * m[j] / (q * g) if j < 2 else -su / g) * measure.density(np.array([a]))[0]

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", integrate.IntegrationWarning)  # roundoff near 1e-9: cond(W) = 1e8
            total += [integrate.quad(kernel, lo, hi, args=(j,), points=points, limit=500, epsabs=0,
                                     epsrel=1e-13)[0] for j in range(3)]
    return (1 + e) * total[:2] / total[2]


@pytest.mark.parametrize("flux", ["physical", "configuration"])
@pytest.mark.parametrize("theta", [1.0, -1.0, 2.5])
@pytest.mark.parametrize("u", [[0.5, -1.0], [-0.3, -1.0]])
def test_planar_gaussian_slopes_with_a_nearly_singular_delassus_matrix(theta, u, flux):
    """W = R diag(1e-8, 1) Rᵀ: 1/mᵀWm peaks (width 1e-4) at the tilt of the least eigenvector."""
    R = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    W = R @ np.diag([1e-8, 1.0]) @ R.T
    u = np.array(u) / np.linalg.norm(u)
    measure = mbi.GaussianSlopes(0.3, dim=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)  # rounding, amplified by cond(W) = 1e8: it says so
        P = impulses(mbi.RoughLaw(measure, 0.5, flux=flux), W, u[None])[0]
    ref = planar_slopes_reference(measure, 0.5, W, u, flux)
    # the rule converges geometrically; what is left is rounding amplified by |W||P|/|WP| ~ 1e6
    assert w_error(P[0], ref, W) < 1e-7
    plain = rule_average(mbi.RoughLaw(measure, 0.5, flux=flux).spec, W, u[None], (256,))[0][0][0]
    assert w_error(plain, ref, W) > 1e3 * w_error(P[0], ref, W)


def test_a_product_rule_of_millions_of_facets_does_not_drift_with_rounding():
    """cond(W) = 1.3e8: 256 nodes a piece put 4·10⁶ facets on the row. Summed pairwise, the result
    stays where 64 nodes put it; summed naively it drifted by 1e-7 (rounding × |W||P|/|WP|)."""
    rng = np.random.default_rng(28)
    W = spd(rng, 3, 10 ** rng.uniform(3, 9))
    measure = mbi.GaussianSlopes(rng.uniform(0.05, 0.8))
    u = rng.normal(size=3)
    u[2] = -abs(u[2]) - 0.01
    u /= np.linalg.norm(u)
    P64, P256 = (impulses(mbi.RoughLaw(measure, 0.5, nodes=n), W, u[None])[0][0] for n in (64, 256))
    assert w_error(P256, P64, W) < 1e-10


def _graded_slopes_case(seed: int) -> None:
    """Random W with cond 1e3…1e9, random σ and incidence: finite, no energy gained, and an error
    estimate that a rule with twice the nodes confirms (or an AccuracyWarning that says it was not met)."""
    rng = np.random.default_rng(seed)
    W = spd(rng, 3, 10 ** rng.uniform(3, 9))
    measure = mbi.GaussianSlopes(rng.uniform(0.05, 0.8))
    u = rng.normal(size=3)
    u[2] = -abs(u[2]) - 0.01
    u /= np.linalg.norm(u)
    law = mbi.RoughLaw(measure, 0.5)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", mbi.AccuracyWarning)
        P, est, nodes = impulses(law, W, u[None])
    assert np.all(np.isfinite(P)) and (not caught or est[0] > law.rtol)
    assert -0.5 * P[0] @ (2 * u + W @ P[0]) >= -1e-12  # energy lost, in contact space (unit u)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)
        finer = impulses(mbi.RoughLaw(measure, 0.5, nodes=min(2 * nodes, 256)), W, u[None])[0]
    assert w_error(P[0], finer[0], W) <= 10 * est[0] + 1e-9


@settings(max_examples=4, deadline=None)  # 10–500 ms each
@given(st.integers(0, 2**32 - 1))
def test_graded_slopes_on_random_nearly_singular_w(seed):
    _graded_slopes_case(seed)


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_graded_slopes_on_random_nearly_singular_w_nightly(seed):
    """The same over 300 cases: ``pytest -m slow``."""
    _graded_slopes_case(seed)


def test_accuracy_warning_points_at_the_callers_line():
    """Whatever the entry point (impact, apply, apply_batch), the warning names the user's line."""
    mech, J, A = upright_ur5()
    v = np.linalg.lstsq(J, [0.2, 0.1, -1.0], rcond=None)[0]
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5, method="adaptive", max_nodes=64)  # plain, too few nodes for this contact
    calls = [lambda: mbi.impact(mech, UPRIGHT, v, mbi.PointContact("tool0"), law),
             lambda: law.apply(A, J, v, [0, 0, 1]),
             lambda: law.apply_batch(A, J, np.array([v, 2 * v]), [0, 0, 1])]
    for call in calls:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", mbi.AccuracyWarning)
            call()
        assert caught and all(w.filename == __file__ for w in caught)


def test_ring_coefficients_reproduce_the_quadratic_form(rng):
    W = spd(rng, 3, 50.0)
    alpha, phi = 0.7, rng.uniform(0, 2 * math.pi, 9)
    q0, a1, b1, a2, b2 = ring_quadratic_form(math.sin(alpha), math.cos(alpha), W)
    m = np.column_stack([math.sin(alpha) * np.cos(phi), math.sin(alpha) * np.sin(phi), np.full(9, math.cos(alpha))])
    q = q0 + a1 * np.cos(phi) + b1 * np.sin(phi) + a2 * np.cos(2 * phi) + b2 * np.sin(2 * phi)
    np.testing.assert_allclose(q, np.einsum("ki,ij,kj->k", m, W, m), rtol=1e-13)

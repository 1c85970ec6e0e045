"""Graded azimuth quadrature for nearly singular Delassus matrices (arms near singular postures)."""

import functools
import math
import warnings

import numpy as np
import pytest
from scipy import integrate

import mbimpact as mbi
from mbimpact.quadrature import graded_azimuth_rule, ring_minima

from conftest import UPRIGHT_UR5 as UPRIGHT
from conftest import mechanism


def upright_ur5():
    mech = mechanism("ur5")
    J = mech.point_jacobian(UPRIGHT, "tool0")
    return mech, J, mech.mass_matrix(UPRIGHT)


def reference(alpha, e, W, u, flux="metric"):
    """(2.8) by adaptive scipy.quad, told where the kernels peak."""
    s, c = math.sin(alpha), math.cos(alpha)
    gamma, delta = (1.5, 0.5) if flux == "metric" else (1.0, 0.0)

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
        P, est, nodes = mbi.RoughLaw(mbi.Cone(alpha), 0.5).contact_impulses(W, u[None])
    ref = reference(alpha, 0.5, W, u)  # scipy itself reports roundoff near 1e-11 here
    assert np.linalg.norm((P[0] - ref) @ W) < 1e-9 * np.linalg.norm(ref @ W)
    assert nodes <= 128
    # the estimate is honest against the same graded rule with 8× more nodes (rounding scatter ~1e-11)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5)
    fine = law._average(W, u[None], 1024, functools.partial(graded_azimuth_rule, alpha, ring_minima(alpha, W)))[0][0]
    assert np.linalg.norm((P[0] - fine) @ W) <= (10 * est[0] + 1e-11) * np.linalg.norm(fine @ W)
    # the whole pipeline on the robot stays sound there
    v = np.linalg.lstsq(J, u, rcond=None)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)
        res = mbi.impact(mech, UPRIGHT, v, mbi.PointContact("tool0"), mbi.RoughLaw(mbi.Cone(alpha), 0.5))
    assert res.energy_loss >= 0 and res.error_estimate < 1e-9


def test_uniform_rule_needs_far_more_nodes_there():
    """What the grading buys: 20 000 plain nodes are still off by ~1e-6."""
    mech, J, A = upright_ur5()
    metric = mbi.ContactMetric.from_arrays(A, J)
    W = metric.W
    u = np.array([0.2, 0.1, -1.0]) / np.linalg.norm([0.2, 0.1, -1.0])
    ref = reference(0.3, 0.5, W, u)
    phi = 2 * math.pi * np.arange(20_000) / 20_000  # the whole cone faces u: the periodic trapezoid rule
    ring = mbi.Facets(np.column_stack([math.sin(0.3) * np.cos(phi), math.sin(0.3) * np.sin(phi),
                                       np.full(phi.size, math.cos(0.3))]))
    plain, _, _ = mbi.RoughLaw(ring, 0.5).contact_impulses(W, u[None])
    assert np.linalg.norm((plain[0] - ref) @ W) > 1e-7 * np.linalg.norm(ref @ W)
    graded, _, _ = mbi.RoughLaw(mbi.Cone(0.3), 0.5, nodes=64).contact_impulses(W, u[None])
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

"""Compliant facets: Kelvin–Voigt normal force, tangential spring, Coulomb slip, resolved in time."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.facets import CompliantFacet, compliant_impulses

SPHERE = np.array([[3.5, 0.0], [0.0, 1.0]])  # contact-space W of a solid sphere, unit mass: W_tt/W_nn = 7/2


def incidences(degrees: np.ndarray) -> np.ndarray:
    t = np.radians(degrees)
    return np.column_stack([np.sin(t), -np.cos(t)])


def facet_impulses(facet: CompliantFacet, W: np.ndarray, U: np.ndarray) -> np.ndarray:
    return facet.facet_impulse(np.broadcast_to(W, (len(U),) + W.shape).copy(), U)


def random_problems(rng: np.random.Generator, d: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    A = rng.normal(size=(n, d, d))
    W = A @ np.swapaxes(A, 1, 2) + 0.3 * np.eye(d)
    U = rng.normal(size=(n, d))
    U[:, -1] = -np.abs(U[:, -1]) - 0.1
    return W, U


def test_frictionless_compliant_facet_is_newtons(rng: np.random.Generator) -> None:
    """μ = 0: the Kelvin–Voigt impact alone, (2.5): P = −(1+e) u_n / W_nn along the facet normal."""
    for d in (2, 3):
        W, U = random_problems(rng, d, 12)
        P = CompliantFacet(0.7, 0.0, 0.8).facet_impulse(W, U)
        assert np.allclose(P[:, :-1], 0.0)
        assert np.allclose(P[:, -1], -1.7 * U[:, -1] / W[:, -1, -1], rtol=1e-5)  # RK4, 48 steps a period


@pytest.mark.parametrize("omega", [1, 2, 3])
def test_sticking_throughout_is_a_tangential_oscillation(omega: int) -> None:
    """Elastic normal (e = 1: the contact lasts τ_c = π) and no slip: u_t oscillates at
    ω_t = √(κ_t W_tt/W_nn), so u_t⁺/u_t⁻ = cos(π ω_t). With ω_t an integer the spring is
    relaxed when the contact ends, so sticking holds to the end for a finite μ: on a sphere
    κ_t = 2/7 reverses the contact point's velocity completely, κ_t = 8/7 gives it back."""
    kappa_t = omega**2 / 3.5
    U = incidences(np.array([1.0, 10.0, 30.0]))
    P = facet_impulses(CompliantFacet(1.0, 20.0, kappa_t), SPHERE, U)
    ratio = (U[:, 0] + 3.5 * P[:, 0]) / U[:, 0]
    assert np.allclose(ratio, math.cos(math.pi * omega), atol=1e-6)
    assert np.allclose(-(U[:, 1] + P[:, 1]) / U[:, 1], 1.0, atol=1e-6)


def test_sphere_reversal_and_dip_below_rigid_rolling() -> None:
    """Maw–Barber–Fawcett behaviour of an elastic sphere (W_tt/W_nn = 7/2, Mindlin-like κ_t = 0.8, μ = 0.1):
    the contact point's tangential velocity reverses at small incidence, the centre's tangential
    restitution dips below the rigid rolling value 5/7 and tends to rigid sliding at large incidence."""
    e, mu = 0.98, 0.1
    deg = np.array([2.0, 8.0, 12.0, 16.0, 20.0, 25.0, 60.0, 70.0, 80.0])
    U = incidences(deg)
    P = facet_impulses(CompliantFacet(e, mu, 0.8), SPHERE, U)
    et_com = 1.0 + P[:, 0] / U[:, 0]  # unit mass, no spin before: Δv_t = P_t
    et_cp = (U[:, 0] + 3.5 * P[:, 0]) / U[:, 0]
    small = deg < 30
    assert et_cp[small].min() < -0.3  # reversal of the contact point
    assert et_com[small].min() < 5 / 7 - 0.08  # the dip below rolling
    assert et_com[0] > 5 / 7  # near normal incidence the tangential spring gives back energy
    big = deg >= 60
    rigid_slide = 1.0 - mu * (1.0 + e) / np.tan(np.radians(deg[big]))
    assert np.allclose(et_com[big], rigid_slide, atol=3e-3)
    # with κ_t = 2/7 the reversal is complete at normal incidence (cos π = −1), up to damping and slip
    u1 = incidences(np.array([1.0]))
    P = facet_impulses(CompliantFacet(e, mu, 2 / 7), SPHERE, u1)
    assert (u1[0, 0] + 3.5 * P[0, 0]) / u1[0, 0] < -0.99


def _physical_reference(W: np.ndarray, u: np.ndarray, e: float, mu: float, kappa_t: float, M: float,
                        steps_per_period: int = 6000) -> np.ndarray:
    """An independent integration in physical time t: symplectic Euler on u̇ = W F with
    F_n = −(M²/W_nn) δ_n − (2kM/W_nn) δ̇_n and a tangential spring K_t = κ_t M²/W_nn with Coulomb slip."""
    k = mbi.k_from_e(e)
    Wnn = W[:, -1, -1]
    Kn, Cn, Kt = M**2 / Wnn, 2 * k * M / Wnn, kappa_t * M**2 / Wnn
    omega = M * math.sqrt(max(3.5 * kappa_t, 1.0)) * 1.2
    dt = 2 * math.pi / omega / steps_per_period
    u = u.copy()
    dn = np.zeros(len(u))
    xi = np.zeros((len(u), u.shape[1] - 1))
    P = np.zeros_like(u)
    done = np.zeros(len(u), dtype=bool)
    out = np.zeros_like(u)
    for step in range(50 * steps_per_period):
        Fn = -Kn * dn - Cn * u[:, -1]
        Ft = -Kt[:, None] * xi
        bound = mu * np.maximum(Fn, 0.0)
        size = np.linalg.norm(Ft, axis=1)
        over = size > bound
        Ft[over] *= (bound[over] / size[over])[:, None]
        F = np.column_stack([Ft, Fn])
        u = u + dt * np.einsum("nij,nj->ni", W, F)
        P = P + dt * F
        dn = dn + dt * u[:, -1]
        xi = xi + dt * u[:, :-1]
        size = np.linalg.norm(Kt[:, None] * xi, axis=1)
        Fn1 = -Kn * dn - Cn * u[:, -1]
        bound = mu * np.maximum(Fn1, 0.0)
        over = size > bound
        xi[over] *= (bound[over] / size[over])[:, None]
        ended = (dn >= 0.0) & ~done & (step > 0)
        out[ended], done = P[ended], done | ended
        if done.all():
            return out
    raise AssertionError("reference integration did not end")


def test_independent_of_the_stiffness_M(rng: np.random.Generator) -> None:
    """The impulse does not depend on M (scale invariance, as (2.5)): an independent physical-time
    integration at M = 30 and M = 3000 gives the facet law's dimensionless result."""
    W = np.broadcast_to(SPHERE, (4, 2, 2)).copy()
    W[2] = [[2.0, 0.4], [0.4, 1.3]]
    U = incidences(np.array([5.0, 15.0, 30.0, 60.0]))
    facet = CompliantFacet(0.8, 0.15, 0.8)
    P = facet.facet_impulse(W, U)
    refs = [_physical_reference(W, U, 0.8, 0.15, 0.8, M) for M in (30.0, 3000.0)]
    assert np.allclose(refs[0], refs[1], rtol=1e-9, atol=1e-12)  # the reference itself is M-free
    assert np.abs(refs[0] - P).max() < 2e-3 * np.abs(P).max()  # first-order reference, 6000 steps a period
    # the resolved history scales as t ~ 1/M and F ~ M, the impulse not at all
    h1, h2 = facet.history(W[0], U[0], 1.0), facet.history(W[0], U[0], 1e4)
    assert np.allclose(h1.t, 1e4 * h2.t) and np.allclose(h1.force, h2.force / 1e4) and np.allclose(h1.P, h2.P)
    assert np.allclose(np.trapezoid(h1.force, h1.t, axis=0), h1.P, rtol=0.05)


def test_integrator_converges(rng: np.random.Generator) -> None:
    """Errors fall with the resolution, against a 10× finer solution; the default (48) is within
    the documented accuracy: 1e-5 on planar facets, 1e-3 on spatial ones (first order where the
    slip turns the spring)."""
    k = mbi.k_from_e(0.6)
    for d, tol in ((2, 1e-5), (3, 1e-3)):
        W, U = random_problems(rng, d, 10)
        ref = compliant_impulses(W, U, k, 0.3, 0.8, 480)
        scale = np.abs(ref).max()
        err = [np.abs(compliant_impulses(W, U, k, 0.3, 0.8, n) - ref).max() / scale for n in (12, 24, 48, 96)]
        assert err[3] < err[1] and err[2] < err[0]
        assert err[0] / err[3] > 5  # at least first order (8 over three doublings), up to noise
        assert err[2] < tol


def test_homogeneous_planar_in_space_and_passive(rng: np.random.Generator) -> None:
    facet = CompliantFacet(0.6, 0.3, 0.8)
    W, U = random_problems(rng, 2, 10)
    P = facet.facet_impulse(W, U)
    # degree 1 in u, −1 in W (the regime tests are scale-free; rounding can tip a borderline one)
    assert np.allclose(facet.facet_impulse(W, 7.3 * U), 7.3 * P, rtol=1e-8)
    assert np.allclose(facet.facet_impulse(2.5 * W, U), P / 2.5, rtol=1e-8)
    # the sphere in space, incidence in the x-z plane: the planar result with no sideways impulse
    # (to the spatial integrator's accuracy: its slipping steps are substepped differently)
    W3 = np.diag([3.5, 3.5, 1.0])
    U2 = incidences(np.array([3.0, 20.0, 50.0]))
    U3 = np.column_stack([U2[:, 0], np.zeros(3), U2[:, 1]])
    P2 = facet_impulses(facet, SPHERE, U2)
    P3 = facet_impulses(facet, W3, U3)
    assert np.allclose(P3[:, [0, 2]], P2, rtol=5e-4) and np.allclose(P3[:, 1], 0.0, atol=1e-14)
    # the kinetic energy never grows: −Pᵀ(u₋ + u₊)/2 ≥ 0 with u₊ = u₋ + W P
    for d in (2, 3):
        W, U = random_problems(rng, d, 30)
        P = facet.facet_impulse(W, U)
        Up = U + np.einsum("nij,nj->ni", W, P)
        assert np.all(-0.5 * np.einsum("nd,nd->n", P, U + Up) >= -1e-9)

"""Coulomb facets: the planar closed form, the spatial steps, and their averages."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.facets import CoulombFacet, NewtonFacet, planar_coulomb, spatial_coulomb

RESTITUTIONS = ("energetic", "poisson", "newton")


def random_problem(rng: np.random.Generator, d: int) -> tuple[np.ndarray, np.ndarray]:
    Q, _ = np.linalg.qr(rng.normal(size=(d, d)))
    W = (Q * rng.uniform(0.1, 3.0, d)) @ Q.T
    u = rng.normal(size=d)
    u[-1] = -abs(u[-1]) - 0.05
    return W, u


def rel(P: np.ndarray, ref: np.ndarray, W: np.ndarray) -> float:
    return float(np.linalg.norm((P - ref) @ W) / np.linalg.norm(ref @ W))


@pytest.mark.parametrize("restitution", RESTITUTIONS)
def test_planar_closed_form_matches_the_coulomb_law(restitution: Any, rng: np.random.Generator) -> None:
    """Slip, stop, stick, reversal, all three hypotheses: the closed form equals CoulombLaw's integration."""
    for _ in range(40):
        W, u = random_problem(rng, 2)
        mu, e = rng.uniform(0.0, 1.5), rng.uniform(0.0, 1.0)
        ref = mbi.CoulombLaw(e, mu, restitution, rtol=1e-12).contact_impulses(W, u[None]).P[0]
        P = planar_coulomb(W[None], u[None], mu, e, restitution)[0]
        assert rel(P, ref, W) < 1e-9


def test_planar_sphere_closed_forms() -> None:
    """A solid sphere (W = diag(7/2, 1)): rolling gives e_t = 5/7, sliding 1 − μ(1+e) cot θ, κ = e always."""
    W = np.array([[3.5, 0.0], [0.0, 1.0]])
    e, mu = 0.8, 0.2
    theta = np.radians(np.linspace(2.0, 85.0, 30))
    U = np.column_stack([np.sin(theta), -np.cos(theta)])
    P = planar_coulomb(np.broadcast_to(W, (30, 2, 2)), U, mu, e)
    kappa = -(U[:, 1] + P[:, 1]) / U[:, 1]
    et = 1.0 + P[:, 0] / U[:, 0]  # unit mass: Δv_t = P_t
    slides = np.tan(theta) > (7 / 2) * mu * (1 + e)  # the slip does not stop before the end
    assert np.allclose(kappa, e, rtol=1e-13)
    assert np.allclose(et[~slides], 5 / 7, rtol=1e-12)
    assert np.allclose(et[slides], 1 - mu * (1 + e) / np.tan(theta[slides]), rtol=1e-12)


@pytest.mark.parametrize("restitution", RESTITUTIONS)
def test_spatial_steps_reduce_to_the_planar_closed_form(restitution: Any, rng: np.random.Generator) -> None:
    """A spatial facet whose slip stays on one line (W_tt ∝ I, W_tn ∥ u_t) is a planar one."""
    for _ in range(8):
        a, c = rng.uniform(0.3, 3.0, 2)
        b = rng.uniform(-0.6, 0.6) * math.sqrt(a * c)
        phi = rng.uniform(0, 2 * math.pi)
        t = np.array([math.cos(phi), math.sin(phi)])
        W3 = np.eye(3) * a
        W3[2, 2] = c
        W3[:2, 2] = W3[2, :2] = b * t
        ut, un = rng.normal(), -rng.uniform(0.1, 2.0)
        mu, e = rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0)
        P2 = planar_coulomb(np.array([[[a, b], [b, c]]]), np.array([[ut, un]]), mu, e, restitution)[0]
        P3 = spatial_coulomb(W3[None], np.array([[ut * t[0], ut * t[1], un]]), mu, e, restitution, 100)[0]
        ref = np.array([P2[0] * t[0], P2[0] * t[1], P2[1]])
        assert rel(P3, ref, W3) < 2e-3


def test_spatial_steps_converge_to_the_coulomb_law(rng: np.random.Generator) -> None:
    """Anisotropic W: the slip direction curves; the steps converge to CoulombLaw's integration
    (second order while slipping) and are within 1e-3 at the default 100 steps."""
    problems = [random_problem(rng, 3) for _ in range(20)]
    W = np.array([p[0] for p in problems])
    U = np.array([p[1] for p in problems])
    mu, e = 0.3, 0.6
    ref = np.array([mbi.CoulombLaw(e, mu, rtol=1e-12).contact_impulses(w, u[None]).P[0] for w, u in problems])
    errors = []
    for steps in (25, 100, 400):
        P = spatial_coulomb(W, U, mu, e, "energetic", steps)
        errors.append(max(rel(P[i], ref[i], W[i]) for i in range(len(W))))
    assert errors[1] < 1e-3
    assert errors[2] < errors[1] < errors[0]
    assert errors[2] < errors[0] / 4  # at least first order overall (second order without reversal)


def test_frictionless_coulomb_facets_are_newton_facets(rng: np.random.Generator) -> None:
    for d, rough in ((2, mbi.GaussianSlopes(0.3, dim=2)), (3, mbi.Cone(0.35))):
        W, _ = random_problem(rng, d)
        U = rng.normal(size=(6, d))
        U[:, -1] = -np.abs(U[:, -1]) - 0.3
        U /= np.linalg.norm(U, axis=1)[:, None]
        newton = mbi.RoughLaw(rough, facet=NewtonFacet(0.7), method="fixed", nodes=16).contact_impulses(W, U)
        for restitution in (RESTITUTIONS if d == 2 else ("energetic",)):
            facet = CoulombFacet(0.7, 0.0, restitution)  # type: ignore[arg-type]
            coulomb = mbi.RoughLaw(rough, facet=facet, method="fixed", nodes=16).contact_impulses(W, U)
            assert np.allclose(coulomb.P, newton.P, rtol=1e-9, atol=1e-12)
            assert coulomb.method == "fixed[coulomb]"


def test_one_coulomb_facet_is_coulombs_law() -> None:
    """A smooth surface has one facet, the base: the rough law of Coulomb facets is Coulomb's law,
    on a mechanism given by its arrays (a planar rod: W couples the directions)."""
    A = np.array([[2.0, 0.3, 0.1], [0.3, 1.0, 0.2], [0.1, 0.2, 0.5]])
    J = np.array([[1.0, 0.0, -0.7], [0.0, 1.0, 0.4]])
    V = np.array([[math.sin(t), -math.cos(t), 0.5] for t in np.radians([5.0, 25.0, 45.0, 70.0])])
    for mu in (0.05, 0.3, 1.0):
        law = mbi.RoughLaw(mbi.Smooth(), facet=CoulombFacet(0.6, mu))
        ref = mbi.CoulombLaw(0.6, mu, rtol=1e-12).apply_batch(A, J, V, [0.0, 1.0])
        out = law.apply_batch(A, J, V, [0.0, 1.0])
        assert np.allclose(out.V_plus, ref.V_plus, rtol=1e-9, atol=1e-12)
        assert out.method == "exact[coulomb]"
        assert np.all(out.energy_loss >= -1e-12)  # energetic restitution never creates energy

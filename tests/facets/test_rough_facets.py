"""Facet laws inside the rough law (2.8): through mbi.impact, batches, averages and energy."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.facets import CompliantFacet, CoulombFacet, FacetLaw, HuntCrossleyFacet, NewtonFacet
from mbimpact.calibration import Ball


def test_pinocchio_sphere_equals_the_sphere_arrays() -> None:
    """The shipped floating sphere through mbi.impact (Pinocchio's A and J) and the calibration body's
    arrays (A = diag(m, m, m, I, I, I), J = [I, −[r]ₓ]) give the same impact, for every facet law."""
    mech = mbi.Mechanism.from_urdf(mbi.model_path("sphere"), floating=True)
    contact = mbi.PointContact("bottom", normal=np.array([0.0, 0.0, 1.0]), tangent=np.array([1.0, 0.0, 0.0]))
    q = mech.neutral()
    A, J = Ball(radius=0.05, mass=1.0).arrays(3)
    v = np.array([0.6, -0.2, -1.0, 0.0, 3.0, 1.0])
    for facet in (NewtonFacet(0.7), CoulombFacet(0.7, 0.3), CompliantFacet(0.7, 0.3, 0.8), HuntCrossleyFacet(0.1)):
        law = mbi.RoughLaw(mbi.Cone(0.2), facet=facet, nodes=16)
        res = mbi.impact(mech, q, v, contact, law)
        ref = law.apply(A, J, v, [0.0, 0.0, 1.0])
        assert np.allclose(res.v_plus, ref.v_plus, rtol=1e-9, atol=1e-12)
        assert res.law.facet == facet
        assert res.method == ("fixed" if isinstance(facet, NewtonFacet) else f"fixed[{facet.name}]")
        assert res.energy_loss >= -1e-12


def test_exact_and_monte_carlo_agree_for_any_facet_law() -> None:
    """A sampled sawtooth averages to the exact two-facet sum (the weights (2.7) are the same)."""
    W = np.array([[2.0, 0.3], [0.3, 1.0]])
    U = np.array([[math.sin(t), -math.cos(t)] for t in (0.1, 0.5, 0.9)])
    for facet in (CoulombFacet(0.6, 0.4), CompliantFacet(0.6, 0.4, 0.8)):
        exact = mbi.RoughLaw(mbi.Sawtooth(0.35), facet=facet).contact_impulses(W, U)
        mc = mbi.RoughLaw(mbi.Sawtooth(0.35), facet=facet, method="monte-carlo", samples=4000,
                          seed=3).contact_impulses(W, U)
        assert exact.method == f"exact[{facet.name}]" and mc.method == f"monte-carlo[{facet.name}]"
        err = np.linalg.norm(mc.P - exact.P, axis=1) / np.linalg.norm(exact.P, axis=1)
        assert np.all(err < 4 * mc.error + 1e-12)  # within four standard errors


def test_adaptive_average_converges_to_a_fine_rule() -> None:
    W = np.array([[3.5, 0.0], [0.0, 1.0]])
    U = np.array([[math.sin(t), -math.cos(t)] for t in np.radians([10.0, 40.0, 70.0])])
    rough = mbi.GaussianSlopes(0.2, dim=2)
    for facet in (CoulombFacet(0.8, 0.2), CompliantFacet(0.8, 0.2, 0.8)):
        adaptive = mbi.RoughLaw(rough, facet=facet).contact_impulses(W, U)
        fine = mbi.RoughLaw(rough, facet=facet, nodes=256).contact_impulses(W, U)
        assert adaptive.method == f"adaptive[{facet.name}]"
        assert np.allclose(adaptive.P, fine.P, rtol=5e-4)


@pytest.mark.parametrize("facet", [CoulombFacet(0.5, 0.6), CoulombFacet(0.5, 0.6, "poisson"),
                                   CompliantFacet(0.5, 0.6, 0.5), HuntCrossleyFacet(0.3)])
def test_the_average_never_creates_energy(facet: FacetLaw, rng: np.random.Generator) -> None:
    """Each dissipative facet impact loses energy, and averaging loses more (T is convex in P)."""
    for d, rough in ((2, mbi.GaussianSlopes(0.4, dim=2)), (3, mbi.Cone(0.4))):
        Q, _ = np.linalg.qr(rng.normal(size=(d, d)))
        W = (Q * rng.uniform(0.2, 2.0, d)) @ Q.T
        A = np.linalg.inv(W)  # J = I: W is the inverse mass matrix
        V = rng.normal(size=(4, d))
        V[:, -1] = -np.abs(V[:, -1]) - 0.2
        out = mbi.RoughLaw(rough, facet=facet, nodes=12, repeat=True).apply_batch(A, np.eye(d), V, np.eye(d)[-1])
        assert np.all(out.energy_loss >= -1e-10 * np.einsum("bd,de,be->b", V, A, V))
        assert np.all(out.separates)


def test_rough_coulomb_facets_give_friction_frictionless_ones_little(rng: np.random.Generator) -> None:
    """On a sphere (W_tt/W_nn = 7/2) gently rough facets (σ = 0.05) without friction give almost no
    impulse ratio; Coulomb facets give about their μ while sliding."""
    A, J = Ball(0.01, 0.01).arrays(2)
    theta = np.radians([60.0, 70.0])
    V = np.column_stack([np.sin(theta), -np.cos(theta), np.zeros(2)])
    rough = mbi.GaussianSlopes(0.05, dim=2)
    newton = mbi.RoughLaw(rough, facet=NewtonFacet(0.9), nodes=32).apply_batch(A, J, V, [0, 1])
    coulomb = mbi.RoughLaw(rough, facet=CoulombFacet(0.9, 0.3), nodes=32).apply_batch(A, J, V, [0, 1])
    assert np.all(newton.mu < 0.1)
    assert np.allclose(coulomb.mu, 0.3, atol=0.08)

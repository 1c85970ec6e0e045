"""Ring expansion of a Cone at fixed W (batch path) against the exact-arc quadrature and (2.10)."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging.ring import ring_expansion

from tests.helpers import ROBOTS, impulses, last_frame, mechanism, relative_du, spd, unit_velocities, upright_ur5_delassus


@given(st.integers(0, 2**32 - 1), st.floats(0.05, 1.5), st.sampled_from(["configuration", "physical"]),
       st.floats(1.0, 1e3))
def test_ring_expansion_equals_exact_arc_quadrature(seed, alpha, flux, cond):
    rng = np.random.default_rng(seed)
    W = spd(rng, 3, cond)
    U = unit_velocities(rng, 200)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux=flux)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", mbi.AccuracyWarning)
        P, err, _ = impulses(law, W, U)  # ≥ 32 rows: the ring path (or its fallback)
    # only a fallback quadrature limited by rounding (strongly anisotropic W) may warn, and says by how much
    assert not caught or (ring_expansion(alpha, W, flux) is None and err.max() > law.rtol)
    if cond <= 100:  # beyond, strongly anisotropic W may need the graded quadrature instead
        assert ring_expansion(alpha, W, flux) is not None
    ref, _, _ = impulses(mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux=flux, nodes=1024), W, U[:31].copy())
    assert relative_du(P[:31], ref, W).max() < max(1e-12, 1e-14 * cond)  # rounding grows with cond W
    assert np.all(err < 1e-11)  # truncation + rounding of up to 1024 terms


def test_ring_expansion_matches_corrected_2_10_for_a_point_mass():
    alpha, e = 0.4, 0.3
    rng = np.random.default_rng(2)
    U = unit_velocities(rng, 100, beta_max=math.pi / 2 - alpha - 1e-3)  # the whole cone faces u
    V = 3.0 * U
    res = mbi.RoughLaw(mbi.Cone(alpha), e).apply_batch(np.eye(3), np.eye(3), V, [0, 0, 1])
    ca, s2c = math.cos(alpha), math.sin(alpha) ** 2 * math.cos(alpha)
    vl, vn = V[:, :2], np.abs(V[:, 2])
    closed = (1 + e) / ca * np.column_stack([-vl * s2c, vn * ca**3 + (vl * vl).sum(1) / vn * s2c / 2])
    np.testing.assert_allclose(res.dV, closed, rtol=1e-13, atol=1e-13 * np.abs(closed).max())


def test_batch_on_a_robot_equals_single_impacts_in_both_regimes():
    mech = mechanism("panda")
    q = np.array([0.1, -0.4, 0.2, -2.0, 0.1, 1.6, 0.3, 0.0, 0.0])[: mech.nq]
    J, A = mech.point_jacobian(q, mech.frame_names[-1]), mech.mass_matrix(q)
    rng = np.random.default_rng(5)
    U = unit_velocities(rng, 64)
    V = np.linalg.lstsq(J, U.T, rcond=None)[0].T
    law = mbi.RoughLaw(mbi.Cone(0.6), 0.7)
    batch = law.apply_batch(A, J, V, [0, 0, 1])
    assert batch.nodes < 200  # a short series, not a quadrature refined to its limit
    for i in (0, 20, 40, 63):  # normal incidence … grazing, across the switch at β = π/2 − α
        one = law.apply(A, J, V[i], [0, 0, 1])
        np.testing.assert_allclose(batch.V_plus[i], one.v_plus, rtol=1e-12, atol=1e-12)
    assert np.all(batch.energy_loss >= 0.0)


def test_ring_expansion_refuses_facets_the_mechanism_cannot_push():
    """mᵀWm = 0 on part of the ring: no smooth series; the law falls back on quadrature."""
    e = np.array([1.0, 0.0, 0.3])  # mᵀWm = (mᵀe)² vanishes where cos φ = −0.3 cot α
    W = np.outer(e, e)
    assert ring_expansion(1.2, W, "configuration") is None
    U = unit_velocities(np.random.default_rng(0), 40, beta_max=1.0)
    with pytest.warns(mbi.AccuracyWarning):  # the flux weight diverges at mᵀWm = 0: flagged
        P, _, nodes = impulses(mbi.RoughLaw(mbi.Cone(1.2), 0.5), W, U)
    assert np.all(np.isfinite(P)) and nodes >= 16


def test_nearly_singular_w_falls_back_on_quadrature():
    """UR5 upright: W's eigenvalues span 1e7, the kernels are too peaked for a short series."""
    assert ring_expansion(0.3, upright_ur5_delassus(), "configuration") is None


@pytest.mark.parametrize("scale", [1e-8, 1e8])
@pytest.mark.parametrize("rough", [mbi.Cone(0.5), mbi.GaussianSlopes(0.4)], ids=repr)  # ring, tilt table
def test_batch_paths_are_homogeneous_of_degree_one(scale, rough):
    rng = np.random.default_rng(4)
    A, J = spd(rng, 5, 1e2), rng.normal(size=(3, 5))
    V = rng.normal(size=(1100, 5))  # enough rows for both batch paths
    V[V @ J[2] > 0] *= -1
    law = mbi.RoughLaw(rough, 0.4)
    base = law.apply_batch(A, J, V, [0, 0, 1]).dV
    np.testing.assert_allclose(law.apply_batch(A, J, scale * V, [0, 0, 1]).dV, scale * base,
                               rtol=1e-12, atol=1e-12 * scale * np.abs(base).max())


@given(st.sampled_from(ROBOTS), st.integers(0, 2**32 - 1), st.floats(0.05, 1.4), st.sampled_from(["configuration", "physical"]))
def test_batch_equals_single_impacts_on_robots(robot, seed, alpha, flux):
    """Random example-robot-data configurations: the ring path of a batch equals single impacts."""
    mech = mechanism(robot)
    rng = np.random.default_rng(seed)
    q = mech.random_configuration(rng)
    frame = last_frame(mech)
    J, A = mech.point_jacobian(q, frame), mech.mass_matrix(q)
    if np.linalg.svd(J, compute_uv=False)[-1] < 1e-6 * max(1.0, np.abs(J).max()):
        return  # rank-deficient here: covered by the hard cases
    V = rng.normal(size=(40, mech.nv))
    V[V @ J[2] > 0] *= -1
    law = mbi.RoughLaw(mbi.Cone(alpha), float(rng.uniform(0, 1)), flux=flux)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)  # ill-conditioned postures say so
        batch = law.apply_batch(A, J, V, [0, 0, 1])
        one = [law.apply(A, J, V[i], [0, 0, 1]) for i in (0, 39)]
    for i, res in zip((0, 39), one):
        du = batch.U_plus[i] - batch.U_minus[i]
        assert np.linalg.norm(du - (res.u_plus - res.u_minus)) <= 1e-9 * np.linalg.norm(du)
    assert np.all(batch.energy_loss >= -1e-12 * np.abs(batch.U_minus).max() ** 2)

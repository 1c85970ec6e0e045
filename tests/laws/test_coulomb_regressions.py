"""Coulomb law regressions: impacts that hung, raised a bare RuntimeError or gained energy.

Every call runs under :func:`time_limit`: a call that hangs fails its test instead of
hanging the run; integration steps are counted through ``result.nodes``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.laws import coulomb
from tests.helpers import time_limit

RESTITUTIONS = ["newton", "poisson", "energetic"]
EPS = np.finfo(float).eps


@pytest.fixture(autouse=True, scope="module")
def _compiled_phases() -> None:
    """Load (or, with a cold numba cache, compile: seconds) the law's kernels outside the time limits."""
    coulomb.compile_kernels()


def guarded(law: mbi.CoulombLaw, *args: object, seconds: float = 10.0) -> mbi.ImpactResult:
    with time_limit(seconds):
        return law.apply(*args)  # type: ignore[arg-type]


def energy_bound(res: mbi.ImpactResult) -> float:
    """Rounding bound of the computed energy change: 64 ε cond(W) |P| (|u₋| + |u₊|).

    The impulse errs by ~ε cond(W) |P| (W_tt g = −b, the change of frame), and
    ΔT = Pᵀ(u₋ + u₊)/2 (with u₊ = u₋ + W P formed in floats) amplifies that by |u₋| + |u₊|.
    """
    W = res.J @ np.linalg.solve(res.A, res.J.T)
    lam = np.linalg.eigvalsh(0.5 * (W + W.T))
    cond = lam[-1] / max(lam[lam > 1e-12 * lam[-1]].min(), 1e-300)
    return 64 * EPS * cond * np.linalg.norm(res.P) * (np.linalg.norm(res.u_minus) + np.linalg.norm(res.u_plus))


NEAR_NORMAL_W = np.array([[.035, .0075, .018], [.0075, .052, .0135], [.018, .0135, .024]])


@pytest.mark.parametrize("restitution", RESTITUTIONS)
@pytest.mark.parametrize("slip", [1e-12, 1e-10, 1e-9, 3e-8, 1.5e-7, 1e-6, 1e-3])
def test_near_normal_spatial_impact_that_can_stick_returns(restitution, slip):
    """|u_t| / |u| between ~1e-9 and ~1.5e-7 with friction that can stick used to hang: the stop
    event started negative and never fired, the starting mode being decided against 1e-9."""
    L = np.linalg.cholesky(NEAR_NORMAL_W)
    res = guarded(mbi.CoulombLaw(0.5, 1.0, restitution), np.eye(3), L, np.linalg.solve(L, [slip, 0, -1.0]), [0, 0, 1])
    assert res.nodes < 200  # integration steps, if any
    np.testing.assert_allclose(res.u_plus[:2], 0.0, atol=1e-9)  # it sticks
    assert res.mu <= 1.0 * (1 + 1e-9)
    if restitution == "newton":
        assert res.u_plus[2] == pytest.approx(0.5, abs=1e-12)
    else:
        assert res.u_plus[2] == pytest.approx(0.5, abs=max(1e-12, slip))  # the slip barely changes it
        assert res.energy_loss >= -energy_bound(res)


@pytest.mark.parametrize("restitution", RESTITUTIONS)
def test_rank_one_delassus_matrix_jams_instead_of_hanging(restitution):
    """One degree of freedom moving the contact along (1, 1): u_t = u_n all along, so the slip
    stops exactly when compression ends and the contact jams (W [g; 1] = 0 while sticking)."""
    res = guarded(mbi.CoulombLaw(0.5, 1.5, restitution), [[1.0]], [[1.0], [1.0]], [-1.0], [0, 1])
    np.testing.assert_allclose(res.u_plus, 0.0, atol=1e-14)  # plastic: restitution is out of reach
    assert res.energy_loss == pytest.approx(res.T_minus, rel=1e-12)
    assert np.all(np.isfinite(res.P)) and res.P_n > 0


@pytest.mark.parametrize("restitution", RESTITUTIONS)
def test_grazing_rank_one_spatial_contact_returns(restitution):
    """Rank-1 W in 3-D: the slip runs along the invariant direction j_t and stops with u = 0."""
    J = [[0.09], [0.75], [0.65]]
    res = guarded(mbi.CoulombLaw(0.5, 0.9, restitution), np.eye(1), J, [-1.0], [0, 0, 1])
    np.testing.assert_allclose(res.u_plus, 0.0, atol=1e-14)
    assert res.nodes == 1  # a straight slip: closed form
    j = np.ravel(J)
    np.testing.assert_allclose(res.P, j / (j @ j), rtol=1e-12)  # the least impulse that stops the one DOF


@pytest.mark.parametrize("restitution", RESTITUTIONS)
@pytest.mark.parametrize("mu", [0.0, 0.2, 0.9, 5.0, 50.0])
def test_rank_one_grazing_with_any_friction_never_raises_a_bare_error(restitution, mu):
    """Rank-1 W in 3-D; the last J jams with u_n at rounding level (+3e-16) after a straight slip:
    Stronge's end used to wait for that to deliver the work, with an impulse of 4e14."""
    for J in ([[0.09], [0.75], [0.65]], [[0.0], [0.0], [1.0]], [[1.0], [0.0], [1e-8]], [[1.0], [1e-9], [1e-6]],
              [[-0.10586607], [-0.20573606], [4.14949342]]):
        try:
            res = guarded(mbi.CoulombLaw(0.5, mu, restitution), np.eye(1), J, [-1.0], [0, 0, 1])
        except mbi.ImpactError:
            continue  # a named error is fine (e.g. the normal out of reach)
        assert np.all(np.isfinite(res.P)) and np.abs(res.P).max() < 1e3
        assert res.energy_loss >= -energy_bound(res) or restitution == "newton"


@pytest.mark.parametrize("restitution", RESTITUTIONS)
@pytest.mark.parametrize("scale", [1e-300, 1e-170, 1e-162, 1e-100, 1.0, 1e100, 1e154, 1e160, 1e300])
def test_velocity_scales_far_from_one(restitution, scale):
    """Homogeneous of degree 1 in u: P(s u) = s P(u); these scales used to give NaN or RuntimeError."""
    law = mbi.CoulombLaw(0.5, 0.3, restitution)
    rng = np.random.default_rng(4)
    A = rng.normal(size=(4, 4))
    A = A @ A.T + np.eye(4)
    J = rng.normal(size=(3, 4))
    v = np.linalg.lstsq(J, [0.3, -0.2, -1.0], rcond=None)[0]
    ref = guarded(law, A, J, v, [0, 0, 1])
    res = guarded(law, A, J, v * scale, [0, 0, 1])
    np.testing.assert_allclose(res.P / scale, ref.P, rtol=1e-12, atol=1e-14 * np.abs(ref.P).max())


@pytest.mark.parametrize("restitution", RESTITUTIONS)
@pytest.mark.parametrize("scale", [1e-150, 1e-40, 1e40, 1e150])
def test_mass_scales_far_from_one(restitution, scale):
    """Homogeneous of degree −1 in W = J A⁻¹ Jᵀ: the impulse scales with the mass."""
    law = mbi.CoulombLaw(0.7, 0.4, restitution)
    W = np.array([[1.0, 0.3, 0.2], [0.3, 0.8, -0.1], [0.2, -0.1, 0.5]])
    v = np.array([0.4, -0.1, -1.0])
    ref = guarded(law, np.linalg.inv(W), np.eye(3), v, [0, 0, 1])
    res = guarded(law, np.linalg.inv(W) * scale, np.eye(3), v, [0, 0, 1])
    np.testing.assert_allclose(res.P / scale, ref.P, rtol=1e-9)


@pytest.mark.parametrize("restitution", ["poisson", "energetic"])
@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("slip", [0.0, 1e-300, 1e-14, 1e-11, 1e-9, 1e-7, 1e-4])
def test_elastic_impact_with_a_tiny_slip_creates_no_energy(restitution, d, slip):
    """e = 1 with a slip below the old 1e-9 threshold started 'sticking' with u_t ≠ 0 left in place:
    the kinetic energy grew. It must not grow beyond rounding."""
    rng = np.random.default_rng(11)
    for _ in range(10):
        n = 5
        A = rng.normal(size=(n, n))
        A = A @ A.T + 0.1 * np.eye(n)
        J = rng.normal(size=(d, n))
        W = J @ np.linalg.solve(A, J.T)
        ut = rng.normal(size=d - 1)
        u = np.append(slip * ut / np.linalg.norm(ut), -1.0)
        v = np.linalg.lstsq(J, u, rcond=None)[0]
        res = guarded(mbi.CoulombLaw(1.0, 2.0, restitution), A, J, v, np.eye(d)[-1])
        assert res.energy_loss >= -energy_bound(res), (res.energy_loss, energy_bound(res), np.linalg.cond(W))


def test_integration_failures_are_named_impact_errors(monkeypatch):
    """No RuntimeError anywhere: a give-up is an IntegrationError saying where it stopped."""
    monkeypatch.setattr(coulomb, "_MAX_STEPS", 2)
    W = np.array([[0.50314836, 1.15271262, -0.27604205], [1.15271262, 5.10958421, -2.40727164],
                  [-0.27604205, -2.40727164, 1.55898575]])
    L = np.linalg.cholesky(np.linalg.inv(W))
    with pytest.raises(mbi.IntegrationError, match=r"p_n = [0-9.e+-]+ \(\|u_t\| = "):
        guarded(mbi.CoulombLaw(1.0, 1.5, "energetic"), L @ L.T, np.eye(3), [0.29384942, 0.82099915, -0.56966659],
                [0, 0, 1])
    assert issubclass(mbi.IntegrationError, mbi.ImpactError)


def test_a_curving_slip_that_stops_takes_few_steps():
    """The slip of test_a_3d_slip_that_stops... : it used to chatter about u_t = 0 for millions of
    steps; it settles on its invariant direction and stops in closed form."""
    W = np.array([[0.50314836, 1.15271262, -0.27604205], [1.15271262, 5.10958421, -2.40727164],
                  [-0.27604205, -2.40727164, 1.55898575]])
    L = np.linalg.cholesky(np.linalg.inv(W))
    res = guarded(mbi.CoulombLaw(1.0, 1.5, "energetic"), L @ L.T, np.eye(3), [0.29384942, 0.82099915, -0.56966659],
                  [0, 0, 1])
    assert 1 < res.nodes < 100
    assert np.linalg.norm(res.u_plus[:2]) < 1e-12


@pytest.mark.parametrize("restitution", RESTITUTIONS)
def test_jammed_sticking_contact_ends_plastically_in_three_dimensions(restitution):
    """W [g; 1] = 0 while sticking (two DOF, the normal tied to a tangent): no restitution possible."""
    J = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 0.0]])  # u_n = u_x always
    res = guarded(mbi.CoulombLaw(0.8, 2.0, restitution), np.eye(2), J, [-0.5, 0.3], [0, 0, 1])
    assert res.u_plus[2] == pytest.approx(res.u_plus[0], abs=1e-14)
    assert math.isfinite(res.energy_loss) and res.energy_loss >= -energy_bound(res)

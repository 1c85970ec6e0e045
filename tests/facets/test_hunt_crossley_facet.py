"""Hunt–Crossley facets: a restitution that depends on the facet's normal impact speed."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.facets import HuntCrossleyFacet, hunt_crossley_restitution


def _ode_restitution(x: float, n: float = 1.5) -> float:
    """Integrate δ̈ = −δⁿ (1 + χ δ̇) (K = W_nn = 1) from δ = 0, δ̇ = v; e = exit speed / v (χ v = x)."""
    from scipy.integrate import solve_ivp

    v, chi = 1.0, x

    def rhs(t: float, y: np.ndarray) -> list[float]:
        d = max(y[0], 0.0)
        return [y[1], -(d**n) * (1.0 + chi * y[1])]

    def out(t: float, y: np.ndarray) -> float:
        return y[0]

    out.terminal, out.direction = True, -1  # type: ignore[attr-defined]
    sol = solve_ivp(rhs, (0.0, 100.0), [1e-300, v], events=out, rtol=1e-11, atol=1e-14, method="DOP853")
    return float(-sol.y_events[0][0][1] / v)


@pytest.mark.parametrize("x", [0.01, 0.2, 1.0, 3.0])
def test_closed_form_restitution_is_the_force_law_integrated(x: float) -> None:
    """x − ln(1+x) = −ex − ln(1−ex) is the Hunt–Crossley force integrated through the impact,
    whatever the Hertz exponent (n = 3/2 and n = 1)."""
    e = float(hunt_crossley_restitution(x))
    assert e == pytest.approx(_ode_restitution(x, 1.5), rel=1e-7)
    assert e == pytest.approx(_ode_restitution(x, 1.0), rel=1e-7)


def test_restitution_limits() -> None:
    x = np.array([0.0, 1e-9, 1e-6, 1e-3])
    assert np.allclose(hunt_crossley_restitution(x), 1 - 2 * x / 3, rtol=0, atol=2 * x**2 + 1e-15)
    big = hunt_crossley_restitution(np.array([1e2, 1e4]))
    assert np.all(big < 1.0 / np.array([1e2, 1e4]))  # e x < 1 always: the exit speed is below 1/χ
    assert np.all(np.diff(hunt_crossley_restitution(np.linspace(0, 20, 50))) < 0)  # falls with the speed
    facet = HuntCrossleyFacet(0.1)
    assert facet.restitution(0.01) == pytest.approx(1 - 0.1 * 0.01, abs=1e-6)  # e ≈ 1 − α v


@pytest.mark.parametrize("speed", [0.1, 1.0, 5.0, 20.0])
def test_the_rough_law_is_speed_dependent(speed: float) -> None:
    """Through mbi's pipeline (which scales velocities to unit speed for homogeneous laws) the
    facet sees the physical speed: one smooth facet gives κ = e(v), and the sawtooth at normal
    incidence κ = (1 + e(v cos α)) cos²α − 1, the closed form (2.11) with e(v)."""
    alpha_hc = 0.05
    facet = HuntCrossleyFacet(alpha_hc)
    A, J = np.diag([2.0, 2.0]), np.eye(2)  # W = I/2: the speed scale must not depend on the mass
    smooth = mbi.RoughLaw(mbi.Smooth(), facet=facet).apply(A, J, [0.0, -speed], [0.0, 1.0])
    assert smooth.kappa == pytest.approx(float(facet.restitution(speed)), rel=1e-12)
    assert smooth.method == "exact[hunt-crossley]"
    a = 0.4
    saw = mbi.RoughLaw(mbi.Sawtooth(a), facet=facet).apply(A, J, [0.0, -speed], [0.0, 1.0])
    expected = (1 + float(facet.restitution(speed * math.cos(a)))) * math.cos(a) ** 2 - 1
    assert saw.kappa == pytest.approx(expected, rel=1e-12)


def test_not_homogeneous_and_batched_by_row_speed() -> None:
    """Property 1° fails by design; a batch gives each row its own speed, as single impacts do."""
    law = mbi.RoughLaw(mbi.Cone(0.3), facet=HuntCrossleyFacet(0.2), nodes=24)
    A, J = np.eye(3), np.eye(3)
    V = np.array([[0.3, 0.1, -1.0], [0.6, 0.2, -2.0], [3.0, 1.0, -10.0]])  # one direction, three speeds
    batch = law.apply_batch(A, J, V, [0, 0, 1])
    kappas = batch.kappa
    assert kappas[0] > kappas[1] > kappas[2]  # faster impacts restitute less
    for i, v in enumerate(V):
        single = law.apply(A, J, v, [0, 0, 1])
        assert np.allclose(single.P, batch.P[i], rtol=1e-12)
    assert batch.method == "fixed[hunt-crossley]"
    # repeated micro-impacts keep the physical speeds too
    steep = mbi.RoughLaw(mbi.Sawtooth(1.1), facet=HuntCrossleyFacet(0.2), repeat=True)
    out = steep.apply(np.eye(2), np.eye(2), [0.0, -3.0], [0.0, 1.0])
    assert out.separates
    assert np.isclose(steep.replace(repeat=False).apply(np.eye(2), np.eye(2), [0.0, -1.0], [0.0, 1.0]).kappa,
                      (1 + float(HuntCrossleyFacet(0.2).restitution(math.cos(1.1)))) * math.cos(1.1) ** 2 - 1)

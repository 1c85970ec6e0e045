"""e(k) of (2.8) against a direct integration of the Kelvin–Voigt oscillator (2.4)."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

import mbimpact as mbi


def rebound(M: float, k: float) -> tuple[float, float]:
    """Integrate f'' = -(M² f + 2kM f') from f = 0, f' = -1 until f = 0 again."""

    def rhs(t, y):
        return [y[1], -(M * M * y[0] + 2 * k * M * y[1])]

    def exit_(t, y):
        return y[0]

    exit_.terminal = True
    exit_.direction = 1.0
    sol = solve_ivp(rhs, (0.0, 50.0 / M), [0.0, -1.0], events=exit_, rtol=1e-11, atol=1e-14, method="DOP853",
                    first_step=1e-6 / M)
    assert sol.status == 1, "the facet contact never separated"
    return float(sol.y_events[0][0][1]), float(sol.t_events[0][0])


@pytest.mark.parametrize("k", [0.0, 0.05, 0.2, 0.5, 0.8])
@pytest.mark.parametrize("M", [1.0, 1e3])
def test_e_from_k_matches_kelvin_voigt_integration(k, M):
    e, tau = rebound(M, k)
    assert e == pytest.approx(mbi.e_from_k(k), rel=1e-8, abs=1e-12)
    assert tau == pytest.approx(mbi.impact_duration(M, k), rel=1e-8)


@given(st.floats(0.0, 1.0))
def test_round_trip_e_k(e):
    assert mbi.e_from_k(mbi.k_from_e(e)) == pytest.approx(e, abs=1e-14)


@given(st.floats(0.0, 1.0))
def test_round_trip_k_e(k):
    e = mbi.e_from_k(k)
    if e > 1e-300:  # below this e underflows and k is no longer recoverable
        assert mbi.k_from_e(e) == pytest.approx(k, abs=1e-12)


def test_limits():
    assert mbi.e_from_k(0.0) == 1.0 and mbi.k_from_e(1.0) == 0.0
    assert mbi.e_from_k(1.0) == 0.0 and mbi.k_from_e(0.0) == 1.0
    assert mbi.impact_duration(10.0, 1.0) == math.inf
    # e decreases monotonically in k
    ks = np.linspace(0, 0.99, 50)
    assert np.all(np.diff([mbi.e_from_k(k) for k in ks]) < 0)


def test_rough_law_accepts_k_instead_of_e():
    law = mbi.RoughLaw(mbi.Sawtooth(0.2), k=0.3)
    assert law.e == pytest.approx(mbi.e_from_k(0.3))
    assert mbi.NewtonLaw(k=0.3).e == law.e

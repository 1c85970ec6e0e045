"""Bodies and predictions: a spinning sphere's arrays, and each column against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.facets import CoulombFacet, HuntCrossleyFacet
from mbimpact.calibration import FitError, PointMass, Ball, predict


def test_sphere_arrays_give_the_sphere_delassus_matrix() -> None:
    s = Ball(radius=0.02, mass=0.3)
    for d in (2, 3):
        A, J = s.arrays(d)
        W = J @ np.linalg.solve(A, J.T)
        expected = np.diag([3.5] * (d - 1) + [1.0]) / 0.3  # W_tt / W_nn = 1 + m R²/I = 7/2
        assert np.allclose(W, expected)
    # u = v + ω × r with r = −R n⁰: a sphere rolling forward (ω_y = v_x / R) has a still contact point
    A, J = s.arrays(3)
    v = np.array([1.0, 0.0, 0.0, 0.0, 1.0 / 0.02, 0.0])
    assert np.allclose(J @ v, 0.0)
    m = s.motion(v[None, :], 3)
    assert m.ut[0] == pytest.approx(0.0) and m.spin[0] == pytest.approx(50.0)
    assert Ball(0.02, 0.3, inertia=1e-4).moment == 1e-4
    with pytest.raises(mbi.ParameterError):
        Ball(-1.0, 1.0)


def test_coulomb_sphere_columns_match_rigid_body_closed_forms() -> None:
    """Coulomb's law on a solid sphere (W_tn = 0): κ = e; rolling e_t = 5/7 below the sliding angle,
    e_t = 1 − μ(1+e) cot θ above; ω⁺ R = (5/2)(v_t⁻ − v_t⁺); rebound tan = e_t tan θ / κ; μ read
    is μ."""
    e, mu, R, V = 0.9, 0.1, 0.0025, 3.9
    theta = np.array([5.0, 10.0, 20.0, 40.0, 60.0])
    p = predict(mbi.CoulombLaw(e, mu), theta, Ball(R, 2.6e-4), V)
    t = np.radians(theta)
    slides = np.tan(t) > 3.5 * mu * (1 + e)
    et = np.where(slides, 1 - mu * (1 + e) / np.tan(t), 5 / 7)
    assert np.allclose(p["kappa"], e)
    assert np.allclose(p["et"], et)
    assert np.allclose(p["spin"] * R, 2.5 * V * np.sin(t) * (1 - et))
    assert np.allclose(p["rebound_deg"], np.degrees(np.arctan(et * np.tan(t) / e)))
    assert np.allclose(p["et_cp"][~slides], 0.0, atol=1e-12)  # rolling: the contact point stops
    assert np.allclose(p["mu"][slides], mu)
    # a spatial roughness gives the same for an isotropic smooth surface
    p3 = predict(mbi.RoughLaw(mbi.Cone(1e-9), facet=CoulombFacet(e, mu)), theta, Ball(R, 2.6e-4), V)
    assert np.allclose(p3["et"], et, atol=1e-6)


def test_point_mass_and_speed_dependence() -> None:
    law = mbi.RoughLaw(mbi.Smooth(), facet=HuntCrossleyFacet(0.1))
    slow, fast = (predict(law, [30.0], PointMass(), v) for v in (1.0, 10.0))
    facet = HuntCrossleyFacet(0.1)
    assert slow["kappa"][0] == pytest.approx(float(facet.restitution(math.cos(math.radians(30)))))
    assert fast["kappa"][0] < slow["kappa"][0]
    assert "spin" not in slow and slow["et"][0] == pytest.approx(1.0)
    with pytest.raises(FitError, match="does not rotate"):
        predict(law, [30.0], PointMass(), 1.0, ("spin",))
    with pytest.raises(FitError, match=r"\[0, 90\)"):
        predict(law, [90.0])

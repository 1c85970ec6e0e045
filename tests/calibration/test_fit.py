"""Least-squares calibration recovers known parameters from noisy synthetic data."""

from __future__ import annotations

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.facets import CompliantFacet
from mbimpact.calibration import FitError, ImpactTable, PointMass, Ball, fit, family, predict, with_parameters

BALL = Ball(radius=0.0025, mass=2.6e-4)
ANGLES = np.array([3.0, 8.0, 14.0, 20.0, 27.0, 35.0, 45.0, 55.0, 65.0, 75.0])
#: noise of each column, in its unit (ratios; rad/s; degrees)
NOISE = {"kappa": 0.004, "et": 0.004, "spin": 6.0, "rebound_deg": 0.25, "mu": 0.004}


def synthetic(law: mbi.ImpactLaw, seed: int, columns: tuple[str, ...] = ("kappa", "et", "spin", "rebound_deg"),
              speed: np.ndarray | float = 3.9) -> ImpactTable:
    """The law's predictions for BALL at ANGLES, with seeded Gaussian noise of NOISE's size."""
    rng = np.random.default_rng(seed)
    speeds = np.broadcast_to(np.asarray(speed, dtype=float), ANGLES.shape)
    pred = predict(law, ANGLES, BALL, speeds, columns)
    data = {q: pred[q] + NOISE[q] * rng.normal(size=len(ANGLES)) for q in columns}
    return ImpactTable(ANGLES, data, speeds.copy(), {"source": "synthetic"}, "synthetic")


CASES = [  # (family, true parameters, columns, starts: None = the default, several where not convex)
    ("newton", {"e": 0.85}, ("kappa", "et", "rebound_deg"), None),
    ("coulomb", {"e": 0.8, "mu": 0.15}, ("kappa", "et", "spin", "rebound_deg"), None),
    ("rough-newton", {"sigma": 0.2, "e": 0.8}, ("kappa", "et", "mu"), None),
    ("rough-coulomb", {"sigma": 0.15, "e": 0.8, "mu": 0.2}, ("kappa", "et", "spin", "rebound_deg"), None),
    ("compliant", {"e": 0.85, "mu": 0.15, "kt": 0.6}, ("kappa", "et", "spin", "rebound_deg"), 1),
]


@pytest.mark.parametrize("name,truth,columns,starts", CASES)
def test_fit_recovers_known_parameters(name: str, truth: dict[str, float], columns: tuple[str, ...],
                                       starts: int | None) -> None:
    law = with_parameters(family(name), truth)
    table = synthetic(law, seed=11, columns=columns)
    result = fit(table, name, BALL, starts=starts)  # the template's values are the (first) start
    assert result.success
    for p, value in truth.items():
        # the data's noise sets the tolerance: four standard errors (and the errors are small)
        assert abs(result.params[p] - value) < 4 * result.stderr[p] + 1e-6, (p, result.params[p], result.stderr[p])
        assert result.stderr[p] < 0.15 * max(abs(value), 0.05)
    # the residuals are the noise: each column's RMS within a factor of two of its size
    for q in columns:
        assert 0.3 * NOISE[q] < result.quantity_rms[q] < 2.0 * NOISE[q]


def test_fit_recovers_a_speed_dependent_facet_law() -> None:
    """Hunt–Crossley facets: the table's speeds (2–10 m/s) identify the damping α from κ alone."""
    truth = {"sigma": 0.12, "hc": 0.03}
    law = with_parameters(family("rough-hunt-crossley"), truth)
    speeds = np.tile([2.0, 5.0, 10.0, 4.0, 8.0], 2)
    table = synthetic(law, seed=5, columns=("kappa", "et"), speed=speeds)
    result = fit(table, "rough-hunt-crossley", BALL, starts=1)
    for p, value in truth.items():
        assert abs(result.params[p] - value) < 4 * result.stderr[p], (p, result.params[p], result.stderr[p])
    no_speed = ImpactTable(table.theta_deg, table.columns, None, {}, "no speed")
    with pytest.raises(FitError, match="speed"):
        fit(no_speed, "rough-hunt-crossley", BALL)
    assert fit(no_speed, "rough-hunt-crossley", BALL, speed=5.0, starts=1, max_nfev=3).speed[0] == 5.0


@pytest.mark.slow
def test_fit_recovers_the_rough_compliant_law() -> None:
    truth = {"sigma": 0.1, "e": 0.9, "mu": 0.12, "kt": 0.7}
    law = with_parameters(family("rough-compliant"), truth)
    table = synthetic(law, seed=2)
    result = fit(table, "rough-compliant", BALL)
    for p, value in truth.items():
        assert abs(result.params[p] - value) < 4 * result.stderr[p] + 1e-6


def test_fit_with_fixed_parameters_and_several_starts() -> None:
    """A template law (compliant facets on a smooth surface) with e fixed: two seeded starts give the
    optimum, and the fitted law predicts the data it was fitted to."""
    template = mbi.RoughLaw(mbi.Smooth(), facet=CompliantFacet(0.9, 0.3, 1.2))
    truth = {"mu": 0.12, "kt": 0.7}
    table = synthetic(with_parameters(template, truth), seed=4, columns=("et", "spin"))
    result = fit(table, template, BALL, free=("mu", "kt"), bounds={"kt": (0.3, 1.5)}, starts=2)
    assert result.starts == 2 and result.free == ("mu", "kt")
    assert result.params["e"] == 0.9 and "sigma" not in result.params
    for p in ("mu", "kt"):
        assert abs(result.params[p] - truth[p]) < 4 * result.stderr[p]
    pred = result.predict(ANGLES)
    assert np.sqrt(np.mean((pred["et"] - table.values("et")) ** 2)) == pytest.approx(result.quantity_rms["et"])


def test_fit_errors() -> None:
    table = synthetic(mbi.NewtonLaw(0.8), seed=1, columns=("kappa",))
    with pytest.raises(FitError, match="free parameters"):
        fit(table, "coulomb", BALL, free=("sigma",))
    with pytest.raises(FitError, match="unknown law family"):
        fit(table, "stronge", BALL)
    with pytest.raises(FitError, match="no data"):
        fit(table, "newton", BALL, quantities=("spin",))
    with pytest.raises(FitError, match="both free and fixed"):
        fit(table, "coulomb", BALL, free=("e", "mu"), fixed={"mu": 0.2})
    with pytest.raises(FitError, match="lower < upper"):
        fit(table, "coulomb", BALL, bounds={"mu": (0.5, 0.1)})
    with pytest.raises(FitError, match="ImpactTable"):
        fit({"kappa": [0.5]}, "newton", BALL)  # type: ignore[arg-type]
    spin = ImpactTable(ANGLES, {"spin": np.linspace(10, 100, len(ANGLES))}, None, {}, "spin only")
    with pytest.raises(FitError, match="speed"):
        fit(spin, "coulomb", BALL)
    with pytest.raises(FitError, match="does not rotate"):
        fit(spin, "coulomb", PointMass(), speed=3.0)
    with pytest.raises(FitError, match="cannot vary the roughness"):
        fit(table, mbi.RoughLaw(mbi.Facets(np.array([[0.0, 1.0]]), np.array([1.0])), 0.5), BALL)
    assert isinstance(FitError("x"), mbi.ImpactError)


def test_the_issue_call_form_with_a_collision_sphere_as_the_body() -> None:
    """``mbi.fit(table, law=..., body=mbi.Sphere(radius=..., mass=...), free=...)``: a Sphere with a
    mass is the solid Ball of its radius and mass, so both fits are the same."""
    table = synthetic(mbi.CoulombLaw(0.8, 0.15), seed=3, columns=("kappa", "et", "spin"))
    as_sphere = mbi.fit(table, law="coulomb", body=mbi.Sphere(radius=0.0025, mass=2.6e-4), free=("e", "mu"))
    as_ball = mbi.fit(table, law="coulomb", body=BALL, free=("e", "mu"))
    assert as_sphere.body == BALL
    np.testing.assert_allclose([as_sphere.params["e"], as_sphere.params["mu"]],
                               [as_ball.params["e"], as_ball.params["mu"]], rtol=1e-12)
    assert abs(as_sphere.params["mu"] - 0.15) < 3 * as_sphere.stderr["mu"] + 0.01
    with pytest.raises(FitError, match="mass"):
        mbi.fit(table, law="coulomb", body=mbi.Sphere(0.0025))
    with pytest.raises(FitError, match="Ball, a PointMass or a Sphere"):
        mbi.fit(table, law="coulomb", body="ball")  # type: ignore[arg-type]
    with pytest.raises(mbi.ParameterError, match="mass"):
        mbi.Sphere(0.1, mass=-1.0)

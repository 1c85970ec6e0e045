"""The averaging methods as a family: the registry, what "auto" picks, explicit choices, agreement."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.averaging import AUTO_ORDER, METHODS, Averaging, Fixed
from tests.helpers import UPRIGHT_UR5, mechanism, relative_du, spd, unit_velocities, upright_ur5_delassus

I3 = np.eye(3)


def test_registry_names_every_method_once():
    """One rule a name, at most nine names; a compiled kernel is a backend of its rule, not a name of its own."""
    assert set(AUTO_ORDER) <= set(METHODS) and len(set(AUTO_ORDER)) == len(AUTO_ORDER)
    assert len(METHODS) <= 9 and not any("[" in name or "pass" in name for name in METHODS)
    for name, cls in METHODS.items():
        assert issubclass(cls, Averaging) and cls.name == name
    assert mbi.AVERAGING_METHODS is METHODS
    # every method a measure declares exists
    for rough in (mbi.Smooth(), mbi.Sawtooth(0.3), mbi.Cone(0.3), mbi.GaussianSlopes(0.3), mbi.Profile([0, 1, 0], 1.0)):
        assert set(rough.methods) <= set(METHODS)


@pytest.mark.parametrize("rough, rows, nodes, expected", [
    (mbi.Facets(np.array([[0.3, 0.0, math.sqrt(0.91)], [-0.3, 0.0, math.sqrt(0.91)]])), 1, None, "exact"),
    (mbi.Smooth(), 5, None, "exact"),
    (mbi.Cone(0.3), 1, None, "adaptive[compiled]"),
    (mbi.Cone(0.3), 40, None, "ring"),
    (mbi.Cone(0.3), 40, 16, "fixed"),
    (mbi.Cone(0.3), 1, 16, "fixed"),
    (mbi.GaussianSlopes(0.3), 1, None, "laplace"),
    (mbi.GaussianSlopes(0.3, dim=2), 1, None, "adaptive[compiled]"),
    (mbi.GaussianSlopes(0.3), 3, None, "laplace"),
    (mbi.GaussianSlopes(0.3), 3, 16, "fixed"),
    (mbi.GaussianSlopes(0.3), 1100, None, "laplace"),  # too few rows to pay for a table against the reduction
    (mbi.GaussianSlopes(0.3), 150_000, None, "tilt-table"),
    (mbi.IsotropicSlopes(mbi.GaussianSlopes(0.3).pdf, support=(0.0, 1.5)), 1100, None, "tilt-table"),
    (mbi.GaussianSlopes(0.3, dim=2), 3, None, "adaptive"),
])
def test_auto_picks_by_the_documented_ladder(rough, rows, nodes, expected):
    rng = np.random.default_rng(1)
    d = rough.dim or 3
    W = spd(rng, d, 20.0)
    U = unit_velocities(rng, rows) if d == 3 else np.column_stack([np.linspace(-2, 2, rows), -np.ones(rows)])
    law = mbi.RoughLaw(rough, 0.5, nodes=nodes)
    out = law.contact_impulses(W, U / np.linalg.norm(U, axis=1)[:, None])
    assert out.method == expected


def test_auto_grades_a_nearly_singular_delassus_matrix():
    """One velocity: the poles taken out ("poles"), or with the configuration flux the graded rule compiled
    ("graded[compiled]"); a batch: the graded rule in numpy ("graded")."""
    W, U = upright_ur5_delassus(), np.array([[0.2, 0.1, -0.97]])
    assert mbi.RoughLaw(mbi.Cone(0.3), 0.5).contact_impulses(W, U).method == "poles"
    configuration = mbi.RoughLaw(mbi.Cone(0.3), 0.5, flux="configuration")
    assert configuration.contact_impulses(W, U).method == "graded[compiled]"
    assert mbi.RoughLaw(mbi.Cone(0.3), 0.5).contact_impulses(W, np.vstack([U, U])).method == "graded"


@pytest.mark.parametrize("cond", [1.0, 30.0])
def test_every_method_gives_the_same_impulse(cond):
    """Exact-arc rules, series, tables and shortcuts integrate the same (2.8): agreement to rounding
    (Monte Carlo to its standard error)."""
    rng = np.random.default_rng(7)
    W = spd(rng, 3, cond)
    U = unit_velocities(rng, 40)
    cone = {name: mbi.RoughLaw(mbi.Cone(0.4), 0.5, method=name) for name in ("ring", "adaptive", "graded")}
    ref = cone["adaptive"].contact_impulses(W, U).P
    assert relative_du(cone["ring"].contact_impulses(W, U).P, ref, W).max() < 1e-13 * cond
    fixed = mbi.RoughLaw(mbi.Cone(0.4), 0.5, method="fixed", nodes=64).contact_impulses(W, U)
    assert relative_du(fixed.P, ref, W).max() < 1e-13 * cond and fixed.method == "fixed"
    one = mbi.RoughLaw(mbi.Cone(0.4), 0.5, method="adaptive")  # one velocity: the compiled backend
    for i in (0, 17, 39):
        assert relative_du(one.contact_impulses(W, U[i:i + 1]).P, ref[i:i + 1], W)[0] < 1e-13 * cond
    mc = mbi.RoughLaw(mbi.Cone(0.4), 0.5, method="monte-carlo", samples=20_000, seed=2).contact_impulses(W, U[:5])
    assert mc.method == "monte-carlo"
    assert np.all(relative_du(mc.P, ref[:5], W) < 5 * mc.error + 1e-12)
    slopes = mbi.GaussianSlopes(0.3)
    table = mbi.RoughLaw(slopes, 0.5, method="tilt-table").contact_impulses(W, U)
    product = mbi.RoughLaw(slopes, 0.5, method="adaptive").contact_impulses(W, U[:6])
    assert table.method == "tilt-table" and relative_du(table.P[:6], product.P, W).max() < 1e-12


def test_a_method_is_chosen_by_name_class_or_instance():
    W, U = spd(np.random.default_rng(3), 3, 5.0), unit_velocities(np.random.default_rng(4), 3)
    by = [mbi.RoughLaw(mbi.Cone(0.3), 0.5, method=m, nodes=32) for m in ("fixed", Fixed, Fixed())]
    P = [law.contact_impulses(W, U).P for law in by]
    np.testing.assert_array_equal(P[0], P[1])
    np.testing.assert_array_equal(P[0], P[2])
    assert "method='fixed'" in repr(by[0])


def test_a_user_defined_method_joins_the_family():
    class HalfNodes(Averaging):
        name = "half-nodes"

        def supports(self, spec):
            return spec.roughness.dim == 3

        def average(self, spec, W, U):
            out = mbi.RoughLaw(spec.roughness, spec.e, method="fixed", nodes=16).contact_impulses(W, U)
            return mbi.ContactImpulses(out.P, out.error, out.nodes, self.name)

    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5, method=HalfNodes)
    res = law.apply(I3, I3, [0.3, 0.1, -1.0], [0, 0, 1])
    assert res.method == "half-nodes" and res.nodes == 16


def test_results_record_the_method_that_ran():
    mech = mechanism("ur5")
    q = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
    J = mech.point_jacobian(q, "tool0")
    v = np.linalg.lstsq(J, [0.3, 0.0, -1.0], rcond=None)[0]
    contact = mbi.PointContact("tool0")
    assert mbi.impact(mech, q, v, contact, mbi.NewtonLaw(0.5)).method == "closed-form"
    assert mbi.impact(mech, q, v, contact, mbi.RoughLaw(mbi.Cone(0.3), 0.5)).method == "adaptive[compiled]"
    assert mbi.impact(mech, q, v, contact, mbi.CoulombLaw(0.5, 0.3)).method == "impulse-space"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)
        singular = mbi.impact(mech, UPRIGHT_UR5, np.linalg.lstsq(mech.point_jacobian(UPRIGHT_UR5, "tool0"),
                              [0.2, 0.1, -1.0], rcond=None)[0], contact, mbi.RoughLaw(mbi.Cone(0.3), 0.5))
    assert singular.method == "poles"
    A = mech.mass_matrix(q)
    batch = mbi.RoughLaw(mbi.Cone(0.3), 0.5).apply_batch(A, J, np.tile(v, (50, 1)), [0, 0, 1])
    assert batch.method == "ring" and batch[3].method == "ring"
    assert "adaptive[compiled]" in mbi.impact(mech, q, v, contact, mbi.RoughLaw(mbi.Cone(0.3), 0.5)).summary()


def test_explicit_methods_that_do_not_fit_are_named_errors():
    with pytest.raises(mbi.ParameterError, match="unknown averaging method 'rings'.*'ring'"):
        mbi.RoughLaw(mbi.Cone(0.3), 0.5, method="rings")
    with pytest.raises(mbi.ParameterError, match="'ring' averaging cannot average Sawtooth.*exact"):
        mbi.RoughLaw(mbi.Sawtooth(0.3), 0.5, method="ring")
    with pytest.raises(mbi.ParameterError, match="'tilt-table' averaging cannot average GaussianSlopes.*dim=2"):
        mbi.RoughLaw(mbi.GaussianSlopes(0.3, dim=2), 0.5, method="tilt-table")
    with pytest.raises(mbi.ParameterError, match="method must be"):
        mbi.RoughLaw(mbi.Cone(0.3), 0.5, method=3)  # type: ignore[arg-type]
    # a method that declines this case at run time says why
    with pytest.raises(mbi.ParameterError, match="too peaked"):
        mbi.RoughLaw(mbi.Cone(0.3), 0.5, method="ring").contact_impulses(upright_ur5_delassus(), unit_velocities(
            np.random.default_rng(0), 3))
    with pytest.raises(mbi.ParameterError, match="no graded rule"):
        mbi.RoughLaw(mbi.Cone(0.3), 0.5, method="graded").apply(I3, I3, [0.1, 0.0, -1.0], [0, 0, 1])


def test_thresholds_are_documented_attributes():
    from mbimpact.averaging import Graded, Ring, TiltTableMethod

    assert Ring.min_rows == 32 and TiltTableMethod.min_rows == 1024 and Graded.peaked == 0.15
    W = spd(np.random.default_rng(9), 3, 4.0)
    U = unit_velocities(np.random.default_rng(9), 20)
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    assert law.contact_impulses(W, U).method == "adaptive"  # 20 rows: below the ring's threshold
    try:
        Ring.min_rows = 10
        assert law.contact_impulses(W, U).method == "ring"
    finally:
        Ring.min_rows = 32

"""Tilt-density tables at fixed W (batch path of IsotropicSlopes / GaussianSlopes)."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging import Adaptive
from mbimpact.quadrature import tilt_segments
from mbimpact.averaging.tilt_table import tilt_table

from tests.helpers import impulses, mechanism, relative_du, spd, unit_velocities, upright_ur5_delassus

I3 = np.eye(3)


MEASURES = {
    "gaussian": lambda x: mbi.GaussianSlopes(0.05 + 0.4 * x),
    # a density that does not vanish at the end of its support: the table's τ² substitution
    "bounded": lambda x: mbi.IsotropicSlopes(lambda a: np.sin(2 * a) * (1 + np.cos(3 * a)), support=(0.0, 0.6 + 0.6 * x)),
    # a band of tilts away from 0: a second series beyond β_l = π/2 − lo
    "band": lambda x: mbi.IsotropicSlopes(lambda a: 1 + np.sin(3 * a), support=(0.1 + 0.3 * x, 0.7 + 0.5 * x)),
}


@settings(max_examples=8)  # each example builds a table (~0.3–1 s)
@given(st.integers(0, 2**32 - 1), st.sampled_from(sorted(MEASURES)), st.floats(0.0, 1.0),
       st.sampled_from(["configuration", "physical"]), st.floats(1.0, 30.0))
def test_table_equals_the_adaptive_product_rule(seed, kind, x, flux, cond):
    rng = np.random.default_rng(seed)
    W = spd(rng, 3, cond)
    rough = MEASURES[kind](x)
    U = unit_velocities(rng, 1050)
    law = mbi.RoughLaw(rough, 0.5, flux=flux)
    table = tilt_table(rough, W, flux)
    assert table is not None or cond > 10  # only strongly anisotropic W may be too peaked for a table
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)  # the product rule may stop short of 1e-12
        P, err, _ = impulses(law, W, U)  # ≥ 1024 rows: the table (else the product rule)
        ref, ref_err, _ = impulses(law, W, U[::50].copy())  # 21 rows: the product rule
    assert np.all(relative_du(P[::50], ref, W) < np.maximum(1e-12, 10 * ref_err))
    if table is not None:
        assert np.all(err < 1e-12)


def test_table_reproduces_corrected_2_10_and_4_2_for_a_point_mass():
    """W = I: normal incidence obeys (4.2); below β_h (every facet faces u) the corrected (2.10)."""
    rough, e = mbi.GaussianSlopes(0.2), 0.3
    beta_h = math.pi / 2 - rough.support[1]
    rng = np.random.default_rng(3)
    U = unit_velocities(rng, 1100, beta_max=beta_h * 0.999)
    res = mbi.RoughLaw(rough, e).apply_batch(I3, I3, 2.0 * U, [0, 0, 1])
    c1 = rough.moment(np.cos)
    c3 = rough.moment(lambda a: np.cos(a) ** 3)
    s2c = rough.moment(lambda a: np.sin(a) ** 2 * np.cos(a))
    vl, vn = 2.0 * U[:, :2], np.abs(2.0 * U[:, 2])
    closed = (1 + e) / c1 * np.column_stack([-vl * s2c, vn * c3 + (vl * vl).sum(1) / vn * s2c / 2])
    np.testing.assert_allclose(res.dV, closed, rtol=1e-12, atol=1e-12 * np.abs(closed).max())
    assert res.kappa[0] == pytest.approx((1 + e) * c3 / c1 - 1, rel=1e-13)


def test_batch_on_a_robot_equals_single_impacts():
    mech = mechanism("ur5")
    q = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
    J, A = mech.point_jacobian(q, "tool0"), mech.mass_matrix(q)
    rng = np.random.default_rng(8)
    V = rng.normal(size=(1100, 6))
    V[V @ J[2] > 0] *= -1
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.6)
    batch = law.apply_batch(A, J, V, [0, 0, 1])
    assert batch.nodes < 200  # a table, not a 2 n² product rule
    for i in (0, 549, 1099):
        one = law.apply(A, J, V[i], [0, 0, 1])
        np.testing.assert_allclose(batch.V_plus[i], one.v_plus, rtol=1e-12, atol=1e-12)
    assert np.all(batch.energy_loss >= 0.0)


@pytest.mark.parametrize("flux", ["configuration", "physical"])
def test_a_band_of_tilts_gets_two_series_continuous_across_beta_l(flux):
    """Support (0.2, 0.7): every ring is cut beyond β_l = π/2 − 0.2, where H has a (β − β_l)^{5/2}
    onset; the second series in σ, β = β_l + σ², matches the product rule on both sides."""
    rough = mbi.IsotropicSlopes(lambda a: np.ones_like(a), support=(0.2, 0.7))
    W = spd(np.random.default_rng(1), 3, 10.0)
    table = tilt_table(rough, W, flux)
    assert table is not None and [b for b, _, _ in table.pieces] == pytest.approx([math.pi / 2 - 0.7, math.pi / 2 - 0.2])
    beta_l = math.pi / 2 - 0.2
    near = np.array([[0.6 * math.sin(b), 0.8 * math.sin(b), -math.cos(b)]
                     for b in (beta_l - 1e-3, beta_l - 1e-9, beta_l, beta_l + 1e-9, beta_l + 1e-6, beta_l + 1e-3)])
    U = np.vstack([unit_velocities(np.random.default_rng(2), 1100), near])
    law = mbi.RoughLaw(rough, 0.5, flux=flux)
    P, err, nodes = impulses(law, W, U)  # ≥ 1024 rows: the table
    assert nodes < 200 and np.all(err < 1e-12)
    rows = np.r_[0:1100:50, 1100:1106]
    ref_out = Adaptive().average(law.spec, W, U[rows])
    ref, ref_err = ref_out.P, ref_out.error  # the tilt × azimuth product rule
    assert np.all(relative_du(P[rows], ref, W) < np.maximum(1e-12, 10 * ref_err))
    # continuous across β_l: steps of 1e-9 in β change Δu by ~1e-9 on either side
    assert relative_du(P[1101:1103], P[1102:1104], W).max() < 1e-8


def test_no_table_for_a_nearly_singular_w():
    assert tilt_table(mbi.GaussianSlopes(0.3), upright_ur5_delassus(), "configuration") is None


def test_a_small_last_block_reuses_the_table_of_its_batch(monkeypatch):
    rng = np.random.default_rng(6)
    rough = mbi.GaussianSlopes(0.25)
    law = mbi.RoughLaw(rough, 0.5, flux="configuration")  # (the physical flux may take the Laplace reduction)
    monkeypatch.setattr(mbi.averaging.integrand, "BLOCK_ROWS", 1100)  # 1150 rows: a block of 1100, then one of 50
    res = law.apply_batch(spd(rng, 3, 5.0), I3, unit_velocities(rng, 1150), [0, 0, 1])  # W = A⁻¹
    assert res.nodes < 200 and np.all(res.error_estimate < 1e-12)  # no product rule anywhere
    assert res.method == "tilt-table"
    assert tilt_table(rough, np.diag([1.0, 2.0, 3.0]), "configuration", build=False) is None  # never built: not built now


@pytest.mark.parametrize("gap", [0.0, 1e-10, 1e-6, 1e-2])
def test_tilt_rule_follows_an_onset_just_below_the_support(gap):
    """α* = lo − gap (every ring cut): (α − α*)^{3/2} on [lo, hi] is integrated to rounding
    with 16 nodes, as it is when α* lies inside the support."""
    lo, hi = 0.2, 0.7
    split = np.array([lo - gap])
    tilt, dtilt = tilt_segments(lo, hi, split, 16)
    exact = ((hi - split[0]) ** 2.5 - gap**2.5) / 2.5
    assert dtilt[0] @ (tilt[0] - split[0]) ** 1.5 == pytest.approx(exact, rel=1e-14)


def test_a_table_is_built_where_it_pays_against_the_laplace_reduction(monkeypatch):
    """Gaussian slopes with the physical flux: a batch on a strongly anisotropic W (a table of ~1e7 kernel
    samples) takes the Laplace reduction and builds no table; where the velocities at a W cost the reduction
    more than the table would, "auto" builds it, and the two agree to rounding of rtol."""
    from mbimpact.averaging import tilt_table as module

    rng = np.random.default_rng(4)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    hard = Q @ np.diag([0.2, 40.0, 200.0]) @ Q.T / 240.2
    U = unit_velocities(rng, 2000, 1.4)
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5)
    assert law.contact_impulses(hard, U).method == "laplace"
    assert tilt_table(law.roughness, hard, "physical", build=False) is None
    mild = spd(rng, 3, 3.0)
    mild /= np.trace(mild)
    reduction = law.contact_impulses(mild, U)
    assert reduction.method == "laplace"  # 2000 rows: the table does not pay
    monkeypatch.setattr(module, "_LAPLACE_ROW", 1e4)  # a reduction that costs as much as 1e4 samples a row
    table = law.contact_impulses(mild, U)
    assert table.method == "tilt-table" and tilt_table(law.roughness, mild, "physical", build=False) is not None
    assert relative_du(table.P, reduction.P, mild).max() < 1e-11


def test_a_build_cut_short_by_its_budget_is_tried_again_once_the_budget_has_doubled(monkeypatch):
    """What failed builds waste stays within what the rows cost the reduction: a table whose series run out
    of a budget (cond W = 100: its series need more than their second level) is not started again under a
    budget less than twice that one, and is under one at least twice."""
    from mbimpact.averaging import tilt_table as module

    rng = np.random.default_rng(6)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    W = Q @ np.diag([1.0, 10.0, 100.0]) @ Q.T / 111.0
    rough = mbi.GaussianSlopes(0.3)
    builds = []
    real = module._build

    def counted(*args, **kwargs):
        out = real(*args, **kwargs)
        builds.append((args[3], out[0] is not None, out[1]))
        return out

    monkeypatch.setattr(module, "_build", counted)
    budget = 1e5
    for _ in range(8):  # each refusal names what the table costs at the least, as far as it got to see
        assert tilt_table(rough, W, "physical", budget=budget) is None
        if builds[-1][2] == 2 * budget:  # past its least cost, cut short in its series: retried at twice it
            break
        budget = 1.05 * builds[-1][2]
    else:
        raise AssertionError(f"never cut short in its series: {builds}")
    tried = len(builds)
    assert tilt_table(rough, W, "physical", budget=1.9 * budget) is None and len(builds) == tried  # not retried
    tilt_table(rough, W, "physical", budget=2.0 * budget)
    assert len(builds) == tried + 1 and builds[-1][0] == 2.0 * budget

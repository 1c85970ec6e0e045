"""Section 4 as it really is: (4.1)–(4.3) corrected, domes, and the boundary against full simulations."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbimpact as mbi


def test_formulas_match_the_linearised_rough_law():
    for rough in (mbi.Cone(0.3), mbi.Sawtooth(0.3), mbi.GaussianSlopes(0.3), mbi.GaussianSlopes(0.2, dim=2)):
        st = mbi.section4.stability(rough, 0.8, 1)
        d = rough.dim
        v = np.zeros(d)
        v[-1], v[0] = -1.0, 1e-7
        res = mbi.RoughLaw(rough, 0.8).apply(np.eye(d), np.eye(d), v, np.eye(d)[-1])
        assert -res.dv[0] / 1e-7 == pytest.approx(st.lam, rel=1e-6)  # (4.1)
        assert res.kappa == pytest.approx(st.kappa, rel=1e-9)  # (4.2)


def test_stability_is_0_below_rho_inverse_over_B_below_1_cups_and_domes():
    st = mbi.section4.stability(mbi.Sawtooth(0.7), 1.0, 1)
    assert 1 + st.kappa < st.lam <= 2 and st.B < 0 and st.stabilisable and st.surface == "dome"
    assert st.stable(0.5 * st.B) and not st.stable(1.5 * st.B) and not st.stable(0.01)
    cup = mbi.section4.stability(mbi.Cone(0.3), 0.8, 1)
    assert cup.surface == "cup" and cup.stable(0.5 * cup.B) and not cup.stable(-0.1) and not cup.stable(1.01 * cup.B)
    assert mbi.section4.stability(mbi.Cone(0.3), 0.8, 2).B == pytest.approx(cup.B / 4)
    # the boundary of (4.3) is where the linear map's largest eigenvalue reaches the unit circle
    for st, m in ((cup, 1), (mbi.section4.stability(mbi.Sawtooth(0.7), 1.0, 2), 2)):
        assert st.growth(0.999 * st.B, m) < 0 < st.growth(1.001 * st.B, m)
        assert st.growth(-0.001 * st.B, m) > 0 > st.growth(0.001 * st.B, m)
    # 3-D isotropic roughness: λ = e − κ, so B > 0 whenever κ ≥ 0 (the dome needs planar roughness)
    for alpha in (0.2, 0.5, 0.8):
        st = mbi.section4.stability(mbi.Cone(alpha), 0.9, 1)
        assert st.lam == pytest.approx(0.9 - st.kappa, rel=1e-12)
        assert st.kappa < 0 or st.B > 0


def test_a_measure_that_is_not_isotropic_is_refused():
    with pytest.raises(mbi.RoughnessError, match="not isotropic"):
        mbi.section4.stability(mbi.Facets(np.array([[0.3, 0.0, math.sqrt(0.91)]])), 0.8, 1)
    with pytest.raises(mbi.RoughnessError, match="not isotropic"):  # symmetric in x only
        mbi.section4.stability(mbi.Facets(np.array([[0.3, 0.0, math.sqrt(0.91)], [-0.3, 0.0, math.sqrt(0.91)]])), 0.8, 1)
    four = np.array([[0.3, 0.0, math.sqrt(0.91)], [-0.3, 0.0, math.sqrt(0.91)],
                     [0.0, 0.3, math.sqrt(0.91)], [0.0, -0.3, math.sqrt(0.91)]])  # square symmetry: isotropic here
    st = mbi.section4.stability(mbi.Facets(four), 0.8, 1)
    cone = mbi.section4.stability(mbi.Cone(math.asin(0.3)), 0.8, 1)
    assert st.lam == pytest.approx(cone.lam, rel=1e-12) and st.kappa == pytest.approx(cone.kappa, rel=1e-12)
    with pytest.raises(mbi.ParameterError, match="m"):
        mbi.section4.stability(mbi.Cone(0.3), 0.8, 0)


@pytest.mark.parametrize("rough, e, m, ratios", [
    (mbi.Cone(0.3), 0.8, 1, (-0.5, 0.5, 0.97, 1.03, 1.5)),
    (mbi.Cone(0.5), 0.8, 2, (-0.2, 0.2, 0.97, 1.03)),
    (mbi.Sawtooth(0.7), 1.0, 1, (-0.5, 0.03, 0.5, 0.97, 1.03)),  # B < 0: a dome with B < ρ⁻¹ < 0
])
def test_simulated_growth_follows_the_linear_map_and_changes_sign_at_B(rough, e, m, ratios):
    st = mbi.section4.stability(rough, e, m)
    for r in ratios:
        x = mbi.section4.deviation_run(rough, e, m, r * st.B, periods=20, x0=1e-7)
        assert len(x) == 20 or (len(x) >= 8 and abs(x[-1]) > 1e4 * 1e-7)  # a fast growth leaves the surface
        growth = mbi.section4.growth_rate(x)
        assert growth == pytest.approx(st.growth(r * st.B, m), rel=1e-3, abs=1e-4)
        assert (growth < 0) == (0 < r < 1)  # the boundary within 3 % of B (and at ρ⁻¹ = 0)


def test_a_dome_stabilises_when_lambda_exceeds_one_plus_kappa():
    """The paper's remark says no shape does; a dome with B < ρ⁻¹ < 0 does, a cup does not."""
    rough = mbi.Sawtooth(0.7)
    st = mbi.section4.stability(rough, 1.0, 1)
    dome = mbi.section4.deviation_run(rough, 1.0, 1, 0.5 * st.B, periods=24, x0=1e-4)
    cup = mbi.section4.deviation_run(rough, 1.0, 1, 0.01, periods=24, x0=1e-4)
    assert abs(dome[-1]) < 0.1 * 1e-4 and abs(cup[-1]) > 3 * 1e-4

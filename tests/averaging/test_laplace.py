"""The "laplace" averaging: Gaussian slopes with the physical flux by 1/mᵀWm = ∫ e^{−τ mᵀWm} dτ.

Checked against the corrected closed form (2.10) (W ∝ I), against the product rules on random and nearly
singular W, through the invariants (energy, isotropy), and in its declines and errors.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging import AUTO_ORDER, METHODS, Laplace
from tests.helpers import (UPRIGHT_UR5, mechanism, relative_du, seeds, spd, unit_velocities, upright_ur5_delassus,
                           upright_ur5_velocity)


def law(sigma: float = 0.3, e: float = 0.5, **kw) -> mbi.RoughLaw:
    return mbi.RoughLaw(mbi.GaussianSlopes(sigma), e, method="laplace", **kw)


def product_rule(sigma: float, W: np.ndarray, U: np.ndarray, e: float = 0.5) :
    """The same impulses by the tilt × azimuth product rule: graded where W is nearly singular, else plain."""
    for name in ("graded", "adaptive"):
        try:
            return mbi.RoughLaw(mbi.GaussianSlopes(sigma), e, rtol=1e-13, method=name).contact_impulses(W, U)
        except mbi.ParameterError:  # declined: not peaked enough to grade, or rounding
            continue
    raise AssertionError("no product rule settled")


def turn(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize("beta_deg", [0.0, 20.0, 45.0])
@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_a_point_mass_follows_the_corrected_closed_form(beta_deg, e):
    """W = I, G* = G (the facets' tilts stay far below π/2 − β): (2.10) with the corrected signs, the moments of
    the measure by quadrature in the tilt."""
    sigma = 0.1
    rough = mbi.GaussianSlopes(sigma)
    beta, psi = math.radians(beta_deg), 0.7
    v_l = math.sin(beta) * np.array([math.cos(psi), math.sin(psi)])
    v_n = math.cos(beta)  # |v_n|
    c1 = rough.moment(np.cos)
    c3 = rough.moment(lambda a: np.cos(a) ** 3)
    s2c = rough.moment(lambda a: np.sin(a) ** 2 * np.cos(a))
    expected = (1 + e) / c1 * np.array([*(-2 * v_l * s2c / 2), v_n * c3 + (v_l @ v_l) / v_n * s2c / 2])
    u = np.array([[*v_l, -v_n]])
    out = law(sigma, e).contact_impulses(np.eye(3), u)
    assert out.method == "laplace"
    np.testing.assert_allclose(out.P[0], expected, rtol=1e-12, atol=1e-13)


@settings(max_examples=100, deadline=None)
@given(seed=seeds, log_cond=st.floats(0.0, 7.0), sigma=st.floats(0.05, 2.0), beta=st.floats(0.0, 1.45))
def test_it_agrees_with_the_product_rules(seed, log_cond, sigma, beta):
    """Random W (eigenvalues up to 1e7 apart) and incidences: the product rule's impulse at rtol 1e-13, within
    the two error estimates, and the estimate of "laplace" below 1e-12."""
    rng = np.random.default_rng(seed)
    W = spd(rng, 3, 10**log_cond)
    psi = rng.uniform(0, 2 * math.pi)
    U = np.array([[math.sin(beta) * math.cos(psi), math.sin(beta) * math.sin(psi), -math.cos(beta)]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)
        ref = product_rule(sigma, W, U)
    out = law(sigma).contact_impulses(W, U)
    assert out.error[0] <= 1e-12
    assert relative_du(out.P, ref.P, W)[0] <= 10 * (out.error[0] + ref.error[0]) + 1e-13


@pytest.mark.parametrize("u", [[0.3, 0.1, -1.0], [1.0, 0.3, -0.2], [0.0, 1.0, -0.3], [0.0, 0.0, -1.0],
                               [1.0, 0.0, -1e-3]], ids=["bench", "oblique", "along-valley", "normal", "grazing"])
def test_a_stretched_arm(u):
    """The UR5 with the elbow straight (W's eigenvalues 1e7 apart, a valley of 1/mᵀWm with a point peak in
    it): the graded product rule's impulse, at a few hundred τ nodes whatever the peak's width."""
    W = upright_ur5_delassus()
    U = np.array([u]) / np.linalg.norm(u)
    out = law().contact_impulses(W, U)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.AccuracyWarning)
        ref = product_rule(0.3, W, U)
    assert out.method == "laplace" and out.nodes <= 400
    assert out.error[0] <= 1e-12
    assert relative_du(out.P, ref.P, W)[0] <= 10 * (out.error[0] + ref.error[0]) + 1e-13


def test_the_peak_just_outside_the_facing_half_plane():
    """The slope where mᵀWm is least sits a hair outside G*, the facets facing u: the half-plane's edge cuts
    the peak. The product rule agrees on both sides of the edge."""
    W = upright_ur5_delassus()
    lam, vec = np.linalg.eigh(W)
    w1 = vec[:, 0] if vec[2, 0] > 0 else -vec[:, 0]  # the facet normal where mᵀWm is least
    t = np.cross(w1, [0.0, 0.0, 1.0])
    u0 = np.cross(t, w1)
    u0 *= -np.sign(u0[2]) / np.linalg.norm(u0)  # ⟂ w₁, approaching
    for offset in (1e-3, -1e-3):  # w₁ᵀu = −offset: the peak just inside G*, then just outside
        u = u0 - offset * w1
        U = np.array([u / np.linalg.norm(u)])
        assert U[0, 2] < 0 and np.sign(-(U[0] @ w1)) == np.sign(offset)
        out = law().contact_impulses(W, U)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mbi.AccuracyWarning)
            ref = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, rtol=1e-13, method="graded").contact_impulses(W, U)
        assert relative_du(out.P, ref.P, W)[0] <= 10 * (out.error[0] + ref.error[0]) + 1e-13


@settings(max_examples=60, deadline=None)
@given(seed=seeds, log_cond=st.floats(0.0, 9.0), angle=st.floats(0.0, 2 * math.pi))
def test_energy_never_grows_and_the_answer_turns_with_the_frame(seed, log_cond, angle):
    """T₊ ≤ T₋ (uᵀW⁻¹u does not grow), and an isotropic measure gives the same physical impulse in a tangent
    frame turned about the normal."""
    rng = np.random.default_rng(seed)
    W = spd(rng, 3, 10**log_cond)
    U = unit_velocities(rng, 3, 1.5)
    out = law(e=rng.uniform(0, 1)).contact_impulses(W, U)
    Winv = np.linalg.inv(W)
    for u, P in zip(U, out.P):
        up = u + W @ P
        assert up @ Winv @ up <= (u @ Winv @ u) * (1 + 1e-9)
    R = turn(angle)
    turned = law().contact_impulses(R @ W @ R.T, U @ R.T)
    assert relative_du(turned.P @ R, law().contact_impulses(W, U).P, W).max() <= 1e-11


def test_rows_of_a_batch_are_the_single_calls():
    rng = np.random.default_rng(3)
    W = spd(rng, 3, 1e4)
    U = unit_velocities(rng, 5, 1.4)
    batch = law().contact_impulses(W, U)
    for i in range(len(U)):
        one = law().contact_impulses(W, U[i:i + 1])
        np.testing.assert_array_equal(one.P[0], batch.P[i])
        assert one.nodes <= batch.nodes


def test_auto_takes_it_for_gaussian_slopes_with_the_physical_flux():
    """Single velocities and batches below the tilt table's size; the configuration flux, a planar measure, a
    fixed node count and other facet laws keep the product rules."""
    rng = np.random.default_rng(5)
    W, U = spd(rng, 3, 20.0), unit_velocities(rng, 3, 1.2)
    auto = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5)
    assert auto.contact_impulses(W, U[:1]).method == "laplace"
    assert auto.contact_impulses(W, U).method == "laplace"
    assert auto.contact_impulses(upright_ur5_delassus(), U[:1]).method == "laplace"
    assert AUTO_ORDER.index("tilt-table") < AUTO_ORDER.index("laplace") < AUTO_ORDER.index("graded")
    assert auto.replace(flux="configuration").contact_impulses(W, U[:1]).method == "adaptive[compiled]"
    assert auto.replace(nodes=16).contact_impulses(W, U[:1]).method == "fixed"
    planar = mbi.RoughLaw(mbi.GaussianSlopes(0.3, dim=2), 0.5)
    assert planar.contact_impulses(W[:2, :2], np.array([[0.6, -0.8]])).method == "adaptive[compiled]"
    coulomb = mbi.RoughLaw(mbi.GaussianSlopes(0.3), facet=mbi.CoulombFacet(0.2, 0.5))
    assert not Laplace().supports(coulomb.spec)
    assert METHODS["laplace"] is Laplace


def test_the_impact_of_a_stretched_arm():
    """Through mbi.impact: the UR5 at its near-singular posture, the numpy graded rule's velocities."""
    mech = mechanism("ur5")
    v = upright_ur5_velocity()
    contact = mbi.PointContact("tool0")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        fast = mbi.impact(mech, UPRIGHT_UR5, v, contact, mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5))
        slow = mbi.impact(mech, UPRIGHT_UR5, v, contact, mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, method="graded"))
    assert fast.method == "laplace" and slow.method == "graded[compiled]"
    assert np.linalg.norm(fast.u_plus - slow.u_plus) <= 1e-10 * np.linalg.norm(fast.u_minus)
    assert fast.energy_loss >= 0


@pytest.mark.parametrize("make", [
    lambda: mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, flux="configuration"),
    lambda: mbi.RoughLaw(mbi.GaussianSlopes(1e-9), 0.5),  # below Laplace.min_sigma
    lambda: mbi.RoughLaw(mbi.IsotropicSlopes(mbi.GaussianSlopes(0.3).pdf, support=(0.0, 0.5)), 0.5),  # cut
    lambda: mbi.RoughLaw(mbi.Cone(0.3), 0.5),
], ids=["configuration-flux", "sigma-too-small", "support-cut", "cone"])
def test_naming_it_where_it_does_not_apply_says_what_does(make):
    base = make()
    assert not Laplace().supports(base.spec)
    with pytest.raises(mbi.ParameterError, match="cannot average .*; methods for this measure: ") as info:
        base.replace(method="laplace")
    listed = str(info.value).rsplit(": ", 1)[1].split(", ")
    assert "laplace" not in listed and "adaptive" in listed


def test_it_declines_a_facet_the_mechanism_cannot_push():
    """W of rank 2 whose null direction is a facet normal of the measure: mᵀWm = 0 there, the kernel's integral
    diverges. "laplace" declines (naming it is a ParameterError), and "auto" goes on to the product rules."""
    m0 = np.array([0.1, 0.0, 1.0]) / math.sqrt(1.01)
    P0 = np.eye(3) - np.outer(m0, m0)
    W = P0 @ np.diag([1.0, 2.0, 3.0]) @ P0
    W = 0.5 * (W + W.T)
    U = np.array([[0.0, 0.0, -1.0]])
    assert Laplace().average(law().spec, W, U) is None
    with pytest.raises(mbi.ParameterError, match="cannot be pushed"):
        law().contact_impulses(W, U)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.ImpactWarning)
        try:
            method = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5).contact_impulses(W, U).method
        except mbi.ImpactError:
            method = None
    assert method != "laplace"


def test_an_rtol_beyond_rounding_settles_at_rounding_and_says_so():
    """rtol 1e-17: the levels settle where they agree to the rounding of their sums (100 ε √K, as every rule's),
    and the estimate, with the rounding that no level reduces, says what was reached."""
    W, U = upright_ur5_delassus(), np.array([[0.3, 0.1, -1.0]]) / math.sqrt(1.1)
    tight = law(rtol=1e-17).contact_impulses(W, U)
    assert 1e-17 < tight.error[0] < 1e-12
    out = law(rtol=1e-6).contact_impulses(W, U)  # a loose rtol settles on fewer nodes, its estimate honest
    ref = law().contact_impulses(W, U)
    assert out.nodes < ref.nodes and relative_du(out.P, ref.P, W)[0] <= max(out.error[0], 1e-12)


def test_its_kernels_are_registered():
    out = mbi.compile_kernels()
    assert "mbimpact.averaging.compiled.laplace" in out

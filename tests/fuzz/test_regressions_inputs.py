"""Regressions of the input fuzzer's reproducers in the metric, averaging kernels, contacts and restitution.

One test per reproducer (some parametrised over its close variants). Each asserts the exact named
error class and a fragment of its message, or the physics of a finite result, with warnings turned
into errors (no numpy ``RuntimeWarning`` may leak), and runs its calls under
:func:`tests.helpers.time_limit`.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Iterator

import numpy as np
import pytest

import mbimpact as mbi
from tests.helpers import UPRIGHT_UR5, mechanism, time_limit

LIMIT = 30.0  # seconds per test: generous on a busy 2-core machine
LAWS = [mbi.NewtonLaw(0.5), mbi.RoughLaw(mbi.Cone(0.3), 0.5), mbi.CoulombLaw(0.5, 0.3)]
N0 = np.array([0.0, 0.0, 1.0])
DOWN = np.array([0.0, 0.0, -1.0])


@pytest.fixture(autouse=True)
def strict() -> Iterator[None]:
    """Every warning but mbimpact's own honest ones is an error (a RuntimeWarning leaking out fails the
    test), under a time limit."""
    with warnings.catch_warnings(), time_limit(LIMIT):
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", mbi.ImpactWarning)  # e.g. κ < 0 of a rough law: a result, flagged
        yield


# ---------------------------------------------------------------- 1. local_basis(n0, d=array)

@pytest.mark.parametrize("d", [np.array([3, 3]), np.array([3]), np.array(3.5), "3", None, 2.5, True, math.nan])
def test_local_basis_dimension_that_is_not_an_integer(d):
    """d = np.array([3, 3]) raised numpy's ambiguous-truth ValueError (and np.array([3]) passed)."""
    with pytest.raises(mbi.ParameterError, match="must be the integer 2 or 3"):
        mbi.local_basis(N0, d)
    contact = mbi.PointContact("tool0")
    with pytest.raises(mbi.ParameterError, match="must be the integer 2 or 3"):
        contact.jacobian(mechanism("ur5"), UPRIGHT_UR5, d)


@pytest.mark.parametrize("d", [3.0, np.int64(3), np.float64(3.0)])
def test_local_basis_dimension_given_as_another_integral_number(d):
    np.testing.assert_array_equal(mbi.local_basis(N0, d), mbi.local_basis(N0, 3))


# ---------------------------------------------------------------- 2. RoughLaw(flux=array)

@pytest.mark.parametrize("flux", [np.array([1.0, 2.0]), np.array(["physical", "configuration"]),
                                  np.array("physical"), ["physical"], 1.0])
def test_rough_law_flux_that_is_not_a_string(flux):
    """flux = np.array([1.0, 2.0]) raised numpy's ambiguous-truth ValueError in check_flux."""
    with pytest.raises(mbi.ParameterError, match=re.escape("flux must be 'physical'") + ".*'configuration'"):
        mbi.RoughLaw(mbi.Cone(0.3), 0.5, flux=flux)


def test_rough_law_flux_as_a_numpy_string_still_works():
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5, flux=np.str_("configuration"))
    ref = mbi.RoughLaw(mbi.Cone(0.3), 0.5, flux="configuration")
    A, J = np.eye(3), np.array([[1.0, 0.0, 0.3], [0.0, 1.0, 0.0], [0.0, 0.2, 1.0]])
    np.testing.assert_array_equal(law.apply(A, J, DOWN, N0).P, ref.apply(A, J, DOWN, N0).P)


# ---------------------------------------------------------------- 3. J with entries > 1e150

@pytest.mark.parametrize("law", LAWS, ids=repr)
@pytest.mark.parametrize("A, J", [(np.eye(3), 1e200 * np.eye(3)),  # the reproducer
                                  (1e-310 * np.eye(3), np.eye(3)),  # subnormal A: A⁻¹ Jᵀ overflowed in a division
                                  (1e-200 * np.eye(3), 1e60 * np.eye(3))])
def test_huge_contact_jacobian_is_named(law, A, J):
    """J A⁻¹ Jᵀ overflowed with a RuntimeWarning (metric/delassus.py, and laws/newton.py's J Jᵀ)."""
    with pytest.raises(mbi.NonFiniteError, match=re.escape("J A⁻¹ Jᵀ overflows") + ".*must stay below"):
        law.apply(A, J, DOWN, N0)


@pytest.mark.parametrize("law", LAWS[1:], ids=repr)
def test_delassus_matrix_that_overflows_through_an_ill_conditioned_mass_matrix_is_named(law):
    """max |J|² / (n max |A|) is small, but J A⁻¹ Jᵀ overflows along A's tiny eigenvalue."""
    A, J = np.diag([1.0, 1.0, 1e-160]), 1e80 * np.eye(3)
    with pytest.raises(mbi.NonFiniteError, match=re.escape("the Delassus matrix W = J A⁻¹ Jᵀ overflows")):
        law.apply(A, J, DOWN, N0)


@pytest.mark.parametrize("law", LAWS, ids=repr)
def test_delassus_matrix_within_a_factor_two_of_the_largest_float_is_named(law):
    """W_00 = 1.2e308 is finite, but its symmetrisation ½(W + Wᵀ) gave inf, and tr W, n⁰ᵀ W n⁰ NaN
    with a RuntimeWarning (laws/base.py, laws/coulomb.py)."""
    A = np.array([[2.0, 0.3, 0.1], [0.3, 1.0, 0.2], [0.1, 0.2, 1.5]])
    J = np.array([[1.5e154, 0.2, 0.0], [0.0, 1.0, 0.3], [0.1, 0.0, 1.0]])
    v = np.array([0.3, -0.2, -1.0])
    fragment = re.escape("the Delassus matrix W = J A⁻¹ Jᵀ overflows")
    with pytest.raises(mbi.NonFiniteError, match=fragment):
        law.apply_batch(A, J, np.stack([v, 2.0 * v]), N0)
    if not isinstance(law, mbi.NewtonLaw):  # Newton's single impact forms J Jᵀ first (laws/newton.py)
        with pytest.raises(mbi.NonFiniteError, match=fragment):
            law.apply(A, J, v, N0)


@pytest.mark.parametrize("law", LAWS, ids=repr)
@pytest.mark.parametrize("a, j", [(1e300, 1e150), (5e307, 1e153), (1e-300, 1e-150)])
def test_huge_or_tiny_but_balanced_mass_matrix_and_jacobian_give_the_unscaled_impact(law, a, j):
    """J → jJ, A → j²A leaves W = J A⁻¹ Jᵀ, hence the post-impact velocity, unchanged however large j is."""
    A3 = np.array([[2.0, 0.3, 0.1], [0.3, 1.0, 0.2], [0.1, 0.2, 1.5]])
    J3 = np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.3], [0.1, 0.0, 1.0]])
    v = np.array([0.3, -0.2, -1.0])
    ref = law.apply(A3, J3, v, N0)
    res = law.apply(a * A3, j * J3, v, N0)
    np.testing.assert_allclose(res.v_plus, ref.v_plus, rtol=1e-9, atol=1e-12)
    assert np.all(np.isfinite(res.P)) and np.all(np.isfinite(res.u_plus))


# ---------------------------------------------------------------- 4. A with entries > 1e150, not positive definite

@pytest.mark.parametrize("A, error, fragment", [
    (np.diag([-1.7e308, 1.0, 1.0]), mbi.NotPositiveDefiniteError, "smallest eigenvalue -1.7e+308 (must be > 0)"),
    ([[-1.7e308, 1.7e308, 0.0], [1.7e308, -1.7e308, 0.0], [0.0, 0.0, 1.0]], mbi.NotPositiveDefiniteError,
     "(beyond the float range) (must be > 0)"),  # λ_min = -3.4e308
    ([[1e-10, 1e308, 0.0], [1e308, 1e-10, 0.0], [0.0, 0.0, 1.0]], mbi.NotPositiveDefiniteError,
     "smallest eigenvalue -1e+308"),  # A / max diag overflowed
    ([[1.0, 1.7e308, 0.0], [-1.7e308, 1.0, 0.0], [0.0, 0.0, 1.0]], mbi.NotPositiveDefiniteError,
     "A is not symmetric: max |A - Aᵀ| = beyond the largest float"),  # A - Aᵀ overflowed
    (np.zeros((3, 3)), mbi.NotPositiveDefiniteError, "all its entries are zero"),
])
@pytest.mark.parametrize("law", LAWS, ids=repr)
def test_huge_mass_matrix_that_is_not_positive_definite_is_named(law, A, error, fragment):
    """½(A + Aᵀ) overflowed with a RuntimeWarning while the error was being named."""
    with pytest.raises(error, match=re.escape(fragment)):
        law.apply(A, np.eye(3), DOWN, N0)
    with pytest.raises(error, match=re.escape(fragment)):
        mbi.ContactMetric.from_arrays(A, np.eye(3))


# ---------------------------------------------------------------- 5. PointContact(point=1.7e308)

@pytest.mark.parametrize("point", [[1.7e308, 0.0, 0.0], [0.0, -1e200, 0.0], [1e151, 1e151, 1e151]])
def test_point_contact_offset_beyond_1e150_is_named(point):
    """impact() with a point 1.7e308 away overflowed with RuntimeWarnings in R p, [r]ₓ J and J Jᵀ."""
    with pytest.raises(mbi.ParameterError, match=re.escape("lies too far from the frame origin") + ".*1e\\+150"):
        mbi.PointContact("tool0", point=point)


@pytest.mark.parametrize("law", LAWS, ids=repr)
def test_point_contact_far_but_within_range_gives_a_finite_impact(law):
    mech = mechanism("ur5")
    q = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
    contact = mbi.PointContact("tool0", point=[1e100, 0.0, 0.0])
    J, _ = contact.jacobian(mech, q)
    v = -J[2] / np.abs(J[2]).max()  # the point moves down
    res = mbi.impact(mech, q, v, contact, law)
    assert np.all(np.isfinite(res.v_plus)) and np.all(np.isfinite(res.P)) and np.all(np.isfinite(res.u_plus))
    if isinstance(law, mbi.NewtonLaw):
        assert res.u_plus[2] == pytest.approx(-0.5 * res.u_minus[2], rel=1e-9)


# ---------------------------------------------------------------- 6. impact_duration(M=5e-324)

@pytest.mark.parametrize("M, k", [(5e-324, 0.5), (5e-324, 0.9999999999), (1e-310, 0.0), (1e-300, 1 - 2**-53)])
def test_impact_duration_beyond_the_float_range_is_named(M, k):
    """M = 5e-324 returned inf, and M √(1 - k²) underflowing to 0 raised ZeroDivisionError."""
    fragment = r"is too small for k = .*exceeds the largest float; M must be at least"
    with pytest.raises(mbi.ParameterError, match=fragment):
        mbi.impact_duration(M, k)


@pytest.mark.parametrize("M, k", [(1e-300, 0.0), (1.7976931348623157e308, 1 - 2**-53), (1.0, 0.5), (2.1e-308, 0.0)])
def test_impact_duration_at_the_ends_of_the_range_is_finite(M, k):
    tau = mbi.impact_duration(M, k)
    assert math.isfinite(tau) and tau > 0.0
    assert tau == pytest.approx(math.pi / math.sqrt(1.0 - k * k) / M, rel=1e-15)


@pytest.mark.parametrize("x", [0.0, 5e-324, 1e-310, 1e-300, 1e-16, 0.5, 1 - 1e-16, 1 - 2**-53, 1.0])
def test_restitution_conversions_at_the_ends_of_their_range(x):
    e, k = mbi.e_from_k(x), mbi.k_from_e(x)
    assert 0.0 <= e <= 1.0 and 0.0 <= k <= 1.0
    assert math.copysign(1.0, k) == 1.0  # k_from_e(1) was -0.0
    if 1e-300 < e < 1.0:
        assert mbi.k_from_e(e) == pytest.approx(x, rel=1e-6)


# ---------------------------------------------------------------- 7. magnitudes beyond the float range

A3 = np.array([[2.0, 0.3, 0.1], [0.3, 1.5, 0.2], [0.1, 0.2, 1.0]])
J3 = np.array([[1.0, 0.2, 0.0], [0.1, 1.0, 0.3], [0.0, 0.2, 1.0]])
V3 = np.array([0.1, 0.2, -1.0])


@pytest.mark.parametrize("law", LAWS, ids=repr)
@pytest.mark.parametrize("v, fragment", [
    (np.array([1.7e308, 0.0, -1.7e308]), "beyond the float range"),  # J v at the edge: was NaN (Newton)
    (np.array([0.0, 0.0, -1.7e308]), "beyond the float range"),  # P and v₊ overflow
    (np.array([1.7e308, 1.7e308, -1.7e308]), "the contact velocity J v"),  # J v itself overflows
])
def test_velocities_whose_impact_overflows_are_named(law, v, fragment):
    """A finite v whose contact velocity or impulse lies beyond the float range: a NonFiniteError, for the
    single impact and the batch (the Newton fast path returned NaN with a RuntimeWarning)."""
    with pytest.raises(mbi.NonFiniteError, match=fragment):
        law.apply(A3, J3, v, N0)
    with pytest.raises(mbi.NonFiniteError, match="beyond the float range"):
        law.apply_batch(A3, J3, np.stack([v, V3]), N0)


@pytest.mark.parametrize("law", LAWS, ids=repr)
def test_delassus_matrix_below_the_float_range_is_named(law):
    """A = 1e300 A₃, J = 1e-10 J₃: W ~ 1e-320 (subnormal), so P = −(1+e) u / W overflows although Δv is
    small. Named, without the RuntimeWarnings of base.py, newton.py and coulomb.py."""
    with pytest.raises(mbi.NonFiniteError, match="beyond the float range"):
        law.apply(1e300 * A3, 1e-10 * J3, V3, N0)
    with pytest.raises(mbi.NonFiniteError, match="beyond the float range"):
        law.apply_batch(1e300 * A3, 1e-10 * J3, np.stack([V3, V3]), N0)


@pytest.mark.parametrize("law", LAWS, ids=repr)
def test_huge_jacobian_with_a_huge_mass_matrix_is_the_scaled_impact(law):
    """A = 1e300 A₃, J = 1e200 J₃: W = 1e100 W₃ is finite, but J Jᵀ (Newton's rank test) overflowed with a
    RuntimeWarning. By homogeneity (degree −1 in W, P ∝ u / W) the impulse is 1e-100 that of (A₃, J₃) at
    u = 1e200 J₃ v, i.e. 1e100 that at v; Δv is unchanged."""
    ref = law.apply(A3, J3, V3, N0)
    out = law.apply(1e300 * A3, 1e200 * J3, V3, N0)
    np.testing.assert_allclose(out.dv, ref.dv, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(out.P, 1e100 * ref.P, rtol=1e-9, atol=1e-12 * 1e100)


# ---------------------------------------------------------------- 8. CoulombLaw arguments

@pytest.mark.parametrize("mu", [1e6 * (1 + 1e-15), 1e12, 1e160, 1.7e308])
def test_coulomb_friction_beyond_its_range_is_named(mu):
    """mu = 1e160 raised OverflowError at apply time (and mu ≥ 1e14 jammed): the range is [0, 1e6], as
    for CoulombFacet."""
    with pytest.raises(mbi.ParameterError, match=r"mu = .* is outside \[0, 1e\+06\]"):
        mbi.CoulombLaw(0.5, mu)


def test_coulomb_friction_at_the_top_of_its_range_sticks():
    """mu = 1e6 on a generic W: the slip stops within a normal impulse ~1e-6 of the impact's, so the
    outcome is within ~1e-5 of mu = 1e5's and the tangential contact velocity ends at zero (stick)."""
    W = np.array([[0.035, 0.0075, 0.018], [0.0075, 0.052, 0.0135], [0.018, 0.0135, 0.024]])
    A = np.linalg.inv(W)
    for kind in ("newton", "poisson", "energetic"):
        hi = mbi.CoulombLaw(0.5, 1e6, kind).apply(0.5 * (A + A.T), I3 := np.eye(3), [0.3, 0.1, -1.0], N0)
        lo = mbi.CoulombLaw(0.5, 1e5, kind).apply(0.5 * (A + A.T), I3, [0.3, 0.1, -1.0], N0)
        assert np.all(np.isfinite(hi.P)) and np.abs(hi.P - lo.P).max() < 1e-4 * np.abs(hi.P).max()
        assert np.hypot(*hi.u_plus[:2]) < 1e-8


@pytest.mark.parametrize("restitution", [np.array(["newton", "poisson"]), np.array("newton")[None], 1, None])
def test_coulomb_restitution_that_is_not_a_name(restitution):
    """An array raised numpy's ambiguous-truth ValueError."""
    with pytest.raises(mbi.ParameterError, match="restitution must be one of newton, poisson, energetic"):
        mbi.CoulombLaw(0.5, 0.3, restitution)


# ---------------------------------------------------------------- Newton's law at a nearly rank-deficient J

def _nearly_rank_deficient(seed: int, sigma_min: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A (7×7, cond ~1e4), J (3×7) with singular values 0.3, 0.2, sigma_min, an approaching v and n⁰ — the
    shape of the robot fuzzer's xarm7 reproducer (link4, singular values 0.30, 0.20, 1.1e-7)."""
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(7, 7)))
    A = Q @ np.diag(np.geomspace(1e-2, 1e2, 7)) @ Q.T
    U, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    V, _ = np.linalg.qr(rng.normal(size=(7, 3)))
    J = U @ np.diag([0.3, 0.2, sigma_min]) @ V.T
    n0 = rng.normal(size=3)
    n0 /= np.linalg.norm(n0)
    v = rng.normal(size=7)
    return A, J, (v if n0 @ J @ v < 0 else -v), n0


@pytest.mark.parametrize("sigma_min", [1e-7, 1e-5, 0.0])
@pytest.mark.parametrize("seed", range(4))
def test_newton_at_a_nearly_rank_deficient_jacobian_is_exact(seed, sigma_min):
    """The robot fuzzer's xarm7 reproducer (pin.seed(103), link4): Newton's Δv differed from the dense
    solution by 2.5e-5 relative because a nearly rank-deficient J (σ_min/σ_max ≈ 4e-7, W's eigenvalues
    1e-13 apart) took the general route, which projects P on range(W) and moves Δv by up to
    √(λ_min/λ_max) |Δv|. Newton's impulse is P_n n⁰ whatever the rank: single calls, batches and the
    compiled impact on A's factor (stacked) agree with the dense solution to rounding × cond A, and report
    I = A Δv."""
    A, J, v, n0 = _nearly_rank_deficient(seed, sigma_min)
    y = np.linalg.solve(A, J.T @ n0)
    jn = n0 @ J
    expected = v - 1.5 * (jn @ v) / (jn @ y) * y
    law = mbi.NewtonLaw(0.5)
    tol = 1e4 * 1e-14 * np.abs(v).max()
    res = law.apply(A, J, v, n0)
    np.testing.assert_allclose(res.v_plus, expected, rtol=0, atol=tol)
    np.testing.assert_allclose(res.P, res.P_n * n0, rtol=0, atol=1e-14 * abs(res.P_n))
    assert res.residual < 1e-12
    batch = law.apply_batch(A, J, np.stack([v, 2 * v]), n0)
    np.testing.assert_allclose(batch.V_plus, [expected, 2 * expected], rtol=0, atol=2 * tol)
    # A = U D Uᵀ, U unit upper triangular (Pinocchio's layout): Cholesky of A with its axes reversed
    rev = np.arange(len(A))[::-1]
    upper = np.linalg.cholesky(A[np.ix_(rev, rev)])[np.ix_(rev, rev)]
    D = np.diag(upper) ** 2
    Uf = upper / np.diag(upper)[None, :]
    R = mbi.local_basis(n0, 3)
    stacked = law.compiled_impact().run_stack(law, np.stack([A, A]), np.stack([Uf, Uf]), np.stack([D, D]),
                                              np.stack([J, J]), np.stack([v, 2 * v]), np.stack([R, R]),
                                              lambda i: pytest.fail(f"row {i} declined"))
    np.testing.assert_allclose(stacked.V_plus, [expected, 2 * expected], rtol=0, atol=2 * tol)


# ---------------------------------------------------------------- foreign warnings become mbimpact's

def test_a_tilt_density_quad_cannot_integrate_warns_in_mbimpacts_tree():
    """The nightly input fuzzer: scipy's IntegrationWarning (a UserWarning) leaked from the mass integral
    of an IsotropicSlopes density that quad cannot resolve. It is now an AccuracyWarning saying what
    failed; nothing else is emitted (the strict fixture turns any other warning into an error)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mbi.IsotropicSlopes(lambda a: 1.0 + np.sin(1.0 / (a - 0.3 + 1e-9)), 3, (0.1, 0.5))
    assert [w.category for w in caught] == [mbi.AccuracyWarning]
    assert "did not converge to rtol=1e-13" in str(caught[0].message)


@pytest.mark.parametrize("scale", [1e-300, 1e-150, 1e150, 1e300])
def test_lsoda_complaints_are_named_not_leaked(scale):
    """LSODA reports failures as a UserWarning ("lsoda: Excess accuracy requested …", found for
    velocities near the float range's ends): it leaked beside the IntegrationError. Its text is now
    part of the named error (or an AccuracyWarning when LSODA went on); no foreign warning escapes
    (the strict fixture makes any an error)."""
    mech = mechanism("ur5")
    q = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])  # the input fuzzer's UR5 posture and velocity
    v = np.linalg.lstsq(mech.point_jacobian(q, "tool0"), [0.3, 0.0, -1.0], rcond=None)[0] * scale
    try:
        mbi.resolve(mech, q, v, mbi.PointContact("tool0"), facets=np.array([math.sin(0.2), 0.0, math.cos(0.2)]),
                    M=1e3, e=0.5, dynamics="impact", rtol=1e-8, method="LSODA", t_max=0.5)
    except mbi.IntegrationError as err:
        if str(err).startswith("integration stopped"):  # LSODA gave up: what it said is in the message
            assert "(lsoda: " in str(err)
    except mbi.ImpactError:
        pass

"""One velocity on an isotropic tilt density: the adaptive rule's compiled backend against its numpy form.

The backend runs the adaptive rule of the measure's own product rule (the same tilt segments, azimuth
nodes and doubling) in one compiled call: it must reproduce :meth:`mbimpact.averaging.Adaptive.reference`
to rounding (amplified, as every impulse of (2.8) is, by |W| |P| / |W P|), decide alike when to stop, and
leave to the numpy rule exactly what that would warn of or raise. Closed forms where (2.8) has one: a point mass (W ∝ I) at normal incidence, and
the rotational symmetry of a tangentially isotropic W.
"""

from __future__ import annotations

import ast
import math
import os
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging import Adaptive, backends
from mbimpact.averaging.backends import FIRST_LEVELS
from mbimpact.averaging.compiled import SLOPES as KERNELS
from mbimpact.errors import AccuracyWarning, NoFacingFacetError, ParameterError
from mbimpact.roughness.slopes import GaussianTiltDensity

from tests.helpers import relative_du, seeds, spd, unit_velocities, upright_ur5_delassus

EPS = np.finfo(float).eps
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True, scope="module")
def _compiled() -> None:
    """Load (or, with a cold numba cache, compile: ~10 s) the kernels before the tests."""
    KERNELS.compile()


def velocities(rng: np.random.Generator, d: int, count: int) -> np.ndarray:
    """Unit local-frame velocities over all incidences (both regimes); planar ones on both sides."""
    U = unit_velocities(rng, count)
    if d == 3:
        return U
    side = np.where(np.arange(count) % 2 == 0, 1.0, -1.0)
    return np.column_stack([side * np.hypot(U[:, 0], U[:, 1]), U[:, 2]])


def adaptive(law: mbi.RoughLaw, W: np.ndarray, u: np.ndarray) -> tuple[mbi.ContactImpulses | None, bool]:
    """The numpy adaptive rule on one velocity, and whether it stopped short of rtol (warned) or
    found no facing facet (raised: None)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            out = Adaptive().reference(law.spec, W, u[None])
        except NoFacingFacetError:
            return None, True
    return out, any(issubclass(w.category, AccuracyWarning) for w in caught)


def compiled(spec, W: np.ndarray, U: np.ndarray) -> mbi.ContactImpulses | None:
    """The adaptive rule's compiled backend: its impulses where it settles, else None."""
    return backends.adaptive(spec, W, U)[1]


def check_against_adaptive(law: mbi.RoughLaw, W: np.ndarray, u: np.ndarray) -> mbi.ContactImpulses | None:
    """The compiled rule equals the numpy rule: the same impulse to rounding, the same error estimate and
    node count; or it does not settle, exactly where the numpy rule stops short."""
    fast = compiled(law.spec, W, u[None])
    slow, short = adaptive(law, W, u)
    if fast is None:
        assert short, "declined a velocity the adaptive rule settles"
        return None
    assert not short, "settled a velocity on which the adaptive rule warns"
    assert slow is not None and fast.method == "adaptive[compiled]" and fast.P.shape == (1, len(u))
    floor = 100 * EPS * math.sqrt(law.roughness.rule_size(fast.nodes))
    assert fast.error[0] <= max(law.rtol, floor)
    # rounding, amplified by |W| |P| / |W P| (the adaptive rule's measure of it); seen up to ~8 ε that
    amplification = np.trace(W) * np.linalg.norm(slow.P) / np.linalg.norm(slow.P @ W)
    rounding = 50 * EPS * amplification
    if fast.nodes == slow.nodes:
        assert relative_du(fast.P, slow.P, W)[0] < rounding
        assert abs(fast.error[0] - slow.error[0]) < rounding
    else:  # an estimate within rounding of rtol: the two stop a level apart, both within rtol
        assert abs(math.log2(fast.nodes / slow.nodes)) == 1
        assert min(fast.error[0], slow.error[0]) > 0.5 * law.rtol
        assert relative_du(fast.P, slow.P, W)[0] < 4 * law.rtol
    return fast


@given(seeds, st.floats(math.log(0.05), math.log(3.0)), st.floats(0.0, 3.0), st.floats(0.0, 1.0),
       st.sampled_from(["physical", "configuration"]), st.sampled_from([3, 2]))
def test_gaussian_slopes_equal_the_adaptive_rule(seed, log_sigma, log_cond, e, flux, d):
    """Random SPD W (anisotropic, cond up to 1e3), unit velocities of all incidences, σ from 0.05 to
    3, e in [0, 1], both fluxes, spatial and planar measures."""
    rng = np.random.default_rng(seed)
    cond = 10.0**log_cond
    W = spd(rng, d, cond)
    law = mbi.RoughLaw(mbi.GaussianSlopes(math.exp(log_sigma), dim=d), e, flux=flux)
    for u in velocities(rng, d, 4):
        check_against_adaptive(law, W, u)


def bimodal(alpha: np.ndarray) -> np.ndarray:
    """A tilt density that is not Gaussian (two bumps), on a support that starts above 0."""
    return np.exp(-(((alpha - 0.4) / 0.1) ** 2)) + 0.5 * np.exp(-(((alpha - 1.0) / 0.2) ** 2))


@given(seeds, st.floats(0.0, 3.0), st.sampled_from(["physical", "configuration"]), st.sampled_from([3, 2]))
def test_tabulated_density_equals_the_adaptive_rule(seed, log_cond, flux, d):
    """Any other tilt density (a Python callable) is tabulated at the rule's tilt nodes: the same
    result as the adaptive rule's."""
    rng = np.random.default_rng(seed)
    cond = 10.0**log_cond
    W = spd(rng, d, cond)
    law = mbi.RoughLaw(mbi.IsotropicSlopes(bimodal, dim=d, support=(0.1, 1.3)), 0.5, flux=flux)
    for u in velocities(rng, d, 3):
        check_against_adaptive(law, W, u)


@pytest.mark.parametrize("tabulated", [False, True])
def test_refinement_beyond_the_first_table(tabulated):
    """A velocity that needs more than the first call's levels (8 … 64 nodes) goes on where the
    kernel stopped, with the nodes of every level up to max_nodes, and still equals the adaptive
    rule."""
    rng = np.random.default_rng(7)
    density = GaussianTiltDensity(2.0, 3)
    # a callable that is not the GaussianTiltDensity itself: tabulated, not the kernel's closed form
    rough = mbi.IsotropicSlopes(lambda a: density(a), support=(0.0, math.atan(22.0))) if tabulated \
        else mbi.GaussianSlopes(2.0)
    law = mbi.RoughLaw(rough, 0.5)
    deep = []
    for _ in range(6):
        W = spd(rng, 3, 300.0)
        for u in velocities(rng, 3, 4):
            out = check_against_adaptive(law, W, u)
            if out is not None and out.nodes > rough.initial_nodes << (FIRST_LEVELS - 1):
                deep.append(out.nodes)
    assert deep, "no velocity needed more than the first levels: the test lost its point"


@given(seeds, st.sampled_from([3, 2]))
def test_rank_deficient_delassus_matrix(seed, d):
    """W of rank d − 1 (a mechanism that cannot move the contact point along one direction): facets
    it cannot push are left out alike, and where W nearly annihilates the impulse the adaptive rule
    stops at rounding with a warning, and the compiled pass declines."""
    rng = np.random.default_rng(seed)
    B = rng.normal(size=(d, d - 1))
    W = B @ B.T
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.5, dim=d), 0.5)
    for u in velocities(rng, d, 4):
        check_against_adaptive(law, W, u)


def test_odd_first_level():
    """max_nodes = 10 starts the rule at 5 nodes a piece (odd: no mirror pairs of nodes)."""
    rng = np.random.default_rng(11)
    for d in (3, 2):
        W = spd(rng, d, 10.0)
        law = mbi.RoughLaw(mbi.GaussianSlopes(0.3, dim=d), 0.5, rtol=1e-3, max_nodes=10)
        for u in velocities(rng, d, 5):
            out = check_against_adaptive(law, W, u)
            assert out is None or out.nodes == 10


@pytest.mark.parametrize("d", [3, 2])
@pytest.mark.parametrize("flux", ["physical", "configuration"])
@pytest.mark.parametrize("sigma", [0.05, 0.3, 3.0])
def test_point_mass_at_normal_incidence(d, flux, sigma):
    """W = w I and u = −n⁰: every ring faces u whole, and (2.8) is P = (1+e) E[cos³α] / (w E[cos α]) n⁰
    (both fluxes: they coincide when W ∝ I), the moments of the tilt density."""
    w, e = 2.5, 0.7
    rough = mbi.GaussianSlopes(sigma, dim=d)
    law = mbi.RoughLaw(rough, e, flux=flux, method="adaptive")
    u = np.zeros(d)
    u[-1] = -1.0
    out = law.contact_impulses(w * np.eye(d), u[None])
    exact = np.zeros(d)
    exact[-1] = (1 + e) * rough.moment(lambda a: np.cos(a) ** 3) / (w * rough.moment(np.cos))
    assert out.method == "adaptive[compiled]"
    np.testing.assert_allclose(out.P[0], exact, rtol=1e-11, atol=1e-14 * abs(exact[-1]))


def test_rotating_the_velocity_rotates_the_impulse():
    """W = diag(a, a, b) is isotropic in the tangent plane: turning u about n⁰ turns P alike."""
    W = np.diag([0.7, 0.7, 1.9])
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.4), 0.5, method="adaptive")
    for beta in (0.2, 0.9, 1.4):  # below and above the tilts' incidence split
        u = np.array([math.sin(beta), 0.0, -math.cos(beta)])
        P = law.contact_impulses(W, u[None]).P[0]
        assert abs(P[1]) < 1e-15 * np.linalg.norm(P)  # the mirror symmetry about the plane of u and n⁰
        for psi in (0.7, 2.0, -2.9):
            R = np.array([[math.cos(psi), -math.sin(psi), 0.0], [math.sin(psi), math.cos(psi), 0.0], [0, 0, 1]])
            Q = law.contact_impulses(W, (R @ u)[None]).P[0]
            np.testing.assert_allclose(Q, R @ P, rtol=0, atol=1e-14 * np.linalg.norm(P))


def test_auto_picks_it_for_one_velocity_only():
    """``"auto"``: a single velocity on a tilt density takes the compiled rule; batches, a fixed node
    count and a nearly singular W (graded first) do not; nor does a velocity it does not settle. (With the
    configuration flux: with the physical one, spatial Gaussian slopes go to "laplace".)"""
    rng = np.random.default_rng(5)
    W = spd(rng, 3, 20.0)
    U = unit_velocities(rng, 2, 1.2)
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, flux="configuration")
    assert law.contact_impulses(W, U[:1]).method == "adaptive[compiled]"
    assert law.contact_impulses(W, U).method == "adaptive"
    assert law.replace(nodes=16).contact_impulses(W, U[:1]).method == "fixed"
    assert law.contact_impulses(upright_ur5_delassus(), U[:1]).method == "graded[compiled]"
    planar = mbi.RoughLaw(mbi.GaussianSlopes(0.3, dim=2), 0.5)
    assert planar.contact_impulses(W[:2, :2], np.array([[0.6, -0.8]])).method == "adaptive[compiled]"
    # max_nodes too small for rtol: the compiled rule stops short, the numpy rule runs and warns
    short = law.replace(max_nodes=16)
    with pytest.warns(AccuracyWarning):
        assert short.contact_impulses(W, U[:1]).method == "adaptive"


def test_other_facet_laws_are_not_its_business():
    """Only Newton facets: another facet law keeps the general quadrature, and naming the method
    for it is an error."""
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), facet=mbi.CoulombFacet(0.5, 0.3))
    W = spd(np.random.default_rng(2), 3, 5.0)
    assert law.contact_impulses(W, np.array([[0.3, 0.1, -0.95]]) / math.hypot(0.3, 0.1, 0.95)).method \
        == "adaptive[coulomb]"
    for name in ("laplace", "tilt-table"):  # the rules that integrate Newton facets in closed form
        with pytest.raises(ParameterError, match="cannot average|Newton facets"):
            law.replace(method=name)


def test_a_single_impact_of_an_arm():
    """UR5, GaussianSlopes(0.3), e = 0.5, through mbi.impact with the adaptive rule named ("auto" takes
    "laplace"): the compiled rule, and the numpy rule's result (a batch of two rows) to rounding."""
    mech = mbi.Mechanism.from_robot("ur5")
    q = mech.neutral() + 0.3
    J = mech.point_jacobian(q, "tool0")
    v = np.linalg.lstsq(J, [0.3, 0.1, -1.0], rcond=None)[0]
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5, method="adaptive")
    fast = mbi.impact(mech, q, v, mbi.PointContact("tool0"), law)
    slow = law.apply_batch(mech.mass_matrix(q), J, np.vstack([v, v]), [0, 0, 1])
    assert fast.method == "adaptive[compiled]" and slow.method == "adaptive" and fast.nodes == slow.nodes
    np.testing.assert_allclose(fast.v_plus, slow.V_plus[0], rtol=0, atol=1e-13 * np.linalg.norm(v))


def test_inputs_of_any_layout():
    """A Fortran-ordered W or a strided velocity row gives the same result (copied into the layout
    the kernel is compiled for, not compiled again)."""
    rng = np.random.default_rng(9)
    W = spd(rng, 3, 50.0)
    U = unit_velocities(rng, 3, 1.3)
    law = mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5)
    ref = compiled(law.spec, W, U[1:2])
    other = compiled(law.spec, np.asfortranarray(W), U[1:2, ::-1][:, ::-1])
    assert ref is not None and other is not None
    np.testing.assert_array_equal(ref.P, other.P)  # the same arithmetic on the same numbers, on one machine
    assert not backends.one_velocity(law.spec, W, U)  # several velocities: not its case


def test_interpreted_kernel_matches_compiled():
    """The kernel's source run by Python (NUMBA_DISABLE_JIT=1) gives the compiled result: the same
    arithmetic (the compiled sums reassociated: to rounding)."""
    script = textwrap.dedent("""
        import numpy as np, mbimpact as mbi
        from mbimpact.averaging import backends
        W = np.array([[0.9, 0.2, 0.1], [0.2, 0.5, -0.1], [0.1, -0.1, 1.3]])
        U = {3: np.array([[0.5, 0.3, -0.8]]) / np.linalg.norm([0.5, 0.3, -0.8]), 2: np.array([[-0.6, -0.8]])}
        for d, flux in ((3, "physical"), (3, "configuration"), (2, "physical")):
            law = mbi.RoughLaw(mbi.GaussianSlopes(0.4, dim=d), 0.5, flux=flux)
            out = backends.adaptive(law.spec, W[:d, :d].copy(), U[d])[1]
            print(repr(out.P.tolist()), out.nodes)
    """)
    runs = []
    for disable in ("1", "0"):
        env = dict(os.environ, NUMBA_DISABLE_JIT=disable, PYTHONPATH=str(ROOT))
        done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=600,
                              check=True)
        runs.append([line.rsplit(" ", 1) for line in done.stdout.strip().splitlines()])
    for (P_slow, n_slow), (P_fast, n_fast) in zip(*runs):
        assert n_slow == n_fast
        np.testing.assert_allclose(ast.literal_eval(P_fast), ast.literal_eval(P_slow), rtol=1e-14)

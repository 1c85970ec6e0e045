"""CoulombLaw's compiled phases (:mod:`mbimpact.laws.coulomb_kernels`).

A batch equals its rows applied one by one; the compiled code equals the same source interpreted
(``NUMBA_DISABLE_JIT=1``) to rounding; ``import mbimpact`` does not import numba; failures are named
errors; the first-call cost is measurable.
"""

from __future__ import annotations

import math
import os
import pickle
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.laws import coulomb
from mbimpact.laws.coulomb import compile_kernels

from mbimpact.metric import local_basis

from tests.helpers import approaching, spd, time_limit

RESTITUTIONS = ["newton", "poisson", "energetic"]
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True, scope="module")
def _compiled() -> None:
    """Load (or compile, with a cold numba cache: seconds) the kernels outside any time limit."""
    compile_kernels()


def rod(theta: float) -> tuple[np.ndarray, np.ndarray]:
    """Uniform rod (m = 1, l = 1) striking with one end at angle θ: A, J (2×3)."""
    rx, rz = 0.5 * math.cos(theta), -0.5 * math.sin(theta)
    return np.diag([1.0, 1.0, 1.0 / 12.0]), np.array([[1.0, 0.0, -rz], [0.0, 1.0, rx]])


def spatial_rows(J: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Velocities whose contact velocities cover normal incidence, tiny, moderate and grazing slips
    in all directions (sticking, stopping, curving, sliding throughout)."""
    U = [[0.0, 0.0, -1.0], [1e-9, -2e-9, -1.0], [0.02, 0.01, -1.0], [0.3, -0.2, -1.0], [2.0, 1.0, -0.3]]
    for angle in np.linspace(0.0, 2.0 * math.pi, 9)[:-1]:
        for slip in (0.1, 0.6, 3.0):
            U.append([slip * math.cos(angle), slip * math.sin(angle), -1.0])
    U += [[*rng.normal(size=2), -abs(rng.normal()) - 0.05] for _ in range(8)]
    return np.linalg.lstsq(J, np.array(U).T, rcond=None)[0].T


@pytest.mark.parametrize("kind", RESTITUTIONS)
@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_a_spatial_batch_equals_its_rows_applied_one_by_one(kind, e):
    """Every row of apply_batch (the compiled phases, on numpy's metric) equals apply on it alone (the
    compiled metric around the same phases) to 1e-12, with the same error estimate; μ from
    sliding throughout to sticking, an anisotropic W so that slips curve, and frictions too small to
    stick so that stopped slips reverse."""
    rng = np.random.default_rng(31)
    A = spd(rng, 6, 30.0)
    J = rng.normal(size=(3, 6))
    V = spatial_rows(J, rng)
    W = J @ np.linalg.solve(A, J.T)
    stick = np.linalg.norm(np.linalg.solve(W[:2, :2], W[:2, 2]))
    integrated = closed = 0
    for mu in (0.0, 0.05, 0.3, 0.5 * stick, 1.5 * stick, 4.0 * stick + 1.0):
        law = mbi.CoulombLaw(e, mu, kind)
        with time_limit(60), warnings.catch_warnings():
            warnings.simplefilter("ignore", mbi.NoSeparationWarning)
            batch = law.apply_batch(A, J, V, [0, 0, 1])
            for i in range(len(V)):
                one = law.apply(A, J, V[i], [0, 0, 1])
                np.testing.assert_allclose(batch.V_plus[i], one.v_plus, rtol=1e-12,
                                           atol=1e-12 * np.abs(one.v_plus).max())
                np.testing.assert_allclose(batch.P[i], one.P, rtol=1e-12, atol=1e-12 * np.abs(one.P).max())
                assert batch.error_estimate[i] == one.error_estimate
        integrated += int(np.count_nonzero(batch.error_estimate))
        closed += int(np.count_nonzero(batch.error_estimate == 0.0))
    assert integrated > 20 and closed > 20  # both kinds of rows were compared


@pytest.mark.parametrize("kind", RESTITUTIONS)
def test_a_planar_batch_equals_its_rows_applied_one_by_one(kind):
    """d = 2 (the rod): slips that stop and stick, stop and reverse, or slide throughout."""
    A, J = rod(0.8)
    W = J @ np.linalg.solve(A, J.T)
    ratio = abs(W[0, 1] / W[0, 0])
    V = np.linalg.lstsq(J, np.array([[ut, -1.0] for ut in (-3.0, -0.5, -0.2, 0.0, 1e-12, 0.1, 0.4, 2.0)]).T,
                        rcond=None)[0].T
    for e in (0.0, 0.7, 1.0):
        for mu in (0.0, 0.5 * ratio, 2.0 * ratio, 0.2, 3.0):
            law = mbi.CoulombLaw(e, mu, kind)
            batch = law.apply_batch(A, J, V, [0, 1])
            for i in range(len(V)):
                one = law.apply(A, J, V[i], [0, 1])
                np.testing.assert_allclose(batch.V_plus[i], one.v_plus, rtol=1e-12,
                                           atol=1e-12 * np.abs(one.v_plus).max())
                assert batch.nodes == 1 and one.nodes == 1  # planar: closed forms throughout


# ---------------------------------------------------------------------- compiled = interpreted
def kernel_problems() -> list[tuple[np.ndarray, np.ndarray, float, float, str]]:
    """(W, U, e, μ, restitution): batches of unit velocities through the compiled phases."""
    rng = np.random.default_rng(17)
    out = []
    for k in range(18):
        d = 3 if k % 3 else 2
        n = int(rng.integers(d, 6))
        J = rng.normal(size=(d, n))
        W = J @ np.linalg.solve(spd(rng, n, 100.0), J.T)
        U = rng.normal(size=(5, d))
        U[:, -1] = -np.abs(U[:, -1]) - 0.1
        U[0, :-1] = 0.0  # normal incidence
        U /= np.linalg.norm(U, axis=1)[:, None]
        out.append((0.5 * (W + W.T), U, [0.0, 0.5, 1.0][k % 3], [0.05, 0.3, 1.0, 3.0][k % 4], RESTITUTIONS[k % 3]))
    return out


def kernel_results() -> list[object]:
    """What CoulombLaw.contact_impulses gives on :func:`kernel_problems`: (P, errors, nodes), or the error's
    message."""
    out: list[object] = []
    for W, U, e, mu, kind in kernel_problems():
        law = mbi.CoulombLaw(e, mu, kind)
        try:
            res = law.contact_impulses(W, U)
            out.append((res.P, res.error, res.nodes))
        except mbi.ImpactError as exc:
            out.append(str(exc))
    return out


def test_the_compiled_phases_equal_the_same_source_interpreted(tmp_path):
    """The kernels run by the interpreter (``NUMBA_DISABLE_JIT=1``) give the compiled results to rounding:
    closed forms to a few ε, integrated slips within their tolerance (a step accepted or an event located
    a rounding apart), with the same errors named, the same rows integrated, and error estimates
    to 10⁻³ of each other."""
    script = textwrap.dedent(f"""
        import pickle, sys
        sys.path.insert(0, {str(ROOT)!r})
        from tests.laws.test_coulomb_kernels import kernel_results
        with open({str(tmp_path / 'interpreted.pkl')!r}, "wb") as f:
            pickle.dump(kernel_results(), f)
    """)
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", OPENBLAS_NUM_THREADS="1")
    subprocess.run([sys.executable, "-c", script], check=True, env=env, cwd=ROOT, timeout=600)
    with open(tmp_path / "interpreted.pkl", "rb") as f:
        interpreted = pickle.load(f)
    compiled = kernel_results()
    assert sum(isinstance(r, tuple) and r[-1] > 1 for r in compiled) >= 3  # integrated slips among them
    for (W, U, e, mu, kind), ours, theirs in zip(kernel_problems(), compiled, interpreted):
        assert type(ours) is type(theirs)
        if isinstance(ours, str):
            assert ours == theirs
            continue
        (P, err, nodes), (P_i, err_i, nodes_i) = ours, theirs
        # the same rows integrated; an estimate and a step count move only if a step's acceptance sits a
        # rounding from its threshold
        np.testing.assert_array_equal(err > 0, err_i > 0)
        np.testing.assert_allclose(err, err_i, rtol=1e-3, atol=0)
        assert np.all(np.abs(np.asarray(nodes) - np.asarray(nodes_i)) <= 1)
        tol = np.where(err > 0, 10 * err, 64 * np.finfo(float).eps)  # integrated rows: their tolerance
        scale = np.linalg.norm(P @ W, axis=1)
        assert np.all(np.linalg.norm((P - P_i) @ W, axis=1) <= tol * scale + 1e-300)


def test_only_an_impact_imports_numba():
    """``import mbimpact`` does not import numba (it costs ~0.3 s); the first Coulomb impact does."""
    script = textwrap.dedent("""
        import sys
        import numpy as np
        import mbimpact as mbi
        assert "numba" not in sys.modules
        W = np.array([[1.0, 0.3, 0.2], [0.3, 0.8, -0.1], [0.2, -0.1, 0.5]])
        result = mbi.CoulombLaw(0.5, 0.2).apply(np.linalg.inv(W), np.eye(3), [0.8, -0.6, -1.0], [0, 0, 1])
        assert result.method == "impulse-space" and "numba" in sys.modules
    """)
    subprocess.run([sys.executable, "-c", script], check=True, cwd=ROOT, timeout=300,
                   env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))


def single_cases(rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, list[float]]]:
    """(A, J, v, frame) of single impacts, d = 2 and 3, world-aligned and tilted contact frames, from
    normal incidence to grazing slips, and a rank-deficient J (the general route)."""
    out = []
    for k in range(24):
        d = 3 if k % 4 else 2
        n = int(rng.integers(d, 7))
        A, J = spd(rng, n, 30.0), rng.normal(size=(d, n))
        if k == 5:
            J[2] = J[0]  # rank-deficient: the general route's minimum-norm impulse
        frame = [0.0] * (d - 1) + [1.0] if k % 2 else [*(0.3 * rng.normal(size=d - 1)), 1.0]
        n0 = np.array(frame) / np.linalg.norm(frame)
        R = local_basis(frame, d)
        for slip in (0.0, 1e-3, 0.05, 0.5, 3.0):
            t = rng.normal(size=d - 1)
            u_local = np.append(slip * t / np.linalg.norm(t), -1.0)
            v = np.linalg.lstsq(J, R @ u_local, rcond=None)[0]
            out.append((A, J, approaching(J, v, n0), frame))
    return out


@pytest.mark.parametrize("kind", RESTITUTIONS)
def test_a_single_impact_equals_a_batch_of_one_row(kind):
    """A single impact on arrays (the compiled metric steps around the phases) and a batch of that one row
    (numpy's metric): the same impulse and outcome to rounding, the same step count and error estimate, in
    world-aligned and tilted frames, d = 2 and 3, and on a rank-deficient J (minimum-norm impulse)."""
    rng = np.random.default_rng(43)
    for A, J, v, frame in single_cases(rng):
        W = J @ np.linalg.solve(A, J.T)
        stick = np.linalg.norm(np.linalg.lstsq(W[:-1, :-1], W[:-1, -1], rcond=None)[0])
        for mu in (0.0, 0.3, 1.5 * stick + 0.1):
            for e in (0.0, 0.6):
                law = mbi.CoulombLaw(e, mu, kind)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", mbi.NoSeparationWarning)
                    one = law.apply(A, J, v, frame)
                    batch = law.apply_batch(A, J, v[None], frame)
                tol = 10 * law.rtol if one.error_estimate else 1e-12
                for field, many in (("P", "P"), ("v_plus", "V_plus"), ("u_plus", "U_plus")):
                    got, want = getattr(one, field), getattr(batch, many)[0]
                    np.testing.assert_allclose(got, want, rtol=0, atol=tol * max(np.abs(want).max(), 1.0))
                assert one.error_estimate == batch.error_estimate[0]


def test_a_normal_out_of_reach_takes_the_general_route():
    """n⁰ᵀWn⁰ ≈ 0 (J barely moves the contact along n⁰): the general route names it."""
    J = np.array([[1.0, 0.0], [0.0, 1.0], [1e-8, 0.0]])  # n⁰ᵀWn⁰ = 1e-16 ≤ 1e-14 tr W, yet u_n < 0
    with pytest.raises(mbi.NoImpactError, match="cannot move the contact point along n0"):
        mbi.CoulombLaw(0.5, 0.3).apply(np.eye(2), J, [-1.0, 0.2], [0.0, 0.0, 1.0])


def test_a_delassus_matrix_without_positive_trace_is_a_named_error():
    U = np.array([[0.0, 0.0, -1.0]])
    for rows in (U, np.vstack([U, U])):
        with pytest.raises(mbi.IntegrationError, match=r"positive finite trace, got 0\.0"):
            mbi.CoulombLaw(0.5, 0.0).contact_impulses(np.zeros((3, 3)), rows)
    with pytest.raises(mbi.IntegrationError, match=r"positive finite trace, got nan"):
        mbi.CoulombLaw(0.5, 0.0).contact_impulses(np.full((3, 3), np.nan), U)


def test_compile_kernels_reports_the_first_call_cost():
    imported, jitted = compile_kernels()  # loaded already (the module fixture): nothing left to pay
    assert 0.0 <= imported < 0.05 and 0.0 <= jitted < 0.05


# ---------------------------------------------------------------------- named errors
@pytest.mark.parametrize("rows", [1, 2])
@pytest.mark.parametrize("W, u, mu, e, kind, message", [
    ([[1.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 1.0]], [0.0, 0.0, -1.0], 5.0, 0.5, "energetic",
     r"the contact jams while still approaching \(n·u = -1 at p_n = 0, mode stick\)"),
    ([[1.0, 1.0], [1.0, 1.0]], [0.0, -1.0], 5.0, 0.5, "poisson",
     r"the contact jams while still approaching \(n·u = -1 at p_n = 0, mode stick\)"),
    ([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -0.5]], [0.3, 0.0, -1.0], 0.0, 0.5, "energetic",
     r"compression cannot end \(n·u = -0.958 with rate -0.333 at p_n = 0, mode free\)"),
    ([[1.0, 0.0, 0.2], [0.0, 1.0, 0.0], [0.2, 0.0, -0.5]], [0.3, 0.0, -1.0], 0.3, 0.5, "newton",
     r"compression cannot end \(n·u = -2.57 with rate -0.36 at p_n = 4.31022, mode stick\)"),
])
def test_failures_of_the_phases_are_named_errors(rows, W, u, mu, e, kind, message):
    """Delassus matrices no mechanism has (singular along the sticking impulse, or a negative normal
    entry): the compiled phases report what went wrong, with the numbers."""
    U = np.array([u] * rows) / np.linalg.norm(u)
    with pytest.raises(mbi.IntegrationError, match=message):
        mbi.CoulombLaw(e, mu, kind).contact_impulses(np.array(W), U)


def test_too_many_phases_is_a_named_error(monkeypatch):
    """A planar slip that stops and sticks needs two phases."""
    A, J = rod(0.8)
    W = J @ np.linalg.solve(A, J.T)
    v = np.linalg.lstsq(J, [0.1, -1.0], rcond=None)[0]
    law = mbi.CoulombLaw(0.5, 2.0 * abs(W[0, 1] / W[0, 0]))
    law.apply(A, J, v, [0, 1])
    monkeypatch.setattr(coulomb, "_MAX_PHASES", 1)
    with pytest.raises(mbi.IntegrationError, match=r"more than 1 phases at p_n = [0-9.e+-]+$"):
        law.apply(A, J, v, [0, 1])


def test_the_tableau_is_dop853s():
    """The kernels carry Hairer's DOP853 coefficients themselves (scipy.integrate costs 0.4 s to import)."""
    from scipy.integrate._ivp import dop853_coefficients as tableau

    from mbimpact.laws import coulomb_slip as kernels

    n = tableau.N_STAGES
    assert kernels._NS == n
    for ours, theirs in ((kernels._A, tableau.A[:n, :n]), (kernels._B, tableau.B), (kernels._C, tableau.C[:n]),
                         (kernels._E5, tableau.E5[:n]), (kernels._E3, tableau.E3[:n])):
        assert np.array_equal(ours, theirs)


def test_the_rows_kernel_takes_any_layout():
    """F-ordered, strided and read-only W and U convert to the kernels' one compiled signature (none is
    added), to the same results."""
    from mbimpact.laws import coulomb_kernels as kernels

    for W, U, e, mu, kind in kernel_problems():
        law = mbi.CoulombLaw(e, mu, kind)
        try:
            ref = law.contact_impulses(W, U).P
        except mbi.ImpactError:
            continue
        strided = np.zeros((2 * len(W), 2 * len(W)))
        strided[::2, ::2] = W
        readonly = W.copy()
        readonly.setflags(write=False)
        for Wa in (np.asfortranarray(W), strided[::2, ::2], readonly):
            np.testing.assert_array_equal(law.contact_impulses(Wa, U).P, ref)
    assert len(kernels.impact_rows.signatures) == 1


def test_norm_is_hypot_to_an_ulp():
    """The integration's |(x, y)|: within an ulp of math.hypot, without over- or underflow."""
    from mbimpact.laws.coulomb_slip import _norm

    rng = np.random.default_rng(7)
    for lo, hi in [(-3, 3), (-200, 200), (-320, 308)]:
        x = rng.normal(size=2000) * 10.0 ** rng.uniform(lo, hi, 2000)
        y = rng.normal(size=2000) * 10.0 ** rng.uniform(lo, hi, 2000)
        for a, b in zip(x.tolist(), y.tolist()):
            exact = math.hypot(a, b)
            assert abs(_norm(a, b) - exact) <= math.ulp(exact), (a, b)
    assert _norm(0.0, 0.0) == 0.0 and _norm(-3e-320, 4e-320) == math.hypot(3e-320, 4e-320)
    assert _norm(1e308, 1e308) == math.hypot(1e308, 1e308) and _norm(math.inf, math.nan) == math.inf
    assert math.isnan(_norm(math.nan, 1.0))


def test_a_curving_slip_to_the_end_of_compression_takes_few_steps():
    """The UR5's sliding impact of the speed bench (its local unit-trace W and unit velocity; μ = 0.2,
    plastic): the slip curves throughout, three steps reach the end of compression and two more locate
    it (a quintic Hermite guess, then Newton aimed just past the root); the impulse is the fine
    integration's."""
    from tests.laws.test_coulomb_paths import reference

    W = np.array([[0.3289499726465565, -0.04974230656233071, 0.164939985500229],
                  [-0.04974230656233071, 0.22976109096926203, 0.05945786772841505],
                  [0.164939985500229, 0.05945786772841505, 0.4412889363841815]])
    U = np.array([[2.0, 1.0, -2.0]]) / 3.0
    law = mbi.CoulombLaw(0.0, 0.2)
    out = law.contact_impulses(W, U)
    assert 1 < out.nodes <= 5
    np.testing.assert_allclose(W @ out.P[0], W @ reference(W, U[0], 0.2, 0.0, "energetic"), atol=1e-9)
    assert abs(U[0, 2] + W[2] @ out.P[0]) <= 1e-15  # compression ended: n·u₊ = 0 to rounding

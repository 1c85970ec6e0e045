"""Coulomb law: the closed-form phases and the integrated turning slip against an independent
fine integration (scipy's solve_ivp written here), and properties over random Delassus matrices.

``result.nodes`` counts integration steps (1: closed forms throughout), so the tests can say
which impacts need no integration without timing anything.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.laws.coulomb import compile_kernels
from mbimpact.metric.delassus import spread_bound

from tests.helpers import approaching, seeds, spd
from tests.laws.test_coulomb_regressions import energy_bound, time_limit

RESTITUTIONS = ["newton", "poisson", "energetic"]


@pytest.fixture(autouse=True, scope="module")
def _compiled_phases() -> None:
    """Load (or, with a cold numba cache, compile: seconds) the law's kernels outside the time limits."""
    compile_kernels()


# ---------------------------------------------------------------------- the reference
def reference(W, u, mu, e, kind, stop=1e-9):
    """Impulse-space Coulomb impact by solve_ivp (DOP853, rtol 1e-12), independently of the law.

    Slip: dP_t/dp = −μ û_t until |u_t| < ``stop`` (then the residual is removed by −W_tt⁺ u_t);
    stick: dP_t/dp = −W_tt⁺ W_tn; when that is outside the cone the slip restarts along the
    direction s with W_tn − μ W_tt s ∥ +s found by scanning angles. The normal work restarts at
    maximum compression. Local frame, last axis normal; returns P (d,).
    """
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    d = len(u)
    Wtt, Wtn = W[:-1, :-1], W[:-1, -1]
    pinv = np.linalg.pinv(Wtt, rcond=1e-12)
    stick = -pinv @ Wtn
    can_stick = mu > 0 and np.linalg.norm(stick) <= mu * (1 + 1e-12)
    if d == 2:
        reslip = np.array([math.copysign(1.0, Wtn[0])])
    else:
        def cross(th):
            s = np.array([math.cos(th), math.sin(th)])
            r = Wtn - mu * Wtt @ s
            return r[0] * s[1] - r[1] * s[0]
        grid = np.linspace(0, 2 * math.pi, 3601)
        vals = [cross(t) for t in grid]
        best = None
        for a, b, fa, fb in zip(grid, grid[1:], vals, vals[1:]):
            if fa * fb < 0:
                th = brentq(cross, a, b, xtol=1e-15)
                s = np.array([math.cos(th), math.sin(th)])
                grow = (Wtn - mu * Wtt @ s) @ s
                if grow > 0 and (best is None or grow > best[0]):
                    best = (grow, s)
        reslip = best[1] if best is not None else np.zeros(2)

    def vel(p, y):
        return u + W @ np.append(y[:-1], p)

    p, y = 0.0, np.zeros(d)
    mode = "slip" if mu > 0 and np.linalg.norm(u[:-1]) > 0 else ("free" if mu == 0 else None)
    if mode is None:
        mode = "stick" if can_stick else "reslip"
    pc = Wc = None
    for _ in range(10):
        def rhs(p, y, mode=mode):
            v = vel(p, y)
            if mode == "free":
                g = np.zeros(d - 1)
            elif mode == "stick":
                g = stick
            elif mode == "reslip":
                g = -mu * reslip
            else:
                g = -mu * v[:-1] / np.linalg.norm(v[:-1])
            return np.append(g, v[-1])

        def comp_end(p, y):
            return vel(p, y)[-1]

        def done(p, y):
            if kind == "newton":
                return vel(p, y)[-1] + e * u[-1]
            if kind == "poisson":
                return p - (1 + e) * pc
            return y[-1] + e * e * Wc

        def stops(p, y, mode=mode):
            return np.linalg.norm(vel(p, y)[:-1]) - stop if mode == "slip" else 1.0

        for ev in (comp_end, done, stops):
            ev.terminal = True
        comp_end.direction, done.direction, stops.direction = 1, 1, -1
        events = [stops] + ([comp_end] if pc is None else [done])
        sol = solve_ivp(rhs, (p, p + 1e8), y, method="DOP853", rtol=1e-12, atol=1e-14, events=events)
        assert sol.status == 1, sol.message
        which = min((ev[0], i) for i, ev in enumerate(sol.t_events) if len(ev))[1]
        p, y = sol.t[-1], sol.y[:, -1]
        if events[which] is comp_end:
            pc, Wc, y = p, y[-1], np.append(y[:-1], 0.0)
            if e == 0:
                break
        elif events[which] is done:
            break
        else:
            if can_stick:
                y = np.append(y[:-1] - pinv @ vel(p, y)[:-1], y[-1])
                mode = "stick"
            else:
                mode = "reslip"
    return np.append(y[:-1], p)


def law_P(law, W, u):
    """The law's core on a local-frame problem, W as given and u unit."""
    with time_limit(20):
        out = law.contact_impulses(W, u[None, :] / np.linalg.norm(u))
    return out.P[0] * np.linalg.norm(u), out.nodes


def random_problem(rng, d, cond=100.0):
    n = int(rng.integers(d, 7))
    A = spd(rng, n, cond)
    J = rng.normal(size=(d, n))
    W = J @ np.linalg.solve(A, J.T)
    return 0.5 * (W + W.T)


# ---------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("kind", RESTITUTIONS)
@pytest.mark.parametrize("e", [0.0, 0.4, 1.0])
@pytest.mark.parametrize("mu", [0.0, 0.15, 0.6, 20.0])
def test_planar_impacts_are_closed_forms_equal_to_the_fine_integration(kind, e, mu):
    """d = 2: slip, stop, stick or reverse, all piecewise linear in p_n: no integration step."""
    rng = np.random.default_rng(5)
    for _ in range(6):
        W = random_problem(rng, 2)
        u = np.append(rng.normal(), -abs(rng.normal()) - 0.1)
        P, nodes = law_P(mbi.CoulombLaw(e, mu, kind), W, u)
        assert nodes == 1
        ref = reference(W, u, mu, e, kind)
        np.testing.assert_allclose(W @ P, W @ ref, atol=1e-7 * np.linalg.norm(u))


@pytest.mark.parametrize("kind", RESTITUTIONS)
@pytest.mark.parametrize("e", [0.0, 1.0])
def test_spatial_closed_forms_need_no_integration(kind, e):
    """Frictionless, normal incidence (stick or reslip), a slip along an invariant direction
    (isotropic W_tt with W_tn = 0): closed forms, equal to the fine integration."""
    rng = np.random.default_rng(6)
    W = random_problem(rng, 3)
    iso = np.diag([0.7, 0.7, 1.3])
    cases = [(W, np.array([0.3, -0.2, -1.0]), 0.0), (W, np.array([0.0, 0.0, -1.0]), 0.2),
             (W, np.array([0.0, 0.0, -1.0]), 50.0), (iso, np.array([0.4, 0.3, -1.0]), 0.3),
             (iso, np.array([0.4, 0.3, -1.0]), 5.0)]
    for W_, u, mu in cases:
        P, nodes = law_P(mbi.CoulombLaw(e, mu, kind), W_, u)
        assert nodes == 1, (W_, u, mu)
        np.testing.assert_allclose(W_ @ P, W_ @ reference(W_, u, mu, e, kind), atol=1e-7)


@pytest.mark.parametrize("kind", ["newton", "poisson"])
def test_a_slip_certain_to_stop_in_compression_needs_no_integration(kind):
    """Large μ: u_tᵀW_tt⁻¹u_t decays fast enough that the slip stops before compression can end,
    and then the impulse no longer depends on how it stopped (Newton, Poisson, e = 0)."""
    rng = np.random.default_rng(7)
    for _ in range(5):
        W = random_problem(rng, 3, cond=10)
        u = np.array([*(1e-3 * rng.normal(size=2)), -1.0])
        stick = np.linalg.norm(np.linalg.solve(W[:2, :2], W[:2, 2]))
        law = mbi.CoulombLaw(0.6, 4 * stick + 1, kind)
        P, nodes = law_P(law, W, u)
        assert nodes == 1
        np.testing.assert_allclose(W @ P, W @ reference(W, u, law.mu, 0.6, kind), atol=1e-7)


@pytest.mark.parametrize("kind", RESTITUTIONS)
@pytest.mark.parametrize("mu", [0.05, 0.3, 1.0, 3.0])
def test_turning_spatial_slip_against_the_fine_integration(kind, mu):
    """Random anisotropic W: the slip turns (and may stop, stick or reslip); the integrated phase
    and its hand-over to closed forms agree with solve_ivp at 1e-12 to the reference's accuracy."""
    rng = np.random.default_rng(8)
    for _ in range(4):
        W = random_problem(rng, 3)
        u = np.array([*rng.normal(size=2), -abs(rng.normal()) - 0.2])
        law = mbi.CoulombLaw(0.7, mu, kind)
        P, nodes = law_P(law, W, u)
        ref = reference(W, u, mu, 0.7, kind)
        np.testing.assert_allclose(W @ P, W @ ref, atol=2e-7 * np.linalg.norm(u))


def test_turning_slip_is_integrated_to_the_requested_tolerance():
    """A slip that turns and never stops (small μ): the only error is the integration's."""
    W = np.array([[1.0, 0.45, 0.3], [0.45, 0.4, -0.2], [0.3, -0.2, 0.9]])
    u = np.array([0.8, -0.6, -1.0])
    ref = reference(W, u, 0.1, 0.8, "energetic")
    for rtol, tol in [(1e-6, 1e-5), (1e-10, 1e-9)]:
        P, nodes = law_P(mbi.CoulombLaw(0.8, 0.1, rtol=rtol), W, u)
        assert 1 < nodes < 100
        assert np.linalg.norm(W @ (P - ref)) <= tol * np.linalg.norm(u)


# ---------------------------------------------------------------------- properties
def properties(res, law, u_scale):
    mu, e = law.mu, law.e
    assert np.all(np.isfinite(res.P))
    if law.restitution != "newton":
        assert res.energy_loss >= -energy_bound(res)
    W = res.J @ np.linalg.solve(res.A, res.J.T)
    if spread_bound(W) <= 1e-12:
        # the pipeline reports the minimum-norm P of a (nearly) rank-deficient W: off the cone,
        # and u₊ moved by what the dropped eigenvalues (< 1e-12 λ_max) did with P
        return
    assert res.P_n > 0
    assert np.linalg.norm(res.P_t) <= mu * res.P_n * (1 + 1e-7) + 1e-9 * np.linalg.norm(res.P)
    if law.restitution == "newton":
        # u_n⁺ = e |u_n⁻| unless the contact jammed (then u_n⁺ stays where it stopped, ≥ 0)
        assert res.u_plus[-1] <= e * abs(res.u_minus[-1]) + 1e-8 * u_scale
    if law.restitution != "poisson":  # p_n = (1 + e) p_c may leave u_n⁺ < 0 (then it warns)
        assert res.u_plus[-1] >= -1e-8 * u_scale


@given(seeds, st.sampled_from(RESTITUTIONS), st.sampled_from([0.0, 1.0, 0.5]),
       st.sampled_from([0.0, 0.2, 1.0, 100.0]), st.sampled_from([2, 3]), st.sampled_from([1e-150, 1.0, 1e150]))
def test_random_delassus_matrices(seed, kind, e, mu, d, scale):
    """Any W (random A, J, cond up to 1e4), restitution, e ∈ {0, ½, 1}, μ ∈ {0, …, large},
    d ∈ {2, 3}, velocity scales 1e-150 … 1e150: admissible, energy-consistent, homogeneous."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(d, 7))
    A = spd(rng, n, 10 ** rng.uniform(0, 4))
    J = rng.normal(size=(d, n))
    v = approaching(J, rng.normal(size=n), np.eye(d)[-1])
    law = mbi.CoulombLaw(e, mu, kind)
    with time_limit(20), warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        res = law.apply(A, J, v * scale, np.eye(d)[-1])
        one = law.apply(A, J, v, np.eye(d)[-1])
    properties(res, law, np.linalg.norm(res.u_minus))
    # v·scale rounds differently from v: an ε change of u moves P by up to ε cond(W)
    rtol = max(1e-9, 64 * np.finfo(float).eps * np.linalg.cond(one.J @ np.linalg.solve(A, one.J.T)))
    np.testing.assert_allclose(res.P / scale, one.P, rtol=rtol, atol=rtol * 1e-3 * np.abs(one.P).max())


@given(seeds, st.sampled_from(RESTITUTIONS), st.sampled_from([0.0, 1.0]), st.sampled_from([0.0, 0.5, 50.0]))
def test_rank_deficient_delassus_matrices(seed, kind, e, mu):
    """J with fewer columns than rows (W of rank 1 or 2), or a repeated row: no hang, no bare error."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 3))
    J = rng.normal(size=(3, n))
    if rng.random() < 0.3:
        J = np.vstack([J[:1], J[:1], rng.normal(size=(1, n))])  # u_x = u_y always
    A = spd(rng, n, 10.0)
    v = approaching(J, rng.normal(size=n), np.array([0, 0, 1.0]))
    law = mbi.CoulombLaw(e, mu, kind)
    try:
        with time_limit(20):
            res = law.apply(A, J, v, [0, 0, 1])
    except mbi.NoImpactError:
        return  # J cannot move the contact along the normal
    assert np.all(np.isfinite(res.P))  # (the minimum-norm P of a rank-deficient J may have P_n < 0)
    if kind != "newton":
        assert res.energy_loss >= -energy_bound(res)


@pytest.mark.parametrize("kind", RESTITUTIONS)
def test_apply_batch_rows_equal_apply(kind):
    """The batch runs the same core row by row (one setup of W): identical to single impacts."""
    rng = np.random.default_rng(9)
    A = spd(rng, 6, 50)
    J = rng.normal(size=(3, 6))
    V = rng.normal(size=(60, 6))
    V[V @ J[2] > 0] *= -1
    V[:5] = np.linalg.lstsq(J, np.array([[0, 0, -1.0]] * 5).T, rcond=None)[0].T  # normal incidence
    law = mbi.CoulombLaw(0.5, 0.4, kind)
    with time_limit(60):
        batch = law.apply_batch(A, J, V, [0, 0, 1])
        for i in (0, 7, 33, 59):
            one = law.apply(A, J, V[i], [0, 0, 1])
            np.testing.assert_allclose(batch.V_plus[i], one.v_plus, rtol=1e-12, atol=1e-12 * np.abs(one.v_plus).max())
    assert batch.method == "impulse-space"
    assert np.all(batch.error_estimate[:5] == 0.0)  # closed forms


def test_method_name_and_error_estimate():
    law = mbi.CoulombLaw(0.5, 0.3)
    res = law.apply(np.eye(3), np.eye(3), [0.3, 0.1, -1.0], [0, 0, 1])
    assert res.method == "impulse-space" and res.nodes == 1 and res.error_estimate == 0.0
    W = np.array([[1.0, 0.45, 0.3], [0.45, 0.4, -0.2], [0.3, -0.2, 0.9]])
    res = law.apply(np.linalg.inv(W), np.eye(3), [0.8, -0.6, -1.0], [0, 0, 1])
    assert res.nodes > 1 and res.error_estimate == law.rtol

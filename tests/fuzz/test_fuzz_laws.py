"""Fuzzing the array API of every law and measure: a finite, dissipative answer or a named error, fast.

Each example draws a mass matrix (condition up to 1e8, scale 1e-60…1e60), a contact Jacobian
(sometimes rank-deficient), a velocity, a base normal, a roughness measure and a law. Asserted:

* the call returns within a time limit (a hang fails the test);
* it raises an :class:`mbimpact.ImpactError` or returns finite velocities and impulses;
* the kinetic energy never grows beyond the rounding bound of :func:`tests.helpers.energy_bound`
  ((error estimate + 100 ε cond W) |P| (|u₋| + |u₊|)/2);
* where a reference exists (a cone, by a fixed rule with four times the nodes), the error
  estimate bounds the true error.

The default run takes a small derandomised sample; ``pytest -m slow`` runs 10⁴ examples each.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mbimpact as mbi
from tests.helpers import energy_bound, time_limit

LIMIT = 30.0  # seconds per call: generous on a busy 2-core machine, far below a hang


@st.composite
def problems(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    n = draw(st.integers(1, 7))
    d = draw(st.sampled_from([2, 3]))
    cond = 10.0 ** draw(st.floats(0.0, 8.0))
    scale = 10.0 ** draw(st.integers(-60, 60))
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    A = (Q * np.geomspace(1.0, cond, n)) @ Q.T * scale
    A = 0.5 * (A + A.T)
    J = rng.normal(size=(d, n))
    if draw(st.booleans()) and n > 1:  # rank-deficient
        J[-1] = J[0] * rng.normal()
    v = rng.normal(size=n) * 10.0 ** draw(st.integers(-50, 50))
    n0 = rng.normal(size=d)
    n0 /= np.linalg.norm(n0)
    if n0 @ J @ v > 0:
        v = -v
    W = J @ np.linalg.solve(A, J.T)
    lam = np.linalg.eigvalsh(0.5 * (W + W.T))
    return A, J, v, n0, float(lam[-1] / max(lam[0], lam[-1] * 1e-16))


def measures(d: int) -> st.SearchStrategy[mbi.Roughness]:
    alpha = st.floats(0.0, 1.4)
    common = [st.just(mbi.Smooth())]
    if d == 2:
        return st.one_of(*common, alpha.map(mbi.Sawtooth), st.floats(0.01, 1.0).map(lambda s: mbi.GaussianSlopes(s, 2)),
                         st.lists(st.floats(-0.2, 0.2), min_size=3, max_size=12).map(
                             lambda h: mbi.Profile(np.array(h), 0.05, shadowing=True)))
    return st.one_of(*common, alpha.map(mbi.Cone), st.floats(0.02, 0.8).map(mbi.GaussianSlopes),
                     st.integers(0, 2**31).map(lambda s: _facets(s)))


def _facets(seed: int) -> mbi.Facets:
    rng = np.random.default_rng(seed)
    k = int(rng.integers(1, 9))
    tilt, az = rng.uniform(0, 1.3, k), rng.uniform(0, 2 * math.pi, k)
    m = np.column_stack([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)])
    return mbi.Facets(m, rng.uniform(0.01, 1.0, k))


def check(law: mbi.ImpactLaw, A: np.ndarray, J: np.ndarray, v: np.ndarray, n0: np.ndarray, cond: float) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.ImpactWarning)  # honest warnings are allowed
        warnings.simplefilter("error", RuntimeWarning)  # no numpy overflow leaks out
        try:
            with time_limit(LIMIT):
                res = law.apply(A, J, v, n0)
        except mbi.ImpactError:
            return
    assert np.all(np.isfinite(res.v_plus)) and np.all(np.isfinite(res.P)) and np.all(np.isfinite(res.u_plus))
    if np.isfinite(res.energy_loss):  # energies beyond the float range are ±inf, honestly
        assert res.energy_loss >= -energy_bound(res, cond)[0], (law, res.energy_loss)


@settings(max_examples=40, deadline=None)
@given(problems(), st.data())
def test_rough_law_on_random_arrays(problem, data):
    A, J, v, n0, cond = problem
    rough = data.draw(measures(J.shape[0]))
    law = mbi.RoughLaw(rough, data.draw(st.floats(0.0, 1.0)), flux=data.draw(st.sampled_from(["physical", "configuration"])),
                       repeat=data.draw(st.booleans()))
    check(law, A, J, v, n0, cond)


@settings(max_examples=40, deadline=None)
@given(problems(), st.floats(0.0, 1.0))
def test_newton_law_on_random_arrays(problem, e):
    check(mbi.NewtonLaw(e), *problem)


@settings(max_examples=20, deadline=None)
@given(problems(), st.floats(0.0, 1.0), st.floats(0.0, 3.0), st.sampled_from(["newton", "poisson", "energetic"]))
def test_coulomb_law_on_random_arrays(problem, e, mu, restitution):
    A, J, v, n0, cond = problem
    law = mbi.CoulombLaw(e, mu, restitution)
    if restitution == "newton":  # Newton's kinematic restitution may create energy (slip reversal): only finiteness
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mbi.ImpactWarning)
            try:
                with time_limit(LIMIT):
                    res = law.apply(A, J, v, n0)
            except mbi.ImpactError:
                return
        assert np.all(np.isfinite(res.v_plus))
        return
    check(law, A, J, v, n0, cond)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.05, 1.4), st.floats(0.0, 1.0))
def test_the_error_estimate_bounds_the_true_error_on_a_cone(seed, alpha, e):
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    W = (Q * np.geomspace(1.0, 10 ** rng.uniform(0, 4), 3)) @ Q.T
    u = rng.normal(size=3)
    u[2] = -abs(u[2]) - 1e-3
    u /= np.linalg.norm(u)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.ImpactWarning)
        with time_limit(LIMIT):
            try:
                out = mbi.RoughLaw(mbi.Cone(alpha), e).contact_impulses(W, u[None])
            except mbi.ImpactError:
                return
            # the reference: the same family of rule with many more nodes (graded if the law graded)
            graded = out.method in ("graded", "graded[compiled]")
            reference = {"method": "graded", "nodes": 256} if graded else {"method": "fixed", "nodes": 4096}
            ref = mbi.RoughLaw(mbi.Cone(alpha), e, **reference).contact_impulses(W, u[None])
    true = np.linalg.norm((out.P[0] - ref.P[0]) @ W) / np.linalg.norm(ref.P[0] @ W)
    assert true <= 10 * out.error[0] + 1e-9


# ---------------------------------------------------------------- nightly size: pytest -m slow

@pytest.mark.slow
@settings(max_examples=10_000, deadline=None)
@given(problems(), st.data())
def test_rough_law_on_random_arrays_nightly(problem, data):
    test_rough_law_on_random_arrays.hypothesis.inner_test(problem, data)


@pytest.mark.slow
@settings(max_examples=10_000, deadline=None)
@given(problems(), st.floats(0.0, 1.0))
def test_newton_law_on_random_arrays_nightly(problem, e):
    check(mbi.NewtonLaw(e), *problem)


@pytest.mark.slow
@settings(max_examples=10_000, deadline=None)
@given(problems(), st.floats(0.0, 1.0), st.floats(0.0, 3.0), st.sampled_from(["newton", "poisson", "energetic"]))
def test_coulomb_law_on_random_arrays_nightly(problem, e, mu, restitution):
    test_coulomb_law_on_random_arrays.hypothesis.inner_test(problem, e, mu, restitution)


@pytest.mark.slow
@settings(max_examples=10_000, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.05, 1.4), st.floats(0.0, 1.0))
def test_the_error_estimate_bounds_the_true_error_on_a_cone_nightly(seed, alpha, e):
    test_the_error_estimate_bounds_the_true_error_on_a_cone.hypothesis.inner_test(seed, alpha, e)

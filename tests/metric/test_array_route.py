"""The array route of ``ImpactLaw.apply(A, J, v, frame)``: its fast paths decide and compute as the general
checks and solvers they stand in front of."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.common.validation import as_array
from mbimpact.metric.delassus import ContactMetric

from ..helpers import spd


@pytest.mark.parametrize("n", [1, 3, 6, 18])
def test_the_metric_solves_as_scipys_cholesky_solve(n, rng):
    # the solve calls LAPACK's dpotrs directly, as scipy.linalg.cho_solve does after its checks: the same bits
    A = spd(rng, n, cond=1e6)
    A *= 2.0 / np.max(np.abs(A))  # max |A| in [1, 4): the factor is not rescaled
    J = rng.normal(size=(3, n))
    metric = ContactMetric.from_arrays(A, J)
    L = np.linalg.cholesky(A)
    for b in (J.T, rng.normal(size=n), rng.normal(size=(n, 5))):
        np.testing.assert_array_equal(metric.solve(b), scipy.linalg.cho_solve((L, True), b, check_finite=False))
    np.testing.assert_array_equal(metric.AinvJt, scipy.linalg.cho_solve((L, True), J.T, check_finite=False))
    # other right-hand sides (complex, a stack, a list) take scipy's cho_solve itself
    b = rng.normal(size=n) + 1j * rng.normal(size=n)
    np.testing.assert_array_equal(metric.solve(b), scipy.linalg.cho_solve((L, True), b, check_finite=False))
    b = rng.normal(size=n).tolist()
    np.testing.assert_array_equal(metric.solve(b), scipy.linalg.cho_solve((L, True), b, check_finite=False))


_ENTRY = st.one_of(st.floats(-1e300, 1e300, allow_nan=False), st.integers(-10, 10))


@settings(max_examples=300, deadline=None)
@given(st.lists(_ENTRY, min_size=3, max_size=3), st.sampled_from([list, tuple]))
def test_a_normal_written_out_gives_the_basis_of_the_same_normal_as_an_array(normal, kind):
    frame = kind(normal)
    expected: np.ndarray | type[Exception]
    try:
        expected = mbi.local_basis(np.array(normal, dtype=float), 3)
    except mbi.ImpactError as exc:  # the zero vector
        expected = type(exc)
    if isinstance(expected, np.ndarray):
        got = mbi.local_basis(frame, 3)
        np.testing.assert_array_equal(got, expected)
        np.testing.assert_allclose(got.T @ got, np.eye(3), atol=1e-15)
    else:
        with pytest.raises(expected):
            mbi.local_basis(frame, 3)
    planar = mbi.local_basis(kind(normal[:2]), 2) if any(normal[:2]) else None
    if planar is not None:
        np.testing.assert_array_equal(planar, mbi.local_basis(np.array(normal[:2], dtype=float), 2))


@pytest.mark.parametrize("frame, error", [
    ([0.0, 0.0, math.nan], mbi.NonFiniteError), ((0.0, math.inf, 1.0), mbi.NonFiniteError),
    ([0, 0, 10**400], mbi.ShapeError), ([0, 0, 2**70], mbi.ShapeError), ([2**64, 1.0, 1], mbi.ShapeError),
    ([0, 0, -(2**63) - 1], mbi.ShapeError), ([0, 0, 0], mbi.ShapeError), ([0.0, 1.0], mbi.ShapeError),
])
def test_a_normal_written_out_that_is_not_one_is_named(frame, error):
    with pytest.raises(error):
        mbi.local_basis(frame, 3)
    with pytest.raises(error):
        mbi.NewtonLaw(0.5).apply(np.eye(3), np.eye(3), [0.0, 0.0, -1.0], frame)


def test_a_huge_but_finite_normal_written_out_is_one():
    R = mbi.local_basis([1e308, 1e308, 0.0], 3)  # its sum overflows, its entries do not
    np.testing.assert_allclose(R[:, 2], [math.sqrt(0.5), math.sqrt(0.5), 0.0], rtol=1e-15)


def test_a_small_finite_float64_array_passes_the_checks_as_is(rng):
    A = rng.normal(size=(4, 4))
    assert as_array("A", A, 2, (4, None)) is A
    A[1, 2] = math.nan
    with pytest.raises(mbi.NonFiniteError, match="A contains NaN"):
        as_array("A", A, 2)
    with pytest.raises(mbi.ShapeError, match="axis 0 must have length 3"):
        as_array("A", rng.normal(size=(4, 4)), 2, (3, None))
    with pytest.raises(mbi.ShapeError, match="2 dimension"):
        as_array("A", rng.normal(size=4), 2)
    big = np.full((2, 2), 1e308)  # finite, its sum is not: the full checks pass it
    assert as_array("big", big, 2) is big

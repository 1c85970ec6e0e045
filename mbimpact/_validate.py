"""Small input checks shared by the public entry points."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import NonFiniteError, ParameterError, ShapeError


def as_array(name: str, x: ArrayLike, ndim: int, shape: tuple[int | None, ...] | None = None) -> NDArray[np.float64]:
    """Convert ``x`` to a finite float array with ``ndim`` dimensions.

    ``shape`` entries that are ``None`` are free; the others must match.
    """
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"{name} must be a numeric array, got {type(x).__name__}") from exc
    if a.ndim != ndim:
        raise ShapeError(f"{name} must have {ndim} dimension(s), got shape {a.shape}")
    if shape is not None:
        for axis, (got, want) in enumerate(zip(a.shape, shape)):
            if want is not None and got != want:
                raise ShapeError(f"{name} has shape {a.shape}; axis {axis} must have length {want}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{name} contains NaN or infinity")
    return a


def as_vector(name: str, x: ArrayLike, n: int) -> NDArray[np.float64]:
    """:func:`as_array` for a vector of length ``n``, with a fast path for float arrays.

    A float64 vector of the right length whose squared norm is finite is returned
    as is (single impacts are called in loops); anything else takes the full check.
    """
    if type(x) is np.ndarray and x.dtype == np.float64 and x.shape == (n,) and math.isfinite(x @ x):
        return x
    return as_array(name, x, 1, (n,))


def as_scalar(name: str, x: float, lo: float, hi: float, *, hi_open: bool = False) -> float:
    """A finite float in ``[lo, hi]`` (or ``[lo, hi)`` when ``hi_open``)."""
    try:
        val = float(x)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a real number, got {x!r}") from exc
    if not np.isfinite(val):
        raise NonFiniteError(f"{name} must be finite, got {val}")
    too_high = val >= hi if hi_open else val > hi
    if val < lo or too_high:
        bracket = ")" if hi_open else "]"
        raise ParameterError(f"{name} = {val} is outside [{lo}, {hi}{bracket}")
    return val

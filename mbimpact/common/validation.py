"""Input checks shared by the public entry points: every failure is a named :class:`ImpactError`."""

from __future__ import annotations

import math
import numbers
import operator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import NonFiniteError, ParameterError, ShapeError

__all__ = ["as_array", "as_vector", "as_scalar", "as_count", "quiet_overflow", "check_in_range", "FLOAT64"]


def as_array(name: str, x: ArrayLike, ndim: int, shape: tuple[int | None, ...] | None = None) -> NDArray[np.float64]:
    """Convert ``x`` to a finite real float array with ``ndim`` dimensions.

    ``shape`` entries that are ``None`` are free; the others must match.

    Raises
    ------
    ShapeError
        Not numeric, complex, ragged, or of the wrong shape.
    NonFiniteError
        A NaN or infinite entry.
    """
    # a small finite float64 array of the right shape, as the hot paths pass, is returned as is (what the
    # checks below return for it) after one pass in Python floats: a NaN or ±inf makes the sum non-finite,
    # and the rare finite array whose sum overflows takes the checks (see as_vector)
    if (type(x) is np.ndarray and x.dtype is FLOAT64 and x.ndim == ndim and x.size <= 256
            and (shape is None or all(w is None or g == w for g, w in zip(x.shape, shape)))
            and math.isfinite(sum(x.ravel().tolist()))):
        return x
    if isinstance(x, (str, bytes)) or x is None:
        raise ShapeError(f"{name} must be a numeric array, got {type(x).__name__}")
    try:
        raw = np.asarray(x)
    except (TypeError, ValueError) as exc:  # ragged nested sequences
        raise ShapeError(f"{name} must be a rectangular numeric array: {exc}") from exc
    if np.iscomplexobj(raw):
        raise ShapeError(f"{name} must be real; got a complex array (its imaginary part would be lost)")
    if raw.dtype.kind not in "biuf":
        raise ShapeError(f"{name} must be a numeric array, got dtype {raw.dtype}")
    a = raw.astype(float, copy=False)
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

    A finite float64 vector of the right length is returned as is (single impacts are
    called in loops); anything else takes the full check.
    """
    # the sum of the entries in Python floats, not a finite x·x: the squares of entries beyond 1e154
    # would overflow, and numpy would warn about it (a RuntimeWarning leaking out of a valid call);
    # Python's float sum never warns, a NaN or ±inf makes it non-finite, and the rare finite vector
    # whose sum overflows takes the full check (np.isfinite(x).all() costs a single impact 3× more)
    if type(x) is np.ndarray and x.dtype is FLOAT64 and x.shape == (n,) and math.isfinite(sum(x.tolist())):
        return x
    return as_array(name, x, 1, (n,))


FLOAT64 = np.dtype(np.float64)
"""The native float64 descriptor, compared by identity (``a.dtype is FLOAT64``) on hot paths."""


def as_scalar(name: str, x: object, lo: float, hi: float, *, hi_open: bool = False, lo_open: bool = False) -> float:
    """A finite real number in ``[lo, hi]`` (bounds open where asked)."""
    if isinstance(x, bool) or not isinstance(x, (numbers.Real, np.floating, np.integer)):
        if isinstance(x, np.ndarray) and x.ndim == 0 and x.dtype.kind in "iuf":
            x = x.item()
        else:
            raise ParameterError(f"{name} must be a real number, got {x!r}")
    val = float(x)  # type: ignore[arg-type]
    if not math.isfinite(val):
        raise NonFiniteError(f"{name} must be finite, got {val}")
    too_low = val <= lo if lo_open else val < lo
    too_high = val >= hi if hi_open else val > hi
    if too_low or too_high:
        lb, rb = ("(" if lo_open else "["), (")" if hi_open else "]")
        raise ParameterError(f"{name} = {val:g} is outside {lb}{lo:g}, {hi:g}{rb}")
    return val


def as_count(name: str, x: object, lo: int, hi: int) -> int:
    """An integer in ``[lo, hi]``; floats are accepted only when integral (``64.0``).

    The upper bound keeps a typo (10⁹ nodes) from turning into hours of work.
    """
    if isinstance(x, bool):
        raise ParameterError(f"{name} must be an integer, got {x!r}")
    try:
        val = operator.index(x)  # type: ignore[arg-type]
    except TypeError:
        if isinstance(x, (float, np.floating)) and math.isfinite(x) and float(x).is_integer():
            val = int(x)
        else:
            raise ParameterError(f"{name} must be an integer in [{lo}, {hi}], got {x!r}") from None
    if not lo <= val <= hi:
        raise ParameterError(f"{name} = {val} is outside [{lo}, {hi}]")
    return int(val)


def quiet_overflow() -> np.errstate:
    """A context in which numpy's overflow and invalid-value warnings are silenced.

    For arithmetic whose inputs are finite but may be extreme (velocities near the float
    range, a Delassus matrix near underflow): what overflows is named afterwards by
    :func:`check_in_range`, instead of leaking a RuntimeWarning or a NaN.
    """
    return np.errstate(over="ignore", invalid="ignore", divide="ignore")


def check_in_range(what: str, *arrays: NDArray[np.float64]) -> None:
    """Raise :class:`NonFiniteError` unless every entry of ``arrays`` is finite.

    Small arrays are checked on Python floats, cheaper than a numpy reduction: a NaN or an
    inf makes their sum NaN or inf, and so does a sum that overflows (results within a factor
    of their length of the largest float count as overflowed too).
    """
    total = 0.0
    for a in arrays:
        if a.size > 64:
            if not bool(np.isfinite(a).all()):
                total = math.nan
        else:
            total += sum(a.tolist() if a.ndim == 1 else a.ravel().tolist())
    if not math.isfinite(total):
        raise NonFiniteError(
            f"{what}: beyond the float range (an entry is inf or NaN); the inputs are finite but too "
            f"large or too small together (rescale the velocities, or the units of A and J)"
        )

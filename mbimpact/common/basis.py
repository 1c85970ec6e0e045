"""The local frame of the base surface at the contact: tangents and the normal n⁰."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_array
from ..errors import NonFiniteError, ParameterError, ShapeError

__all__ = ["local_basis"]


def local_basis(frame: ArrayLike, d: int) -> NDArray[np.float64]:
    """Orthonormal contact basis whose last column is the base normal n⁰.

    Parameters
    ----------
    frame : array_like, shape (d,) or (d, d)
        Either the base normal n⁰ (normalised here; the tangent directions are
        then an arbitrary right-handed completion) or a rotation whose last
        column is n⁰ (needed when the facet set is anisotropic).
    d : int
        Contact-space dimension, 2 or 3.

    Returns
    -------
    ndarray, shape (d, d)
        Rotation R: local facet coordinates → world-aligned contact coordinates.

    Raises
    ------
    ParameterError
        ``d`` is not an integer (an array, a string, None, 2.5).
    ShapeError
        ``d`` is not 2 or 3, the normal is zero, or the matrix is not a rotation.
    NonFiniteError
        A NaN or infinite entry.
    """
    if d.__class__ is not int or not (d == 2 or d == 3):  # the hot path's int costs one comparison
        d = check_dimension(d)
    if isinstance(frame, (list, tuple)) and len(frame) == d and all(
            type(x) is float or (type(x) is int and -(2**63) <= x < 2**63) for x in frame):
        # a normal written out, [0, 0, 1], as most calls give it: numpy's conversions cost more than the basis
        # (the ints numpy holds as int64; larger ones take the checks below, as do bools and numpy scalars)
        entries: list[float] = list(frame)
        n = [float(x) for x in entries]
        if not all(map(math.isfinite, n)):
            raise NonFiniteError("frame contains NaN or infinity")
        return _basis_of_normal(n, d)
    try:
        ndim = np.ndim(frame)
    except ValueError as exc:  # ragged nested sequences
        raise ShapeError(f"frame must be the base normal, shape ({d},), or a rotation, shape ({d}, {d}): {exc}") from None
    f = as_array("frame", frame, ndim)
    if f.shape == (d,):
        return _basis_of_normal(f.tolist(), d)
    if f.shape == (d, d):
        err = float(np.max(np.abs(f.T @ f - np.eye(d))))
        if err > 1e-9:
            raise ShapeError(f"frame is not a rotation matrix: max |RᵀR - I| = {err:.3g}")
        return f.copy()
    raise ShapeError(
        f"frame must be the base normal, shape ({d},), or a rotation, shape ({d}, {d}), "
        f"to match J with {d} rows; got shape {f.shape}"
    )


def _basis_of_normal(n: list[float], d: int) -> NDArray[np.float64]:
    """:func:`local_basis` of a finite normal, given as d Python floats (in floats: a basis is built on
    every call of ImpactLaw.apply)."""
    big = max(abs(x) for x in n)
    if big == 0.0:
        raise ShapeError("the base normal n0 is the zero vector")
    n = [x / big for x in n]  # scaled first: no under- or overflow of the norm
    norm = math.sqrt(sum(x * x for x in n))
    n = [x / norm for x in n]
    if d == 2:
        return np.array([[n[1], n[0]], [-n[0], n[1]]])
    k = min(range(3), key=lambda i: abs(n[i]))  # the world axis least aligned with n0
    t = [(1.0 if i == k else 0.0) - n[k] * n[i] for i in range(3)]
    tn = math.sqrt(sum(x * x for x in t))
    t = [x / tn for x in t]
    b = [n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0]]
    return np.array([[t[0], b[0], n[0]], [t[1], b[1], n[1]], [t[2], b[2], n[2]]])


def check_dimension(d: object) -> int:
    """``d`` as the int 2 or 3: an integer, or an integral float (``3.0``), as counts elsewhere.

    Tested by type before any comparison: ``d in (2, 3)`` on an array raises numpy's ambiguous-truth
    ValueError, and on a one-element array passes.
    """
    if isinstance(d, (int, np.integer)) and not isinstance(d, (bool, np.bool_)):
        value = int(d)
    elif isinstance(d, (float, np.floating)) and math.isfinite(d) and float(d).is_integer():
        value = int(d)
    else:
        raise ParameterError(f"d, the contact-space dimension, must be the integer 2 or 3; got {d!r}")
    if value not in (2, 3):
        raise ShapeError(f"contact-space dimension must be 2 or 3, got {value}")
    return value

"""A law's predictions of an impact table's columns, for a body arriving at given angles."""

from __future__ import annotations

import warnings
from collections.abc import Iterable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import FitError, ImpactWarning
from ..laws.base import ImpactLaw
from .bodies import Body, PointMass, as_body
from .quantities import QUANTITIES, predict_quantity

__all__ = ["predict", "contact_dim"]


def contact_dim(law: ImpactLaw) -> int:
    """The contact-space dimension a prediction uses: the law's (its roughness's), else planar (2)."""
    return law.dim if law.dim is not None else 2


def predict(law: ImpactLaw, theta_deg: ArrayLike, body: Body | None = None, speed: ArrayLike = 1.0,
            quantities: tuple[str, ...] | None = None, *, quiet: bool = False) -> dict[str, NDArray[np.float64]]:
    """Predicted table columns for ``body`` (default: the contact point, :class:`PointMass`) arriving at
    incidences ``theta_deg`` (deg from the normal) with speed ``speed`` (m/s), no spin.

    Parameters
    ----------
    law : ImpactLaw
    theta_deg : array_like, shape (B,)
        Incidences in (0, 90) degrees (0 is allowed; tangential ratios are then NaN).
    body : Body, optional
    speed : float or array_like, shape (B,)
        Impact speeds (only ``spin`` and speed-dependent facet laws depend on them).
    quantities : tuple of str, optional
        Columns to predict (default: all the body can give; ``spin`` needs a body with spin).
    quiet : bool
        Silence mbimpact's warnings (a fit explores parameters where κ < 0 warns).

    Returns
    -------
    dict of str to ndarray, shape (B,)
        The columns of :data:`mbimpact.calibration.quantities.QUANTITIES` (see there for their meaning).

    Raises
    ------
    FitError
        A law or body of the wrong kind, incidences or speeds that are not real numbers in range,
        unknown quantities, ``spin`` for a body without spin.
    """
    if not isinstance(law, ImpactLaw):
        raise FitError(f"law must be an impact law (NewtonLaw, RoughLaw, CoulombLaw, ...), got {type(law).__name__}")
    body = PointMass() if body is None else as_body(body)
    theta = np.radians(np.atleast_1d(_reals("theta_deg", theta_deg)))
    if theta.ndim != 1 or not len(theta) or not np.all((theta >= 0) & (theta < np.pi / 2)):
        raise FitError("theta_deg must be incidences in [0, 90) degrees from the normal (a non-empty 1-D array)")
    given = _reals("speed", speed)
    try:
        speeds = np.broadcast_to(given, theta.shape)
    except ValueError:  # numpy's broadcasting error (outside: a FitError is a ValueError too)
        raise FitError(f"speed must be one value or one per incidence ({len(theta)}), got shape "
                       f"{np.shape(speed)}") from None
    if not np.all((speeds > 0) & np.isfinite(speeds)):
        raise FitError("speed must be finite and > 0 (m/s)")
    if quantities is None:
        quantities = tuple(q for q in QUANTITIES if q != "spin" or body.has_spin)
    elif isinstance(quantities, str):  # one name, not its letters
        quantities = (quantities,)
    if not isinstance(quantities, Iterable) or not all(isinstance(q, str) for q in quantities):
        raise FitError(f"quantities must be a tuple of names ({', '.join(QUANTITIES)}), got {quantities!r}")
    unknown = [q for q in quantities if q not in QUANTITIES]
    if unknown:
        raise FitError(f"unknown quantities {unknown}; valid: {', '.join(QUANTITIES)}")
    if "spin" in quantities and not body.has_spin:
        raise FitError(f"{body!r} does not rotate: 'spin' needs a body with spin (mbimpact.Ball)")
    d = contact_dim(law)
    A, J = body.arrays(d)
    V = body.velocities(theta, speeds, d)
    frame = np.eye(d)[-1]
    with warnings.catch_warnings():
        if quiet:
            warnings.simplefilter("ignore", ImpactWarning)
        result = law.apply_batch(A, J, V, frame)
    before, after = body.motion(V, d), body.motion(result.V_plus, d)
    mu = np.asarray(result.mu, dtype=float)
    return {q: predict_quantity(q, before, after, mu) for q in quantities}


def _reals(name: str, x: ArrayLike) -> NDArray[np.float64]:
    """``x`` as a float array; anything but real numbers is a FitError (casting complex would warn and drop
    the imaginary part, a string or None would raise numpy's bare errors)."""
    if x is None or isinstance(x, (str, bytes)):
        raise FitError(f"{name} must be real numbers, got {type(x).__name__}")
    try:
        raw = np.asarray(x)
    except (TypeError, ValueError, OverflowError):  # ragged nested sequences
        raise FitError(f"{name} must be real numbers (a 1-D array)") from None
    if raw.dtype.kind not in "biuf":
        raise FitError(f"{name} must be real numbers, got an array of dtype {raw.dtype}")
    return raw.astype(float)

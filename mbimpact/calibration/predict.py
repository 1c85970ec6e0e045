"""A law's predictions of an impact table's columns, for a body arriving at given angles."""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import FitError, ImpactWarning
from ..laws.base import ImpactLaw
from .bodies import Body, PointMass
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
    """
    body = PointMass() if body is None else body
    theta = np.radians(np.atleast_1d(np.asarray(theta_deg, dtype=float)))
    if theta.ndim != 1 or not np.all((theta >= 0) & (theta < np.pi / 2)):
        raise FitError("theta_deg must be incidences in [0, 90) degrees from the normal (a 1-D array)")
    speeds = np.broadcast_to(np.asarray(speed, dtype=float), theta.shape)
    if not np.all(speeds > 0):
        raise FitError("speed must be > 0 (m/s)")
    if quantities is None:
        quantities = tuple(q for q in QUANTITIES if q != "spin" or body.has_spin)
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

r"""What a column of an impact table means, and how a law predicts it.

Every prediction is made for the table's body (:mod:`mbimpact.calibration.bodies`) arriving in
the x–z plane with centre-of-mass velocity V (sin θ, −cos θ) and no spin, on a surface
with normal e_z; ``+`` marks values after the impact, ``−`` before. For a sphere the
normal velocities of the centre of mass and of the contact point coincide (r ∥ n⁰),
the tangential ones differ by the spin: u_t = v_t − R ω.

============== ====== =================================================================
column         unit   prediction
============== ====== =================================================================
theta_deg      deg    incidence θ from the normal (the table's abscissa; required)
speed          m/s    impact speed V (needed for ``spin`` and speed-dependent laws)
kappa          —      normal restitution κ = −v_n⁺ / v_n⁻ (= −u_n⁺ / u_n⁻), (1.2)
mu             —      impulse ratio |P_t| / P_n read in contact space, (3.1)
et             —      centre-of-mass tangential restitution v_t⁺ / v_t⁻ (5/7 for a rolling
                      solid sphere, 1 without friction)
et_cp          —      contact-point tangential restitution u_t⁺ / u_t⁻ (< 0: the contact
                      point's tangential velocity reverses)
spin           rad/s  rebound angular velocity ω⁺ (ω_y, positive rolls forward along +x)
rebound_deg    deg    centre-of-mass rebound angle from the normal, atan2(v_t⁺, v_n⁺)
rebound_cp_deg deg    contact-point rebound angle from the normal, atan2(u_t⁺, u_n⁺)
============== ====== =================================================================

Residuals are dimensionless: ratios as they are, angles in radians, spins as ωR/V.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .bodies import Body, Motion

__all__ = ["Quantity", "QUANTITIES", "predict_quantity", "residual_scale"]


@dataclass(frozen=True)
class Quantity:
    """One measurable outcome of an impact.

    Attributes
    ----------
    name : str
        Column name in a table.
    unit : str
        Its unit ("" for ratios).
    description : str
        How a law predicts it (see the module's table).
    """

    name: str
    unit: str
    description: str


QUANTITIES: dict[str, Quantity] = {q.name: q for q in (
    Quantity("kappa", "", "normal restitution -v_n+/v_n-"),
    Quantity("mu", "", "impulse ratio |P_t|/P_n"),
    Quantity("et", "", "COM tangential restitution v_t+/v_t-"),
    Quantity("et_cp", "", "contact-point tangential restitution u_t+/u_t-"),
    Quantity("spin", "rad/s", "rebound angular velocity (positive rolls forward)"),
    Quantity("rebound_deg", "deg", "COM rebound angle from the normal"),
    Quantity("rebound_cp_deg", "deg", "contact-point rebound angle from the normal"),
)}


def predict_quantity(name: str, before: Motion, after: Motion, mu: NDArray[np.float64]) -> NDArray[np.float64]:
    """The prediction of column ``name`` (B,) from the motions before and after and the impulse ratios μ (B,).

    Ratios are NaN where their denominator vanishes (normal incidence for ``et``, ``et_cp``).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        if name == "kappa":
            return -after.vn / before.vn
        if name == "mu":
            return mu
        if name == "et":
            return np.where(before.vt != 0.0, after.vt / before.vt, np.nan)
        if name == "et_cp":
            return np.where(before.ut != 0.0, after.ut / before.ut, np.nan)
        if name == "spin":
            return after.spin
        if name == "rebound_deg":
            return np.degrees(np.arctan2(after.vt, after.vn))
        if name == "rebound_cp_deg":
            return np.degrees(np.arctan2(after.ut, after.un))
    raise KeyError(name)  # pragma: no cover — tables only hold known columns


def residual_scale(name: str, body: Body, speed: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per-row factor (B,) that makes a residual in the column's unit dimensionless."""
    if name == "spin":
        return 1.0 / body.spin_scale(speed)
    if name.endswith("_deg"):
        return np.full(len(speed), math.pi / 180.0)
    return np.ones(len(speed))

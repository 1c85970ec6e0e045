"""MuJoCo's contact tuned from a coefficient of restitution: a linear spring-dashpot clipped at zero force.

MuJoCo's soft contact with a negative ``solref = (−k, −b)`` and a flat ``solimp`` (the impedance d
the same at every penetration, :data:`SOLIMP`) is, along the normal, the mass-normalised linear
spring-dashpot ẍ + b ẋ + k x = 0 of the penetration x, with a force that cannot pull: the contact
ends when k x + b ẋ = 0 (ẋ < 0), before the overlap does (T. Schwager, T. Pöschel, "Coefficient of
restitution and linear-dashpot model revisited", Granular Matter 9, 465, 2007; "Coefficient of
restitution for viscoelastic spheres: the effect of delayed recovery", Phys. Rev. E 78, 051304, 2008). With ω₀ = √k, ζ = b/(2ω₀), β = ζ/√(1 − ζ²) and the damped frequency ω_d = ω₀√(1 − ζ²),
x(t) = (v₀/ω_d) e^{−ζω₀t} sin ω_d t, and the force vanishes at ω_d t = π − 2 arctan β, where
ẋ = −v₀ e^{−β(π − 2 arctan β)}:

    e = exp(−β (π − 2 arctan β)),

larger than exp(−βπ), the restitution of a dashpot that may pull (whose ζ gives 0.808, 0.550 and
0.325 for e = 0.8, 0.5, 0.2). At ζ = 1 the contact ends at ω₀t = 2 with e = e⁻²: a clipped
dashpot cannot restitute less than e⁻² ≈ 0.135 underdamped; lower e are not mapped here.

Friction rows have no position in MuJoCo: their reference acceleration is −b_f v_t. By default
they share the normal's b = 2ζω₀ (≈ 0.15 ω₀ for e = 0.8), slow against a contact of about 3/ω₀:
a sphere that a rigid Coulomb impact makes stick slides through the whole contact. Under Coulomb's
impact law they get their own ``solreffriction`` (:func:`friction_solref`), b_f = 2ω₀, and the slip
stops within the contact.
"""

from __future__ import annotations

import math

__all__ = ["STIFFNESS", "SOLIMP", "E_MIN", "clipped_restitution", "damping_ratio", "contact_duration",
           "contact_solref", "friction_solref"]

#: Mass-normalised contact stiffness k [1/s²] of every impact scene, the same at every time step:
#: ω₀ = √k ≈ 3162 rad/s, a contact of about 1 ms (:func:`contact_duration`).
STIFFNESS = 1e7

#: MuJoCo's ``solimp`` (dmin, dmax, width, midpoint, power): flat at 0.99, so that the impedance and
#: with it the effective stiffness do not change with the penetration.
SOLIMP = (0.99, 0.99, 0.001, 0.5, 2.0)

#: The smallest restitution of a clipped dashpot that is not overdamped (ζ = 1).
E_MIN = math.exp(-2.0)


def clipped_restitution(zeta: float) -> float:
    """Restitution of the linear spring-dashpot of damping ratio ζ ∈ [0, 1] whose force is clipped at zero."""
    if not 0.0 <= zeta <= 1.0:
        raise ValueError(f"the damping ratio of an underdamped contact is in [0, 1], got {zeta}")
    if zeta == 1.0:
        return E_MIN
    beta = zeta / math.sqrt(1.0 - zeta * zeta)
    return math.exp(-beta * (math.pi - 2.0 * math.atan(beta)))


def damping_ratio(e: float) -> float:
    """ζ of the clipped linear spring-dashpot whose restitution is e ∈ [e⁻², 1].

    e(ζ) is strictly decreasing: bisection to the last bit (about 60 halvings).
    """
    if not E_MIN <= e <= 1.0:
        raise ValueError(f"a clipped spring-dashpot's restitution is in [e^-2 = {E_MIN:.4f}, 1], got {e}")
    lo, hi = 0.0, 1.0
    while True:
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            return lo if abs(clipped_restitution(lo) - e) <= abs(clipped_restitution(hi) - e) else hi
        if clipped_restitution(mid) > e:
            lo = mid
        else:
            hi = mid


def contact_duration(e: float, stiffness: float = STIFFNESS) -> float:
    """Duration [s] of one clipped contact of restitution e: (π − 2 arctan β)/ω_d (2/ω₀ at ζ = 1)."""
    zeta = damping_ratio(e)
    omega0 = math.sqrt(stiffness)
    if zeta >= 1.0:
        return 2.0 / omega0
    beta = zeta / math.sqrt(1.0 - zeta * zeta)
    return (math.pi - 2.0 * math.atan(beta)) / (omega0 * math.sqrt(1.0 - zeta * zeta))


def contact_solref(e: float, stiffness: float = STIFFNESS) -> tuple[float, float]:
    """MuJoCo's negative ``solref`` (−k, −b) of the clipped contact of restitution e and stiffness k."""
    return -stiffness, -2.0 * damping_ratio(e) * math.sqrt(stiffness)


def friction_solref(stiffness: float = STIFFNESS) -> tuple[float, float]:
    """MuJoCo's ``solreffriction`` (−k, −b_f), b_f = 2√k: a slip decays as exp(−2ω₀t), within the contact."""
    return -stiffness, -2.0 * math.sqrt(stiffness)

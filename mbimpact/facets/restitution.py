"""Restitution of one Kelvin–Voigt facet impact, (2.3)–(2.5) and (2.8).

On a single facet the normalised constraint obeys f'' = -(M² f + 2kM f'), (2.4).
Starting from f = 0, f' = f'_0 < 0, the solution (2.5) re-crosses f = 0 after
tau = pi / (M sqrt(1 - k²)) with f' = -e f'_0, where e depends on the damping
ratio k only, not on the stiffness M.
"""

from __future__ import annotations

import math
import sys

from ..common.validation import as_scalar
from ..errors import ParameterError

__all__ = ["e_from_k", "k_from_e", "impact_duration", "restitution_from"]


def e_from_k(k: float) -> float:
    """Restitution of a Kelvin–Voigt facet, e = exp(-k pi / sqrt(1 - k²)), (2.8).

    Parameters
    ----------
    k : float
        Damping ratio in [0, 1]; k = 1 (critical damping) is the limit e = 0.

    Returns
    -------
    float
        The coefficient e in [0, 1].
    """
    k = as_scalar("k", k, 0.0, 1.0)
    if k == 1.0:
        return 0.0
    return math.exp(-k * math.pi / math.sqrt(1.0 - k * k))


def k_from_e(e: float) -> float:
    """Inverse of :func:`e_from_k`: k = -ln e / sqrt(pi² + ln² e).

    Parameters
    ----------
    e : float
        Restitution in [0, 1]; e = 0 gives k = 1.
    """
    e = as_scalar("e", e, 0.0, 1.0)
    if e == 0.0:
        return 1.0
    ln = math.log(e)
    return abs(ln) / math.sqrt(math.pi**2 + ln * ln)  # |ln e| = -ln e, but +0.0 (not -0.0) at e = 1


def impact_duration(M: float, k: float) -> float:
    """Duration tau = pi / (M sqrt(1 - k²)) of one facet impact, (2.5).

    Infinite for k = 1 (the critically damped contact never separates).

    Parameters
    ----------
    M : float
        Facet stiffness parameter M > 0 of (2.4).
    k : float
        Damping ratio in [0, 1].

    Raises
    ------
    ParameterError
        ``M`` or ``k`` out of range, or an ``M`` so small (for this ``k``) that the duration
        exceeds the largest float.
    """
    k = as_scalar("k", k, 0.0, 1.0)
    M = as_scalar("M", M, 0.0, math.inf, lo_open=True)
    if k == 1.0:
        return math.inf
    # pi / √(1 - k²) first: at most ~2e8 for k < 1, whereas M √(1 - k²) underflows to 0 for a
    # subnormal M (a ZeroDivisionError); a Python float quotient overflows to inf without a warning
    ratio = math.pi / math.sqrt(1.0 - k * k)
    tau = ratio / M
    if not math.isfinite(tau):
        raise ParameterError(
            f"M = {M:g} is too small for k = {k!r}: the impact duration pi / (M sqrt(1 - k²)) exceeds the "
            f"largest float; M must be at least {ratio / sys.float_info.max:.3g}"
        )
    return tau


def restitution_from(e: float | None, k: float | None) -> float:
    """The facet restitution e from exactly one of e or the Kelvin–Voigt damping ratio k.

    Raises
    ------
    ParameterError
        Neither or both given, or a value outside [0, 1].
    """
    if (e is None) == (k is None):
        raise ParameterError("give exactly one of e (restitution) or k (Kelvin–Voigt damping ratio)")
    if e is not None:
        return as_scalar("e", e, 0.0, 1.0)
    return e_from_k(k)  # type: ignore[arg-type]

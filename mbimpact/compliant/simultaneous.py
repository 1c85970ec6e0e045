"""Simultaneous impacts: the compliant resolution beside a single-contact law applied contact by contact."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_count, as_scalar
from ..errors import ParameterError
from ..laws.base import ImpactLaw
from ..mechanism.contact import PointContact
from ..pipeline import impact
from ..mechanism.mechanism import Mechanism
from .resolve import Resolved, check_contacts, check_mechanism, resolve

__all__ = ["SimultaneousReport", "compare_simultaneous"]


@dataclass(frozen=True, eq=False)
class SimultaneousReport:
    """A simultaneous impact resolved in time beside a single-contact law applied contact by contact.

    Attributes
    ----------
    resolved : Resolved
        The compliant resolution (:func:`resolve`).
    sequential : ndarray, shape (nv,)
        Velocity after applying ``law`` to one approaching contact at a time until none approaches.
    difference : float
        |v_resolved − v_sequential| in the A-metric, relative to |v₋|.
    disagree : bool
        ``difference`` above ``tol``: the single-contact law is not a safe shortcut here.
    """

    resolved: Resolved
    sequential: NDArray[np.float64]
    difference: float
    disagree: bool


def compare_simultaneous(
    mech: Mechanism,
    q: ArrayLike,
    v: ArrayLike,
    contacts: Sequence[PointContact],
    law: object,
    *,
    tol: float = 1e-2,
    max_rounds: int = 1000,
    **kwargs: object,
) -> SimultaneousReport:
    """Flag simultaneous impacts where a single-contact law applied contact by contact disagrees
    with the compliant resolution (the several-constraint case of the paper's ref. [7]).

    ``law`` is an impact law (e.g. ``NewtonLaw(e)``); keyword arguments go to :func:`resolve`.

    Raises
    ------
    ParameterError
        ``mech``, ``contacts`` or ``law`` of the wrong kind, ``tol`` < 0 or ``max_rounds`` outside
        [1, 10⁷]; and everything :func:`resolve` raises.
    """
    check_mechanism(mech)
    contacts = check_contacts(contacts)
    if not isinstance(law, ImpactLaw):
        raise ParameterError(f"law must be an impact law (NewtonLaw, RoughLaw, CoulombLaw, ...), "
                             f"got {type(law).__name__}")
    tol = as_scalar("tol", tol, 0.0, math.inf)
    max_rounds = as_count("max_rounds", max_rounds, 1, 10**7)
    q0, v0 = mech.check_state(q, v)
    res = resolve(mech, q0, v0, contacts, **kwargs)  # type: ignore[arg-type]
    vs = v0.copy()
    for _ in range(max_rounds):
        rates = [ct.normal @ mech.point_jacobian(q0, ct.frame, ct.point) @ vs for ct in contacts]
        worst = int(np.argmin(rates))
        if rates[worst] >= -1e-12 * max(1.0, float(np.abs(v0).max())):
            break
        vs = impact(mech, q0, vs, contacts[worst], law).v_plus
    A = mech.mass_matrix(q0)
    diff = res.v_plus - vs
    rel = math.sqrt(float(diff @ A @ diff) / max(float(v0 @ A @ v0), 1e-300))
    return SimultaneousReport(res, vs, rel, rel > tol)

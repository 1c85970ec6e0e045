"""One impact of a mechanism: the pipeline assembled on Pinocchio.

A(q) and J(q) (stage 1) → the contact metric W (stage 2) → the law's contact
impulse (stages 3–5) → Δv = A⁻¹ Jᵀ P and I = Jᵀ P by Lagrange's equations (1.1).
"""

from __future__ import annotations


import numpy as np
from numpy.typing import ArrayLike

from ..common.validation import as_array
from ..errors import ParameterError, ShapeError
from ..metric.delassus import ContactMetric
from ..results.impact import BatchResult, ImpactResult
from ..laws.base import ImpactLaw
from .contact import Contact
from .mechanism import Mechanism

__all__ = ["impact", "impact_batch"]


def _check_parts(mech: object, contact: object, law: object) -> None:
    if not isinstance(mech, Mechanism):
        raise ParameterError(f"mech must be an mbimpact.Mechanism, got {type(mech).__name__}")
    if not isinstance(contact, Contact):
        raise ParameterError(f"contact must be a contact (e.g. mbimpact.PointContact), got {type(contact).__name__}")
    if not isinstance(law, ImpactLaw):
        raise ParameterError(f"law must be an impact law (NewtonLaw, RoughLaw, CoulombLaw, ...), "
                             f"got {type(law).__name__}")


def impact(mech: Mechanism, q: ArrayLike, v: ArrayLike, contact: Contact, law: ImpactLaw) -> ImpactResult:
    """Impact of a mechanism at configuration ``q`` with velocity ``v`` on a contact.

    Parameters
    ----------
    mech : Mechanism
    q : array_like, shape (nq,)
        Configuration (free-flyer quaternions normalised).
    v : array_like, shape (nv,)
        Pre-impact generalised velocity.
    contact : Contact
        E.g. :class:`PointContact`.
    law : ImpactLaw
        :class:`NewtonLaw`, :class:`RoughLaw`, :class:`CoulombLaw`, ...

    Returns
    -------
    ImpactResult
        With ``A = pin.crba(q)`` and ``J`` the contact Jacobian at ``q``.

    Raises
    ------
    ShapeError, NonFiniteError, ParameterError
        Invalid q, v or arguments of the wrong kind.
    NotPositiveDefiniteError
        A(q) is singular (massless links).
    NoImpactError, NoFacingFacetError
        The contact point does not approach the surface, or no facet faces it.
    """
    if type(mech) is not Mechanism or not isinstance(contact, Contact) or not isinstance(law, ImpactLaw):
        _check_parts(mech, contact, law)
    q, v = mech.check_state(q, v)
    J, R = contact.jacobian(mech, q, law.dim or 3)
    return law.apply_metric(ContactMetric.from_mechanism(mech, q, J), v, R)


def impact_batch(mech: Mechanism, Q: ArrayLike, V: ArrayLike, contact: Contact, law: ImpactLaw) -> BatchResult:
    """:func:`impact` for many configurations, one velocity each.

    Parameters
    ----------
    Q : array_like, shape (B, nq)
    V : array_like, shape (B, nv)

    Returns
    -------
    BatchResult
        With per-row ``A`` (B, nv, nv) and ``J`` (B, d, nv).
    """
    _check_parts(mech, contact, law)
    Q = as_array("Q", Q, 2, (None, mech.nq))
    V = as_array("V", V, 2, (Q.shape[0], mech.nv))
    if not len(Q):
        raise ShapeError("Q and V must have at least one row")
    results = [impact(mech, q, v, contact, law) for q, v in zip(Q, V)]
    return BatchResult.stack(results)

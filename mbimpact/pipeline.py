"""One impact of a mechanism: the model's pipeline assembled on Pinocchio.

A(q) and J(q) (stage 1) → the contact metric W (stage 2) → the law's contact impulse (stages 3–5)
→ Δv = A⁻¹ Jᵀ P and I = Jᵀ P by Lagrange's equations (1.1). :func:`impact` takes one of three routes,
chosen here and nowhere else; each gives the same result to rounding, and each hands what it does not
treat to the next:

1. **the compiled front end** (:mod:`mbimpact.mechanism.front`, C++ on the live Pinocchio model): at a
   :class:`~mbimpact.PointContact` of a :class:`~mbimpact.Mechanism` (not of a subclass, which may
   compute J or A otherwise), stage 1 in one call: q and v checked, J(q), A(q) and its factor. A law whose
   compiled impact names a front-end function (Newton's) is computed there whole;
2. **the compiled law**: a law that declares one (:meth:`mbimpact.ImpactLaw.compiled_impact`) runs its
   whole impact in one compiled call on A(q)'s factor;
3. **the pipeline**: :meth:`mbimpact.ImpactLaw.apply_metric` on the metric of A(q)'s factor
   (:class:`~mbimpact.metric.FactoredMetric`): for a homogeneous law, :meth:`~mbimpact.ImpactLaw.contact_impulses`
   between two compiled metric steps; for what those decline, planar contacts and other laws, in numpy,
   where the error is named or the case treated.

:func:`impact_batch` runs route 2 once for all rows where the law has one, else :func:`impact` row by row.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .common.threads import single_blas_thread
from .common.validation import as_array
from .errors import ImpactError, ParameterError, ShapeError
from .laws.base import ImpactLaw
from .mechanism import front
from .mechanism.contact import Contact, PointContact
from .mechanism.mechanism import Mechanism
from .metric.delassus import ContactMetric, FactoredMetric
from .results.impact import BatchResult, ImpactResult

if TYPE_CHECKING:
    from .results.outcomes import ImpactOutcomes

__all__ = ["impact", "impact_batch", "impact_outcomes"]


def _check_parts(mech: object, contact: object, law: object) -> None:
    if not isinstance(mech, Mechanism):
        raise ParameterError(f"mech must be an mbimpact.Mechanism, got {type(mech).__name__}")
    if not isinstance(contact, Contact):
        raise ParameterError(f"contact must be a contact (e.g. mbimpact.PointContact), got {type(contact).__name__}")
    if not isinstance(law, ImpactLaw):
        raise ParameterError(f"law must be an impact law (NewtonLaw, RoughLaw, CoulombLaw, ...), "
                             f"got {type(law).__name__}")


def _front_parts(mech: Mechanism, contact: Contact) -> bool:
    """Whether the compiled front end computes stage 1 of this mechanism and contact: a PointContact of a
    Mechanism, exactly (a subclass may compute J, A or the checks otherwise: it takes the pipeline)."""
    return type(contact) is PointContact and type(mech) is Mechanism


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
    # the parts' kinds are checked once per combination of classes (isinstance on an ABC costs a single
    # impact as much as Newton's arithmetic)
    route = _ROUTES.get((type(mech), type(contact), type(law)))
    if route is None:
        route = _route(mech, contact, law)
    return route(mech, q, v, contact, law)


# The route of each (mechanism, contact, law) combination of classes: the front end's, or the pipeline's
_ROUTES: dict[tuple[type, type, type], Callable[..., ImpactResult]] = {}


def _route(mech: object, contact: object, law: object) -> Callable[..., ImpactResult]:
    _check_parts(mech, contact, law)
    assert isinstance(mech, Mechanism) and isinstance(contact, Contact)
    if len(_ROUTES) > 1000:  # classes made on the fly: keep the table small
        _ROUTES.clear()
    route = _front if _front_parts(mech, contact) else _pipeline
    _ROUTES[(type(mech), type(contact), type(law))] = route
    return route


def _front(mech: Mechanism, q: ArrayLike, v: ArrayLike, contact: PointContact, law: ImpactLaw) -> ImpactResult:
    """Route 1, the compiled front end, at a point contact of a spatial law; what it leaves takes the
    pipeline."""
    compiled = law.compiled_impact()
    whole = None if compiled is None else compiled.front
    if whole is not None:  # the whole impact in C++
        bound = mech.front_end()  # None where the front end is off (front.disabled() included)
        if bound is not None:
            n = mech.nv
            out = np.empty(6 * n + 12 + n * n)
            native = front.NATIVE
            assert native is not None  # a bound front end implies the module loaded
            if whole(native, bound, q, v, mech.frame_id(contact.frame), contact.point, contact.basis(),
                     out) == native.DONE:
                return ImpactResult.from_packed(out, n, 3, law)
    elif law.dim in (None, 3):
        stage = mech.front_stage_one(q, v, mech.frame_id(contact.frame), contact.point)  # None where it is off
        if stage is not None:
            A, U, D, J = stage
            J.setflags(write=False)
            return _on_factor(mech, q, v, law, compiled, A, U, D, J, contact.basis(), True)  # type: ignore[arg-type]
    return _pipeline(mech, q, v, contact, law)


def _pipeline(mech: Mechanism, q: ArrayLike, v: ArrayLike, contact: Contact, law: ImpactLaw) -> ImpactResult:
    """Routes 2 and 3 after the checks that name what is wrong, with the contact's own J and frame."""
    q, v = mech.check_state(q, v)
    d = law.dim or 3
    J, R = contact.jacobian(mech, q, d)
    if J.shape != (d, mech.nv) or R.shape != (d, d):  # a user's Contact subclass: the laws' kernels trust shapes
        raise ShapeError(f"{type(contact).__name__}.jacobian must return J of shape ({d}, {mech.nv}) and a frame R "
                         f"of shape ({d}, {d}); got {J.shape} and {R.shape}")
    # the result keeps J: a contact that refilled one array at every call would change earlier results
    J.setflags(write=False)
    if d == 3:
        A, U, D = mech.factor_arrays(q)
        return _on_factor(mech, q, v, law, law.compiled_impact(), A, U, D, J, R, False)
    return law.apply_metric(ContactMetric.from_mechanism(mech, q, J), v, R)


def _on_factor(mech: Mechanism, q: NDArray[np.float64], v: NDArray[np.float64], law: ImpactLaw, compiled: Any,
               A: NDArray[np.float64], U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64],
               R: NDArray[np.float64], trusted: bool) -> ImpactResult:
    """Routes 2 and 3 from A(q)'s factor (q and v checked): the law's compiled impact, else, or for what it
    declines, the pipeline on the factor's metric. ``trusted``: the arrays are the front end's (numba's
    dispatch is skipped)."""
    if compiled is not None:
        result = compiled.run(law, A, U, D, J, v, R, trusted)
        if result is not None:
            return result
    metric = FactoredMetric(A, J, U, D, lambda: ContactMetric.from_mechanism(mech, q, J), trusted)
    return law.apply_metric(metric, v, R)


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

    Notes
    -----
    Pinocchio's work (J, R and A with its factor per row) runs in lean loops; a law with a compiled impact
    (:meth:`ImpactLaw.compiled_impact`: Newton's, Coulomb's, a :class:`RoughLaw` on a :class:`Cone`) then
    makes it on blocks of rows, on other threads while the next blocks are gathered
    (:func:`mbimpact.set_kernel_threads`), each row :func:`impact`'s result. The other laws, and the rows
    that route leaves, are applied row by row as :func:`impact` does (the same errors and warnings, in row
    order, once ``Q`` and ``V`` have passed their checks as arrays: shape, finite).
    """
    _check_parts(mech, contact, law)
    Q = as_array("Q", Q, 2, (None, mech.nq))
    V = as_array("V", V, 2, (Q.shape[0], mech.nv))
    if not len(Q):
        raise ShapeError("Q and V must have at least one row")
    compiled = law.compiled_impact()
    if compiled is not None and len(Q) > 1 and law.dim in (None, 3):
        with single_blas_thread(len(Q)):  # small matrices: threads only cost
            stacked = _stacked(mech, Q, V, contact, law, compiled)
        if stacked is not None:
            return stacked
    return BatchResult.stack([impact(mech, q, v, contact, law) for q, v in zip(Q, V)])


def _stacked(mech: Mechanism, Q: NDArray[np.float64], V: NDArray[np.float64], contact: Contact, law: ImpactLaw,
             compiled: Any) -> BatchResult | None:
    """Route 2 for every row of a batch, or None (a row needs the row-by-row route)."""
    B, n = len(Q), mech.nv
    A, J, R = np.empty((B, n, n)), np.empty((B, 3, n)), np.empty((B, 3, 3))
    U, D = np.empty((B, n, n)), np.empty((B, n))
    # Q is finite (as_array); only quaternion blocks (nq > nv) need a check per row
    stop = [B]  # the first row that cannot be gathered (B: none)
    # the compiled front end gathers the rows (and checks their quaternions) where it computes stage 1
    front_rows = front.NATIVE is not None and _front_parts(mech, contact)
    if mech.nq != mech.nv and not front_rows:
        for i, q in enumerate(Q):
            try:
                mech.check_configuration(q)
            except ImpactError:
                stop[0] = i
                break

    def gather(a: int, b: int) -> None:
        """J, R and A(q) with its factor U, D of rows a to b, or _Unfilled at the first bad one."""
        if front_rows:  # the compiled front end, row after row, with the quaternion checks
            assert isinstance(contact, PointContact)
            got = mech.front_fill_rows(Q[a:b], mech.frame_id(contact.frame), contact.point, A[a:b], J[a:b],
                                       U[a:b], D[a:b])
            if got is None:  # turned off meanwhile (front.disabled): the row-by-row route
                raise _Unfilled
            R[a:b] = contact.basis()
            if a + got < b:
                stop[0] = a + got
                raise _Unfilled
            return
        end = min(b, stop[0])
        got = contact.fill_jacobians(mech, Q[a:end], 3, J[a:end], R[a:end]) if end > a else 0
        if a + got < b:
            stop[0] = a + got
            raise _Unfilled
        mech.fill_factors(Q[a:b], A[a:b], U[a:b], D[a:b])

    row: Callable[[int], ImpactResult] = lambda k: impact(mech, Q[k], V[k], contact, law)  # noqa: E731
    try:
        result: BatchResult = compiled.run_stack(law, A, U, D, J, V, R, row, gather)
        return result
    except _Unfilled:  # a bad configuration, or a contact that raises or gives arrays of other shapes:
        return None    # the row-by-row route raises the first bad row's error, in row order


def impact_outcomes(mech: Mechanism, q: ArrayLike, v: ArrayLike, contact: Contact, law: ImpactLaw) -> ImpactOutcomes:
    """The impact of :func:`impact` as a random variable over the microrelief, (2.6)–(2.7).

    Parameters
    ----------
    mech, q, v, contact
        As for :func:`impact`.
    law : RoughLaw
        A rough law without ``repeat``.

    Returns
    -------
    ImpactOutcomes
        ``mean`` is :func:`impact`'s result; the facets met, their flux weights, each facet's impact,
        samples and spread as :meth:`mbimpact.RoughLaw.outcomes` gives them, at ``A = pin.crba(q)`` and
        the contact's Jacobian.

    Raises
    ------
    ParameterError
        ``law`` is not a rough law or repeats micro-impacts; arguments of the wrong kind.
    ShapeError, NonFiniteError, NoImpactError, NoFacingFacetError, RoughnessError
        As :func:`impact` raises them.
    """
    from .laws.outcomes import outcomes_at_metric  # deferred: a single impact does not need it
    from .laws.rough import RoughLaw

    _check_parts(mech, contact, law)
    if not isinstance(law, RoughLaw):
        raise ParameterError(f"outcomes are those of a rough law (RoughLaw), got {type(law).__name__}")
    mean = impact(mech, q, v, contact, law)
    q, v = mech.check_state(q, v)
    d = law.dim or 3
    J, R = contact.jacobian(mech, q, d)
    if J.shape != (d, mech.nv) or R.shape != (d, d):
        raise ShapeError(f"{type(contact).__name__}.jacobian must return J of shape ({d}, {mech.nv}) and a frame R "
                         f"of shape ({d}, {d}); got {J.shape} and {R.shape}")
    J.setflags(write=False)
    return outcomes_at_metric(law, ContactMetric.from_mechanism(mech, q, J), v, R, mean)


class _Unfilled(Exception):
    """A row of the stacks could not be gathered (the row-by-row route names it)."""

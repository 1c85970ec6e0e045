"""One impact of a mechanism: the pipeline assembled on Pinocchio.

A(q) and J(q) (stage 1) → the contact metric W (stage 2) → the law's contact
impulse (stages 3–5) → Δv = A⁻¹ Jᵀ P and I = Jᵀ P by Lagrange's equations (1.1).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.threads import single_blas_thread
from ..common.validation import as_array
from ..errors import ImpactError, ParameterError, ShapeError
from ..results.impact import BatchResult, ImpactResult
from ..laws.base import ImpactLaw
from ..laws.newton import NewtonLaw
from ..laws.rough import RoughLaw
from . import front
from .contact import Contact, PointContact
from .mechanism import Mechanism

__all__ = ["impact", "impact_batch"]


# The route of each (mechanism, contact, law) combination of classes, chosen once: the parts' kinds are
# checked then, not on every call
_ROUTES: dict[tuple[type, type, type], Callable[[Any, Any, Any, Any, Any], ImpactResult]] = {}


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
    route = _ROUTES.get((type(mech), type(contact), type(law)))
    if route is None:
        route = _route(mech, contact, law)
    return route(mech, q, v, contact, law)


def _route(mech: Mechanism, contact: Contact, law: ImpactLaw) -> Callable[..., ImpactResult]:
    """The route of this combination of classes. At a point contact, where no part overrides what the
    compiled front end computes: Newton's law whole through it, and the laws that start from A(q)'s
    factor from its stage one. Everything else: the pipeline."""
    _check_parts(mech, contact, law)
    kinds = (type(mech), type(contact), type(law))
    front_end = _front_parts(mech, contact)
    newton = isinstance(law, NewtonLaw) and all(getattr(kinds[2], m) is getattr(NewtonLaw, m)
                                                for m in ("apply_mechanism", "apply_metric"))
    factored = kinds[2].apply_mechanism in _TAKE_FACTOR  # the package's own, which take the factor
    if len(_ROUTES) > 1000:  # classes made on the fly: keep the table small
        _ROUTES.clear()
    route: Callable[..., ImpactResult] = _pipeline
    if front_end:
        route = _newton_front if newton else _front if factored else _pipeline
    _ROUTES[kinds] = route
    return route


def _front_parts(mech: Mechanism, contact: Contact) -> bool:
    """Whether the compiled front end computes what this mechanism and contact would: a point contact, and
    none of the methods it stands for overridden (the pipeline then runs the override)."""
    return (isinstance(contact, PointContact) and type(contact).jacobian is PointContact.jacobian
            and type(contact).basis is PointContact.basis  # (its frame goes to compiled kernels unchecked)
            and all(getattr(type(mech), m) is getattr(Mechanism, m)
                    for m in ("check_state", "check_configuration", "frame_jacobian", "factor_arrays",
                              "fill_factors", "fill_frame_jacobians")))


_TAKE_FACTOR = (ImpactLaw.apply_mechanism, NewtonLaw.apply_mechanism, RoughLaw.apply_mechanism)


def _pipeline(mech: Mechanism, q: ArrayLike, v: ArrayLike, contact: Contact, law: ImpactLaw) -> ImpactResult:
    """The pipeline in Python: checks that name what is wrong, the contact's J and frame, the law."""
    q, v = mech.check_state(q, v)
    d = law.dim or 3
    J, R = contact.jacobian(mech, q, d)
    if J.shape != (d, mech.nv) or R.shape != (d, d):  # a user's Contact subclass: the laws' kernels trust shapes
        _bad_shapes(contact, J, R, d, mech.nv)
    # the result keeps J: a contact that refilled one array at every call would change earlier results
    J.setflags(write=False)
    return law.apply_mechanism(mech, q, v, J, R)


def _front(mech: Mechanism, q: ArrayLike, v: ArrayLike, contact: PointContact, law: ImpactLaw) -> ImpactResult:
    """Stage one of a spatial impact at a point contact in one call of the compiled front end
    (:meth:`Mechanism.front_stage_one`), then the law as the pipeline applies it: the same arguments, the
    same result. What the front end leaves (inputs to check, planar laws) takes the pipeline."""
    if law.dim in (None, 3) and law.reads_factor():
        stage = mech.front_stage_one(q, v, mech.frame_id(contact.frame), contact.point)
        if stage is not None:
            A, U, D, J = stage
            J.setflags(write=False)
            return law.apply_mechanism(mech, q, v, J, contact.basis(), (A, U, D))  # type: ignore[arg-type]
    return _pipeline(mech, q, v, contact, law)


def _newton_front(mech: Mechanism, q: ArrayLike, v: ArrayLike, contact: PointContact, law: NewtonLaw
                  ) -> ImpactResult:
    """Newton's impact at a point contact in one call of the compiled front end: the pipeline's result
    to the bit. What the front end leaves (inputs to check, degenerate impacts) takes the pipeline."""
    bound = mech.front_end()
    native = front.NATIVE
    if bound is not None and native is not None:
        n = mech.nv
        out = np.empty(6 * n + 12 + n * n)
        if native.newton(bound, q, v, mech.frame_id(contact.frame), contact.point, contact.basis(), law.e,
                         out) == native.DONE:
            return ImpactResult.from_packed(out, n, 3, law)
    return _pipeline(mech, q, v, contact, law)


def _bad_shapes(contact: Contact, J: NDArray[np.float64], R: NDArray[np.float64], d: int, nv: int) -> None:
    raise ShapeError(f"{type(contact).__name__}.jacobian must return J of shape ({d}, {nv}) and a frame R of shape "
                     f"({d}, {d}); got {J.shape} and {R.shape}")


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
    Pinocchio's work (J, R and A per row) runs in lean loops; a law with a closed
    form (:meth:`ImpactLaw.apply_stack`: Newton's) then treats all rows at once with
    batched LAPACK, and a law whose single impact is one compiled call on Pinocchio's factor
    of A(q) (:meth:`ImpactLaw.apply_factored_stack`: a :class:`RoughLaw` on a :class:`Cone`,
    the :class:`CoulombLaw`) makes that call on blocks of rows, on other threads while the
    next blocks are gathered (:func:`mbimpact.set_kernel_threads`), each row :func:`impact`'s
    result to the bit. The other laws, and the rows those routes leave, are applied row by
    row as :func:`impact` does (the same errors and warnings, in row order, once ``Q`` and
    ``V`` have passed their checks as arrays: shape, finite).
    """
    _check_parts(mech, contact, law)
    Q = as_array("Q", Q, 2, (None, mech.nq))
    V = as_array("V", V, 2, (Q.shape[0], mech.nv))
    if not len(Q):
        raise ShapeError("Q and V must have at least one row")
    with single_blas_thread(len(Q)):  # batched LAPACK on small matrices: threads only cost
        stacked = _stacked(mech, Q, V, contact, law) if len(Q) > 1 else None
    if stacked is not None:
        return stacked
    results = [impact(mech, q, v, contact, law) for q, v in zip(Q, V)]
    return BatchResult.stack(results)


def _stacked(mech: Mechanism, Q: NDArray[np.float64], V: NDArray[np.float64], contact: Contact, law: ImpactLaw
             ) -> BatchResult | None:
    """The vectorised route of :func:`impact_batch`, or None (the law has none, or a row needs the
    row-by-row route)."""
    factored = law.factored_stack()
    if not factored and type(law).apply_stack is ImpactLaw.apply_stack:
        return None
    d, B, n = law.dim or 3, len(Q), mech.nv
    A, J, R = np.empty((B, n, n)), np.empty((B, d, n)), np.empty((B, d, d))
    # Q is finite (as_array); only quaternion blocks (nq > nv) need a check per row
    stop = [B]  # the first row that cannot be gathered (B: none)
    # the compiled front end gathers the rows (and checks their quaternions) where it computes what the
    # contact and mechanism would
    front_rows = d == 3 and front.NATIVE is not None and _front_parts(mech, contact)
    if mech.nq != mech.nv and not front_rows:
        for i, q in enumerate(Q):
            try:
                mech.check_configuration(q)
            except ImpactError:
                stop[0] = i
                break

    def gather(a: int, b: int, U: NDArray[np.float64] | None = None, D: NDArray[np.float64] | None = None) -> None:
        """J, R and A(q) (and its factor U, D) of rows a to b, or _Unfilled at the first bad one."""
        if front_rows:  # the compiled front end, row after row, with the quaternion checks
            assert isinstance(contact, PointContact)
            got = mech.front_fill_rows(Q[a:b], mech.frame_id(contact.frame), contact.point, A[a:b], J[a:b],
                                       None if U is None else U[a:b], None if D is None else D[a:b])
            if got is None:  # turned off meanwhile (front.disabled): the row-by-row route
                raise _Unfilled
            R[a:b] = contact.basis()
            if a + got < b:
                stop[0] = a + got
                raise _Unfilled
            return
        end = min(b, stop[0])
        got = contact.fill_jacobians(mech, Q[a:end], d, J[a:end], R[a:end]) if end > a else 0
        if a + got < b:
            stop[0] = a + got
            raise _Unfilled
        mech.fill_factors(Q[a:b], A[a:b], None if U is None else U[a:b], None if D is None else D[a:b])

    try:
        if factored:  # Pinocchio's work block by block, overlapped with the law's compiled calls on the rows gathered
            U, D = np.empty((B, n, n)), np.empty((B, n))
            return law.apply_factored_stack(A, U, D, J, V, R, lambda k: impact(mech, Q[k], V[k], contact, law),
                                            lambda a, b: gather(a, b, U, D))
        gather(0, B)
    except _Unfilled:  # a bad configuration, or a contact that raises or gives arrays of other shapes:
        return None    # the row-by-row route raises the first bad row's error, in row order
    return law.apply_stack(A, J, V, R)


class _Unfilled(Exception):
    """A row of the stacks could not be gathered (the row-by-row route names it)."""

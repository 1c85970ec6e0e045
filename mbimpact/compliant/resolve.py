"""The constructive model resolved in time: Kelvin–Voigt contacts on the full dynamics.

The law (2.8) is the limit M → ∞ of a physical process: while a facet constraint
is violated (f < 0) the force (2.3) Q* = −(M² f + 2kM ḟ) ∇fᵀ acts, until f changes
sign again. :func:`resolve` integrates that process on the mechanism's dynamics
(Pinocchio's ABA with the Kelvin–Voigt generalised forces; gravity, Coriolis and
the change of A(q), J(q) included) for one or several contacts, each with its own
facet, M and k. :func:`resolve_rough` draws facets from a roughness measure with
the flux weights (2.7) and averages the resolved impacts.

Each facet constraint is normalised as in (2.2): f = mᵀ(p(q) − p(q⁰)) / √(mᵀW⁰m),
so that |N| = 1 in the A-metric at q⁰ and f̈ = −(M² f + 2kM ḟ) holds exactly when
A and J are frozen (``dynamics="impact"``), the paper's (2.4).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, cast

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from ..common.geometry import offset_point_jacobian
from ..common.validation import as_array, as_count, as_scalar
from ..mechanism.contact import PointContact
from ..errors import (
    AccuracyWarning,
    IntegrationError,
    NoFacingFacetError,
    NoImpactError,
    ParameterError,
    ShapeError,
    warn,
)
from ..mechanism.mechanism import Mechanism
from ..facets.restitution import impact_duration, k_from_e
from ..roughness.base import check_normals

__all__ = ["Resolved", "resolve", "check_mechanism", "check_contacts"]

#: Largest velocity entry :func:`resolve` integrates: the forces M² f (M ≤ 1e9) stay far inside the float range.
MAX_SPEED = 1e100

# stiff-capable integrators of scipy.integrate.solve_ivp
_METHODS = ("LSODA", "Radau", "BDF")


@dataclass(frozen=True, eq=False)
class Resolved:
    """Outcome of a compliant impact integrated in time.

    Attributes
    ----------
    v_plus : ndarray, shape (nv,)
        Velocity at separation (or at ``t_max`` if the contacts never separate).
    q_plus : ndarray, shape (nq,)
        Configuration at separation.
    duration : float
        Time from touch-down to separation.
    tau : ndarray, shape (c,)
        (2.5)'s single-facet duration π / (M √(1 − k²)) per contact.
    impulse : ndarray, shape (nv,)
        Generalised impulse ∫ Q* dt of the contact forces.
    contact_impulse : ndarray, shape (c,)
        ∫ −(M² f + 2kM ḟ) dt per contact (normal impulse of the normalised constraint).
    t : ndarray, shape (T,)
        Output times.
    f : ndarray, shape (c, T)
        Normalised penetration history (negative inside).
    status : {"separated", "no_separation"}
        Whether every contact separated within ``t_max``.
    nfev : int
        Right-hand-side evaluations.
    """

    v_minus: NDArray[np.float64]
    v_plus: NDArray[np.float64]
    q_plus: NDArray[np.float64]
    duration: float
    tau: NDArray[np.float64]
    impulse: NDArray[np.float64]
    contact_impulse: NDArray[np.float64]
    t: NDArray[np.float64]
    f: NDArray[np.float64]
    status: str
    nfev: int

    @property
    def dv(self) -> NDArray[np.float64]:
        """Velocity jump v₊ − v₋, shape (nv,)."""
        return self.v_plus - self.v_minus

    @property
    def max_penetration(self) -> NDArray[np.float64]:
        """Largest −f per contact, shape (c,)."""
        return np.maximum(-self.f.min(axis=1), 0.0)


class _OutOfEvaluations(Exception):
    """Raised by the right-hand side of :func:`resolve` past ``max_evaluations`` (with where it was)."""

    def __init__(self, t: float, y: NDArray[np.float64]) -> None:
        super().__init__(t)
        self.t, self.y = float(t), np.array(y, dtype=float)


def check_mechanism(mech: object) -> Mechanism:
    """``mech`` if it is a :class:`Mechanism` (a :class:`ParameterError` naming what it got otherwise)."""
    if not isinstance(mech, Mechanism):
        raise ParameterError(f"mech must be an mbimpact.Mechanism, got {type(mech).__name__}")
    return mech


def check_contacts(contacts: object) -> list[PointContact]:
    """One :class:`PointContact` or a sequence of them, as a list (at least one).

    Raises
    ------
    ParameterError
        Anything else (a string, None, a contact of another kind).
    ShapeError
        An empty sequence.
    """
    if isinstance(contacts, PointContact):
        return [contacts]
    try:
        out = list(contacts)  # type: ignore[call-overload]
    except TypeError:
        out = None
    if out is not None:
        bad = [type(c).__name__ for c in out if not isinstance(c, PointContact)]
        if not bad:
            if not out:
                raise ShapeError("at least one contact is needed")
            return out
        what = f"a sequence holding {bad[0]}"
    else:
        what = type(contacts).__name__
    raise ParameterError(f"contacts must be a PointContact or a list of PointContact, got {what}")


def _per_contact(name: str, x: float | Sequence[float] | None, count: int) -> list[float | None]:
    if x is None or np.isscalar(x) or (isinstance(x, np.ndarray) and x.ndim == 0):
        return [x] * count  # type: ignore[list-item]
    try:
        vals: list[float | None] = list(x)  # type: ignore[arg-type]
    except TypeError:
        raise ParameterError(f"{name} must be a number or a sequence of {count} numbers, got {x!r}") from None
    if len(vals) != count:
        raise ShapeError(f"{name} has {len(vals)} entries for {count} contacts")
    return vals


def resolve(
    mech: Mechanism,
    q: ArrayLike,
    v: ArrayLike,
    contacts: PointContact | Sequence[PointContact],
    facets: ArrayLike | None = None,
    *,
    M: float | Sequence[float] = 1e3,
    k: float | Sequence[float] | None = None,
    e: float | Sequence[float] | None = None,
    dynamics: Literal["full", "impact"] = "full",
    gravity: bool = True,
    rtol: float = 1e-9,
    method: str = "LSODA",
    t_max: float | None = None,
    surface_points: ArrayLike | None = None,
    max_evaluations: int = 100_000,
) -> Resolved:
    """Integrate one or several Kelvin–Voigt contacts from touch-down to separation.

    Parameters
    ----------
    mech : Mechanism
    q : array_like, shape (nq,)
        Configuration at touch-down (every contact point on its surface, f = 0).
    v : array_like, shape (nv,)
        Velocity at touch-down.
    contacts : PointContact or sequence of PointContact
    facets : array_like, shape (3,) or (c, 3), optional
        Facet normal of each contact in its local frame (last component along n⁰);
        default: the base normal (smooth facet).
    M : float or sequence
        Stiffness parameter of (2.3) [1/s], > 0, per contact or shared.
    k, e : float or sequence
        Damping ratio in [0, 1] or the equivalent restitution e (exactly one; default k = 0).
    dynamics : {"full", "impact"}
        "full": Pinocchio ABA with the configuration, Coriolis and (if ``gravity``)
        gravity terms; "impact": A(q⁰) and J(q⁰) frozen, no other force — the
        paper's (2.4), in which the velocity jump does not depend on M.
    rtol : float
        Relative tolerance of the integrator (absolute tolerances scale with M).
    method : str
        ``scipy.integrate.solve_ivp`` method; stiff-capable "LSODA" (default) or "Radau".
    t_max : float, optional
        Integration limit, ≥ 1e-3 π / max(M); default 50 π / min(M) (k = 1 never separates: the
        limit is reported).
    surface_points : array_like, shape (c, 3), optional
        A point of each contact's surface plane; then f(q⁰) must be 0 (checked).
    max_evaluations : int
        Bound on the right-hand-side evaluations (a few thousand suffice for an ordinary impact);
        beyond it an :class:`IntegrationError` says where the integration was (the time reached and
        the contacts' penetrations). The full dynamics of an arm at a nearly singular posture is so
        stiff that it may need more; ``dynamics="impact"`` (A and J frozen, (2.4)) resolves such an
        impact in a few hundred.

    Returns
    -------
    Resolved

    Raises
    ------
    ParameterError
        ``mech`` not a :class:`Mechanism`, ``contacts`` not point contacts, M outside [1e-3, 1e9],
        k or e outside [0, 1], both k and e, rtol outside [1e-13, 1e-3], t_max below 1e-3 π / max(M),
        ``gravity`` not a bool, an unknown dynamics or method, velocity entries above :data:`MAX_SPEED`.
    ShapeError, NonFiniteError
        Invalid q, v, facets or surface points.
    NoImpactError
        No contact approaches its surface.
    NoFacingFacetError
        A facet does not face the velocity of its contact point (mᵀu ≥ 0) while
        the base surface does.
    IntegrationError
        The integrator gave up; the message gives the time reached.
    """
    from scipy.integrate import solve_ivp  # deferred: scipy.integrate costs 0.1 s to import

    check_mechanism(mech)
    contacts = check_contacts(contacts)
    c = len(contacts)
    q0, v0 = mech.check_state(q, v)
    if float(np.abs(v0).max()) > MAX_SPEED:
        raise ParameterError(f"resolve takes velocities up to {MAX_SPEED:g} (the forces M² f of the integration "
                             f"must stay finite), got |v| up to {float(np.abs(v0).max()):.3g}")
    # M sets the time scale π/M of a facet impact: beyond these bounds the times underflow or the
    # integration of the full dynamics over ~50π/M runs for ever
    Ms = [as_scalar("M", m, 1e-3, 1e9) for m in cast(list[float], _per_contact("M", M, c))]
    if not isinstance(dynamics, str) or dynamics not in ("full", "impact"):
        raise ParameterError(f"dynamics must be 'full' (Pinocchio ABA) or 'impact' (A and J frozen, (2.4)), got {dynamics!r}")
    if not isinstance(gravity, bool):
        raise ParameterError(f"gravity must be True or False, got {gravity!r}")
    if not isinstance(method, str) or method not in _METHODS:
        raise ParameterError(f"method must be one of the stiff integrators {', '.join(_METHODS)}, got {method!r}")
    rtol = as_scalar("rtol", rtol, 1e-13, 1e-3)
    if t_max is not None:
        # from a thousandth of the shortest facet duration π/M: a shorter horizon resolves nothing
        t_max = as_scalar("t_max", t_max, 1e-3 * math.pi / max(Ms), math.inf)
    max_evaluations = as_count("max_evaluations", max_evaluations, 100, 10**9)
    if k is not None and e is not None:
        raise ParameterError("give at most one of k (damping ratio) or e (restitution)")
    if e is not None:
        ks = [k_from_e(x) for x in _per_contact("e", e, c)]  # type: ignore[arg-type]
    else:
        ks = [as_scalar("k", x if x is not None else 0.0, 0.0, 1.0) for x in _per_contact("k", k, c)]
    if facets is None:
        local = np.tile([0.0, 0.0, 1.0], (c, 1))
    else:
        try:
            ndim = np.ndim(facets)
        except ValueError:  # ragged nested sequences: as_array names the problem
            ndim = 2
        local = as_array("facets", facets, ndim)
        local = np.tile(local, (c, 1)) if local.ndim == 1 else local
        if local.shape != (c, 3):
            raise ShapeError(f"facets must have shape (3,) or ({c}, 3), got {local.shape}")
        local = check_normals("facets", local)

    model = mech.model.copy()
    if not gravity or dynamics == "impact":
        model.gravity.linear[:] = 0.0
    data = model.createData()
    fids = [mech.frame_id(ct.frame) for ct in contacts]
    A0 = pin.crba(model, data, q0).copy()
    pin.framesForwardKinematics(model, data, q0)
    m_world = np.stack([ct.basis() @ local[i] for i, ct in enumerate(contacts)])
    J0 = np.stack([mech.point_jacobian(q0, ct.frame, ct.point) for ct in contacts])  # (c, 3, nv)
    grads0 = np.einsum("cd,cdn->cn", m_world, J0)  # mᵀJ, (c, nv)
    W0 = np.einsum("cn,cn->c", grads0, np.linalg.solve(A0, grads0.T).T)
    if np.any(W0 <= 0):
        raise NoImpactError("a contact point cannot move along its facet normal (mᵀW m = 0)")
    scale = np.sqrt(W0)
    p0 = np.stack([mech.frame_position(q0, ct.frame, ct.point) for ct in contacts])
    if surface_points is not None:
        sp = as_array("surface_points", surface_points, 2, (c, 3))
        gap = np.einsum("cd,cd->c", np.stack([ct.normal for ct in contacts]), p0 - sp)
        bad = np.flatnonzero(np.abs(gap) > 1e-9 * max(1.0, float(np.abs(p0).max())))
        if bad.size:
            raise NoImpactError(f"contact {bad[0]} is not on its surface at the start: gap {gap[bad[0]]:.3g} (f must be 0)")
    base_rate = np.einsum("cd,cdn,n->c", np.stack([ct.normal for ct in contacts]), J0, v0)
    if not np.any(base_rate < 0):
        raise NoImpactError("no contact point approaches its surface: n0·(J v) ≥ 0 for every contact")
    rate = grads0 @ v0
    bad = np.flatnonzero((base_rate < 0) & (rate >= 0))
    if bad.size:
        raise NoFacingFacetError(f"the facet of contact {bad[0]} does not face the velocity: mᵀu = {rate[bad[0]]:.3g} ≥ 0")

    nv = mech.nv
    Mv, kv = np.array(Ms), np.array(ks)
    A0inv = np.linalg.inv(A0) if dynamics == "impact" else None

    def state(y: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Configuration, f (c,), ∇f (c, nv) and the extra data of one state."""
        dq = y[:nv]
        if dynamics == "impact":
            return q0, (grads0 @ dq) / scale, grads0 / scale[:, None], dq
        qc = pin.integrate(model, q0, dq)
        pin.computeJointJacobians(model, data, qc)
        pin.updateFramePlacements(model, data)
        f = np.empty(c)
        G = np.empty((c, nv))
        for i, (ct, fid) in enumerate(zip(contacts, fids)):
            oMf = data.oMf[fid]
            r = oMf.rotation @ ct.point
            J6 = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            Jp = offset_point_jacobian(J6, r)
            f[i] = m_world[i] @ (oMf.translation + r - p0[i]) / scale[i]
            G[i] = m_world[i] @ Jp / scale[i]
        return qc, f, G, dq

    def forces(f: NDArray[np.float64], fdot: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.where(f < 0.0, -(Mv * Mv * f + 2.0 * kv * Mv * fdot), 0.0)

    evaluations = 0

    def rhs(t: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
        nonlocal evaluations
        evaluations += 1
        if evaluations > max_evaluations:  # checked here: one call of the integrator may take any number
            raise _OutOfEvaluations(t, y)
        qc, f, G, dq = state(y)
        vel = y[nv: 2 * nv]
        lam = forces(f, G @ vel)
        tau = G.T @ lam
        if dynamics == "impact":
            assert A0inv is not None
            acc, dqdt = A0inv @ tau, vel
        else:
            acc = pin.aba(model, data, qc, vel, tau)
            dqdt = np.linalg.solve(pin.dIntegrate(model, q0, dq, pin.ARG1), vel)
        return np.concatenate([dqdt, acc, tau, lam])

    def crossing(i: int, direction: float):
        def event(t: float, y: NDArray[np.float64]) -> float:
            return float(state(y)[1][i])

        event.terminal = True  # type: ignore[attr-defined]
        event.direction = direction  # type: ignore[attr-defined]
        return event

    tau_facet = np.array([impact_duration(m, kk) for m, kk in zip(Ms, ks)])
    t_end = t_max if t_max is not None else 50.0 * math.pi / float(Mv.min())
    y = np.zeros(3 * nv + c)
    y[nv: 2 * nv] = v0
    t0 = 0.0
    # absolute tolerances per block: displacements are O(|v| τ), velocities O(|v|)
    # absolute tolerances on the scale of the jump, (1+e)|ḟ₀||N| per contact — not of |v|, which
    # at grazing incidence is far larger than the jump the integration must resolve
    N0 = np.linalg.solve(A0, grads0.T) / scale  # (nv, c), unit A-metric normals
    vscale = max(float(np.max(2.0 * np.abs(rate) * np.abs(N0).max(axis=0))), 1e-300)
    atol = np.concatenate([np.full(nv, vscale / Mv.max()), np.full(nv, vscale),
                           np.full(nv + c, vscale * float(np.sqrt(W0).min()))]) * rtol
    nudge = 1e-6 / float(Mv.max())  # steps off an event so that no event function starts at 0
    ts, fs, nfev = [0.0], [np.zeros(c)], 0
    status = "no_separation"

    def advance(t1: float, events: list) -> object:
        nonlocal nfev, t0, y
        try:
            with warnings.catch_warnings(record=True) as caught:
                # LSODA reports its failures as a UserWarning, outside mbimpact's tree: its message
                # joins the named IntegrationError below instead
                warnings.filterwarnings("always", message="lsoda", category=UserWarning)
                sol = solve_ivp(rhs, (t0, t1), y, method=method, events=events or None, rtol=rtol, atol=atol,
                                first_step=min(1e-3 / float(Mv.max()), (t1 - t0) / 4) or None)
            lsoda = [str(w.message) for w in caught if w.category is UserWarning and str(w.message).startswith("lsoda")]
            for w in caught:  # anything else passes through as it came
                if str(w.message) not in lsoda:
                    warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        except _OutOfEvaluations as stop:
            raise IntegrationError(f"the compliant impact needed more than {max_evaluations} evaluations; stopped at "
                                   f"t = {stop.t:.6g} of {t_end:.6g} (τ = {float(tau_facet.min()):.3g}), penetrations "
                                   f"{np.round(-state(stop.y)[1], 12).tolist()}; dynamics='impact' (A and J frozen) "
                                   "resolves a stiff impact in far fewer") from None
        nfev = evaluations
        if sol.status == -1:
            said = "".join(f" ({text})" for text in lsoda)
            raise IntegrationError(f"integration stopped at t = {sol.t[-1]:.6g} of {t_end:.6g}: {sol.message}{said}")
        for text in lsoda:  # LSODA complained but went on: its warning, as mbimpact's
            warn(AccuracyWarning, f"the compliant impact's integration (LSODA) warned: {text}")
        ts.extend(sol.t[1:].tolist())
        fs.extend(state(yy)[1] for yy in sol.y[:, 1:].T)
        t0, y = float(sol.t[-1]), sol.y[:, -1].copy()
        return sol

    rate0 = float(np.abs(rate).max())
    f_tol, rate_tol = 100 * rtol * rate0 / float(Mv.min()), 100 * rtol * rate0  # below: integration noise
    advance(min(nudge, t_end), [])
    for _ in range(10_000):  # one phase per contact event (contacts may open and close again)
        _, f, G, _ = state(y)
        fdot = G @ y[nv: 2 * nv]
        leaving = ((f > f_tol) & (fdot >= 0.0)) | ((f >= -f_tol) & (fdot > rate_tol))
        if np.all(leaving):
            status = "separated"
            break
        if np.all(np.abs(f) <= f_tol) and np.all(np.abs(fdot) <= rate_tol):
            break  # crept to rest on the surface (k → 1 or a pressing load): no separation
        if t0 >= t_end:
            break
        # inside: watch for the exit (f ↑ 0); outside: watch for a re-entry (f ↓ 0)
        sol = advance(t_end, [crossing(i, 1.0 if f[i] < 0 else -1.0) for i in range(c)])
        if sol.status == 0:  # type: ignore[attr-defined]
            break
        advance(min(t0 + nudge, t_end), [])
    q_plus = pin.integrate(model, q0, y[:nv]) if dynamics == "full" else q0.copy()
    return Resolved(
        v_minus=v0.copy(), v_plus=y[nv: 2 * nv].copy(), q_plus=q_plus, duration=t0, tau=tau_facet,
        impulse=y[2 * nv: 3 * nv].copy(), contact_impulse=y[3 * nv:].copy(), t=np.array(ts),
        f=np.array(fs).T, status=status, nfev=nfev,
    )

"""Event-driven simulation of a scene: free flight, impacts, resting contact.

Free flight is Pinocchio's forward dynamics with only the forces the scene
declares. Impacts are the events f = 0 with ḟ < 0 (``scipy.integrate.solve_ivp``
events on the gap of every open contact); the contact's law is applied to the
velocity relative to the surface. A contact whose rebound is slower than
``rest_velocity`` (on a fixed surface) switches to resting contact — the
documented end of a Zeno accumulation of bounces — and lifts off again when its
contact force would pull. Contacts that strike at the same instant are resolved
together with the compliant model of :func:`mbimpact.resolve`.

The ``work`` counters of the result record what was computed, so that a scene's
undeclared effects can be shown to cost nothing.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..common.geometry import offset_point_jacobian
from ..errors import IntegrationError
from ..laws.base import ImpactLaw
from ..laws.newton import NewtonLaw
from ..metric import ContactMetric, local_basis
from ..apps.progress import Progress
from ..compliant.resolve import resolve
from ..laws.rough import RoughLaw
from ..roughness import Smooth
from .scene import Scene, SceneContact

__all__ = ["ImpactRecord", "Trajectory", "simulate"]

# Two contacts whose gaps close within this time are treated as simultaneous.
_SIMULTANEOUS = 1e-9
# Penetration at which an impact event fires [m]; leaves room for rounding at take-off.
_GAP_SLACK = 1e-10


@dataclass(frozen=True)
class ImpactRecord:
    """One impact: time, contact, relative contact velocity before/after, κ, μ, impulse, energy loss.

    A record with ``rest=True`` marks the switch to resting contact (its un_minus is the
    rebound velocity that fell below ``rest_velocity``)."""

    t: float
    contact: int
    un_minus: float
    ut_minus: float
    un_plus: float
    ut_plus: float
    kappa: float
    mu: float
    impulse: float
    energy_loss: float
    rest: bool = False  # the contact switched to resting contact here


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Sampled states, the impact log and the work counters of a simulation."""

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    v: NDArray[np.float64]
    energy: NDArray[np.float64]
    gaps: NDArray[np.float64]
    gap_rates: NDArray[np.float64]
    impacts: list[ImpactRecord]
    work: Counter
    status: str
    resting: tuple[bool, ...] = field(default=())

    def first_rest_time(self) -> float | None:
        """Time at which a contact first came to rest (None if never)."""
        rest = [r.t for r in self.impacts if r.rest]
        return rest[0] if rest else None


def _effective_law(law: ImpactLaw) -> ImpactLaw:
    """No microrelief ⇒ the Newton path: no facet work at all."""
    if isinstance(law, RoughLaw) and isinstance(law.roughness, Smooth):
        return NewtonLaw(law.e)
    return law


class _Sim:
    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.mech = scene.mechanism
        self.model = self.mech.model.copy()
        if not scene.gravity:
            self.model.gravity.linear[:] = 0.0
        self.data = self.model.createData()
        self.laws = [_effective_law(c.law) for c in scene.contacts]
        self.fids = [self.mech.frame_id(c.frame) for c in scene.contacts]
        self.work: Counter = Counter()
        self.resting = [False] * len(scene.contacts)
        nv = self.mech.nv
        self.tau0 = scene.torque if scene.torque is not None else None
        self.nv = nv
        # a moving surface can cross a free-flight parabola twice within one (exact) step:
        # sample each surface period finely enough for the gap events to see every crossing
        freqs = [c.surface.frequency for c in scene.contacts if c.surface.moving]
        self.max_step = 1.0 / (40.0 * max(freqs)) if freqs else math.inf

    # ---------------------------------------------------------------- geometry
    def offset(self, c: SceneContact, t: float) -> tuple[float, float]:
        if not c.surface.moving:
            return 0.0, 0.0
        self.work["surface_motion"] += 1
        return c.surface.offset(t)

    def contact_state(self, i: int, q: NDArray[np.float64], v: NDArray[np.float64], t: float, kinematics: bool = True):
        """Gap f, local normal n, point Jacobian J (3, nv), relative velocity u (3,)."""
        c = self.scene.contacts[i]
        if kinematics:
            pin.computeJointJacobians(self.model, self.data, q)
            pin.updateFramePlacements(self.model, self.data)
        oMf = self.data.oMf[self.fids[i]]
        r = oMf.rotation @ c.point
        J6 = pin.getFrameJacobian(self.model, self.data, self.fids[i], pin.LOCAL_WORLD_ALIGNED)
        J = offset_point_jacobian(J6, r)
        a, adot = self.offset(c, t)
        f, n = c.surface.gap(oMf.translation + r, a)
        u = J @ v - adot * c.surface.normal
        return f, n, J, u

    # ---------------------------------------------------------------- dynamics
    def torque(self, v: NDArray[np.float64]) -> NDArray[np.float64]:
        tau = np.zeros(self.nv) if self.tau0 is None else self.tau0.copy()
        if self.scene.damping:
            self.work["damping"] += 1
            tau -= self.scene.damping * v
        return tau

    def accel(self, q: NDArray[np.float64], v: NDArray[np.float64], t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Acceleration and the resting contacts' normal forces λ (≥ 0 pushes)."""
        self.work["dynamics"] += 1
        if self.scene.gravity:
            self.work["gravity"] += 1
        tau = self.torque(v)
        rest = [i for i, r in enumerate(self.resting) if r]
        if not rest:
            return pin.aba(self.model, self.data, q, v, tau), np.zeros(0)
        A = pin.crba(self.model, self.data, q)
        b = pin.rnea(self.model, self.data, q, v, np.zeros(self.nv))
        pin.forwardKinematics(self.model, self.data, q, v, np.zeros(self.nv))
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        rows: list[NDArray[np.float64]] = []
        drift: list[float] = []
        normal_rows: list[tuple[int, NDArray[np.float64]]] = []
        for i in rest:
            c = self.scene.contacts[i]
            _, n, J, _ = self.contact_state(i, q, v, t, kinematics=False)
            acc = pin.getFrameClassicalAcceleration(self.model, self.data, self.fids[i], pin.LOCAL_WORLD_ALIGNED)
            w = pin.getFrameVelocity(self.model, self.data, self.fids[i], pin.LOCAL_WORLD_ALIGNED).angular
            r = self.data.oMf[self.fids[i]].rotation @ c.point
            a_point = acc.linear + np.cross(w, np.cross(w, r))
            basis = np.eye(3) if c.rest == "stick" else n[None, :]  # pinned point or normal only
            normal_rows.append((len(rows), n if c.rest == "stick" else np.ones(1)))
            rows.extend(basis @ J)
            drift.extend(basis @ a_point)
        Jc = np.array(rows)
        k = len(rows)
        K = np.block([[A, -Jc.T], [Jc, np.zeros((k, k))]])
        sol = np.linalg.lstsq(K, np.concatenate([tau - b, -np.array(drift)]), rcond=None)[0]
        lam = sol[self.nv:]
        normal_forces = np.array([float(nr @ lam[s: s + len(nr)]) for s, nr in normal_rows])
        return sol[: self.nv], normal_forces

    # ---------------------------------------------------------------- impacts
    def apply_impact(self, i: int, q: NDArray[np.float64], v: NDArray[np.float64], t: float) -> tuple[NDArray[np.float64], ImpactRecord]:
        f, n, J, u = self.contact_state(i, q, v, t)
        law = self.laws[i]
        if isinstance(law, RoughLaw):
            self.work["facet_average"] += 1
        else:
            self.work["newton_impact"] += 1
        A = pin.crba(self.model, self.data, q).copy()
        if law.dim == 2:
            # planar roughness: the plane of n and the world x axis (projected) carries the facets
            t1 = np.array([1.0, 0.0, 0.0]) - n[0] * n
            t1 /= np.linalg.norm(t1)
            B = np.stack([t1, n])
            metric = ContactMetric.from_symmetric(A, B @ J)
            P = B.T @ law.impulses(metric, (B @ u)[None, :], np.eye(2)).P[0]
        else:
            metric = ContactMetric.from_symmetric(A, J)
            P = law.impulses(metric, u[None, :], local_basis(n, 3)).P[0]
        dv = np.linalg.solve(A, J.T @ P)
        return v + dv, self.record(i, t, n, u, u + J @ dv, P)

    def record(self, i: int, t: float, n: NDArray[np.float64], u0: NDArray[np.float64], u1: NDArray[np.float64], P: NDArray[np.float64]) -> ImpactRecord:
        un0, un1 = float(n @ u0), float(n @ u1)
        pn = float(n @ P)
        pt = float(np.linalg.norm(P - pn * n))
        return ImpactRecord(t, i, un0, float(np.linalg.norm(u0 - un0 * n)), un1, float(np.linalg.norm(u1 - un1 * n)),
                            -un1 / un0 if un0 else 0.0, pt / pn if pn > 0 else 0.0, float(np.linalg.norm(P)),
                            -0.5 * float(P @ (u0 + u1)))

    def energy(self, q: NDArray[np.float64], v: NDArray[np.float64]) -> float:
        T = pin.computeKineticEnergy(self.model, self.data, q, v)
        return T + (pin.computePotentialEnergy(self.model, self.data, q) if self.scene.gravity else 0.0)


def simulate(scene: Scene, samples: int = 2000, progress: bool = False) -> Trajectory:
    """Simulate a scene for ``scene.duration`` seconds.

    Parameters
    ----------
    scene : Scene
    samples : int
        Number of equally spaced output times (impact instants are added).
    progress : bool
        Draw a progress bar on stderr.

    Returns
    -------
    Trajectory
        ``status`` is "completed", or "max_impacts" if ``scene.max_impacts`` was reached.
    """
    from scipy.integrate import solve_ivp  # deferred: scipy.integrate costs 0.1 s to import

    sim = _Sim(scene)
    model, nv, nc = sim.model, sim.nv, len(scene.contacts)
    grid = np.linspace(0.0, scene.duration, samples)
    out_t, out_q, out_v = [], [], []
    impacts: list[ImpactRecord] = []
    q, v, t = scene.q0.copy(), scene.v0.copy(), 0.0
    bar = Progress(100, scene.name, enabled=progress)
    shown = 0
    status = "completed"

    def emit(tt: float, qq: NDArray[np.float64], vv: NDArray[np.float64]) -> None:
        out_t.append(tt)
        out_q.append(qq.copy())
        out_v.append(vv.copy())

    emit(t, q, v)
    while t < scene.duration:
        anchor = q.copy()

        def config(y: NDArray[np.float64]) -> NDArray[np.float64]:
            return pin.integrate(model, anchor, y[:nv])

        def rhs(tt: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
            qq, vv = config(y), y[nv:]
            a, _ = sim.accel(qq, vv, tt)
            dq = np.linalg.solve(pin.dIntegrate(model, anchor, y[:nv], pin.ARG1), vv)
            return np.concatenate([dq, a])

        def gap_event(i: int):
            def ev(tt: float, y: NDArray[np.float64]) -> float:
                # shifted by _GAP_SLACK: a contact leaving its surface starts at f ≈ 0 (±rounding)
                # and must not be able to slip through unseen
                return sim.contact_state(i, config(y), y[nv:], tt)[0] + _GAP_SLACK

            ev.terminal, ev.direction = True, -1.0  # type: ignore[attr-defined]
            return ev

        def lift_event(i: int):
            rest = [j for j, r in enumerate(sim.resting) if r]

            def ev(tt: float, y: NDArray[np.float64]) -> float:
                return float(sim.accel(config(y), y[nv:], tt)[1][rest.index(i)])

            ev.terminal, ev.direction = True, -1.0  # type: ignore[attr-defined]
            return ev

        events = [lift_event(i) if sim.resting[i] else gap_event(i) for i in range(nc)]
        y0 = np.concatenate([np.zeros(nv), v])
        t_eval = grid[(grid > t) & (grid <= scene.duration)]
        sol = solve_ivp(rhs, (t, scene.duration), y0, method="DOP853", events=events, t_eval=t_eval,
                        rtol=scene.rtol, atol=scene.rtol * 1e-3, dense_output=False, max_step=sim.max_step)
        if sol.status == -1:
            raise IntegrationError(f"free flight stopped at t = {sol.t[-1] if len(sol.t) else t:.6g}: {sol.message}")
        if len(sol.t):
            for tt, yy in zip(sol.t, np.asarray(sol.y).T):
                emit(tt, config(yy), yy[nv:])
        hits = [(ev[0], i, ys[0]) for i, (ev, ys) in enumerate(zip(sol.t_events, sol.y_events)) if len(ev)]
        if not hits:
            break
        t_e, i, y_e = min(hits, key=lambda h: h[0])
        q, v, t = config(y_e), y_e[nv:].copy(), float(t_e)
        if sim.resting[i]:  # lift-off
            sim.resting[i] = False
            sim.work["lift_off"] += 1
        else:
            q, v = _impact(sim, i, q, v, t, impacts)
        emit(t, q, v)
        if len(impacts) >= scene.max_impacts:
            status = "max_impacts"
            break
        now = int(100 * t / scene.duration) if scene.duration > 0 else 100
        while shown < now:
            bar.step(f"t={t:.3g}s, {len(impacts)} impacts")
            shown += 1
    while shown < 100:
        bar.step(f"{len(impacts)} impacts")
        shown += 1
    order = np.argsort(out_t, kind="stable")
    T = np.array(out_t)[order]
    Q, V = np.array(out_q)[order], np.array(out_v)[order]
    energy = np.array([sim.energy(qq, vv) for qq, vv in zip(Q, V)])
    gaps = np.zeros((len(T), nc))
    rates = np.zeros((len(T), nc))
    for k, (tt, qq, vv) in enumerate(zip(T, Q, V)):
        pin.computeJointJacobians(model, sim.data, qq)
        pin.updateFramePlacements(model, sim.data)
        for i in range(nc):
            f, n, _, u = sim.contact_state(i, qq, vv, tt, kinematics=False)
            gaps[k, i], rates[k, i] = f, float(n @ u)
    return Trajectory(T, Q, V, energy, gaps, rates, impacts, sim.work, status, tuple(sim.resting))


def _impact(sim: _Sim, i: int, q: NDArray[np.float64], v: NDArray[np.float64], t: float,
            impacts: list[ImpactRecord]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Apply the impact(s) at an event: simultaneous contacts, repeated impacts, rest."""
    scene = sim.scene
    f, n, J, u = sim.contact_state(i, q, v, t)
    if float(n @ u) >= 0.0:  # grazing: the gap closed without approach
        return q, v
    others = []
    for j in range(len(scene.contacts)):
        if j != i and not sim.resting[j]:
            fj, nj, _, uj = sim.contact_state(j, q, v, t)
            if fj <= -float(nj @ uj) * _SIMULTANEOUS and float(nj @ uj) < 0:
                others.append(j)
    if others:
        group = [i] + others
        sim.work["resolve"] += 1
        from ..mechanism.contact import PointContact

        contacts = [PointContact(scene.contacts[j].frame, normal=sim.contact_state(j, q, v, t)[1], point=scene.contacts[j].point)
                    for j in group]
        states = [sim.contact_state(j, q, v, t) for j in group]
        res = resolve(sim.mech, q, v, contacts, M=[scene.contacts[j].M for j in group],
                      e=[sim.laws[j].e for j in group], dynamics="impact")
        v_new = res.v_plus
        for j, (fj, nj, Jj, uj) in zip(group, states):
            u1 = Jj @ v_new - (uj - Jj @ v)
            P = nj * float(res.contact_impulse[group.index(j)])
            impacts.append(sim.record(j, t, nj, uj, u1, P))
        v = v_new
    else:
        for _ in range(50):  # κ < 0 (very rough surfaces): the next impact follows at once
            v, rec = sim.apply_impact(i, q, v, t)
            impacts.append(rec)
            if rec.un_plus >= 0.0:
                break
    c = scene.contacts[i]
    f, n, J, u = sim.contact_state(i, q, v, t)
    slow = float(n @ u) < scene.rest_velocity
    if slow and not c.surface.moving and c.surface.kind == "plane":
        # Zeno: rebound slower than rest_velocity ⇒ resting contact (a plastic impact first)
        A = pin.crba(sim.model, sim.data, q).copy()
        metric = ContactMetric.from_symmetric(A, J)
        R = local_basis(n, 3)
        if float(n @ u) < 0:
            P = NewtonLaw(0.0).impulses(metric, u[None, :], R).P[0]
            v = v + metric.AinvJt @ P
        else:
            P = np.zeros(3)
        v = _hold(sim, c, q, v, n, J)  # no residual normal (or, pinned, any) velocity
        sim.resting[i] = True
        sim.work["rest"] += 1
        impacts.append(ImpactRecord(t, i, float(n @ u), 0.0, 0.0, 0.0, 0.0, 0.0, float(np.linalg.norm(P)), 0.0, rest=True))
    elif float(n @ u) < 0.0:
        raise IntegrationError(f"contact {i} still approaches its moving surface after 50 impacts at t = {t:.6g}")
    for j, resting in enumerate(sim.resting):  # an impact elsewhere moves the resting contacts too
        if resting and j != i:
            _, nj, Jj, uj = sim.contact_state(j, q, v, t)
            if float(nj @ uj) > scene.rest_velocity:
                sim.resting[j] = False  # thrown off its surface
                sim.work["lift_off"] += 1
            else:
                v = _hold(sim, scene.contacts[j], q, v, nj, Jj)  # stays: plastic, as for coming to rest
    return q, v


def _hold(sim: _Sim, c: SceneContact, q: NDArray[np.float64], v: NDArray[np.float64],
          n: NDArray[np.float64], J: NDArray[np.float64]) -> NDArray[np.float64]:
    """Remove the constrained velocity of a resting contact (normal, or all of it when pinned)."""
    A = pin.crba(sim.model, sim.data, q).copy()
    G = J if c.rest == "stick" else (n @ J)[None, :]
    AinvGt = np.linalg.solve(A, G.T)
    return v - AinvGt @ np.linalg.lstsq(G @ AinvGt, G @ v, rcond=1e-12)[0]



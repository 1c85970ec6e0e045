"""Simulation of a scene: free flight, impacts, persistent contact, with guarantees.

The run alternates two phases.

*Free flight* (no contact persistent): Pinocchio's forward dynamics with only the forces
the scene declares, integrated by DOP853 step by step. After every accepted step the gap
of every open contact is checked on the step's dense output — at the step's ends, at
interior points, and at the minimum of the gap wherever its rate changes sign inside
the step, so that grazing crossings are found too — and the first crossing is located
by root finding. The contact's law is applied there to the velocity relative to the
surface (rough laws with their repeated micro-impacts); contacts that strike together
are resolved by the scene's rule (:mod:`mbimpact.simulation.multi`). A contact that has
just struck is disarmed until its gap opens again, but a disarmed contact that comes
back below its surface is still an impact: a crossing is never ignored.

*Persistent contact* (one contact or more resting or sliding): velocity-level time
stepping with the scene's ``contact_step`` (first order, Moreau's scheme): the impulses
of the persistent contacts over each step solve a Coulomb cone problem (Pinocchio's
ADMM, :mod:`mbimpact.simulation.cones`), so normal forces push only, a contact lifts
off when it would pull, and sticking and sliding follow from the friction cone with the
declared μ. The other contacts keep their event detection along each step's path.

A contact comes to rest when its rebound is slower than ``rest_velocity``; the time of
its accumulating bounces (Zeno) is summed as a geometric series from the ratio of the
last rebounds, and the rest is dated at their limit. The run stops with a named status
— never "completed" — when a limit is reached (impacts, events per simulated second,
wall time) or a guarantee cannot be kept (penetration deeper than ``tolerance``, an
integration failure); the message says where and why.

The ``work`` counters of the result record what was computed, so that a scene's
undeclared effects can be shown to cost nothing.
"""

from __future__ import annotations

import math
import time
from collections import Counter, deque
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..apps.progress import Progress
from ..errors import ImpactError, IntegrationError
from ..laws.base import ImpactLaw
from ..laws.newton import NewtonLaw
from ..laws.rough import RoughLaw
from ..roughness import Smooth
from .cones import ConeSolver
from .kinematics import ContactKinematics, ContactState
from .multi import ImpactSolver, Impulses, choose_rule
from .scene import Scene
from .trajectory import ContactEvent, Trajectory

__all__ = ["simulate"]

# interior points of a free step at which every open contact's gap is checked
_SCAN_POINTS = 4
# a window of simulated time over which the event rate is measured [s]
_RATE_WINDOW = 0.01
# rounds of alternating impacts and plastic contact impulses at one instant
_MAX_ROUNDS = 100


def _impact_law(law: ImpactLaw) -> ImpactLaw:
    """The law a scene applies: no microrelief ⇒ Newton's (no facet work); rough laws repeat
    their micro-impacts until the contact separates."""
    if isinstance(law, RoughLaw) and isinstance(law.roughness, Smooth):
        return NewtonLaw(law.e)
    if isinstance(law, RoughLaw) and not law.repeat:
        return law.replace(repeat=True)
    return law


class _Stop(Exception):
    """Ends the run with a status and a message."""

    def __init__(self, status: str, message: str) -> None:
        super().__init__(message)
        self.status, self.message = status, message


class _Run:
    def __init__(self, scene: Scene, samples: int, progress: bool) -> None:
        from scipy.integrate import DOP853  # deferred: scipy.integrate costs 0.1 s to import

        self.DOP853 = DOP853
        self.scene = scene
        mech = scene.mechanism
        self.mech = mech
        self.model = mech.model.copy()
        if not scene.gravity:
            self.model.gravity.linear[:] = 0.0
        self.data = self.model.createData()
        self.kin = ContactKinematics(scene, self.model, self.data)
        self.nc, self.nv, self.nq = len(scene.contacts), mech.nv, mech.nq
        self.euclidean = self.model.nq == self.model.nv
        self.laws = [_impact_law(c.law) for c in scene.contacts]
        self.frictions = [c.friction for c in scene.contacts]
        self.active = [False] * self.nc
        self.armed = [True] * self.nc
        self.pushing = [False] * self.nc  # the persistent contact pushed in the last step
        self.rebounds: list[list[tuple[float, float]]] = [[] for _ in range(self.nc)]
        self.last_impact = [-math.inf] * self.nc
        self.events: list[ContactEvent] = []
        self.work: Counter[str] = Counter()
        self.cones = ConeSolver()
        self.rng = np.random.default_rng(0)
        self.grid = np.linspace(0.0, scene.duration, max(2, samples))
        self.next_sample = 1
        self.out_t: list[float] = []
        self.out_q: list[NDArray[np.float64]] = []
        self.out_v: list[NDArray[np.float64]] = []
        self.out_active: list[tuple[bool, ...]] = []
        self.out_forces: list[NDArray[np.float64]] = []
        self.forces = np.zeros((self.nc, 3))  # mean contact forces over the last persistent-contact step
        self.start = time.perf_counter()
        self.recent: deque[float] = deque()
        self.peak_rate = 0.0
        self.impacts = 0
        self.mask = np.ones(self.nv)
        if self.model.njoints > 1 and self.model.joints[1].shortname() == "JointModelFreeFlyer":
            self.mask[:6] = 0.0  # the free-flyer is not actuated
        freqs = [c.surface.frequency for c in scene.contacts if c.surface.moving]
        # a moving surface can cross a flight twice within a long step: a step is a fraction of its period
        self.max_step = min(1.0 / (16.0 * max(freqs)) if freqs else math.inf, scene.duration / 4)
        self.bar = Progress(100, scene.name, enabled=progress)
        self.shown = 0

    # ---------------------------------------------------------------- forces and dynamics
    def torque(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        scene = self.scene
        tau = np.zeros(self.nv) if scene.torque is None else scene.torque.copy()
        if scene.damping:
            self.work["damping"] += 1
            tau -= scene.damping * v
        if scene.pd is not None:
            self.work["pd"] += 1
            err = pin.difference(self.model, q, scene.pd.q_ref)
            tau += self.mask * (scene.pd.kp * err - scene.pd.kd * v)
        return tau

    def acceleration(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        self.work["dynamics"] += 1
        if self.scene.gravity:
            self.work["gravity"] += 1
        return pin.aba(self.model, self.data, q, v, self.torque(t, q, v))

    def configuration(self, anchor: NDArray[np.float64], dq: NDArray[np.float64]) -> NDArray[np.float64]:
        if self.euclidean:
            return anchor + dq
        return pin.integrate(self.model, anchor, dq)

    # ---------------------------------------------------------------- bookkeeping
    def emit(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64]) -> None:
        self.out_t.append(t)
        self.out_q.append(q.copy())
        self.out_v.append(v.copy())
        self.out_active.append(tuple(self.active))
        self.out_forces.append(self.forces.copy() if any(self.active) else np.zeros((self.nc, 3)))

    def event(self, e: ContactEvent) -> None:
        self.events.append(e)
        self.recent.append(e.t)
        while self.recent and e.t - self.recent[0] > _RATE_WINDOW:
            self.recent.popleft()
        rate = len(self.recent) / _RATE_WINDOW
        self.peak_rate = max(self.peak_rate, rate)
        if len(self.recent) > max(20.0, self.scene.max_events_per_second * _RATE_WINDOW):
            raise _Stop("event_limit", f"{len(self.recent)} events within {_RATE_WINDOW:g} s of simulated time "
                                       f"before t = {e.t:.9g} (contact {e.contact}, {e.kind}): over "
                                       f"max_events_per_second = {self.scene.max_events_per_second:g}")

    def check_limits(self, t: float) -> None:
        elapsed = time.perf_counter() - self.start
        if elapsed > self.scene.max_wall_time:
            raise _Stop("wall_time", f"stopped at t = {t:.9g} s after {elapsed:.3g} s of wall time "
                                     f"(max_wall_time = {self.scene.max_wall_time:g} s)")
        now = int(100 * t / self.scene.duration)
        while self.shown < min(now, 100):
            self.bar.step(f"t={t:.3g}s, {self.impacts} impacts")
            self.shown += 1

    # ---------------------------------------------------------------- the run
    def run(self) -> Trajectory:
        scene = self.scene
        t, q, v = 0.0, scene.q0.copy(), scene.v0.copy()
        status, message = "completed", ""
        try:
            v = self.classify_start(t, q, v)
            self.emit(t, q, v)
            stalled = 0
            while t < scene.duration:
                before = (t, len(self.events), tuple(self.active))
                if any(self.active):
                    t, q, v = self.contact_phase(t, q, v)
                else:
                    t, q, v = self.free_phase(t, q, v)
                # every pass must move time, log an event or change a contact's mode
                stalled = stalled + 1 if (t, len(self.events), tuple(self.active)) == before else 0
                if stalled > 100:
                    raise _Stop("event_limit", f"no progress at t = {t:.9g}: the same event keeps recurring")
        except _Stop as stop:
            status, message = stop.status, stop.message
        except IntegrationError as exc:
            status, message = "integration_error", str(exc)
        while self.shown < 100:
            self.bar.step(f"{self.impacts} impacts")
            self.shown += 1
        return self.finish(status, message)

    def classify_start(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        """Contacts starting on their surface: resting, leaving, or striking at t = 0."""
        gaps, rates = self.kin.rates(q, v, t)
        tol, rest = self.scene.tolerance, self.scene.rest_velocity
        striking = [i for i in range(self.nc) if gaps[i] <= tol and rates[i] < -rest]
        for i in range(self.nc):
            if gaps[i] <= tol and -rest <= rates[i] <= rest:
                self.active[i] = True
                self.event(ContactEvent(t, i, "rest", float(rates[i])))
            elif gaps[i] <= tol:
                self.armed[i] = False
        if striking:
            v = self.impact(t, q, v, striking)
        return v

    # ---------------------------------------------------------------- free flight
    def free_phase(self, t0: float, q0: NDArray[np.float64], v0: NDArray[np.float64]
                   ) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        scene, nv = self.scene, self.nv
        anchor = q0.copy()

        def rhs(t: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
            q, v = self.configuration(anchor, y[:nv]), y[nv:]
            a = self.acceleration(t, q, v)
            if self.euclidean:
                return np.concatenate([v, a])
            dq = np.linalg.solve(pin.dIntegrate(self.model, anchor, y[:nv], pin.ARG1), v)
            return np.concatenate([dq, a])

        y0 = np.concatenate([np.zeros(nv), v0])
        atol = max(scene.rtol * 1e-3, 1e-15)
        solver = self.DOP853(rhs, t0, y0, scene.duration, rtol=scene.rtol, atol=atol, max_step=self.max_step)
        while True:
            message = solver.step()
            if solver.status == "failed":
                raise _Stop("integration_error", f"free flight stopped at t = {solver.t:.9g}: {message}")
            self.work["free_steps"] += 1
            dense = solver.dense_output()

            def state(t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
                y = dense(t)
                return self.configuration(anchor, y[:nv]), y[nv:]

            found = self.scan(state, solver.t_old, solver.t)
            t_end = found[0] if found else solver.t
            self.sample(state, t_end)
            if found:
                t_e, kind, which = found
                q, v = state(t_e)
                self.emit(t_e, q, v)  # the state just before the event, then just after
                v = self.at_event(t_e, q, v, kind, which)
                self.emit(t_e, q, v)
                return t_e, q, v
            self.check_limits(solver.t)
            if solver.status == "finished":
                q, v = state(solver.t)
                self.emit(solver.t, q, v)
                return solver.t, q, v

    def sample(self, state: Any, t_end: float) -> None:
        """Emit the output grid points up to ``t_end``."""
        while self.next_sample < len(self.grid) and self.grid[self.next_sample] <= t_end:
            tg = float(self.grid[self.next_sample])
            q, v = state(tg)
            self.emit(tg, q, v)
            self.next_sample += 1

    def scan(self, state: Any, ta: float, tb: float) -> tuple[float, str, list[int]] | None:
        """The first event of the open contacts on [ta, tb]: (time, kind, contacts), kind "crossing"
        (an impact) or "touch" (a disarmed contact back on its surface with no approach speed)."""
        from scipy.optimize import brentq

        ts = np.linspace(ta, tb, _SCAN_POINTS + 2)
        values = []
        for t in ts:
            q_t, v_t = state(t)
            values.append(self.kin.rates(q_t, v_t, float(t)))
        gaps = np.array([g for g, _ in values])
        rates = np.array([r for _, r in values])
        tol = self.scene.tolerance
        first: tuple[float, str, list[int]] | None = None
        xtol = 4 * np.finfo(float).eps * max(1.0, abs(tb))

        def gap_of(i: int) -> Any:
            return lambda t: float(self.kin.gaps(state(t)[0], t)[i])

        def rate_of(i: int) -> Any:
            def rate(t: float) -> float:
                q, v = state(t)
                return float(self.kin.rates(q, v, t)[1][i])

            return rate

        def down(i: int, a: float, b: float, ga: float, ra: float) -> tuple[float, str]:
            """Where contact i's gap goes from ≥ 0 at a to < 0 at b. A gap that starts on the surface
            (the instant of the last event) first rises to an apex: the crossing is found after it,
            so that no event repeats itself; an apex still on the surface is a touch."""
            if ga <= 1e-3 * tol:
                if ra <= 0.0:
                    return a, "crossing" if ra < 0.0 else "touch"
                rate = rate_of(i)
                if rate(b) >= 0.0:  # still rising at b: the gap went below by rounding only
                    return a, "touch"
                apex = float(brentq(rate, a, b, xtol=xtol))
                if gap_of(i)(apex) <= 1e-3 * tol:
                    return apex, "touch"
                a = apex
            return float(brentq(gap_of(i), a, b, xtol=xtol)), "crossing"

        for i in range(self.nc):
            if self.active[i]:
                continue
            armed = self.armed[i]
            event: tuple[float, str] | None = None
            if not armed and gaps[0, i] < 0 and rates[0, i] < 0:
                event = (ta, "crossing")  # already coming back below its surface
            for k in range(1, len(ts)):
                if event is not None:
                    break
                if not armed and gaps[k - 1, i] > tol:
                    armed = True
                g0, g1, r0, r1 = gaps[k - 1, i], gaps[k, i], rates[k - 1, i], rates[k, i]
                if armed:
                    if g0 >= 0.0 > g1:
                        event = down(i, ts[k - 1], ts[k], g0, r0)
                    elif g0 >= 0.0 and g1 >= 0.0 and r0 < 0.0 < r1:  # a minimum inside: a grazing crossing?
                        t_min = brentq(rate_of(i), ts[k - 1], ts[k], xtol=xtol)
                        if gap_of(i)(t_min) < 0.0:
                            event = down(i, ts[k - 1], t_min, g0, r0)
                elif g1 < 0.0 and r1 < 0.0:  # disarmed, and back below the surface while approaching
                    if g0 >= -1e-3 * tol:  # from on or above it (the last event left it at 0 ± rounding)
                        event = down(i, ts[k - 1], ts[k], g0, r0)
                    elif r0 >= 0.0:  # it never left: back on the surface with no approach speed
                        event = (brentq(rate_of(i), ts[k - 1], ts[k], xtol=xtol), "touch")
                    else:
                        event = (ts[k - 1], "crossing")
            if event is not None and (first is None or event[0] < first[0]):
                first = (event[0], event[1], [i])
            elif event is None:
                self.armed[i] = armed
        if first is not None:
            for i in range(self.nc):  # arming up to the event only
                if not self.active[i] and not self.armed[i]:
                    self.armed[i] = bool(np.any(gaps[ts <= first[0], i] > tol))
        return first

    # ---------------------------------------------------------------- events
    def at_event(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], kind: str, which: list[int]
                 ) -> NDArray[np.float64]:
        if kind == "touch":
            i = which[0]
            self.active[i] = True
            self.event(ContactEvent(t, i, "rest", 0.0, rule="touch"))
            return v
        gaps, rates = self.kin.rates(q, v, t)
        tol = self.scene.tolerance
        group = sorted(set(which) | {j for j in range(self.nc) if not self.active[j] and gaps[j] <= tol and rates[j] < 0})
        if not any(rates[j] < 0.0 for j in group):  # on the surface but not approaching: nothing strikes
            for j in group:
                if rates[j] <= self.scene.rest_velocity:  # grazing along it: it rests there
                    self.active[j] = True
                    self.event(ContactEvent(t, j, "rest", float(rates[j]), rule="touch"))
                else:
                    self.armed[j] = False
            return v
        return self.impact(t, q, v, group)

    def impact(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], group: list[int]) -> NDArray[np.float64]:
        """Apply the impact of the contacts ``group`` (by their law, or the scene's rule when several
        strike together), alternate with plastic frictional impulses at persistent contacts until
        nothing approaches, then classify: rest (after the Zeno tail), lift-off, or open."""
        scene = self.scene
        # a contact striking again within chatter_time is in persistent contact: its impacts are
        # plastic and frictional (the persistent contact's μ), no longer its law's
        chatter_time = float(scene.chatter_time)  # type: ignore[arg-type]  # set by Scene
        chatter = [i for i in group if t - self.last_impact[i] < chatter_time]
        for i in chatter:
            self.active[i] = True
            t_rest = self.zeno_tail(i, t)
            self.rebounds[i].clear()
            self.event(ContactEvent(t_rest, i, "rest", rule="chatter" + (" after the Zeno tail" if t_rest > t else "")))
        group = [i for i in group if i not in chatter]
        A, factor = self.mech.factorise(q)
        solver = ImpactSolver(self.laws, self.frictions, A, factor.solve, self.rng, self.cones, scene.samples)
        if not group:
            persistent = [s for s in self.kin.states(q, v, t) if self.active[s.index]]
            if any(s.un < 0.0 for s in persistent if s.index in chatter):
                dv, _ = solver.cone_impulses([(s.index, s.frame, s.J, s.u, self.frictions[s.index], 0.0)
                                              for s in persistent])
                self.work["plastic_contact"] += 1
                v = v + dv
            return v
        before = self.state_map(q, v, t)
        active = [i for i in range(self.nc) if self.active[i]]
        rule = choose_rule(scene.simultaneous, [self.laws[i] for i in group]) if len(group) > 1 else "law"
        totals: dict[int, NDArray[np.float64]] = {}
        v_new = v.copy()
        error = 0.0
        for rounds in range(_MAX_ROUNDS):
            states = self.state_map(q, v_new, t)
            struck = [states[i] for i in group if states[i].un < 0.0]
            if rounds == 0 or struck:
                out = self.strike(solver, [states[i] for i in group] if rounds == 0 else struck,
                                  [states[i] for i in active], rule, q, v_new, t)
                v_new = v_new + out.dv
                error = max(error, out.error)
                for i, P in out.P.items():
                    totals[i] = totals.get(i, 0.0) + P
                states = self.state_map(q, v_new, t)
            pushed = [states[i] for i in active if states[i].un < -1e-12 * (1.0 + abs(before[i].un))]
            again = [i for i in group if states[i].un < -1e-12 * (1.0 + abs(before[i].un))]
            if pushed:
                out = solver.plastic([states[i] for i in active])
                self.work["plastic_contact"] += 1
                v_new = v_new + out.dv
                for i, P in out.P.items():
                    totals[i] = totals.get(i, 0.0) + P
                continue
            if not again:
                break
        else:  # the alternation does not settle: one plastic frictional impulse at all of them
            states = self.state_map(q, v_new, t)
            out = solver.plastic([states[i] for i in sorted(set(group) | set(active))])
            v_new = v_new + out.dv
        after = self.state_map(q, v_new, t)
        self.impacts += 1
        if self.impacts >= scene.max_impacts:
            self.record_impacts(t, group, before, after, totals, rule, error)
            raise _Stop("max_impacts", f"max_impacts = {scene.max_impacts} reached at t = {t:.9g}")
        self.record_impacts(t, group, before, after, totals, rule, error)
        for i in group:
            un = after[i].un
            self.last_impact[i] = t
            if un < scene.rest_velocity:
                self.rest(t, i, un)
            else:
                self.armed[i] = False
                self.rebounds[i].append((t, un))
        for i in active:  # thrown off its surface by the impact elsewhere
            if after[i].un > scene.rest_velocity:
                self.active[i], self.armed[i] = False, False
                self.event(ContactEvent(t, i, "lift", before[i].un, before[i].ut, after[i].un, after[i].ut))
        return v_new

    def state_map(self, q: NDArray[np.float64], v: NDArray[np.float64], t: float) -> dict[int, ContactState]:
        """Every contact's state, by index."""
        return {s.index: s for s in self.kin.states(q, v, t)}

    def strike(self, solver: ImpactSolver, struck: list[ContactState], active: list[ContactState], rule: str,
               q: NDArray[np.float64], v: NDArray[np.float64], t: float) -> Impulses:
        if len(struck) == 1 or rule == "law":
            out = Impulses(np.zeros(self.nv), {}, "law")
            for s in sorted(struck, key=lambda s: s.un):
                law = self.laws[s.index]
                self.work["facet_average" if isinstance(law, RoughLaw) else "newton_impact"
                          if isinstance(law, NewtonLaw) else "coulomb_impact"] += 1
                (now,) = self.kin.states(q, v + out.dv, t, [s.index])
                if now.un >= 0.0:
                    continue
                one = solver.single(now, law.dim)
                out = Impulses(out.dv + one.dv, {**out.P, **one.P}, one.rule)
            return out
        self.work[f"simultaneous_{rule}"] += 1
        if rule == "newton":
            return solver.newton(struck, active)
        if rule == "rough":
            return solver.rough(struck, active)
        if rule == "compliant":
            return self.compliant(struck, q, v, t)
        # sequential: each contact's law, the most approaching first, until none approaches
        total = Impulses(np.zeros(self.nv), {}, "sequential")
        for _ in range(_MAX_ROUNDS):
            states = self.kin.states(q, v + total.dv, t, [s.index for s in struck])
            worst = min(states, key=lambda s: s.un)
            if worst.un >= -1e-12 * (1.0 + max(abs(s.un) for s in struck)):
                break
            one = solver.single(worst, self.laws[worst.index].dim)
            total = Impulses(total.dv + one.dv, {i: total.P.get(i, 0.0) + one.P.get(i, 0.0)  # type: ignore[misc]
                                                 for i in set(total.P) | set(one.P)}, "sequential")
        return total

    def compliant(self, struck: list[ContactState], q: NDArray[np.float64], v: NDArray[np.float64], t: float
                  ) -> Impulses:
        from ..compliant.resolve import resolve
        from ..mechanism.contact import PointContact

        scene = self.scene
        if any(scene.contacts[s.index].surface.moving for s in struck):
            raise _Stop("integration_error", "the 'compliant' rule needs fixed surfaces")
        contacts = [PointContact(scene.contacts[s.index].frame, normal=s.normal, point=scene.contacts[s.index].point)
                    for s in struck]
        try:
            res = resolve(self.mech, q, v, contacts, M=[scene.contacts[s.index].stiffness for s in struck],
                          e=[self.laws[s.index].e for s in struck], dynamics="impact")
        except ImpactError as exc:
            raise _Stop("integration_error", f"compliant resolution of contacts {[s.index for s in struck]} at "
                                             f"t = {t:.9g} failed: {exc}") from exc
        P = {s.index: s.normal * float(res.contact_impulse[k]) for k, s in enumerate(struck)}
        return Impulses(res.v_plus - v, P, "compliant")

    def record_impacts(self, t: float, group: list[int], before: dict[int, ContactState],
                       after: dict[int, ContactState], totals: dict[int, Any], rule: str, error: float) -> None:
        for i in group:
            b, a = before[i], after[i]
            P = np.asarray(totals.get(i, np.zeros(3)), dtype=float)
            pn = float(b.normal @ P)
            pt = float(np.linalg.norm(P - pn * b.normal))
            self.event(ContactEvent(
                t, i, "impact", b.un, b.ut, a.un, a.ut, -a.un / b.un if b.un < 0 else 0.0,
                pt / pn if pn > 0 else 0.0, float(np.linalg.norm(P)), -0.5 * float(P @ (b.u + a.u)),
                repr(self.laws[i]) if rule == "law" else rule, len(group)))

    def rest(self, t: float, i: int, un: float) -> None:
        """Contact i comes to rest after an impact with rebound ``un`` below rest_velocity."""
        t_rest = self.zeno_tail(i, t, un)
        self.active[i] = True
        self.rebounds[i].clear()
        self.event(ContactEvent(t_rest, i, "rest", un, rule="rest" if t_rest == t else "rest after the Zeno tail"))

    def zeno_tail(self, i: int, t: float, un: float | None = None) -> float:
        """The limit of contact i's accumulating bounces, from the impact at ``t`` (with rebound ``un``,
        or, when None, the impact it is about to make): the bounces left last in proportion to their
        rebound speeds, which shrink by the ratio r of the last rebounds, so they sum to a geometric
        series. ``t`` itself when the rebounds do not shrink geometrically."""
        history = self.rebounds[i]
        if un is not None:
            history = history + [(t, un)]
        if len(history) < 3 or not history[-1][1] > 0.0:
            return t
        (_, u3), (t2, u2), (t1, u1) = history[-3:]
        r, r_prev = u1 / u2, u2 / u3
        if not (0.0 < r < 1.0 and abs(r - r_prev) <= 0.05 * r):
            return t
        if un is not None:  # rest after the impact at t = t1: the next flight lasts r (t1 − t2)
            return t + r * (t1 - t2) / (1.0 - r)
        return t + r * (t - t1) / (1.0 - r)  # about to strike at t after the flight t − t1

    # ---------------------------------------------------------------- persistent contact
    def contact_phase(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64]
                      ) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        scene = self.scene
        gaps0 = self.kin.gaps(q, t)
        while t < scene.duration and any(self.active):
            h = min(scene.contact_step, scene.duration - t)
            q1, v1 = self.velocity_step(t, q, v, h)
            gaps1, rates1 = self.kin.rates(q1, v1, t + h)
            if any(self.active[i] and gaps1[i] < -0.1 * scene.tolerance for i in range(self.nc)):
                q1 = self.project(t + h, q1, gaps1)
                gaps1, rates1 = self.kin.rates(q1, v1, t + h)
            hit = self.path_crossing(t, q, v1, h, gaps0, gaps1, rates1)
            if hit is not None:
                s, group = hit
                if s > 0.0:
                    q, v = self.velocity_step(t, q, v, s)
                    t += s
                self.emit(t, q, v)
                gaps, rates = self.kin.rates(q, v, t)
                group = sorted(set(group) | {j for j in range(self.nc) if not self.active[j]
                                             and gaps[j] <= scene.tolerance and rates[j] < 0})
                v = self.impact(t, q, v, group)
                self.emit(t, q, v)
                gaps0 = self.kin.gaps(q, t)
                continue
            t, q, v, gaps0 = t + h, q1, v1, gaps1
            self.work["contact_steps"] += 1
            self.lift_offs(t, gaps1, rates1)
            while self.next_sample < len(self.grid) and self.grid[self.next_sample] <= t + 1e-12:
                self.next_sample += 1
                self.emit(t, q, v)
            self.check_limits(t)
        return t, q, v

    def velocity_step(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], h: float
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """One step of Moreau's scheme: v⁺ = v + h a_free + A⁻¹ Jcᵀ λ, q⁺ = q ⊕ h v⁺, λ on the cones."""
        active = [i for i in range(self.nc) if self.active[i]]
        v_free = v + h * self.acceleration(t, q, v)
        states = self.kin.states(q, v_free, t, active)
        A, factor = self.mech.factorise(q)
        Jc = np.vstack([s.frame.T @ s.J for s in states])
        AinvJt = factor.solve(Jc.T)
        G = Jc @ AinvJt
        G = 0.5 * (G + G.T)
        g = np.empty(3 * len(states))
        for k, s in enumerate(states):
            surface = self.scene.contacts[s.index].surface
            if surface.moving:
                self.work["surface_motion"] += 1
                # the mean velocity of the surface over the step: the gap then closes exactly
                mean = (surface.offset(t + h)[0] - surface.offset(t)[0]) / h * surface.normal
                u = s.J @ v_free - mean
            else:
                u = s.u
            g[3 * k: 3 * k + 3] = s.frame.T @ u
            g[3 * k + 2] += s.gap / h  # the predicted gap at the step's end stays ≥ 0
        mus = tuple(self.frictions[i] for i in active)
        if any(mus):
            self.work["friction_cone"] += 1
        lam = self.cones.solve(G, g, mus)
        scale = float(np.abs(lam[2::3]).max(initial=0.0))
        self.forces[:] = 0.0
        for k, (i, s) in enumerate(zip(active, states)):
            self.pushing[i] = bool(lam[3 * k + 2] > 1e-9 * scale)
            self.forces[i] = s.frame @ lam[3 * k: 3 * k + 3] / h
        v1 = v_free + AinvJt @ lam
        return self.configuration(q, h * v1), v1

    def project(self, t: float, q: NDArray[np.float64], gaps: NDArray[np.float64]) -> NDArray[np.float64]:
        """Back onto the surfaces: the step moves a persistent contact off its surface by O(h²) (a
        rotating body's points move along straight lines for a step). When that puts a contact below
        its surface, the smallest change of q in the kinetic metric that puts the pushing contacts
        (and any below its surface) at gap 0."""
        active = [i for i in range(self.nc) if self.active[i]]
        for _ in range(3):
            # the next step's gap term closes small drifts; a drift below the surface is projected now
            if not any(gaps[i] < -0.1 * self.scene.tolerance for i in active):
                return q
            rows = [i for i in active if self.pushing[i] or gaps[i] < 0.0]
            states = self.kin.states(q, np.zeros(self.nv), t, rows)
            Jn = np.array([s.normal @ s.J for s in states])
            A, factor = self.mech.factorise(q)
            AinvJt = factor.solve(Jn.T)
            dq = -AinvJt @ np.linalg.lstsq(Jn @ AinvJt, gaps[rows], rcond=1e-12)[0]
            q = self.configuration(q, dq)
            gaps = self.kin.gaps(q, t)
            self.work["projection"] += 1
        return q

    def path_crossing(self, t: float, q: NDArray[np.float64], v1: NDArray[np.float64], h: float,
                      g0: NDArray[np.float64], g1: NDArray[np.float64], r1: NDArray[np.float64]
                      ) -> tuple[float, list[int]] | None:
        """An open contact crossing its surface along the step's path q(s) = q ⊕ s v⁺, s ∈ [0, h]
        (gaps ``g0`` at its start, ``g1`` and rates ``r1`` at its end): the fraction s of the step at
        the crossing, and the contact."""
        from scipy.optimize import brentq

        tol = self.scene.tolerance
        first: tuple[float, list[int]] | None = None
        for i in range(self.nc):
            if self.active[i]:
                continue
            if not self.armed[i] and g0[i] > tol:
                self.armed[i] = True
            if not (g1[i] < 0.0 and (self.armed[i] or r1[i] < 0.0)):
                continue
            if g0[i] < 0.0:
                s = 0.0
            else:
                s = brentq(lambda s, i=i: float(self.kin.gaps(self.configuration(q, s * v1), t + s)[i]), 0.0, h,
                           xtol=4 * np.finfo(float).eps * max(1.0, h))
            if first is None or s < first[0]:
                first = (s, [i])
        return first

    def lift_offs(self, t: float, gaps: NDArray[np.float64], rates: NDArray[np.float64]) -> None:
        """A persistent contact whose gap opened (the cone gave it no push) becomes open."""
        for i in range(self.nc):
            if self.active[i] and not self.pushing[i] and gaps[i] > self.scene.tolerance and rates[i] > 0.0:
                self.active[i], self.armed[i] = False, False
                self.event(ContactEvent(t, i, "lift", 0.0, 0.0, float(rates[i])))
            elif self.active[i] and gaps[i] < -self.scene.tolerance:
                raise _Stop("penetration", f"persistent contact {i} ({self.scene.contacts[i].frame}) is "
                                           f"{-gaps[i]:.3g} m inside its surface at t = {t:.9g}, beyond the tolerance "
                                           f"{self.scene.tolerance:g} m; reduce contact_step")

    # ---------------------------------------------------------------- result
    def finish(self, status: str, message: str) -> Trajectory:
        order = np.argsort(self.out_t, kind="stable")
        T = np.array(self.out_t)[order]
        Q, V = np.array(self.out_q)[order], np.array(self.out_v)[order]
        active = np.array(self.out_active, dtype=bool).reshape(len(self.out_t), self.nc)[order]
        forces = np.array(self.out_forces).reshape(len(self.out_t), self.nc, 3)[order]
        gaps = np.empty((len(T), self.nc))
        rates = np.empty((len(T), self.nc))
        energy = np.empty(len(T))
        for k, (t, q, v) in enumerate(zip(T, Q, V)):
            gaps[k], rates[k] = self.kin.rates(q, v, float(t))
            energy[k] = pin.computeKineticEnergy(self.model, self.data, q, v)
            if self.scene.gravity:
                energy[k] += pin.computePotentialEnergy(self.model, self.data, q)
        self.work["surface_motion"] += self.kin.surface_evaluations
        tol = self.scene.tolerance
        if status == "completed" and gaps.size and gaps.min() < -tol:
            k, i = (int(x) for x in np.unravel_index(int(np.argmin(gaps)), gaps.shape))
            status = "penetration"
            message = (f"contact {i} ({self.scene.contacts[i].frame}) is {-gaps[k, i]:.3g} m inside its surface at "
                       f"t = {T[k]:.9g}, beyond the tolerance {tol:g} m")
        return Trajectory(T, Q, V, energy, gaps, rates, active, forces, self.events, self.work, status, message,
                          time.perf_counter() - self.start, self.peak_rate, tol)


def simulate(scene: Scene, samples: int = 2000, progress: bool = False) -> Trajectory:
    """Simulate a scene for ``scene.duration`` seconds.

    Parameters
    ----------
    scene : Scene
    samples : int
        Number of equally spaced output times (event instants are added).
    progress : bool
        Draw a progress bar on stderr (only when stderr is a terminal).

    Returns
    -------
    Trajectory
        ``status`` is "completed" only when the whole duration was simulated with every
        contact at or above its surface (within ``scene.tolerance``); otherwise it names
        the limit reached or the guarantee that could not be kept, and ``message`` says
        where and why.
    """
    if not isinstance(scene, Scene):
        raise ImpactError(f"simulate needs a Scene (mbimpact.Scene or mbimpact.load_scene), got {type(scene).__name__}")
    return _Run(scene, samples, progress).run()

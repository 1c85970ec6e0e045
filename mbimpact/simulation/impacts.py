"""Impacts in a run: the struck points, their laws, the persistent contacts, and what follows.

An impact involves the points that strike — the one point of a frame contact, or the witness
points of a collision pair within its patch (a face landing flat strikes at its corners) — and
the points already in persistent contact. One point strikes by its contact's law; several by
the scene's rule (:mod:`~mbimpact.simulation.multi`). Persistent points take part as plastic
frictional contacts: when the impact pushes them into their surface a plastic impulse follows,
and the two alternate until nothing approaches.

Afterwards each struck contact is classified: at rest when it rebounds slower than
``rest_velocity`` (after the geometric tail of its accumulating bounces, Zeno), open and
disarmed otherwise. A contact that strikes again sooner than ``chatter_time`` becomes
persistent. A further point of a pair already resting (a box on an edge whose other edge lands)
strikes by the law while the pair stays persistent.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..errors import ImpactError
from ..laws.newton import NewtonLaw
from ..laws.rough import RoughLaw
from .multi import ImpactSolver, Impulses, choose_rule
from .run import RunState, Stop
from .scene_contacts import SceneCollision, SceneContact
from .state import ContactState, slowest
from .trajectory import ContactEvent

__all__ = ["Impacts"]

# rounds of alternating impacts and plastic contact impulses at one instant
MAX_ROUNDS = 100


def _small(scale: float) -> float:
    """Rounding of a normal velocity of size ``scale``."""
    return 1e-12 * (1.0 + abs(scale))


class Impacts:
    """The impacts of a run, on its :class:`~mbimpact.simulation.run.RunState`."""

    def __init__(self, state: RunState) -> None:
        self.state = state

    def at_event(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], kind: str, which: list[int]
                 ) -> NDArray[np.float64]:
        if kind == "touch":
            i = which[0]
            self.state.active[i] = True
            self.state.event(ContactEvent(t, i, "rest", 0.0, rule="touch"))
            return v
        gaps, rates = self.state.kin.rates(q, v, t)
        tol = self.state.band
        group = sorted(set(which) | {j for j in range(self.state.nc) if not self.state.active[j] and gaps[j] <= tol and rates[j] < 0})
        if not any(rates[j] < 0.0 for j in group):  # on the surface but not approaching: nothing strikes
            for j in group:
                if rates[j] <= self.state.scene.rest_velocity:  # grazing along it: it rests there
                    self.state.active[j] = True
                    self.state.event(ContactEvent(t, j, "rest", float(rates[j]), rule="touch"))
                else:
                    self.state.armed[j] = False
            return v
        return self.impact(t, q, v, group)

    def impact(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], group: list[int]) -> NDArray[np.float64]:
        """The impact of the contacts ``group`` at (t, q, v): open contacts striking, or persistent
        pairs with a further point striking. Returns the velocity after it."""
        scene = self.state.scene
        rest_velocity = scene.rest_velocity
        # a contact striking again within chatter_time is in persistent contact: its impacts are
        # plastic and frictional (the persistent contact's μ), no longer its law's
        chatter_time = float(scene.chatter_time)  # type: ignore[arg-type]  # set by Scene
        points = self.state.kin.state_map(q, v, t, sorted(set(group) | {i for i in range(self.state.nc) if self.state.active[i]}))
        chatter, where = [], {}
        for i in group:
            mine = points.get(i, [])
            if self.state.active[i] or not mine:
                continue
            same, where[i] = self.state.kin.same_feature(i, q, np.array([s.point for s in mine]), self.state.last_struck[i])
            # a pair striking elsewhere on its body (another corner of a box) is a new impact, not chatter,
            # and starts a new series of rebounds (for the Zeno tail)
            if not same:
                self.state.rebounds[i].clear()
            elif t - self.state.last_impact[i] < chatter_time:
                chatter.append(i)
        for i in chatter:
            self.state.active[i] = True
            t_rest = self.zeno_tail(i, t)
            self.state.rebounds[i].clear()
            self.state.event(ContactEvent(t_rest, i, "rest", rule="chatter" + (" after the Zeno tail" if t_rest > t else "")))
        secondary = [i for i in group if self.state.active[i] and i not in chatter]
        opening = [i for i in group if not self.state.active[i]]
        active = [i for i in range(self.state.nc) if self.state.active[i]]
        # the struck points: every point of an open contact; the fast-approaching points of a resting pair
        struck: list[ContactState] = [s for i in opening for s in points.get(i, [])]
        struck += [s for i in secondary for s in points.get(i, []) if s.un < -rest_velocity]
        struck_ids = {id(s) for s in struck}
        persistent = [s for i in active for s in points.get(i, []) if id(s) not in struck_ids]
        A, factor = self.state.mech.factorise(q)
        solver = ImpactSolver(self.state.laws, self.state.frictions, A, factor.solve, self.state.rng, self.state.cones, scene.samples)
        if not struck:
            now = [s for s in persistent if s.un < 0.0]
            if now:
                out = solver.plastic(persistent)
                self.state.work["plastic_contact"] += 1
                v = v + out.dv
            return v
        laws = [self.state.laws[s.index] for s in struck]
        rule = "law" if len(struck) == 1 else choose_rule(scene.simultaneous, laws)
        totals: dict[tuple[int, int], Any] = {}
        v_new = v.copy()
        error = 0.0
        for rounds in range(MAX_ROUNDS):
            now_struck = [s.at(v_new) for s in struck]
            approaching = [s for s in now_struck if s.un < 0.0]
            if rounds == 0 or approaching:
                out = self.strike(solver, now_struck if rounds == 0 else approaching,
                                  [s.at(v_new) for s in persistent], rule, q, v_new, t)
                v_new = v_new + out.dv
                error = max(error, out.error)
                for key, P in out.P.items():
                    totals[key] = totals.get(key, 0.0) + P
            pushed = [s for s in persistent if s.at(v_new).un < -_small(s.un)]
            again = [s for s in struck if s.at(v_new).un < -_small(s.un)]
            if pushed:
                out = solver.plastic([s.at(v_new) for s in persistent])
                self.state.work["plastic_contact"] += 1
                v_new = v_new + out.dv
                for key, P in out.P.items():
                    totals[key] = totals.get(key, 0.0) + P
                continue
            if not again:
                break
        else:  # the alternation does not settle: one plastic frictional impulse at all of them
            out = solver.plastic([s.at(v_new) for s in struck + persistent])
            v_new = v_new + out.dv
        self.state.impacts += 1
        by_contact: dict[int, list[ContactState]] = {}
        for s in struck:
            by_contact.setdefault(s.index, []).append(s)
        self.record_impacts(t, by_contact, v_new, totals, rule, error, len(by_contact))
        if self.state.impacts >= scene.max_impacts:
            raise Stop("max_impacts", f"max_impacts = {scene.max_impacts} reached at t = {t:.9g}")
        for i, mine in by_contact.items():
            if i in secondary:  # a further point of a resting pair: the pair stays persistent
                continue
            un = max(s.at(v_new).un for s in mine)  # the contact leaves when all its points do
            self.state.last_impact[i] = t
            self.state.last_struck[i] = where.get(i)
            if un < rest_velocity:
                self.rest(t, i, un)
            else:
                self.state.armed[i] = False
                self.state.rebounds[i].append((t, un))
        for i in active:  # thrown off its surface by the impact elsewhere
            mine = [s for s in persistent if s.index == i]
            if mine and i not in secondary and min(s.at(v_new).un for s in mine) > rest_velocity:
                b = slowest(mine)
                a = b.at(v_new)
                self.state.active[i], self.state.armed[i] = False, False
                self.state.event(ContactEvent(t, i, "lift", b.un, b.ut, a.un, a.ut))
        return v_new

    def strike(self, solver: ImpactSolver, struck: list[ContactState], active: list[ContactState], rule: str,
               q: NDArray[np.float64], v: NDArray[np.float64], t: float) -> Impulses:
        """The impulses of the struck points by ``rule`` ("law": each by its contact's law)."""
        if len(struck) == 1 or rule == "law":
            out = Impulses(np.zeros(self.state.nv), {}, "law")
            for s in sorted(struck, key=lambda s: s.un):
                law = self.state.laws[s.index]
                self.state.work["facet_average" if isinstance(law, RoughLaw) else "newton_impact"
                          if isinstance(law, NewtonLaw) else "coulomb_impact"] += 1
                now = s.at(v + out.dv)
                if now.un >= 0.0:
                    continue
                one = solver.single(now, law.dim)
                out = Impulses(out.dv + one.dv, _add(out.P, one.P), one.rule)
            return out
        self.state.work[f"simultaneous_{rule}"] += 1
        if rule == "newton":
            return solver.newton(struck, active)
        if rule == "rough":
            return solver.rough(struck, active)
        if rule == "compliant":
            return self.compliant(struck, q, v, t)
        # sequential: each point by its contact's law, the most approaching first, until none approaches
        total = Impulses(np.zeros(self.state.nv), {}, "sequential")
        scale = max(abs(s.un) for s in struck)
        for _ in range(MAX_ROUNDS):
            worst = min((s.at(v + total.dv) for s in struck), key=lambda s: s.un)
            if worst.un >= -_small(scale):
                break
            one = solver.single(worst, self.state.laws[worst.index].dim)
            total = Impulses(total.dv + one.dv, _add(total.P, one.P), "sequential")
        return total

    def compliant(self, struck: list[ContactState], q: NDArray[np.float64], v: NDArray[np.float64], t: float
                  ) -> Impulses:
        """The "compliant" rule: the Kelvin–Voigt contacts (2.3) of the struck points in time."""
        from ..compliant.resolve import resolve
        from ..mechanism.contact import PointContact

        scene, mech = self.state.scene, self.state.mech
        contacts = []
        for s in struck:
            c = scene.contacts[s.index]
            if isinstance(c, SceneContact):
                if c.surface.moving:
                    raise Stop("integration_error", "the 'compliant' rule needs fixed surfaces")
                contacts.append(PointContact(c.frame, normal=s.normal, point=c.point))
            elif isinstance(c, SceneCollision) and c.obstacle is not None:
                # the witness point as a point of its body's frame
                frame = self.state.model.names[mech.collision_model().joint(str(c.body))]
                pin.framesForwardKinematics(self.state.model, self.state.data, q)
                local = self.state.data.oMf[mech.frame_id(frame)].actInv(s.point)
                contacts.append(PointContact(frame, normal=s.normal, point=local))
            else:
                raise Stop("integration_error", f"the 'compliant' rule needs frame contacts or obstacles; contact "
                                                f"{s.index} ({c.label}) is a pair of the mechanism's own bodies")
        try:
            res = resolve(mech, q, v, contacts, M=[scene.contacts[s.index].stiffness for s in struck],
                          e=[self.state.laws[s.index].e for s in struck], dynamics="impact")
        except ImpactError as exc:
            raise Stop("integration_error", f"compliant resolution of contacts {sorted({s.index for s in struck})} "
                                            f"at t = {t:.9g} failed: {exc}") from exc
        P = {s.key: s.normal * float(res.contact_impulse[k]) for k, s in enumerate(struck)}
        return Impulses(res.v_plus - v, P, "compliant")

    def record_impacts(self, t: float, by_contact: dict[int, list[ContactState]], v_after: NDArray[np.float64],
                       totals: dict[tuple[int, int], Any], rule: str, error: float, together: int) -> None:
        """One impact event per struck contact, measured at its most approaching point."""
        for i, mine in by_contact.items():
            b = slowest(mine)
            a = b.at(v_after)
            P = sum((np.asarray(totals[s.key], dtype=float) for s in mine if s.key in totals), np.zeros(3))
            pn = float(b.normal @ P)
            pt = float(np.linalg.norm(P - pn * b.normal))
            work = 0.0
            for s in mine:
                Pk = totals.get(s.key)
                if Pk is not None:
                    work -= 0.5 * float(np.asarray(Pk) @ (s.u + s.at(v_after).u))
            self.state.event(ContactEvent(
                t, i, "impact", b.un, b.ut, a.un, a.ut, -a.un / b.un if b.un < 0 else 0.0,
                pt / pn if pn > 0 else 0.0, float(np.linalg.norm(P)), work,
                repr(self.state.laws[i]) if rule == "law" else rule, together, len(mine), b.point.copy()))

    def rest(self, t: float, i: int, un: float) -> None:
        """Contact i comes to rest after an impact with rebound ``un`` below rest_velocity."""
        t_rest = self.zeno_tail(i, t, un)
        self.state.active[i] = True
        self.state.rebounds[i].clear()
        self.state.event(ContactEvent(t_rest, i, "rest", un, rule="rest" if t_rest == t else "rest after the Zeno tail"))

    def zeno_tail(self, i: int, t: float, un: float | None = None) -> float:
        """The limit of contact i's accumulating bounces, from the impact at ``t`` (with rebound ``un``,
        or, when None, the impact it is about to make): the bounces left last in proportion to their
        rebound speeds, which shrink by the ratio r of the last rebounds, so they sum to a geometric
        series. ``t`` itself when the rebounds do not shrink geometrically."""
        history = self.state.rebounds[i]
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


def _add(a: dict[tuple[int, int], Any], b: dict[tuple[int, int], Any]) -> dict[tuple[int, int], Any]:
    """Impulses by point, summed."""
    out = dict(a)
    for i, P in b.items():
        out[i] = out.get(i, 0.0) + P
    return out

"""Persistent contact: velocity-level time stepping on Coulomb cones, with lift-off and new strikes.

While one contact or more rests or slides, the run steps with the scene's ``contact_step``
(first order, Moreau's scheme): the impulses of the persistent points over each step solve a
Coulomb cone problem (Pinocchio's ADMM, :mod:`~mbimpact.simulation.cones`), so normal forces
push only, a contact lifts off when it would pull, and sticking and sliding follow from the
friction cone with the declared μ. A collision pair rests on every point of its contact patch
(a box lying flat on its four corners).

Along each step's path the open contacts keep their event detection, and so does every
further point of a resting pair: a box resting on an edge whose other edge comes down strikes
there by its law, at the instant the edge lands.

Where every contact is a frame contact on a fixed plane, the steps between events run in one
compiled call (:mod:`~mbimpact.simulation.compiled_steps`), the same steps to rounding; this module
takes the steps at which something happens.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from .compiled_steps import compiled_steps
from .impacts import Impacts
from .run import RunState, Stop
from .scene_contacts import SceneContact
from .trajectory import ContactEvent

__all__ = ["Persistent"]

# b ↦ K⁻¹ b for a step's mass matrix K
Solve = Callable[[NDArray[np.float64]], NDArray[np.float64]]


class Persistent:
    """The persistent-contact phase of a run: it advances the run's :class:`~mbimpact.simulation.run.RunState`
    and hands new strikes to the run's :class:`~mbimpact.simulation.impacts.Impacts`."""

    def __init__(self, state: RunState, impacts: Impacts) -> None:
        self.state, self.impacts = state, impacts
        self.compiled = compiled_steps(state)  # the step's compiled backend, where the scene's contacts allow it

    def contact_phase(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64]
                      ) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        scene = self.state.scene
        gaps0 = self.state.kin.gaps(q, t)
        instant = 0  # events in a row at the same instant
        while t < scene.duration and any(self.state.active):
            if self.compiled is not None:
                taken = self.compiled.take(t, q, v, gaps0)
                t, q, v, gaps0 = taken.t, taken.q, taken.v, taken.gaps
                if taken.steps:
                    instant = 0
                if taken.reason in ("lift", "full", "budget"):
                    # its last step is taken: what the Python route does after a step
                    if taken.reason == "lift":
                        self.lift_offs(t, taken.gaps, taken.rates)
                    self.emit_samples(t, q, v)
                    self.state.check_limits(t)
                    continue
                # else the Python route takes this step
                if t >= scene.duration:
                    break
            h = min(scene.contact_step, scene.duration - t)
            free = self.free_velocity(t, q, v, h)
            if self.separating(t, q, v, free[0], h, gaps0):
                break  # every persistent contact lifted off: free flight from here
            w = self.step_velocity(t, q, v, h, free)  # the step's velocity, expressed at q: the path is q ⊕ s w
            q1 = self.state.step_configuration(q, h * w)
            v1 = self.state.transport(q, q1, w)
            gaps1, rates1 = self.state.kin.rates(q1, v1, t + h)
            hit = self.path_crossing(t, q, w, h, gaps0, gaps1, rates1)
            if hit is not None and hit[0] == 0.0 and self.pushed_in(t, q, v, hit[1]):
                continue  # the contact joined the persistent ones: the step again, with it
            if hit is not None:
                s, group = hit
                pushing, forces = list(self.state.pushing), self.state.forces.copy()
                t_s, q_s, v_s = t, q, v
                if s > 0.0:
                    # the velocity of a step of length s, on the path the crossing was found on (so that
                    # the struck point is on its surface)
                    q_s, t_s = self.state.step_configuration(q, s * w), t + s
                    # with the gap term over the whole step: gap/s for a crossing found 1e-15 s into the step
                    # was a huge velocity (energy blow-ups of passive scenes)
                    v_s = self.state.transport(q, q_s, self.step_velocity(t, q, v, s, horizon=h))
                gaps, rates = self.state.kin.rates(q_s, v_s, t_s)
                if any(self.state.active[i] and gaps[i] < -0.1 * self.state.band for i in range(self.state.nc)):
                    # the persistent points drift O(s²) below their surfaces inside a step: back on them
                    q_s = self.project(t_s, q_s, gaps)
                    gaps, rates = self.state.kin.rates(q_s, v_s, t_s)
                group = sorted(set(group) | {j for j in range(self.state.nc) if not self.state.active[j]
                                             and gaps[j] <= self.state.band and rates[j] < 0})
                logged = len(self.state.events)
                v_after = self.impacts.impact(t_s, q_s, v_s, group)
                if len(self.state.events) > logged or v_after is not v_s:
                    instant = instant + 1 if t_s == t else 0
                    if instant > 100:
                        raise Stop("event_limit", f"no progress at t = {t:.9g}: contacts {group} strike again and "
                                                  "again at the same instant")
                    self.state.emit(t_s, q_s, v_s)
                    t, q, v = t_s, q_s, v_after
                    self.state.emit(t, q, v)
                    gaps0 = self.state.kin.gaps(q, t)
                    self.state.check_limits(t)
                    continue
                # nothing struck (a further point of a resting pair arriving slower than rest_velocity):
                # it joins the persistent contact through the step's gap term and the projection
                self.state.pushing, self.state.forces = pushing, forces
            instant = 0
            if any(self.state.active[i] and gaps1[i] < -0.1 * self.state.band for i in range(self.state.nc)):
                q1 = self.project(t + h, q1, gaps1)
                gaps1, rates1 = self.state.kin.rates(q1, v1, t + h)
            t, q, v, gaps0 = t + h, q1, v1, gaps1
            self.state.work["contact_steps"] += 1
            self.lift_offs(t, gaps1, rates1)
            self.emit_samples(t, q, v)
            self.state.check_limits(t)
        return t, q, v

    def emit_samples(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64]) -> None:
        """The output grid's samples up to the end t of a step, at its state."""
        while self.state.next_sample < len(self.state.grid) and self.state.grid[self.state.next_sample] <= t + 1e-12:
            self.state.next_sample += 1
            self.state.emit(t, q, v)

    def free_velocity(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], h: float
                      ) -> tuple[NDArray[np.float64], Solve]:
        """The velocity v + h a_free after a step of length h without contact forces (expressed at q), and
        the solve b ↦ K⁻¹ b of the step's mass matrix K (A, or A + h D with damping), for its impulses."""
        A, factor = self.state.mech.factorise(q)
        if self.state.damper.any():
            # the velocity-proportional torques implicitly, (A + h D) v⁺ = A (v + h a₀) + Jᵀλ with a₀ the
            # acceleration without them: explicitly v⁺ would grow by |1 − h·rate| a step, unstable once
            # h·rate > 2 (rate = damping_rate, up to 1e9 1/s for the damping allowed on light bodies)
            K = A + h * np.diag(self.state.damper)
            a0 = self.step_acceleration(t, q, v, damped=False)
            with np.errstate(over="ignore", invalid="ignore"):  # an overflow is caught as non-finite below
                v_free = np.asarray(np.linalg.solve(K, A @ (v + h * a0)), float)

            def solve(b: NDArray[np.float64]) -> NDArray[np.float64]:
                return np.asarray(np.linalg.solve(K, b), float)
        else:
            a = self.step_acceleration(t, q, v)
            with np.errstate(over="ignore", invalid="ignore"):  # an overflow is caught as non-finite below
                v_free = v + h * a
            solve = factor.solve
        if not np.isfinite(v_free).all():
            raise Stop("integration_error", f"persistent contact stopped at t = {t:.9g}: the dynamics overflowed "
                                            f"(|v| = {float(np.abs(v).max()):.3g})")
        return v_free, solve

    def step_velocity(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], h: float,
                      free: tuple[NDArray[np.float64], Solve] | None = None, horizon: float | None = None
                      ) -> NDArray[np.float64]:
        """One step of Moreau's scheme: v⁺ = v + h a_free + A⁻¹ Jcᵀ λ with λ on the cones (v⁺ expressed
        at q; the step then moves q along q ⊕ s v⁺), and the contact forces of the step. ``free``:
        :meth:`free_velocity` of this step, when already computed. ``horizon``: the time over which the
        persistent points' gaps are closed (default h; a sub-step up to a crossing closes them over the
        whole step)."""
        active = [i for i in range(self.state.nc) if self.state.active[i]]
        v_free, solve = self.free_velocity(t, q, v, h) if free is None else free
        states = self.state.kin.states(q, v_free, t, active)
        Jc = np.vstack([s.frame.T @ s.J for s in states])
        AinvJt = solve(Jc.T)
        G = Jc @ AinvJt
        G = 0.5 * (G + G.T)
        g = np.empty(3 * len(states))
        for k, s in enumerate(states):
            c = self.state.scene.contacts[s.index]
            if isinstance(c, SceneContact) and c.surface.moving:
                self.state.work["surface_motion"] += 1
                # the mean velocity of the surface over the step: the gap then closes exactly
                mean = (c.surface.offset(t + h)[0] - c.surface.offset(t)[0]) / h * c.surface.normal
                u = s.J @ v_free - mean
            else:
                u = s.u
            g[3 * k: 3 * k + 3] = s.frame.T @ u
            g[3 * k + 2] += s.gap / (h if horizon is None else horizon)  # the predicted gap at the end stays ≥ 0
        mus = tuple(self.state.frictions[s.index] for s in states)
        if any(mus):
            self.state.work["friction_cone"] += 1
        lam = self.state.cones.solve(G, g, mus)
        scale = float(np.abs(lam[2::3]).max(initial=0.0))
        self.state.forces[:] = 0.0
        for i in active:
            self.state.pushing[i] = False
        for k, s in enumerate(states):
            self.state.pushing[s.index] |= bool(lam[3 * k + 2] > 1e-9 * scale)
            self.state.forces[s.index] += s.frame @ lam[3 * k: 3 * k + 3] / h
        return v_free + AinvJt @ lam

    def separating(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], v_free: NDArray[np.float64],
                   h: float, gaps: NDArray[np.float64]) -> bool:
        """Whether every persistent contact leaves its surface by itself over the next step (``gaps`` at
        (q, t)); if so they all lift off now, at t, and the run goes on in free flight.

        Zero contact forces then solve the contact problem (for frictionless contacts, the only
        solution). Moreau's step cannot see it: its velocity-level constraint, with the Jacobian at the
        step's start, misses the point's centripetal acceleration J̇v — after a plastic impact a
        pendulum's tip leaving the surface on its arc was pushed off it by a spurious impulse, and the
        explicit steps until its lift-off fed it O(h²) energy each (issue #14).

        A contact separates when its free acceleration opens the gap, beyond rounding (1e-3 band, as in
        the flight's event location), over a step: f(h) + f(−h) − 2 f(0) > 1e-3 band with f(s) the gap
        along the free motion q ⊕ (s v + s² a / 2), a = (v_free − v) / h — a central difference, blind
        to the O(h) error of the normal velocity that a persistent contact carries — and is still leaving
        at the step's end. Not when it is below the rounding: the step's gap term puts it back on its
        surface first.
        """
        rounding = 1e-3 * self.state.band
        active = [i for i in range(self.state.nc) if self.state.active[i]]
        if any(gaps[i] < -rounding for i in active):
            return False
        dv = 0.5 * h * (v_free - v)  # h² a / 2
        with np.errstate(over="ignore", invalid="ignore"):  # a huge trial state is simply not separating
            ahead, behind = self.state.step_configuration(q, h * v + dv), self.state.step_configuration(q, -h * v + dv)
        if not (np.isfinite(ahead).all() and np.isfinite(behind).all()):
            return False
        gaps_ahead, rates_ahead = self.state.kin.rates(ahead, self.state.transport(q, ahead, v_free), t + h)
        if not all(rates_ahead[i] > 0.0 for i in active):
            return False
        gaps_behind = self.state.kin.gaps(behind, t - h)
        if not all(gaps_ahead[i] + gaps_behind[i] - 2.0 * gaps[i] > rounding for i in active):
            return False
        _, rates = self.state.kin.rates(q, v, t)
        for i in active:
            self.state.active[i], self.state.armed[i], self.state.pushing[i] = False, False, False
            self.state.event(ContactEvent(t, i, "lift", 0.0, 0.0, float(rates[i]), rule="free motion"))
        return True

    def step_acceleration(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], damped: bool = True
                          ) -> NDArray[np.float64]:
        """The rate of change of v over a step: :meth:`acceleration`, except that a free flyer's linear
        part is the classical acceleration of its origin, Rᵀ p̈ = a + ω × v (body axes).

        The step moves the origin along a straight line and keeps its world velocity
        (:meth:`step_configuration`, :meth:`transport`), so v changes by Rᵀ p̈ only. Pinocchio's
        spatial acceleration a is the rate of the body-axis components, which also turn with the body:
        added on top of the transport, it turned the world velocity by −ω h a step and lengthened it
        by O(h²) — a torque-free spinning body on a frictionless plane gained 0.2 % of its energy in
        0.25 s (issue #14).
        """
        a = self.state.acceleration(t, q, v, damped)
        if self.state.free_flyer:
            with np.errstate(over="ignore", invalid="ignore"):  # an overflow is caught as non-finite by the caller
                a[:3] += np.cross(v[3:6], v[:3])
        return a

    def project(self, t: float, q: NDArray[np.float64], gaps: NDArray[np.float64]) -> NDArray[np.float64]:
        """Back onto the surfaces: the step moves a persistent contact off its surface by O(h²) (a
        rotating body's points move along straight lines for a step). When that puts a contact below
        its surface, the smallest change of q in the kinetic metric that puts the pushing points
        (and any contact below its surface) at gap 0.

        Open contacts are held too: putting the resting points back moves the others, and an open
        contact about to strike was pushed below its surface by it (by up to 3e-6 m)."""
        band = 0.1 * self.state.band
        for _ in range(3):
            # the next step's gap term closes small drifts; a drift below the surface is projected now
            below = [i for i in range(self.state.nc) if gaps[i] < -band]
            if not below:
                return q
            held = [i for i in range(self.state.nc) if i in below or (self.state.active[i] and self.state.pushing[i])]
            rows = [s for s in self.state.kin.states(q, np.zeros(self.state.nv), t, held)
                    if self.state.pushing[s.index] and self.state.active[s.index] or s.gap < 0.0]
            Jn = np.array([s.normal @ s.J for s in rows])
            A, factor = self.state.mech.factorise(q)
            AinvJt = factor.solve(Jn.T)
            dq = -AinvJt @ np.linalg.lstsq(Jn @ AinvJt, np.array([s.gap for s in rows]), rcond=1e-12)[0]
            q = self.state.configuration(q, dq)
            gaps = self.state.kin.gaps(q, t)
            self.state.work["projection"] += 1
        return q

    def path_crossing(self, t: float, q: NDArray[np.float64], v1: NDArray[np.float64], h: float,
                      g0: NDArray[np.float64], g1: NDArray[np.float64], r1: NDArray[np.float64]
                      ) -> tuple[float, list[int]] | None:
        """The first strike along the step's path q(s) = q ⊕ s v⁺, s ∈ [0, h] (gaps ``g0`` at its
        start, ``g1`` and rates ``r1`` at its end): an open contact crossing its surface, or a
        further point of a resting pair crossing fast (its nearest point at the step's end is below
        the surface and approaching faster than ``rest_velocity``). The fraction s of the step at
        the crossing, and the contact."""
        from scipy.optimize import brentq

        tol = self.state.band
        xtol = 4 * np.finfo(float).eps * max(1.0, h)
        first: tuple[float, list[int]] | None = None

        def down(f: Callable[[float], float], a: float) -> float | None:
            """Where f goes below 0 on [a, h]: a when it is there already, None when it ends above (the
            path's start is rounded by :meth:`step_configuration`, so f(a) is evaluated, never assumed)."""
            fa = f(a)
            if fa < 0.0:
                return a
            if f(h) >= 0.0:
                return None
            return float(brentq(f, a, h, xtol=xtol)) if fa > 0.0 else a

        for i in range(self.state.nc):
            s: float | None
            if self.state.active[i]:
                if not (self.state.kin.is_pair(i) and g1[i] < -0.1 * tol and r1[i] < -self.state.scene.rest_velocity):
                    continue
                # the material point that is nearest at the step's end, followed back along the path
                gap = self.state.kin.material_gap(i, self.state.step_configuration(q, h * v1), t + h)
                if gap(q) <= 0.0:  # on the surface already: a resting point drifting, for the projection
                    continue
                def material(s: float, gap: Callable[[NDArray[np.float64]], float] = gap) -> float:
                    return gap(self.state.step_configuration(q, s * v1))

                s = down(material, 0.0)
            else:
                if not self.state.armed[i] and g0[i] > tol:
                    self.state.armed[i] = True
                if not g1[i] < 0.0:
                    continue

                def along(s: float, i: int = i) -> float:
                    return float(self.state.kin.gaps(self.state.step_configuration(q, s * v1), t + s)[i])

                if self.state.armed[i] or r1[i] < 0.0:
                    s = down(along, 0.0)
                else:
                    # disarmed after an impact, and below its surface at the step's end though leaving it
                    # there: the step's path rose and came back down (the point of a turning body), a
                    # strike after the apex; or the step pushed it in from the start
                    s = self.rearmed(along, h, xtol)
            if s is not None and (first is None or s < first[0]):
                first = (s, [i])
        return first

    def pushed_in(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], group: list[int]) -> bool:
        """Open contacts of ``group`` that the step pushes below their surfaces from its start while v
        itself does not approach them (a contact thrown off by an impact elsewhere, pulled back by the
        persistent contacts' impulses): no impact can happen at v, so they join the persistent contact
        and the cone problem decides whether they push or lift off. Whether any did."""
        _, rates = self.state.kin.rates(q, v, t)
        joined = [i for i in group if not self.state.active[i] and rates[i] >= 0.0]
        for i in joined:
            self.state.active[i], self.state.armed[i] = True, False
            self.state.event(ContactEvent(t, i, "rest", float(rates[i]), rule="pushed back by the contact step"))
        return bool(joined)

    def rearmed(self, along: Callable[[float], float], h: float, xtol: float) -> float | None:
        """The strike of a disarmed contact found below its surface at the end of a step (gap ``along(s)``
        on the step's path): after the highest of a few points of the path, where the gap comes down
        through 0; at the step's start if it never rose above its surface."""
        from scipy.optimize import brentq

        ss = np.linspace(0.0, h, 6)
        fs = [along(float(s)) for s in ss]
        top = int(np.argmax(fs))
        if fs[top] <= 1e-3 * self.state.band or top == len(ss) - 1:
            return 0.0
        return float(brentq(along, float(ss[top]), h, xtol=xtol))

    def lift_offs(self, t: float, gaps: NDArray[np.float64], rates: NDArray[np.float64]) -> None:
        """A persistent contact whose gap opened (the cone gave it no push) becomes open."""
        for i in range(self.state.nc):
            if self.state.active[i] and not self.state.pushing[i] and gaps[i] > self.state.band and rates[i] > 0.0:
                self.state.active[i], self.state.armed[i] = False, False
                self.state.event(ContactEvent(t, i, "lift", 0.0, 0.0, float(rates[i])))
            elif self.state.active[i] and gaps[i] < -self.state.scene.tolerance:
                raise Stop("penetration", f"persistent contact {i} ({self.state.scene.contacts[i].label}) is "
                                          f"{-gaps[i]:.3g} m inside its surface at t = {t:.9g}, beyond the tolerance "
                                          f"{self.state.scene.tolerance:g} m; reduce contact_step")

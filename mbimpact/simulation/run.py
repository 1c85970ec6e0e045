"""The state of one simulation run and its bookkeeping: one explicit object the parts of the run take.

:class:`RunState` holds what every part reads and writes: the scene, Pinocchio's workspace, each
contact's mode (open and armed, open and disarmed after an impact, persistent), the output samples,
the event log and the counters of the work done, and the limits that stop a run with a named status.
The parts are :class:`~mbimpact.simulation.flight.FreeFlight`,
:class:`~mbimpact.simulation.impacts.Impacts` and :class:`~mbimpact.simulation.persistent.Persistent`,
each made with the state (and the impacts, which the phases hand their events to);
:mod:`~mbimpact.simulation.simulator` runs them. Progress is reported to a callable the caller passes
in (the apps layer draws it).
"""

from __future__ import annotations

import math
import time
from collections import Counter, deque
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..laws.base import ImpactLaw
from ..laws.newton import NewtonLaw
from ..laws.rough import RoughLaw
from ..roughness import Smooth
from .cones import ConeSolver
from .kinematics import ContactKinematics
from .scene import Scene
from .scene_contacts import SceneContact
from .trajectory import ContactEvent

__all__ = ["BAND_MAX", "ENERGY_SLACK", "CONTACT_ENERGY_RATE", "RunState", "Stop", "scene_law", "passive", "Progress"]

#: A progress callback: ``progress(percent, note)`` is called as the simulated time passes each percent of the
#: scene's duration (at most 100 times a run), with a short note of the work done.
Progress = Callable[[int, str], None]

# a window of simulated time over which the event rate is measured [s]
RATE_WINDOW = 0.01

#: The largest height [m] above its surface at which a contact still touches it (the default ``tolerance``);
#: a run's band is min(tolerance, BAND_MAX). The scene's tolerance bounds penetration, the guarantee of a
#: completed run; the band says where a contact is: on its surface (resting, striking with others,
#: projected back below −band/10) or off it (armed again, lifted off). Taken as the tolerance itself, a
#: large one (1e308 is valid) held a contact 7 cm above its surface in persistent contact — it would strike
#: at a distance at t = 0, and never lifted off, its flight integrated by first-order contact steps (#14).
BAND_MAX = 1e-8


#: The energy a passive run may gain beyond its flight's integration error, as a fraction of its energy scale
#: |E₀| + |E| + 1 J. Impacts by passive laws only dissipate; a larger gain is a defect of the run, stopped as
#: ``energy_growth``.
ENERGY_SLACK = 1e-6
#: Beyond it, once a run has taken persistent-contact steps, ``CONTACT_ENERGY_RATE · contact_step`` of the
#: scale [1/s]: Moreau's scheme is first order, and while a contact slides its energy oscillates by O(h) (a
#: frictionless double pendulum's tip sliding on a floor: 2.5e-6 of the scale at h = 1 ms, 2e-5 at 4 ms;
#: legged robots and boxes resting: 1e-13 to 1e-10). The blow-ups this guards against gain 1e4 times the scale.
CONTACT_ENERGY_RATE = 10.0


def passive(scene: Scene) -> bool:
    """No energy enters the scene: fixed surfaces, no declared torques or PD, and no law that may create
    energy (Coulomb's with Newton's kinematic restitution, on its own or as the facets of a rough law)."""
    if scene.torque is not None or scene.pd is not None:
        return False
    for c in scene.contacts:
        if isinstance(c, SceneContact) and c.surface.moving:
            return False
        law = c.law
        facet = law.facet if isinstance(law, RoughLaw) else law
        if getattr(facet, "restitution", None) == "newton":
            return False
    return True


def scene_law(law: ImpactLaw) -> ImpactLaw:
    """The law a scene applies: no microrelief with Newton facets ⇒ Newton's law (no facet work);
    rough laws repeat their micro-impacts until the contact separates."""
    if isinstance(law, RoughLaw) and isinstance(law.roughness, Smooth) and law.facet.newton_restitution is not None:
        return NewtonLaw(law.facet.newton_restitution)
    if isinstance(law, RoughLaw) and not law.repeat:
        return law.replace(repeat=True)
    return law


class Stop(Exception):
    """Ends the run with a status and a message."""

    def __init__(self, status: str, message: str) -> None:
        super().__init__(message)
        self.status, self.message = status, message


class RunState:
    """One run of a scene: state, output and limits (see the module docstring)."""

    def __init__(self, scene: Scene, samples: int, progress: Progress | None) -> None:
        self.start = time.perf_counter()  # max_wall_time counts the set-up (a first import of scipy) too
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
        self.band = min(scene.tolerance, BAND_MAX)  # where a contact touches its surface (see BAND_MAX)
        self.nc, self.nv, self.nq = len(scene.contacts), mech.nv, mech.nq
        self.euclidean = self.model.nq == self.model.nv
        self.laws = [scene_law(c.law) for c in scene.contacts]
        self.frictions = [c.friction for c in scene.contacts]
        self.active = [False] * self.nc
        self.armed = [True] * self.nc
        self.pushing = [False] * self.nc  # the persistent contact pushed in the last step
        self.rebounds: list[list[tuple[float, float]]] = [[] for _ in range(self.nc)]
        self.last_impact = [-math.inf] * self.nc
        self.last_struck: list[NDArray[np.float64] | None] = [None] * self.nc  # in body coordinates (pairs)
        self.events: list[ContactEvent] = []
        self.work: Counter[str] = Counter()
        self.cones = ConeSolver()
        self.rng = np.random.default_rng(0)
        self.grid = np.linspace(0.0, scene.duration, max(2, samples))
        self.next_sample = 1
        self.out_t: list[float] = []
        self.out_contact: list[tuple[NDArray[np.float64], NDArray[np.float64]] | None] = []
        self.out_energy: list[float | None] = []  # where the run computed it (a passive run checks it)
        self.out_q: list[NDArray[np.float64]] = []
        self.out_v: list[NDArray[np.float64]] = []
        self.out_active: list[tuple[bool, ...]] = []
        self.out_forces: list[NDArray[np.float64]] = []
        self.forces = np.zeros((self.nc, 3))  # mean contact forces over the last persistent-contact step
        self.recent: deque[float] = deque()
        self.peak_rate = 0.0
        self.impacts = 0
        self.mask = np.ones(self.nv)
        self.free_flyer = self.model.njoints > 1 and self.model.joints[1].shortname() == "JointModelFreeFlyer"
        if self.free_flyer:
            self.mask[:6] = 0.0  # the free-flyer is not actuated
        # the velocity-proportional torques −damper ∘ v (joint damping, the PD's kd): the stiff part of the
        # dynamics, integrated implicitly (free flight: Radau when stiff; persistent contact: in the step)
        self.damper = np.full(self.nv, scene.damping)
        if scene.pd is not None:
            self.damper += scene.pd.kd * self.mask
        freqs = [c.surface.frequency for c in scene.contacts if isinstance(c, SceneContact) and c.surface.moving]
        # a moving surface can cross a flight twice within a long step: a step is a fraction of its period
        self.max_step = min(1.0 / (16.0 * max(freqs)) if freqs else math.inf, scene.duration / 4)
        self.progress = progress
        self.shown = 0
        self.passive = passive(scene)
        self.energy_data = self.model.createData()
        self.energy0: float | None = None

    # ---------------------------------------------------------------- forces and dynamics
    def torque(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], damped: bool = True
               ) -> NDArray[np.float64]:
        """The declared joint torques at (t, q, v); without the velocity-proportional ones (``damper``)
        when not ``damped`` (an implicit step adds them itself)."""
        scene = self.scene
        tau = np.zeros(self.nv) if scene.torque is None else scene.torque.copy()
        # a trial state of a rejected step may be huge: an overflow here is caught as a non-finite
        # result by the caller (a named status), not leaked as a RuntimeWarning
        with np.errstate(over="ignore", invalid="ignore"):
            if scene.damping:
                self.work["damping"] += 1
                if damped:
                    tau -= scene.damping * v
            if scene.pd is not None:
                self.work["pd"] += 1
                err = pin.difference(self.model, q, scene.pd.q_ref)
                if damped:
                    tau += self.mask * (scene.pd.kp * err - scene.pd.kd * v)
                else:
                    tau += self.mask * (scene.pd.kp * err)
        return tau

    def acceleration(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], damped: bool = True
                     ) -> NDArray[np.float64]:
        self.work["dynamics"] += 1
        if self.scene.gravity:
            self.work["gravity"] += 1
        return pin.aba(self.model, self.data, q, v, self.torque(t, q, v, damped))

    def damping_rate(self, q: NDArray[np.float64]) -> float:
        """The fastest decay rate [1/s] of the velocity-proportional torques at q: max(damper) / λmin(A(q)),
        an upper bound of the largest eigenvalue of A⁻¹ diag(damper). An explicit step longer than a few
        times its inverse is unstable."""
        top = float(self.damper.max(initial=0.0))
        if top == 0.0:
            return 0.0
        A = pin.crba(self.model, self.data, q)
        low = float(np.linalg.eigvalsh(A)[0])
        return top / low if low > 0.0 else math.inf

    def configuration(self, anchor: NDArray[np.float64], dq: NDArray[np.float64]) -> NDArray[np.float64]:
        """anchor ⊕ dq (Pinocchio's integration: a free flyer moves along a screw)."""
        if self.euclidean:
            return anchor + dq
        return pin.integrate(self.model, anchor, dq)

    def step_configuration(self, q: NDArray[np.float64], dq: NDArray[np.float64]) -> NDArray[np.float64]:
        """q advanced by dq over a persistent-contact step: as :meth:`configuration`, except that a free
        flyer's origin moves along a straight line (R³ × SO(3) instead of SE(3)). The screw of SE(3)
        turns a rolling sphere about its contact point, so its centre would dip by R ω² h² / 2 every
        step and be projected back up, feeding it energy; on the straight line it rolls level."""
        if not self.free_flyer:
            return self.configuration(q, dq)
        out = pin.integrate(self.model, q, dq)
        R = pin.Quaternion(q[3:7]).matrix()
        out[:3] = q[:3] + R @ dq[:3]
        quat = pin.Quaternion(R @ pin.exp3(dq[3:6])).coeffs()
        # normalised every step: the rounding of the rotation product would otherwise accumulate over
        # thousands of contact steps until q is no longer a configuration (a sphere spinning on a plane)
        out[3:7] = quat / np.linalg.norm(quat)
        return out

    def transport(self, q0: NDArray[np.float64], q1: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        """A velocity at q0 expressed at q1 with the same world linear velocity of a free flyer."""
        if not self.free_flyer:
            return v
        out = v.copy()
        out[:3] = pin.Quaternion(q1[3:7]).matrix().T @ (pin.Quaternion(q0[3:7]).matrix() @ v[:3])
        return out

    def surface_moving(self, i: int) -> bool:
        """Contact i is on a moving surface."""
        c = self.scene.contacts[i]
        return isinstance(c, SceneContact) and c.surface.moving

    # ---------------------------------------------------------------- bookkeeping
    def emit(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64],
             contact: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None) -> None:
        """Record the state at t (``contact``: its gaps and rates, where the phase computed them). The
        output runs forward in time: grid times before t that were not emitted (passed inside a
        persistent-contact step that ended at an impact) are dropped, never emitted later from a phase
        that starts after them — a free flight's dense output would extrapolate them backwards with the
        post-impact velocity, below the surfaces."""
        while self.next_sample < len(self.grid) and self.grid[self.next_sample] < t:
            self.next_sample += 1
        self.out_t.append(t)
        self.out_contact.append(contact)
        self.out_q.append(q.copy())
        self.out_v.append(v.copy())
        self.out_active.append(tuple(self.active))
        self.out_forces.append(self.forces.copy() if any(self.active) else np.zeros((self.nc, 3)))
        # the energy where a passive run checks it (finish() then reuses it); the state is recorded first
        self.out_energy.append(None)
        if self.passive:
            self.out_energy[-1] = self.check_energy(t, q, v)

    def energy(self, q: NDArray[np.float64], v: NDArray[np.float64]) -> float:
        """Kinetic plus potential energy at (q, v) [J]."""
        # a workspace of its own: the kinematics of the contacts stay as the caller left them
        out = float(pin.computeKineticEnergy(self.model, self.energy_data, q, v))
        if self.scene.gravity:
            out += float(pin.computePotentialEnergy(self.model, self.energy_data, q))
        return out

    def check_energy(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64]) -> float:
        """Stop a passive run (status "energy_growth") whose energy rose above its start by more than the
        flight's integration error (twice the fuzzers' bound of 2 rtol per free step, of the scale),
        :data:`ENERGY_SLACK` of the scale and, after persistent contact, the first-order error of its steps
        (:data:`CONTACT_ENERGY_RATE`). The state was recorded: the output ends where it grew. Returns the
        energy at (q, v)."""
        e = self.energy(q, v)
        if self.energy0 is None:
            self.energy0 = e
            return e
        rtol = max(self.scene.rtol, 100 * np.finfo(float).eps)
        scale = abs(self.energy0) + abs(e) + 1.0
        slack = scale * (ENERGY_SLACK + 4.0 * rtol * (self.work["free_steps"] + 1))
        if self.work["contact_steps"]:
            slack += scale * CONTACT_ENERGY_RATE * self.scene.contact_step
        if not e - self.energy0 <= slack:  # a NaN energy is growth too
            self.passive = False  # reported once
            raise Stop("energy_growth", f"the energy of a passive scene rose by {e - self.energy0:.3g} J (from "
                                        f"{self.energy0:.9g} J to {e:.9g} J) by t = {t:.9g}, beyond its integration "
                                        f"error ({slack:.3g} J): a defect of the run; please report the scene")
        return e

    def event(self, e: ContactEvent) -> None:
        self.events.append(e)
        self.recent.append(e.t)
        while self.recent and e.t - self.recent[0] > RATE_WINDOW:
            self.recent.popleft()
        rate = len(self.recent) / RATE_WINDOW
        self.peak_rate = max(self.peak_rate, rate)
        if len(self.recent) > max(20.0, self.scene.max_events_per_second * RATE_WINDOW):
            raise Stop("event_limit", f"{len(self.recent)} events within {RATE_WINDOW:g} s of simulated time "
                                      f"before t = {e.t:.9g} (contact {e.contact}, {e.kind}): over "
                                      f"max_events_per_second = {self.scene.max_events_per_second:g}")

    def check_wall_time(self, t: float) -> None:
        """Stop (status "wall_time") once the run has used ``max_wall_time``. Cheap (a clock read): it is
        called inside the integrations too, so that a stiff or stalling step loop cannot overrun."""
        elapsed = time.perf_counter() - self.start
        if elapsed > self.scene.max_wall_time:
            raise Stop("wall_time", f"stopped at t = {t:.9g} s after {elapsed:.3g} s of wall time "
                                    f"(max_wall_time = {self.scene.max_wall_time:g} s)")

    def check_limits(self, t: float) -> None:
        self.check_wall_time(t)
        self.report(int(100 * t / self.scene.duration), f"t={t:.3g}s, {self.impacts} impacts")

    def report(self, percent: int, note: str) -> None:
        """Tell the progress callback of every percent of the duration passed up to ``percent``."""
        progress = self.progress
        while self.shown < min(percent, 100):
            self.shown += 1
            if progress is not None:
                progress(self.shown, note)

    def sample_until(self, state: Any, t_end: float) -> None:
        """Emit the output grid points up to ``t_end`` (``state(t)`` gives (q, v))."""
        while self.next_sample < len(self.grid) and self.grid[self.next_sample] <= t_end:
            tg = float(self.grid[self.next_sample])
            q, v = state(tg)
            self.emit(tg, q, v)
            self.next_sample += 1

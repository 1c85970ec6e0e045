"""Simulation of a scene: free flight, impacts, persistent contact, with guarantees.

The run alternates two phases: *free flight* (:mod:`~mbimpact.simulation.flight`), in which
every open contact's gap is watched on each integration step so that no crossing is missed,
and *persistent contact* (:mod:`~mbimpact.simulation.persistent`), velocity-level steps on
Coulomb cones with lift-off and new strikes. Impacts (:mod:`~mbimpact.simulation.impacts`)
happen where a contact crosses its surface: by the contact's law at one point, by the scene's
rule at several.

A contact comes to rest when its rebound is slower than ``rest_velocity``; the time of its
accumulating bounces (Zeno) is summed as a geometric series from the ratio of the last
rebounds, and the rest is dated at their limit. The run stops with a named status — never
"completed" — when a limit is reached (impacts, events per simulated second, wall time) or a
guarantee cannot be kept (penetration deeper than ``tolerance``, an integration failure); the
message says where and why.

The ``work`` counters of the result record what was computed, so that a scene's undeclared
effects can be shown to cost nothing.
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from ..errors import ImpactError, IntegrationError, ParameterError
from .flight import FreeFlight
from .impacts import Impacts
from .persistent import Persistent
from .run import Progress, RunState, Stop
from .scene import Scene
from .trajectory import ContactEvent, Trajectory

__all__ = ["simulate"]


class _Run:
    """One run of a scene: its state, and the parts that advance it."""

    def __init__(self, scene: Scene, samples: int, progress: Progress | None) -> None:
        self.state = state = RunState(scene, samples, progress)
        self.impacts = Impacts(state)
        self.flight = FreeFlight(state, self.impacts)
        self.persistent = Persistent(state, self.impacts)

    def run(self) -> Trajectory:
        scene = self.state.scene
        t, q, v = 0.0, scene.q0.copy(), scene.v0.copy()
        status, message = "completed", ""
        try:
            v = self.classify_start(t, q, v)
            self.state.emit(t, q, v)
            stalled = 0
            while t < scene.duration:
                before = (t, len(self.state.events), tuple(self.state.active))
                if any(self.state.active):
                    t, q, v = self.persistent.contact_phase(t, q, v)
                else:
                    t, q, v = self.flight.free_phase(t, q, v)
                if t < scene.duration:  # a phase may end at its first event, before its own check
                    self.state.check_wall_time(t)
                # every pass must move time, log an event or change a contact's mode
                stalled = stalled + 1 if (t, len(self.state.events), tuple(self.state.active)) == before else 0
                if stalled > 100:
                    raise Stop("event_limit", f"no progress at t = {t:.9g}: the same event keeps recurring")
        except Stop as stop:
            status, message = stop.status, stop.message
        except IntegrationError as exc:
            status, message = "integration_error", str(exc)
        self.state.report(100, f"{self.state.impacts} impacts")
        return self.finish(status, message)

    def classify_start(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        """Contacts starting on their surface: resting, leaving, or striking at t = 0."""
        gaps, rates = self.state.kin.rates(q, v, t)
        tol, rest = self.state.band, self.state.scene.rest_velocity  # touching: within the band (a start below it is valid)
        striking = [i for i in range(self.state.nc) if gaps[i] <= tol and rates[i] < -rest]
        for i in range(self.state.nc):
            if gaps[i] <= tol and -rest <= rates[i] <= rest:
                self.state.active[i] = True
                self.state.event(ContactEvent(t, i, "rest", float(rates[i])))
            elif gaps[i] <= tol:
                self.state.armed[i] = False
        if striking:
            v = self.impacts.impact(t, q, v, striking)
        return v

    def finish(self, status: str, message: str) -> Trajectory:
        order = np.argsort(self.state.out_t, kind="stable")
        T = np.array(self.state.out_t)[order]
        Q, V = np.array(self.state.out_q)[order], np.array(self.state.out_v)[order]
        active = np.array(self.state.out_active, dtype=bool).reshape(len(self.state.out_t), self.state.nc)[order]
        forces = np.array(self.state.out_forces).reshape(len(self.state.out_t), self.state.nc, 3)[order]
        gaps = np.empty((len(T), self.state.nc))
        rates = np.empty((len(T), self.state.nc))
        energy = np.empty(len(T))
        known = [self.state.out_contact[j] for j in order]
        energies = [self.state.out_energy[j] for j in order]
        for k, (t, q, v) in enumerate(zip(T, Q, V)):
            sample, e = known[k], energies[k]
            gaps[k], rates[k] = self.state.kin.rates(q, v, float(t)) if sample is None else sample
            energy[k] = self.state.energy(q, v) if e is None else e
        self.state.work["surface_motion"] += self.state.kin.surface_evaluations
        if self.state.kin.collision_queries:
            self.state.work["collision_queries"] += self.state.kin.collision_queries
        tol = self.state.scene.tolerance
        if status == "completed" and gaps.size and gaps.min() < -tol:
            k, i = (int(x) for x in np.unravel_index(int(np.argmin(gaps)), gaps.shape))
            status = "penetration"
            message = (f"contact {i} ({self.state.scene.contacts[i].label}) is {-gaps[k, i]:.3g} m inside its surface at "
                       f"t = {T[k]:.9g}, beyond the tolerance {tol:g} m")
        return Trajectory(T, Q, V, energy, gaps, rates, active, forces, self.state.events, self.state.work, status, message,
                          time.perf_counter() - self.state.start, self.state.peak_rate, tol)


def simulate(scene: Scene, samples: int = 2000, progress: Progress | None = None) -> Trajectory:
    """Simulate a scene for ``scene.duration`` seconds.

    Parameters
    ----------
    scene : Scene
    samples : int
        Number of equally spaced output times (event instants are added).
    progress : callable, optional
        ``progress(percent, note)``, called as the simulated time passes each percent of the duration
        (the ``mbimpact run`` command draws a bar with it).

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
    if progress is not None and not callable(progress):
        raise ParameterError(f"progress must be a callable progress(percent, note) or None, got {progress!r}")
    return _Run(scene, samples, progress).run()

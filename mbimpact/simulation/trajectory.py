"""What a simulation returns: sampled states, the event log, work counters and a status."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

__all__ = ["ContactEvent", "ImpactRecord", "Trajectory", "STATUSES"]

#: How a run ends. Only "completed" means the whole duration was simulated with every guarantee kept.
STATUSES = ("completed", "max_impacts", "event_limit", "wall_time", "penetration", "integration_error", "energy_growth")

EventKind = Literal["impact", "rest", "lift", "stick", "slip"]


@dataclass(frozen=True)
class ContactEvent:
    """One event at one contact: an impact, the switch to persistent contact, or a lift-off.

    Attributes
    ----------
    t : float
        Time [s]. For ``kind == "rest"`` the end of the geometric tail of accumulating bounces.
    contact : int
        Index of the contact in the scene.
    kind : {"impact", "rest", "lift"}
    un_minus, un_plus : float
        Relative normal velocity of the contact point before and after [m/s] (< 0 approaching).
    ut_minus, ut_plus : float
        Relative tangential speed before and after [m/s].
    kappa, mu : float
        Restitution −u_n⁺/u_n⁻ and friction ratio |P_t|/P_n of the impact (0 when not defined).
    impulse : float
        |P| of the contact impulse [N s].
    energy_loss : float
        Kinetic energy lost at this contact's impulse, −Pᵀ(u₋ + u₊)/2 [J].
    rule : str
        The law or multi-contact rule that produced it.
    group : int
        Number of contacts that struck together (1: a single impact).
    points : int
        Number of this contact's points that struck (a collision pair's face or edge: several).
    point : ndarray, shape (3,), optional
        Impacts: where the contact's most approaching point struck, world frame [m] (a collision
        pair's witness point on the body).
    """

    t: float
    contact: int
    kind: str
    un_minus: float = 0.0
    ut_minus: float = 0.0
    un_plus: float = 0.0
    ut_plus: float = 0.0
    kappa: float = 0.0
    mu: float = 0.0
    impulse: float = 0.0
    energy_loss: float = 0.0
    rule: str = ""
    group: int = 1
    points: int = 1
    point: NDArray[np.float64] | None = None

    @property
    def rest(self) -> bool:
        """Whether this event is the switch to persistent contact."""
        return self.kind == "rest"


#: The former name of :class:`ContactEvent`.
ImpactRecord = ContactEvent


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Sampled states, the event log and the work counters of a simulation.

    Attributes
    ----------
    t : ndarray, shape (T,)
    q, v : ndarray, shapes (T, nq), (T, nv)
    energy : ndarray, shape (T,)
        Kinetic plus (if declared) gravitational potential energy [J].
    gaps, gap_rates : ndarray, shape (T, c)
        Gap f of each contact [m] (≥ −tolerance at every sample) and its relative normal velocity [m/s].
    active : ndarray, shape (T, c), bool
        Whether each contact is persistent (resting or sliding) at each sample.
    forces : ndarray, shape (T, c, 3)
        Mean force of each persistent contact over the time step ending at each sample
        (world frame, on the mechanism) [N]; 0 for open contacts and in free flight.
    events : list of ContactEvent
    work : Counter
        What was computed: ``free_steps``, ``contact_steps`` (``compiled_contact_steps`` of them in one compiled call), ``facet_average``, ``newton_impact``,
        ``friction_cone``, ``gravity``, ``damping``, ``surface_motion``, …
    status : str
        One of :data:`STATUSES`.
    message : str
        Why the run ended where it did (empty when completed).
    wall_time : float
        Wall-clock seconds spent.
    peak_event_rate : float
        The largest number of events per simulated second seen (over windows of 10 ms).
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    v: NDArray[np.float64]
    energy: NDArray[np.float64]
    gaps: NDArray[np.float64]
    gap_rates: NDArray[np.float64]
    active: NDArray[np.bool_]
    forces: NDArray[np.float64]
    events: list[ContactEvent]
    work: Counter[str]
    status: str
    message: str = ""
    wall_time: float = 0.0
    peak_event_rate: float = 0.0
    tolerance: float = 1e-8
    info: dict[str, float] = field(default_factory=dict)

    @property
    def impacts(self) -> list[ContactEvent]:
        """The impacts and rest switches (the events of kinds "impact" and "rest")."""
        return [e for e in self.events if e.kind in ("impact", "rest")]

    @property
    def completed(self) -> bool:
        return self.status == "completed"

    def first_rest_time(self, contact: int | None = None) -> float | None:
        """Time at which a contact (or any) first came to rest, tail included (None if never)."""
        rest = [e.t for e in self.events if e.kind == "rest" and (contact is None or e.contact == contact)]
        return rest[0] if rest else None

    def impact_times(self, contact: int | None = None) -> NDArray[np.float64]:
        """Times of the impacts (not rests) of a contact, or of all."""
        return np.array([e.t for e in self.events if e.kind == "impact" and (contact is None or e.contact == contact)])

    def before(self, t: float) -> int:
        """Index of the sample just before an event at ``t`` (the state before the impact)."""
        return int(np.searchsorted(self.t, t, side="left"))

    @property
    def min_gap(self) -> float:
        """The smallest gap over all samples and contacts [m]."""
        return float(self.gaps.min()) if self.gaps.size else 0.0

    @property
    def resting(self) -> tuple[bool, ...]:
        """Which contacts are persistent at the end."""
        return tuple(bool(x) for x in self.active[-1]) if len(self.active) else ()

    def summary(self) -> str:
        """A few lines: status, events, energy, rest, what was computed."""
        lines = [f"status {self.status}" + (f": {self.message}" if self.message else ""),
                 f"{len(self.impact_times())} impacts, {sum(e.kind == 'rest' for e in self.events)} rests, "
                 f"{sum(e.kind == 'lift' for e in self.events)} lift-offs; energy {self.energy[0]:.6g} J → "
                 f"{self.energy[-1]:.6g} J; min gap {self.min_gap:.3g} m",
                 f"wall time {self.wall_time:.3g} s ({self.t[-1] / max(self.wall_time, 1e-9):.3g} simulated s per s); "
                 f"peak {self.peak_event_rate:.3g} events per simulated s"]
        return "\n".join(lines)

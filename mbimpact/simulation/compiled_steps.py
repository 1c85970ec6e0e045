"""Persistent-contact steps in one compiled call: the backend of :mod:`~mbimpact.simulation.persistent`'s
step for frame contacts on fixed planes.

Moreau's step of a legged robot standing on its feet is a few microseconds of Pinocchio's work (CRBA
and its factor, the nonlinear effects, the contact Jacobians, the Delassus matrix, a cone problem)
and, around it, a millisecond of Python. :func:`mbimpact.mechanism.native` ``contact_steps``
(``native_contact.cpp``) takes the steps in C++, the same algorithm as the Python step, projections
back onto the surfaces included, until something happens that the Python route treats: every
persistent contact leaving by itself, an open contact crossing its surface, a cone problem its
solver does not settle, a lift-off or a penetration. It returns the state of its last completed
step, and the Python route takes the next step from there, so a run takes the same steps and events
on either route, with results equal to rounding and to the cone solver's tolerance (Pinocchio's ADMM
on the Python route; in C++ the sticking solution where it holds, else projected Gauss–Seidel with
Pinocchio's Coulomb block update).

Used where the compiled front end is (:func:`mbimpact.mechanism.front.status`) and every contact of
the scene is a frame contact on a fixed plane; :func:`compiled_steps` says whether a run can.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..mechanism import front
from .run import RunState

__all__ = ["CompiledSteps", "compiled_steps", "REASONS"]

#: Why a call returned, by its code: "budget" (its steps taken, or the duration reached), "separating",
#: "crossing", "solver", "invalid" (the Python route takes the next step), "lift" (the last step ended
#: with a lift-off or a penetration for the Python route to name), "full" (its output rows).
REASONS = ("budget", "separating", "crossing", "solver", "lift", "full", "invalid")

# slots of the parameter vector (native_contact.cpp: enum Par)
_T, _STEP, _DURATION, _BAND, _TOL, _FF, _KP, _KD, _HAS_PD, _DAMPING, _HAS_DAMPER, _MAX_STEPS, _NEXT, _STEPS, _ROWS, \
    _PGS_TOL, _PGS_ITERATIONS, _REASON, _PROJECTIONS = range(19)
# columns of a contact's row (enum Col)
_JOINT, _LOCAL, _NORMAL, _ORIGIN, _FRAME, _MU, _ACTIVE, _ARMED, _PUSHING, _COLS = 0, 1, 4, 7, 10, 19, 20, 21, 22, 23

#: Steps per call at most: the run's clock and progress are read between calls.
MAX_STEPS = 256
#: Sweeps of the compiled projected Gauss–Seidel before a cone problem is handed to Pinocchio's ADMM
#: (rank-deficient problems, where PGS converges slowly: a biped's soles on four corners each).
PGS_SWEEPS = 500


@dataclass
class Taken:
    """What one call did: the state it reached, its steps, and why it returned."""

    t: float
    q: NDArray[np.float64]
    v: NDArray[np.float64]
    gaps: NDArray[np.float64]
    rates: NDArray[np.float64]
    steps: int
    reason: str


def compiled_steps(state: RunState) -> CompiledSteps | None:
    """The compiled steps of a run, or None where its contacts need the Python route (collision pairs,
    moving or curved surfaces) or the compiled front end is not in use."""
    native = front.NATIVE
    kin = state.kin
    if native is None or not hasattr(native, "contact_steps") or kin.collisions is not None or kin.points is None:
        return None
    points = kin.points
    if points.moving or points.curved:  # no collision pairs: every contact is a frame contact
        return None
    return CompiledSteps(state, native)


class CompiledSteps:
    """The buffers of a run's compiled contact steps (see the module docstring)."""

    def __init__(self, state: RunState, native: object) -> None:
        self.state, self.native = state, native
        scene, points = state.scene, state.kin.points
        assert points is not None
        nc, nq, nv = state.nc, state.nq, state.nv
        self.data = state.model.createData()  # a workspace of its own
        self.bound = native.bind(state.model, self.data)  # type: ignore[attr-defined]
        self.contacts = np.zeros((nc, _COLS))
        for i in range(nc):
            row = self.contacts[i]
            row[_JOINT] = points.joints[i]
            row[_LOCAL:_LOCAL + 3] = points.local[i]
            row[_NORMAL:_NORMAL + 3] = points.N[i]
            row[_ORIGIN:_ORIGIN + 3] = points.O[i]
            row[_FRAME:_FRAME + 9] = points.frame(i, points.N[i]).reshape(9)
            row[_MU] = state.frictions[i]
        self.tau0 = np.zeros(nv) if scene.torque is None else np.array(scene.torque, dtype=float)
        self.damper = np.array(state.damper, dtype=float)
        self.q_ref = np.array(scene.q0 if scene.pd is None else scene.pd.q_ref, dtype=float)
        self.mask = np.array(state.mask, dtype=float)
        self.par = np.zeros(19)
        self.par[_STEP], self.par[_DURATION] = scene.contact_step, scene.duration
        self.par[_BAND], self.par[_TOL] = state.band, scene.tolerance
        self.par[_FF] = float(state.free_flyer)
        if scene.pd is not None:
            self.par[_KP], self.par[_KD], self.par[_HAS_PD] = scene.pd.kp, scene.pd.kd, 1.0
        self.par[_DAMPING], self.par[_HAS_DAMPER] = scene.damping, float(state.damper.any())
        self.par[_MAX_STEPS] = MAX_STEPS
        # a problem PGS does not settle in PGS_SWEEPS sweeps goes to the Python route's ADMM
        self.par[_PGS_TOL], self.par[_PGS_ITERATIONS] = state.cones.tolerance, PGS_SWEEPS
        # a sample per row: t, q, v, the contact forces (c, 3), gaps (c,) and rates (c,)
        self.rows = np.empty((2 * MAX_STEPS + 8, 1 + nq + nv + 5 * nc))
        self.gaps, self.rates = np.zeros(nc), np.zeros(nc)
        self.lam = np.zeros(3 * nc)
        self.forces = np.zeros(3 * nc)
        # the work of one step, as the Python step counts it
        self.per_step = {"contact_steps": 1, "compiled_contact_steps": 1, "dynamics": 1}
        if scene.gravity:
            self.per_step["gravity"] = 1
        if scene.pd is not None:
            self.per_step["pd"] = 1
        if scene.damping:
            self.per_step["damping"] = 1

    def take(self, t: float, q: NDArray[np.float64], v: NDArray[np.float64], gaps: NDArray[np.float64]) -> Taken:
        """Steps from (t, q, v) (``gaps`` at q), their output samples emitted; the state it reached."""
        state = self.state
        active = [i for i in range(state.nc) if state.active[i]]
        mus = tuple(state.frictions[i] for i in active)
        for i in range(state.nc):
            self.contacts[i, _ACTIVE] = state.active[i]
            self.contacts[i, _ARMED] = state.armed[i]
            self.contacts[i, _PUSHING] = state.pushing[i]
        warm = state.cones.warm_start(mus)
        self.lam[:] = 0.0
        if warm is not None and warm.shape == (3 * len(active),):
            self.lam[:3 * len(active)] = warm
        self.forces[:] = state.forces.reshape(-1)
        self.par[_T], self.par[_NEXT] = t, state.next_sample
        q, v = np.array(q, dtype=float), np.array(v, dtype=float)
        self.gaps[:] = gaps
        code = self.native.contact_steps(self.bound, q, v, self.par, self.contacts, self.tau0,  # type: ignore[attr-defined]
                                         self.damper, self.q_ref, self.mask, self.gaps, self.rates, self.lam,
                                         self.forces, state.grid, self.rows)
        steps = int(self.par[_STEPS])
        nq, nv, nc = state.nq, state.nv, state.nc
        if steps:  # counted first: the output's checks (a passive run's energy) read them
            for key, n in self.per_step.items():
                state.work[key] += n * steps
            if any(mus):
                state.work["friction_cone"] += steps
            if self.par[_PROJECTIONS]:
                state.work["projection"] += int(self.par[_PROJECTIONS])
        f0 = 1 + nq + nv
        for row in self.rows[:int(self.par[_ROWS])]:
            state.forces = row[f0:f0 + 3 * nc].reshape(nc, 3).copy()
            state.emit(float(row[0]), row[1:1 + nq].copy(), row[1 + nq:f0].copy(),
                       (row[f0 + 3 * nc:f0 + 4 * nc].copy(), row[f0 + 4 * nc:].copy()))
        if steps:
            for i in active:
                state.pushing[i] = bool(self.contacts[i, _PUSHING])
            state.forces = self.forces.reshape(nc, 3).copy()
            state.cones.remember(mus, self.lam[:3 * len(active)])
        for i in range(nc):
            state.armed[i] = bool(self.contacts[i, _ARMED])
        state.next_sample = max(state.next_sample, int(self.par[_NEXT]))
        return Taken(float(self.par[_T]), q, v, self.gaps.copy(), self.rates.copy(), steps, REASONS[code])

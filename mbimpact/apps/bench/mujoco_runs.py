"""MuJoCo runs of the compared scenes (:mod:`~mbimpact.apps.bench.mujoco`): timed bare runs, and the
measured first impact at a given contact-onset phase.

A measured run starts with one step of φ·dt (φ ∈ (0, 1]) and goes on at dt: the step grid is shifted
by φ·dt against the motion, so the contact begins at that phase within a step, as from a drop
height that differs by less than one step of fall. It is stepped in one call up to a few
milliseconds before mbimpact's first impact (free flight, the same in both), then step by step from
Python while it is measured.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .mujoco_models import Init

__all__ = ["Contact", "timed_run", "through_contact", "first_impact", "base_velocity", "unstable"]

#: Free flight measured step by step before the first impact [s] (at least three steps).
_LEAD = 2e-3


def unstable(mujoco: Any, d: Any) -> bool:
    """Whether MuJoCo met a non-finite acceleration (it then resets the state and warns)."""
    return int(d.warning[int(mujoco.mjtWarning.mjWARN_BADQACC)].number) > 0 or not bool(np.all(np.isfinite(d.qpos)))


def timed_run(mujoco: Any, m: Any, init: Init, duration: float) -> tuple[float, Any]:
    """Wall time of one bare ``mj_step(m, d, nstep)`` over ``duration`` from the initial state, and the final data."""
    steps = int(round(duration / m.opt.timestep))
    d = mujoco.MjData(m)
    init(m, d)
    start = time.perf_counter()
    mujoco.mj_step(m, d, nstep=steps)
    return time.perf_counter() - start, d


def _start(mujoco: Any, m: Any, init: Init, phase: float, t_until: float) -> Any:
    """MjData after one step of ``phase``·dt and the whole steps that stay before ``t_until``."""
    dt = float(m.opt.timestep)
    d = mujoco.MjData(m)
    init(m, d)
    m.opt.timestep = phase * dt
    try:
        mujoco.mj_step(m, d)
    finally:
        m.opt.timestep = dt
    steps = int(math.floor((t_until - float(d.time)) / dt))
    if steps > 0:
        mujoco.mj_step(m, d, nstep=steps)
    return d


@dataclass(frozen=True)
class Contact:
    """A body's first contact, stepped through: its state before the step that made it and after the
    last step in which it touched, and the deepest penetration in between [m]."""

    qvel_before: NDArray[np.float64]
    qpos_after: NDArray[np.float64]
    qvel_after: NDArray[np.float64]
    penetration: float


def through_contact(mujoco: Any, m: Any, init: Init, t_touch: float, phase: float, t_max: float) -> Contact | None:
    """The first contact of a single free body (the ball, the sphere); None if it never ended or blew up."""
    d = _start(mujoco, m, init, phase, t_touch - max(_LEAD, 3 * m.opt.timestep))
    before = d.qvel.copy()
    touched, penetration = False, 0.0
    while d.time < t_max:
        previous = d.qvel.copy()
        mujoco.mj_step(m, d)
        if d.ncon:
            if not touched:
                before, touched = previous, True
            penetration = max(penetration, -float(np.min(d.contact.dist[:d.ncon])))
        elif touched:
            return None if unstable(mujoco, d) else Contact(before, d.qpos.copy(), d.qvel.copy(), penetration)
    return None


def _normal_velocity(mujoco: Any, m: Any, scratch: Any, qpos: NDArray[np.float64], qvel: NDArray[np.float64],
                     body: int, local: NDArray[np.float64], normal: NDArray[np.float64]) -> float:
    """Velocity along ``normal`` of a point fixed in ``body`` (body coordinates ``local``) at (qpos, qvel)."""
    scratch.qpos[:] = qpos
    mujoco.mj_kinematics(m, scratch)
    mujoco.mj_comPos(m, scratch)
    point = scratch.xpos[body] + scratch.xmat[body].reshape(3, 3) @ local
    jacp = np.zeros((3, m.nv))
    mujoco.mj_jac(m, scratch, jacp, None, point, body)
    return float(normal @ (jacp @ qvel))


def first_impact(mujoco: Any, m: Any, init: Init, t_touch: float, phase: float, t_end: float
                 ) -> tuple[tuple[float, ...], float]:
    """Restitution κ = −u_n⁺/u_n⁻ of each robot geom in the first impact, and the deepest penetration [m].

    κ is measured at the deepest point of the geom's first contact (fixed in its body): u_n⁻ before the
    step that made that contact, u_n⁺ after the last step in which the geom still touched (at ``t_end``
    if it never left). Every geom touching before the first one leaves counts as striking with it.
    """
    d = _start(mujoco, m, init, phase, t_touch - max(_LEAD, 3 * m.opt.timestep))
    scratch = mujoco.MjData(m)
    obstacle = {g for g in range(m.ngeom) if int(m.geom_bodyid[g]) == 0}  # the world's geoms
    penetration = 0.0
    struck: dict[int, tuple[int, NDArray[np.float64], NDArray[np.float64], float]] = {}
    leaving: dict[int, float] = {}
    kappa: dict[int, float] = {}
    qpos, qvel = d.qpos.copy(), d.qvel.copy()
    while d.time < t_end and (not struck or len(kappa) < len(struck)):
        qpos[:], qvel[:] = d.qpos, d.qvel
        mujoco.mj_step(m, d)
        touching: dict[int, tuple[float, NDArray[np.float64], NDArray[np.float64]]] = {}
        con = d.contact
        for c in range(d.ncon):
            penetration = max(penetration, -float(con.dist[c]))
            g1, g2 = int(con.geom1[c]), int(con.geom2[c])
            robot, sign = (g2, 1.0) if g1 in obstacle else (g1, -1.0)  # normal: obstacle → robot
            if robot not in touching or con.dist[c] < touching[robot][0]:
                touching[robot] = (float(con.dist[c]), con.pos[c].copy(), sign * con.frame[c, :3])
        for g, (_, point, normal) in touching.items():
            if g not in struck and not kappa:  # the point that struck, fixed in its body; its velocity before
                b = int(m.geom_bodyid[g])
                local = d.xmat[b].reshape(3, 3).T @ (point - d.xpos[b])
                struck[g] = (b, local, normal, _normal_velocity(mujoco, m, scratch, qpos, qvel, b, local, normal))
        for g, (b, local, normal, u_minus) in struck.items():
            if g in kappa:
                continue
            if g in touching:  # its velocity after each step it touched; the last one is how it left
                leaving[g] = _normal_velocity(mujoco, m, scratch, d.qpos, d.qvel, b, local, normal)
            else:
                kappa[g] = -leaving[g] / u_minus
    if unstable(mujoco, d):
        return (), math.nan
    for g, (_, _, _, u_minus) in struck.items():  # never left its contact within the run
        kappa.setdefault(g, -leaving[g] / u_minus)
    return tuple(kappa.values()), penetration


def base_velocity(mujoco: Any, m: Any, init: Init, t_touch: float, phase: float, t_end: float
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Times, the free base's vertical velocity (world frame) at each step from just before ``t_touch`` to
    ``t_end``, and the deepest penetration [m]; empty arrays if MuJoCo blew up."""
    d = _start(mujoco, m, init, phase, t_touch - max(_LEAD, 3 * m.opt.timestep))
    t, vz = [float(d.time)], [float(d.qvel[2])]
    penetration = 0.0
    while d.time < t_end:
        mujoco.mj_step(m, d)
        t.append(float(d.time))
        vz.append(float(d.qvel[2]))
        if d.ncon:
            penetration = max(penetration, -float(np.min(d.contact.dist[:d.ncon])))
    if unstable(mujoco, d):
        return np.empty(0), np.empty(0), math.nan
    return np.array(t), np.array(vz), penetration

"""Frame contacts seen from a configuration: points fixed to frames against declared surfaces.

The gaps, normals, Jacobians and relative velocities of every :class:`~mbimpact.SceneContact`,
vectorised over contacts: one placement, velocity and Jacobian per joint, whatever the number
of points on it. No collision geometry is involved (the effects-declared principle).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..common.geometry import offset_point_jacobian
from ..common.basis import local_basis
from .scene_contacts import SceneContact
from .state import ContactState

__all__ = ["PointKinematics"]

_X = np.array([1.0, 0.0, 0.0])


class PointKinematics:
    """Pinocchio kinematics of frame contacts on a shared workspace.

    Parameters
    ----------
    contacts : list of SceneContact
    slots : list of int
        Each contact's index in the scene.
    mech : Mechanism
    model, data : pinocchio Model and Data
        The simulation's model and its workspace.
    """

    def __init__(self, contacts: list[SceneContact], slots: list[int], mech: Any, model: Any, data: Any) -> None:
        self.model, self.data = model, data
        self.contacts, self.slots = contacts, slots
        self.fids = [mech.frame_id(c.frame) for c in contacts]
        self.nv = mech.nv
        # every contact point is fixed to a joint: its position in the joint's frame, grouped by joint
        local = []
        for c, fid in zip(contacts, self.fids):
            frame = model.frames[fid]
            local.append(frame.placement.translation + frame.placement.rotation @ c.point)
        self.local = np.array(local).reshape(len(contacts), 3)
        joints = [int(model.frames[fid].parentJoint) for fid in self.fids]
        self.joints = joints
        self.groups = [(j, np.array([k for k, jj in enumerate(joints) if jj == j])) for j in sorted(set(joints))]
        surfaces = [c.surface for c in contacts]
        # the surfaces as arrays (c, ·): planes have 1/ρ = 0, fixed surfaces amplitude 0
        self.N = np.array([s.normal for s in surfaces]).reshape(len(contacts), 3)
        self.O = np.array([s.origin for s in surfaces]).reshape(len(contacts), 3)
        self.inv_rho = np.array([0.0 if not s.curved else 1.0 / s.rho for s in surfaces])
        self.amp = np.array([s.amplitude if s.moving else 0.0 for s in surfaces])
        self.omega = np.array([2.0 * np.pi * s.frequency for s in surfaces])
        self.phase = np.array([s.phase for s in surfaces])
        self.moving = bool(np.any(self.amp != 0.0))
        self.curved = bool(np.any(self.inv_rho != 0.0))
        self._frames: dict[int, NDArray[np.float64]] = {}
        self.surface_evaluations = 0  # evaluations of moving surfaces (a declared effect's work)

    def __len__(self) -> int:
        return len(self.contacts)

    def offset(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """a(t) and ȧ(t) of every surface, shape (c,) each."""
        if not self.moving:
            zero = np.zeros(len(self.contacts))
            return zero, zero
        self.surface_evaluations += 1
        arg = self.omega * t + self.phase
        return self.amp * np.sin(arg), self.amp * self.omega * np.cos(arg)

    def _points(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World positions (c, 3) of the contact points and their offsets from their joints' origins
        in world axes (joint placements current)."""
        P = np.empty((len(self.fids), 3))
        R = np.empty((len(self.fids), 3))
        for j, idx in self.groups:
            M = self.data.oMi[j]
            R[idx] = self.local[idx] @ M.rotation.T
            P[idx] = M.translation + R[idx]
        return P, R

    def _surface(self, P: NDArray[np.float64], t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Gaps (c,) and unit normals (c, 3) of the surfaces at the points P (c, 3)."""
        d = P - self.O
        h = np.einsum("cd,cd->c", self.N, d)
        a, _ = self.offset(t)
        if not self.curved:
            return h - a, self.N
        lateral = d - h[:, None] * self.N
        gaps = h - 0.5 * self.inv_rho * np.einsum("cd,cd->c", lateral, lateral) - a
        grad = self.N - lateral * self.inv_rho[:, None]
        return gaps, grad / np.linalg.norm(grad, axis=1)[:, None]

    def gaps(self, t: float) -> NDArray[np.float64]:
        """f of every contact, shape (c,) (forward kinematics done on the workspace)."""
        return self._surface(self._points()[0], t)[0]

    def rates(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Gaps and relative normal velocities, shapes (c,), (c,) (kinematics with v done)."""
        P, R = self._points()
        gaps, normals = self._surface(P, t)
        U = np.empty_like(P)
        for j, idx in self.groups:
            rot = self.data.oMi[j].rotation
            vel = self.data.v[j]  # in the joint's frame
            w, L = vel.angular, self.local[idx]
            wxL = np.column_stack([w[1] * L[:, 2] - w[2] * L[:, 1], w[2] * L[:, 0] - w[0] * L[:, 2],
                                   w[0] * L[:, 1] - w[1] * L[:, 0]])
            U[idx] = (vel.linear + wxL) @ rot.T
        _, adot = self.offset(t)
        # the surface moves along its axis n⁰: the relative normal velocity is n·(u − ȧ n⁰)
        rates = np.einsum("cd,cd->c", normals, U) - adot * np.einsum("cd,cd->c", normals, self.N)
        return gaps, rates

    def states(self, v: NDArray[np.float64], t: float, which: list[int]) -> list[ContactState]:
        """Full states of the contacts ``which`` (local indices; joint Jacobians computed)."""
        P, R = self._points()
        gaps, normals = self._surface(P, t)
        _, adot = self.offset(t)
        out = []
        joint_J: dict[int, NDArray[np.float64]] = {}
        for i in which:
            j = self.joints[i]
            if j not in joint_J:
                joint_J[j] = np.asarray(pin.getJointJacobian(self.model, self.data, j, pin.LOCAL_WORLD_ALIGNED)
                                        ).reshape(6, self.nv)
            J = offset_point_jacobian(joint_J[j], R[i])
            svel = adot[i] * self.N[i]
            out.append(ContactState(self.slots[i], float(gaps[i]), normals[i], self.frame(i, normals[i]), J,
                                    J @ v - svel, svel, P[i].copy(), (self.slots[i], 0)))
        return out

    def material_gap(self, i: int, t: float) -> Any:
        """Gap of contact i as a function of q (forward kinematics done inside)."""
        def gap(q: NDArray[np.float64]) -> float:
            pin.forwardKinematics(self.model, self.data, q)
            return float(self.gaps(t)[i])
        return gap

    def frame(self, i: int, n: NDArray[np.float64]) -> NDArray[np.float64]:
        """Local frame (t₁, t₂, n) at contact i: t₁ along its declared tangent (or world x), projected."""
        if self.inv_rho[i] == 0.0:  # a plane: one frame for good
            cached = self._frames.get(i)
            if cached is None:
                cached = self._frames[i] = self._frame(i, n)
            return cached
        return self._frame(i, n)

    def _frame(self, i: int, n: NDArray[np.float64]) -> NDArray[np.float64]:
        t = self.contacts[i].tangent
        t = _X if t is None else t
        t1 = t - float(t @ n) * n
        norm = float(np.linalg.norm(t1))
        if norm < 1e-6:
            return local_basis(n, 3)
        t1 = t1 / norm
        return np.column_stack([t1, np.cross(n, t1), n])

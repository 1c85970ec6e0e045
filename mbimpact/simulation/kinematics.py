"""The contacts of a scene seen from a configuration: gaps, normals, Jacobians, relative velocities."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..common.geometry import offset_point_jacobian
from ..metric.basis import local_basis
from .scene import Scene

__all__ = ["ContactState", "ContactKinematics"]


@dataclass(frozen=True, eq=False)
class ContactState:
    """One contact at one state.

    Attributes
    ----------
    index : int
        The contact's index in the scene.
    gap : float
        f(p, t) [m].
    normal : ndarray, shape (3,)
        Unit normal of the surface at the contact point.
    frame : ndarray, shape (3, 3)
        Local frame: columns t₁, t₂, n (t₁ along the contact's declared tangent, projected).
    J : ndarray, shape (3, nv)
        World-aligned translational Jacobian of the contact point.
    u : ndarray, shape (3,)
        Velocity of the contact point relative to the surface, J v − ȧ n⁰.
    surface_velocity : ndarray, shape (3,)
        Velocity of the surface, ȧ n⁰.
    """

    index: int
    gap: float
    normal: NDArray[np.float64]
    frame: NDArray[np.float64]
    J: NDArray[np.float64]
    u: NDArray[np.float64]
    surface_velocity: NDArray[np.float64]

    @property
    def un(self) -> float:
        """Relative normal velocity (< 0: approaching)."""
        return float(self.normal @ self.u)

    @property
    def ut(self) -> float:
        """Relative tangential speed."""
        return float(np.linalg.norm(self.u - self.un * self.normal))


class ContactKinematics:
    """Pinocchio kinematics of a scene's contact points on a private workspace, vectorised over contacts.

    Parameters
    ----------
    scene : Scene
    model, data : pinocchio Model and Data
        The simulation's model (gravity as declared) and its workspace.
    """

    def __init__(self, scene: Scene, model: Any, data: Any) -> None:
        self.scene, self.model, self.data = scene, model, data
        mech = scene.mechanism
        self.contacts = scene.contacts
        self.fids = [mech.frame_id(c.frame) for c in scene.contacts]
        self.nv = mech.nv
        # every contact point is fixed to a joint: its position in the joint's frame, grouped by joint
        # (one placement, velocity and Jacobian per joint, whatever the number of points on it)
        local = []
        for c, fid in zip(scene.contacts, self.fids):
            frame = model.frames[fid]
            local.append(frame.placement.translation + frame.placement.rotation @ c.point)
        self.local = np.array(local)
        joints = [int(model.frames[fid].parentJoint) for fid in self.fids]
        self.groups = [(j, np.array([k for k, jj in enumerate(joints) if jj == j])) for j in sorted(set(joints))]
        surfaces = [c.surface for c in scene.contacts]
        # the surfaces as arrays (c, ·): planes have 1/ρ = 0, fixed surfaces amplitude 0
        self.N = np.array([s.normal for s in surfaces])
        self.O = np.array([s.origin for s in surfaces])
        self.inv_rho = np.array([0.0 if not s.curved else 1.0 / s.rho for s in surfaces])
        self.amp = np.array([s.amplitude if s.moving else 0.0 for s in surfaces])
        self.omega = np.array([2.0 * np.pi * s.frequency for s in surfaces])
        self.phase = np.array([s.phase for s in surfaces])
        self.moving = bool(np.any(self.amp != 0.0))
        self.curved = bool(np.any(self.inv_rho != 0.0))
        self._frames: dict[int, NDArray[np.float64]] = {}
        self.surface_evaluations = 0  # evaluations of moving surfaces (a declared effect's work)

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

    def gaps(self, q: NDArray[np.float64], t: float) -> NDArray[np.float64]:
        """f of every contact at (q, t), shape (c,)."""
        pin.forwardKinematics(self.model, self.data, q)
        return self._surface(self._points()[0], t)[0]

    def rates(self, q: NDArray[np.float64], v: NDArray[np.float64], t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Gaps and relative normal velocities of every contact, shapes (c,), (c,)."""
        pin.forwardKinematics(self.model, self.data, q, v)
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
        # the surface moves along its axis n⁰, and n·n⁰ = 1/|∇f| ... written as n·(u − ȧ n⁰)
        rates = np.einsum("cd,cd->c", normals, U) - adot * np.einsum("cd,cd->c", normals, self.N)
        return gaps, rates

    def states(self, q: NDArray[np.float64], v: NDArray[np.float64], t: float, which: list[int] | None = None
               ) -> list[ContactState]:
        """Full contact states (Jacobians included) of the contacts ``which`` (default all)."""
        which = list(range(len(self.contacts))) if which is None else which
        if not which:
            return []
        pin.computeJointJacobians(self.model, self.data, q)
        P, R = self._points()
        gaps, normals = self._surface(P, t)
        _, adot = self.offset(t)
        out = []
        joint_J: dict[int, NDArray[np.float64]] = {}
        joint_of = {int(k): j for j, idx in self.groups for k in idx}
        for i in which:
            j = joint_of[i]
            if j not in joint_J:
                joint_J[j] = np.asarray(pin.getJointJacobian(self.model, self.data, j, pin.LOCAL_WORLD_ALIGNED)
                                        ).reshape(6, self.nv)
            J = offset_point_jacobian(joint_J[j], R[i])
            svel = adot[i] * self.N[i]
            out.append(ContactState(i, float(gaps[i]), normals[i], self.frame(i, normals[i]), J, J @ v - svel, svel))
        return out

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


_X = np.array([1.0, 0.0, 0.0])

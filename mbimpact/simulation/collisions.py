"""Collision contacts seen from a configuration: coal's gaps, witness points and contact patches.

Every :class:`~mbimpact.SceneCollision` pair is a contact whose gap is the signed distance of
the pair. The pairs are grouped into one :class:`~mbimpact.GapModel` per obstacle (and one for
the mechanism's own pairs), so that a configuration costs one kinematics pass per group and
one narrow-phase query per pair. Event detection needs only distances and their rates (no
Jacobians); impacts and persistent contact take the whole contact patch of a pair: every
witness point within the scene's ``patch_tolerance`` of its nearest one, each with its own
Jacobian, so that a face lying flat rests on its corners.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..geometry.gap import Gap, contact_frame
from ..geometry.gap_model import GapModel
from .scene_contacts import SceneCollision
from .state import ContactState

__all__ = ["CollisionKinematics"]


class CollisionKinematics:
    """The collision pairs of a scene.

    Parameters
    ----------
    contacts : list of SceneCollision
        Concrete pairs (one body, one obstacle or other object each).
    slots : list of int
        Each pair's index in the scene.
    mech : Mechanism
    patch_tolerance : float
        Witness points within this distance [m] of a pair's nearest point belong to its patch.
    """

    def __init__(self, contacts: list[SceneCollision], slots: list[int], mech: Any, patch_tolerance: float) -> None:
        self.contacts, self.slots, self.mech = contacts, slots, mech
        self.patch_tolerance = patch_tolerance
        self.nv = mech.nv
        groups: dict[Any, list[int]] = {}
        for k, c in enumerate(contacts):
            groups.setdefault(c.obstacle if c.obstacle is not None else "self", []).append(k)
        # (gap model, local contact indices, their pair indices in the model)
        self.groups: list[tuple[GapModel, list[int], list[int]]] = []
        for key, members in groups.items():
            if key == "self":
                gm = GapModel(mech, self_pairs=[(str(contacts[k].body), str(contacts[k].other)) for k in members])
                pairs = [gm.pair_index(str(contacts[k].body), str(contacts[k].other)) for k in members]
            else:
                gm = GapModel(mech, [key], bodies=[str(contacts[k].body) for k in members])
                pairs = [gm.pair_index(str(contacts[k].body), gm.obstacle_names[0]) for k in members]
            self.groups.append((gm, members, pairs))
        cm = mech.collision_model()
        self.joints = [cm.joint(str(c.body)) for c in contacts]
        self.other_joints = [cm.joint(c.other) if c.other is not None else 0 for c in contacts]
        # a feature of a body (a corner, the neighbourhood of a sphere's contact point) is this close to a
        # struck point in the body's frame: a quarter of the object's bounding radius
        self.feature_size = [0.25 * float(cm.geometry(str(c.body)).aabb_radius) for c in contacts]
        self.data = mech.model.createData()  # for the material points of a witness (secondary strikes)
        self.queries = 0  # narrow-phase evaluations (a declared effect's work)

    def __len__(self) -> int:
        return len(self.contacts)

    def gaps(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """Signed distance of every pair, shape (c,)."""
        out = np.empty(len(self.contacts))
        for gm, members, pairs in self.groups:
            out[members] = gm.distances(q)[pairs]
            self.queries += len(pairs)
        return out

    def rates(self, q: NDArray[np.float64], v: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Distances and their rates (the normal velocity of the nearest witness points), shapes (c,)."""
        f, r = np.empty(len(self.contacts)), np.empty(len(self.contacts))
        for gm, members, pairs in self.groups:
            fg, rg = gm.rates(q, v)
            f[members], r[members] = fg[pairs], rg[pairs]
            self.queries += len(pairs)
        return f, r

    def states(self, q: NDArray[np.float64], v: NDArray[np.float64], which: list[int],
               distances: NDArray[np.float64] | None = None) -> list[ContactState]:
        """Every point of the contact patches of the pairs ``which`` (local indices): the witness
        points within ``patch_tolerance`` of each pair's nearest one; at least the nearest."""
        if not which:
            return []
        d = self.gaps(q) if distances is None else distances
        tol = self.patch_tolerance
        out: list[ContactState] = []
        for gm, members, pairs in self.groups:
            mine = [(k, p) for k, p in zip(members, pairs) if k in which]
            if not mine:
                continue
            margin = max(tol, max(float(d[k]) for k, _ in mine) + tol)
            found: dict[int, list[Gap]] = {}
            for g in gm.contact_points(q, margin=margin, patch_tolerance=tol, pairs=[p for _, p in mine]):
                found.setdefault(g.pair, []).append(g)
            self.queries += len(mine)
            for k, p in mine:
                points = found.get(p) or [gm.gap(q, p)]  # above the margin: the nearest points
                out += [self._state(k, g, v, n) for n, g in enumerate(points)]
        return out

    def _state(self, k: int, g: Gap, v: NDArray[np.float64], n: int) -> ContactState:
        c = self.contacts[k]
        R = contact_frame(g.normal, c.tangent)
        return ContactState(self.slots[k], g.distance, g.normal, R, g.jacobian, g.jacobian @ v, np.zeros(3),
                            g.point, (self.slots[k], n))

    def body_points(self, k: int, q: NDArray[np.float64], points: NDArray[np.float64]) -> NDArray[np.float64]:
        """World points (m, 3) of pair k's body at q, in the body's joint frame (m, 3)."""
        pin.forwardKinematics(self.mech.model, self.data, q)
        M = self.data.oMi[self.joints[k]]
        return (np.asarray(points).reshape(-1, 3) - M.translation) @ M.rotation

    def material_gap(self, k: int, q_ref: NDArray[np.float64]) -> Any:
        """The gap at pair k's nearest witness points at ``q_ref``, followed as material points of
        their bodies: n·(p_B(q) − p_O(q)) with the normal frozen. A function of q; exact for a
        corner of a polytope over a half-space, first order otherwise (it locates the instant a
        further point of a resting pair strikes)."""
        gm, members, pairs = next(grp for grp in self.groups if k in grp[1])
        g = gm.gap(q_ref, pairs[members.index(k)])
        model, data = self.mech.model, self.data
        pin.forwardKinematics(model, data, q_ref)
        jb, jo = self.joints[k], self.other_joints[k]
        local_b = data.oMi[jb].actInv(g.point)
        local_o = data.oMi[jo].actInv(g.other_point)
        n = np.array(g.normal)

        def gap(q: NDArray[np.float64]) -> float:
            pin.forwardKinematics(model, data, q)
            return float(n @ (data.oMi[jb].act(local_b) - data.oMi[jo].act(local_o)))

        return gap

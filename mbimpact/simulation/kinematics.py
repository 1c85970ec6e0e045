"""A scene's contacts seen from a state: gaps, rates, and the points the solvers act on.

Frame contacts (:mod:`~mbimpact.simulation.points`) and collision pairs
(:mod:`~mbimpact.simulation.collisions`) are evaluated by their own means and merged in the
scene's order: a scene with frame contacts only never touches collision geometry.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from .collisions import CollisionKinematics
from .points import PointKinematics
from .scene import Scene
from .scene_contacts import SceneCollision, SceneContact
from .state import ContactState

__all__ = ["ContactKinematics", "ContactState"]


class ContactKinematics:
    """Every contact of a scene.

    Parameters
    ----------
    scene : Scene
    model, data : pinocchio Model and Data
        The simulation's model (gravity as declared) and its workspace.
    """

    def __init__(self, scene: Scene, model: Any, data: Any) -> None:
        self.scene, self.model, self.data = scene, model, data
        self.nc = len(scene.contacts)
        frames = [i for i, c in enumerate(scene.contacts) if isinstance(c, SceneContact)]
        pairs = [i for i, c in enumerate(scene.contacts) if isinstance(c, SceneCollision)]
        self.frame_slots, self.pair_slots = np.array(frames, dtype=int), np.array(pairs, dtype=int)
        self.points = PointKinematics([scene.contacts[i] for i in frames], frames,  # type: ignore[misc]
                                      scene.mechanism, model, data) if frames else None
        self.collisions = CollisionKinematics([scene.contacts[i] for i in pairs], pairs,  # type: ignore[misc]
                                              scene.mechanism, scene.patch_tolerance) if pairs else None
        self._local = {int(s): k for k, s in enumerate(frames)} | {int(s): k for k, s in enumerate(pairs)}

    @property
    def surface_evaluations(self) -> int:
        """Evaluations of moving surfaces so far."""
        return self.points.surface_evaluations if self.points is not None else 0

    @property
    def collision_queries(self) -> int:
        """Narrow-phase pair evaluations so far."""
        return self.collisions.queries if self.collisions is not None else 0

    def is_pair(self, i: int) -> bool:
        """Contact i is a collision pair (several witness points possible)."""
        return isinstance(self.scene.contacts[i], SceneCollision)

    def gaps(self, q: NDArray[np.float64], t: float) -> NDArray[np.float64]:
        """f of every contact at (q, t), shape (c,)."""
        out = np.empty(self.nc)
        if self.points is not None:
            pin.forwardKinematics(self.model, self.data, q)
            out[self.frame_slots] = self.points.gaps(t)
        if self.collisions is not None:
            out[self.pair_slots] = self.collisions.gaps(q)
        return out

    def rates(self, q: NDArray[np.float64], v: NDArray[np.float64], t: float
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Gaps and relative normal velocities of every contact, shapes (c,), (c,)."""
        gaps, rates = np.empty(self.nc), np.empty(self.nc)
        if self.points is not None:
            pin.forwardKinematics(self.model, self.data, q, v)
            gaps[self.frame_slots], rates[self.frame_slots] = self.points.rates(t)
        if self.collisions is not None:
            gaps[self.pair_slots], rates[self.pair_slots] = self.collisions.rates(q, v)
        return gaps, rates

    def states(self, q: NDArray[np.float64], v: NDArray[np.float64], t: float, which: list[int] | None = None
               ) -> list[ContactState]:
        """The points of the contacts ``which`` (default all), Jacobians included: one per frame
        contact, a whole contact patch per collision pair."""
        which = list(range(self.nc)) if which is None else which
        if not which:
            return []
        out: list[ContactState] = []
        frames = [self._local[i] for i in which if not self.is_pair(i)]
        if frames and self.points is not None:
            pin.computeJointJacobians(self.model, self.data, q)
            out += self.points.states(v, t, frames)
        pairs = [self._local[i] for i in which if self.is_pair(i)]
        if pairs and self.collisions is not None:
            out += self.collisions.states(q, v, pairs)
        return out

    def state_map(self, q: NDArray[np.float64], v: NDArray[np.float64], t: float, which: list[int] | None = None
                  ) -> dict[int, list[ContactState]]:
        """:meth:`states` grouped by contact."""
        out: dict[int, list[ContactState]] = {}
        for s in self.states(q, v, t, which):
            out.setdefault(s.index, []).append(s)
        return out

    def same_feature(self, i: int, q: NDArray[np.float64], points: NDArray[np.float64],
                     before: NDArray[np.float64] | None) -> tuple[bool, NDArray[np.float64] | None]:
        """Whether the world ``points`` (m, 3) of contact i at q are where it struck ``before`` (its
        struck points in body coordinates), and the points in body coordinates. A frame contact is
        one point: always the same feature."""
        if not self.is_pair(i):
            return True, None
        assert self.collisions is not None
        k = self._local[i]
        local = self.collisions.body_points(k, q, points)
        if before is None or not len(local):
            return before is None, local
        d = np.linalg.norm(local[:, None, :] - before[None, :, :], axis=2).min()
        return bool(d < self.collisions.feature_size[k]), local

    def material_gap(self, i: int, q: NDArray[np.float64], t: float) -> Any:
        """Contact i's gap as a function of q, following the material point(s) that are nearest at q."""
        k = self._local[i]
        if self.is_pair(i):
            assert self.collisions is not None
            return self.collisions.material_gap(k, q)
        assert self.points is not None
        return self.points.material_gap(k, t)

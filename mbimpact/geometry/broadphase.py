"""The broad phase: conservative lower bounds of every pair's distance from bounding spheres.

Each bounded collision object is enclosed in a sphere centred on its geometry frame's origin c,
of radius r = |a| + ρ where (a, ρ) is the sphere of its local AABB as coal computes it. For a pair
of bounded objects ``|c₁ − c₂| − r₁ − r₂`` is a lower bound of their distance; for a bounded
object and a half-space ``{x : n·x ≤ d}`` it is ``n·c − d − r``.
Pairs with an unbounded object of another kind get −∞ (always sent to the narrow phase). A pair
whose lower bound exceeds a cutoff (a margin, an event-detection band) cannot be closer than the
cutoff and is skipped: the result is exact, not approximate.

Pinocchio's own ``BroadPhaseManager`` is not used: it answers collision queries only (no lower
bounds for a distance cutoff), and in our trials an unbounded plane in its AABB tree made it miss
collisions, while half-spaces are the usual obstacles here.

Cost (``mbimpact bench --part geometry`` measures it; CPU time): the bounds take ~35–45 µs for solo12's 17
moving objects (one placement read per moving object, a dozen numpy operations), while a narrow-phase
distance costs ~0.7 µs per pair for primitives and hulls against a half-space, ~2 µs between hulls.
For solo12 at a 1 cm cutoff: 4 feet × ground 10 µs without, 48 µs with; 17 links × ground 23 vs
69 µs; 51 pairs among 20 objects 67 vs 70 µs; every self-collision pair plus the ground (133 pairs)
273 vs 164 µs. So the broad phase is used only when a model has at least
:data:`BROAD_PHASE_MIN_PAIRS` (32) pairs and at least twice as many pairs as objects in them, and
only for queries with a cutoff or a margin (a plain distance query needs every pair anyway).
"""

from __future__ import annotations

from typing import Any

import coal
import numpy as np
from numpy.typing import NDArray

__all__ = ["BROAD_PHASE_MIN_PAIRS", "BoundingSpheres", "use_broad_phase"]

#: Fewest pairs for which a gap model filters pairs by bounding spheres before the narrow phase
#: (measured: below it, reading the placements costs more
#: than the queries it saves).
BROAD_PHASE_MIN_PAIRS = 32


def use_broad_phase(n_pairs: int, n_objects: int) -> bool:
    """Whether the broad phase pays for ``n_pairs`` pairs among ``n_objects`` objects."""
    return n_pairs >= BROAD_PHASE_MIN_PAIRS and n_pairs >= 2 * n_objects


class BoundingSpheres:
    """Lower bounds of the distances of a fixed list of pairs of a ``pinocchio.GeometryModel``.

    Each bounded object gets the sphere centred on its geometry frame's origin that contains its
    local AABB sphere (radius ``|c| + r``): looser than the AABB sphere when the geometry is off its
    origin, but one placement read per moving object and no rotation. Objects on the universe joint
    (obstacles) are placed once, at construction; a half-space fixed to a moving joint counts as
    unbounded.

    Parameters
    ----------
    geometry_model : pinocchio.GeometryModel
        The objects (their local AABBs must have been computed).
    pairs : sequence of (int, int)
        Object indices of each pair.
    """

    def __init__(self, geometry_model: Any, pairs: list[tuple[int, int]]) -> None:
        objs = sorted({i for p in pairs for i in p})
        self.objects = np.array(objs, dtype=int)
        slot = {o: k for k, o in enumerate(objs)}
        n = len(objs)
        self.center = np.zeros((n, 3))  # world centres of the fixed objects (joint 0)
        self.radius = np.zeros(n)
        halfspace = np.zeros(n, dtype=bool)
        unbounded = np.zeros(n, dtype=bool)
        hs_normal = np.zeros((n, 3))
        hs_offset = np.zeros(n)
        self.moving: list[tuple[int, int]] = []  # (slot, object index) of the objects that move
        for k, o in enumerate(objs):
            go = geometry_model.geometryObjects[o]
            g = go.geometry
            fixed = int(go.parentJoint) == 0
            M = go.placement  # on joint 0 the placement is the world pose
            if isinstance(g, coal.Halfspace) and fixed:
                halfspace[k] = True
                hs_normal[k] = M.rotation @ g.n
                hs_offset[k] = g.d + hs_normal[k] @ M.translation
            elif isinstance(g, (coal.Halfspace, coal.Plane)) or not np.isfinite(g.aabb_radius) or g.aabb_radius < 0.0:
                unbounded[k] = True
            else:
                self.radius[k] = float(np.linalg.norm(g.aabb_center)) + g.aabb_radius
                if fixed:
                    self.center[k] = M.translation
                else:
                    self.moving.append((k, o))
        i = np.array([slot[a] for a, _ in pairs], dtype=int)
        j = np.array([slot[b] for _, b in pairs], dtype=int)
        never = unbounded[i] | unbounded[j] | (halfspace[i] & halfspace[j])
        both = ~never & ~halfspace[i] & ~halfspace[j]
        self._never = np.flatnonzero(never)
        self._both = np.flatnonzero(both)
        self._bi, self._bj = i[both], j[both]
        self._brad = self.radius[i[both]] + self.radius[j[both]]
        hs = ~never & ~both  # exactly one of the two is a half-space
        self._hs = np.flatnonzero(hs)
        body = np.where(halfspace[i], j, i)[hs]
        plane = np.where(halfspace[i], i, j)[hs]
        self._hbody = body
        self._hnormal = hs_normal[plane]
        self._hoffset = hs_offset[plane] + self.radius[body]
        self.n_pairs = len(pairs)

    def lower_bounds(self, geometry_data: Any) -> NDArray[np.float64]:
        """Lower bound (P,) of each pair's signed distance, from the placements in ``geometry_data.oMg``
        (call ``pin.updateGeometryPlacements`` first)."""
        c = self.center.copy()
        oMg = geometry_data.oMg
        for k, o in self.moving:
            c[k] = oMg[o].translation
        lb = np.empty(self.n_pairs)
        d = c[self._bi] - c[self._bj]
        lb[self._both] = np.sqrt(np.einsum("pk,pk->p", d, d)) - self._brad
        lb[self._hs] = np.einsum("pk,pk->p", self._hnormal, c[self._hbody]) - self._hoffset
        lb[self._never] = -np.inf
        return lb

"""Every gap of a mechanism at once: the per-pair evaluation a simulator calls on every step.

A :class:`GapModel` is built once for a mechanism, a list of obstacles and a list of pairs; it
holds one ``pinocchio.GeometryModel`` (the mechanism's collision objects, then the obstacles on the
universe joint) and, per thread, its ``pinocchio.Data`` and ``GeometryData``. The queries:

=============================== ===============================================
query                           returns
=============================== ===============================================
:meth:`GapModel.distances`      signed distances (P,), no Jacobian
:meth:`GapModel.rates`          distances and their rates ḟ (P,), no Jacobian
:meth:`GapModel.gaps`           a :class:`Gap` per pair, with J and ∇f
:meth:`GapModel.evaluate`       the same as stacked arrays (:class:`GapArrays`)
:meth:`GapModel.contact_points` every witness point within a margin (contact
                                patches), each a :class:`Gap`
=============================== ===============================================

The shape of the objects hardly matters to the cost of a query (``mbimpact bench --part geometry``
measures them); a triangle-soup mesh (``Mesh(convex=False)``) costs hundreds of times a convex hull.
With a ``cutoff`` (distances, gaps, evaluate) or a ``margin`` (contact points) and many pairs, the
bounding-sphere broad phase of :mod:`mbimpact.geometry.broadphase` skips the pairs that cannot be that
close.

The kinematics are computed once per query: ``pin.forwardKinematics`` (distances) or
``pin.computeJointJacobians`` (gaps, contact points), then ``pin.updateGeometryPlacements``; the
Jacobian of a witness point is its joint's world-aligned Jacobian shifted to the point
(``[I | −[r]ₓ] J₆``, one 3×6 product).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_scalar
from ..errors import CollisionNotFoundError, GeometryError, ParameterError
from .broadphase import BoundingSpheres, use_broad_phase
from .collision_model import CollisionModel
from .gap import Gap, GapArrays
from .pairs import Pair, object_names, self_pair_indices, unique_label
from .patches import PatchPoint, read_contact, read_patch
from .shapes import Shape

if TYPE_CHECKING:
    from ..mechanism.mechanism import Mechanism

__all__ = ["GapModel", "Pair"]

#: Tolerance of coal's GJK and EPA in every query: 1e-6 (coal's default) leaves an error of that
#: order in distances of polytope pairs; 1e-9 costs nothing measurable for primitives and hulls.
GJK_TOLERANCE = 1e-9


class GapModel:
    """The gaps of chosen pairs of a mechanism's collision objects and obstacles.

    Parameters
    ----------
    mech : Mechanism
        Its collision model is loaded if it was not yet (:meth:`mbimpact.Mechanism.collision_model`).
    obstacles : Shape or sequence of Shape
        World obstacles (:class:`~mbimpact.geometry.HalfSpace`, ``Box``, ``Sphere``, ``Capsule``,
        ``Cylinder``, ``Mesh``). Their names are their ``name`` (or kind), made unique by a suffix
        ``_1``, ``_2``, ... (``"halfspace"``, ``"halfspace_1"``).
    bodies : sequence of str, optional
        Collision objects paired with every obstacle. Default: every object that moves (whose
        parent joint is not the universe).
    self_pairs : sequence of (str, str), or "all", optional
        Pairs of collision objects of the mechanism, ``(body, other)``: the normal points from
        ``other`` to ``body``. ``"all"``: every pair of objects on different joints that are not
        parent and child in the kinematic tree (adjacent links touch at their joint), at least
        one of them moving, minus those an SRDF disables.
    srdf : str or Path, optional
        SRDF file whose ``<disable_collisions>`` entries are removed from ``self_pairs="all"``.

    Raises
    ------
    CollisionNotFoundError
        An unknown collision object name (close matches listed).
    GeometryError
        No pair at all, or the mechanism has no collision object to pair.
    ParameterError
        An obstacle that is not a shape, a pair of an object with itself.
    """

    def __init__(self, mech: Mechanism, obstacles: Sequence[Shape] | Shape = (), *, bodies: Sequence[str] | None = None,
                 self_pairs: Sequence[Pair] | str | None = None, srdf: str | Path | None = None) -> None:
        from ..mechanism.mechanism import Mechanism

        if not isinstance(mech, Mechanism):
            raise ParameterError(f"mech must be an mbimpact.Mechanism, got {type(mech).__name__}")
        obstacles = [obstacles] if isinstance(obstacles, Shape) else list(obstacles)
        for k, o in enumerate(obstacles):
            if not isinstance(o, Shape):
                raise ParameterError(f"obstacles[{k}] must be a shape (HalfSpace, Box, Sphere, Capsule, Cylinder, "
                                     f"Mesh), got {type(o).__name__}")
        cm: CollisionModel = mech.collision_model()
        self.mech = mech
        self.collision_model = cm
        self.version = cm.version
        self.obstacles = tuple(obstacles)
        model = mech.model
        gm = pin.GeometryModel()
        for go in cm.geometry_model.geometryObjects:
            gm.addGeometryObject(go)
        taken = set(cm.names)
        self.obstacle_names: tuple[str, ...] = ()
        for o in obstacles:
            name = unique_label(o.label, taken)
            taken.add(name)
            gm.addGeometryObject(pin.GeometryObject(name, 0, o.placement(), o.geometry()))
            self.obstacle_names += (name,)
        nb = len(cm)

        # ---------------------------------------------------------------- pairs
        index_pairs: list[tuple[int, int]] = []
        if obstacles:
            body_names = cm.moving if bodies is None else object_names(cm, bodies, "bodies")
            if not body_names:
                raise GeometryError(
                    f"{mech.name} has no moving collision object to pair with the obstacles"
                    + ("" if len(cm) else ": its model file has no <collision> element; attach shapes with "
                       "mech.collision_model().add(name, frame, shape)"))
            index_pairs += [(cm.index(b), nb + k) for b in body_names for k in range(len(obstacles))]
        elif bodies is not None:
            raise ParameterError("bodies are paired with obstacles, and no obstacle was given")
        index_pairs += self_pair_indices(cm, self_pairs, srdf)
        if not index_pairs:
            raise GeometryError("no pair to evaluate: give obstacles, or self_pairs")
        seen: set[tuple[int, int]] = set()
        for i, j in index_pairs:
            if (i, j) in seen or (j, i) in seen:
                raise ParameterError(f"the pair ({gm.geometryObjects[i].name!r}, {gm.geometryObjects[j].name!r}) "
                                     "is given twice")
            seen.add((i, j))
            gm.addCollisionPair(pin.CollisionPair(i, j))
        # pinocchio keeps the order given: o1 = the body, whose normal is coal's negated
        self._flip = [int(cp.first) != i for cp, (i, _) in zip(gm.collisionPairs, index_pairs)]
        self._index_pairs = index_pairs
        self._geometry_model = gm
        self._joints = [int(go.parentJoint) for go in gm.geometryObjects]
        self.pairs: tuple[Pair, ...] = tuple(
            (gm.geometryObjects[i].name, gm.geometryObjects[j].name) for i, j in index_pairs)
        self._pair_index = {p: k for k, p in enumerate(self.pairs)}
        n_objects = len({o for p in index_pairs for o in p})
        self.broad_phase = use_broad_phase(len(index_pairs), n_objects)
        self._spheres = BoundingSpheres(gm, index_pairs)
        self._local = threading.local()
        self._zero_jacobian = np.zeros((3, model.nv))

    # ------------------------------------------------------------ per-thread workspace
    def _workspace(self) -> Any:
        local = self._local
        if getattr(local, "data", None) is None:
            gd = self._geometry_model.createData()
            for k in range(len(self._index_pairs)):
                for req in (gd.distanceRequests[k], gd.collisionRequests[k]):
                    req.gjk_tolerance = GJK_TOLERANCE
                    req.epa_tolerance = GJK_TOLERANCE
                # pinocchio's GeometryData turns contact information off: the patch needs its normal
                # (without it, box against box gives NaN patches)
                gd.collisionRequests[k].enable_contact = True
            local.gdata = gd
            local.margin = 0.0
            local.patch_tolerance = None
            local.data = self.mech.model.createData()
        return local

    def _kinematics(self, q: ArrayLike, jacobians: bool) -> tuple[Any, Any]:
        qv = self.mech.check_configuration(q)
        local = self._workspace()
        model, data, gd = self.mech.model, local.data, local.gdata
        if jacobians:
            pin.computeJointJacobians(model, data, qv)
        else:
            pin.forwardKinematics(model, data, qv)
        pin.updateGeometryPlacements(model, data, self._geometry_model, gd)
        return data, gd

    def _candidates(self, gd: Any, cutoff: float | None) -> tuple[list[int], NDArray[np.float64] | None]:
        """Pairs the narrow phase must evaluate for ``cutoff``, and the broad phase's lower bounds."""
        if cutoff is None or not self.broad_phase:
            return list(range(len(self._index_pairs))), None
        lb = self._spheres.lower_bounds(gd)
        return np.flatnonzero(lb <= cutoff).tolist(), lb

    def _jacobian(self, data: Any, joint: int, p: NDArray[np.float64], cache: dict[int, Any]) -> NDArray[np.float64]:
        """World-aligned translational Jacobian (3, nv) of the point at world position p fixed to ``joint``:
        J_p = J_lin − [r]ₓ J_ang with r = p − (joint origin), in one product [I | −[r]ₓ] J₆."""
        if joint == 0:
            return self._zero_jacobian
        entry = cache.get(joint)
        if entry is None:
            # reshaped: eigenpy returns a (6,) vector for a single-dof model
            J6 = np.asarray(pin.getJointJacobian(self.mech.model, data, joint, pin.LOCAL_WORLD_ALIGNED)
                            ).reshape(6, self._zero_jacobian.shape[1])
            entry = cache[joint] = (J6, data.oMi[joint].translation)
        J6, origin = entry
        x, y, z = (p - origin).tolist()
        return np.array(((1.0, 0.0, 0.0, 0.0, z, -y), (0.0, 1.0, 0.0, -z, 0.0, x), (0.0, 0.0, 1.0, y, -x, 0.0))) @ J6

    def _gap(self, k: int, data: Any, point: PatchPoint, cache: dict[int, Any]) -> Gap:
        pb, po, n, dist = point
        i, j = self._index_pairs[k]
        J = self._jacobian(data, self._joints[i], pb, cache)
        if self._joints[j] != 0:
            J = J - self._jacobian(data, self._joints[j], po, cache)
        elif J is self._zero_jacobian:
            J = J.copy()
        body, other = self.pairs[k]
        return Gap.trusted(body, other, float(dist), n, pb, po, J, n @ J, k)

    def _nearest(self, k: int, gd: Any) -> PatchPoint:
        r = pin.computeDistance(self._geometry_model, gd, k)
        a, b = r.getNearestPoint1(), r.getNearestPoint2()
        d = r.min_distance
        if self._flip[k]:
            a, b = b, a
            n = np.array(r.normal)
        else:
            n = -r.normal
        nn = n @ n
        if not 0.25 < nn < 4.0:  # no usable normal from coal: the witness points give it
            n = (a - b) / d if d != 0.0 else np.array([0.0, 0.0, 1.0])
            nn = n @ n
        return a, b, n / math.sqrt(nn), d

    # ------------------------------------------------------------ queries
    def __len__(self) -> int:
        return len(self._index_pairs)

    def __repr__(self) -> str:
        return f"GapModel({self.mech.name!r}, {len(self)} pairs{', broad phase' if self.broad_phase else ''})"

    def pair_index(self, body: str, other: str) -> int:
        """Index of the pair ``(body, other)`` in :attr:`pairs`.

        Raises
        ------
        CollisionNotFoundError
            No such pair (the message lists the pairs of ``body``).
        """
        k = self._pair_index.get((body, other))
        if k is None:
            mine = [p for p in self.pairs if p[0] == body]
            hint = (f"pairs of {body!r}: {', '.join(map(str, mine[:10]))}" if mine
                    else f"bodies: {', '.join(sorted({p[0] for p in self.pairs}))}")
            raise CollisionNotFoundError(f"no pair ({body!r}, {other!r}) in this gap model; {hint}")
        return k

    def distances(self, q: ArrayLike, cutoff: float | None = None) -> NDArray[np.float64]:
        """Signed distance of every pair (no Jacobian): for event detection.

        Parameters
        ----------
        q : array_like, shape (nq,)
        cutoff : float, optional
            With the broad phase on (many pairs), pairs whose bounding spheres are farther apart
            than ``cutoff`` are not evaluated: their entry is a lower bound of their distance,
            greater than ``cutoff``. Entries ≤ cutoff are always exact.

        Returns
        -------
        ndarray, shape (P,)
            In the order of :attr:`pairs`.
        """
        _, gd = self._kinematics(q, jacobians=False)
        cut = None if cutoff is None else as_scalar("cutoff", cutoff, -math.inf, math.inf, hi_open=True)
        todo, lb = self._candidates(gd, cut)
        out = np.empty(len(self._index_pairs)) if lb is None else lb.copy()
        gm = self._geometry_model
        for k in todo:
            out[k] = pin.computeDistance(gm, gd, k).min_distance
        return out

    def rates(self, q: ArrayLike, v: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Signed distance f and its rate ḟ = n·(ṗ_B − ṗ_O) of every pair, without Jacobians.

        The rate is the normal velocity of the witness points (relative, for a self-collision
        pair): where the witness set is one point it is the derivative of f along the motion
        (the witness points slide along the surfaces, orthogonally to n). For event detection: one
        forward pass with v instead of the Jacobians.

        Parameters
        ----------
        q : array_like, shape (nq,)
        v : array_like, shape (nv,)

        Returns
        -------
        f, rate : ndarray, shape (P,) each
            In the order of :attr:`pairs`.
        """
        qv = self.mech.check_configuration(q)
        vv = np.asarray(v, dtype=float)
        if vv.shape != (self._zero_jacobian.shape[1],):
            raise ParameterError(f"v must have shape ({self._zero_jacobian.shape[1]},), got {vv.shape}")
        local = self._workspace()
        model, data, gd = self.mech.model, local.data, local.gdata
        pin.forwardKinematics(model, data, qv, vv)
        pin.updateGeometryPlacements(model, data, self._geometry_model, gd)
        n = len(self._index_pairs)
        f, rate = np.empty(n), np.empty(n)
        joints = self._joints
        motion: dict[int, tuple[list[float], list[float], list[float]]] = {}  # per joint, in world axes
        gm = self._geometry_model
        for k in range(n):
            res = pin.computeDistance(gm, gd, k)
            d = res.min_distance
            a, b = res.getNearestPoint1().tolist(), res.getNearestPoint2().tolist()
            nx, ny, nz = res.normal.tolist()
            if self._flip[k]:
                a, b = b, a
            else:
                nx, ny, nz = -nx, -ny, -nz
            nn = nx * nx + ny * ny + nz * nz
            if not 0.25 < nn < 4.0:  # no usable normal from coal: the witness points give it (as _nearest)
                nx, ny, nz = ((a[0] - b[0]) / d, (a[1] - b[1]) / d, (a[2] - b[2]) / d) if d != 0.0 else (0.0, 0.0, 1.0)
                nn = nx * nx + ny * ny + nz * nz
            s = 1.0 / math.sqrt(nn)
            nk = (nx * s, ny * s, nz * s)
            i, j = self._index_pairs[k]
            r = self._point_rate(data, joints[i], a, nk, motion)
            if joints[j] != 0:
                r -= self._point_rate(data, joints[j], b, nk, motion)
            f[k], rate[k] = d, r
        return f, rate

    @staticmethod
    def _point_rate(data: Any, joint: int, p: list[float], n: tuple[float, float, float],
                    motion: dict[int, tuple[list[float], list[float], list[float]]]) -> float:
        """n · (world velocity of the point at world position p fixed to ``joint``), kinematics with v done.

        In floats: for 3-vectors, numpy's call overhead is most of the cost."""
        if joint == 0:
            return 0.0
        m = motion.get(joint)
        if m is None:
            M, vel = data.oMi[joint], data.v[joint]  # the joint's spatial velocity is in its own frame
            R = M.rotation
            m = motion[joint] = ((R @ vel.linear).tolist(), (R @ vel.angular).tolist(), M.translation.tolist())
        (vx, vy, vz), (wx, wy, wz), (ox, oy, oz) = m
        rx, ry, rz = p[0] - ox, p[1] - oy, p[2] - oz
        ux, uy, uz = vx + wy * rz - wz * ry, vy + wz * rx - wx * rz, vz + wx * ry - wy * rx
        return n[0] * ux + n[1] * uy + n[2] * uz

    def gaps(self, q: ArrayLike, cutoff: float | None = None) -> list[Gap]:
        """The gap of every pair (or of those with distance ≤ ``cutoff``), Jacobians included.

        Parameters
        ----------
        q : array_like, shape (nq,)
        cutoff : float, optional
            Keep only the gaps with ``distance ≤ cutoff`` (the broad phase skips the far pairs).

        Returns
        -------
        list of Gap
            In the order of :attr:`pairs`, one per pair kept.
        """
        data, gd = self._kinematics(q, jacobians=True)
        cut = None if cutoff is None else as_scalar("cutoff", cutoff, -math.inf, math.inf, hi_open=True)
        todo, _ = self._candidates(gd, cut)
        cache: dict[int, Any] = {}
        out = []
        for k in todo:
            near = self._nearest(k, gd)
            if cut is None or near[3] <= cut:
                out.append(self._gap(k, data, near, cache))
        return out

    def evaluate(self, q: ArrayLike, cutoff: float | None = None) -> GapArrays:
        """:meth:`gaps` as stacked arrays, the Jacobians computed for all pairs at once.

        Cheaper than :meth:`gaps` (no object per pair), and ready to stack into constraint matrices.

        Parameters
        ----------
        q : array_like, shape (nq,)
        cutoff : float, optional
            Keep only the pairs with ``distance ≤ cutoff``.

        Returns
        -------
        GapArrays
            ``distance`` (P,), ``normal``, ``point``, ``other_point`` (P, 3), ``jacobian``
            (P, 3, nv), ``gradient`` (P, nv), ``pairs`` (P,).
        """
        data, gd = self._kinematics(q, jacobians=True)
        cut = None if cutoff is None else as_scalar("cutoff", cutoff, -math.inf, math.inf, hi_open=True)
        todo, _ = self._candidates(gd, cut)
        kept, rows = [], []
        for k in todo:
            near = self._nearest(k, gd)
            if cut is None or near[3] <= cut:
                kept.append(k)
                rows.append(near)
        nv = self._zero_jacobian.shape[1]
        P = len(kept)
        pb, po, n = np.empty((P, 3)), np.empty((P, 3)), np.empty((P, 3))
        d = np.empty(P)
        J = np.empty((P, 3, nv))
        grad = np.empty((P, nv))
        cache: dict[int, Any] = {}
        joints = self._joints
        for row, (k, (a, b, nk, dk)) in enumerate(zip(kept, rows)):
            i, j = self._index_pairs[k]
            Jk = self._jacobian(data, joints[i], a, cache)
            if joints[j] != 0:
                Jk = Jk - self._jacobian(data, joints[j], b, cache)
            pb[row], po[row], n[row], d[row], J[row] = a, b, nk, dk, Jk
            grad[row] = nk @ Jk
        return GapArrays(np.array(kept, dtype=int), d, n, pb, po, J, grad)

    def gap(self, q: ArrayLike, pair: int | Pair = 0) -> Gap:
        """The gap of one pair, given by index or by ``(body, other)`` names."""
        k = self.pair_index(*pair) if isinstance(pair, tuple) else int(pair)
        if not 0 <= k < len(self._index_pairs):
            raise ParameterError(f"pair index {k} is outside [0, {len(self._index_pairs) - 1}]")
        data, gd = self._kinematics(q, jacobians=True)
        return self._gap(k, data, self._nearest(k, gd), {})

    def contact_points(self, q: ArrayLike, margin: float = 1e-3, patch_tolerance: float = 1e-3,
                       pairs: Sequence[int] | None = None) -> list[Gap]:
        """Every witness point of every pair closer than ``margin``: whole contact patches.

        Parameters
        ----------
        q : array_like, shape (nq,)
        margin : float
            Pairs with a signed distance below ``margin`` [m] are in contact (coal's security
            margin); ≥ 0, so that exactly touching pairs count.
        patch_tolerance : float
            Points of the two support sets within this distance [m] along the normal of the
            deepest point belong to the patch (coal's patch tolerance, > 0).
        pairs : sequence of int, optional
            Only these pairs (indices into :attr:`pairs`); default all.

        Returns
        -------
        list of Gap
            One per patch point (4 for a box lying flat, 2 for a box on an edge, 1 for a sphere;
            see :mod:`mbimpact.geometry.patches`), grouped by pair in the order of :attr:`pairs`;
            ``distance`` is the patch's signed distance.
        """
        m = as_scalar("margin", margin, 0.0, math.inf, hi_open=True)
        tol = as_scalar("patch_tolerance", patch_tolerance, 0.0, math.inf, lo_open=True, hi_open=True)
        data, gd = self._kinematics(q, jacobians=True)
        local = self._local
        gm = self._geometry_model
        n = len(self._index_pairs)
        if local.margin != m:
            for k in range(n):
                gd.collisionRequests[k].security_margin = m
            local.margin = m
        if local.patch_tolerance != tol:
            for k in range(n):
                gd.contactPatchRequests[k].setPatchTolerance(tol)
            local.patch_tolerance = tol
        if pairs is None:
            todo, _ = self._candidates(gd, m)
        else:
            todo = sorted({int(k) for k in pairs})
            if todo and not (0 <= todo[0] and todo[-1] < n):
                raise ParameterError(f"pair indices must lie in [0, {n - 1}], got {list(pairs)}")
        cache: dict[int, Any] = {}
        out = []
        for k in todo:
            if not pin.computeCollision(gm, gd, k):
                continue
            pin.computeContactPatch(gm, gd, k)
            res = gd.contactPatchResults[k]
            points = read_patch(res.getContactPatch(0), self._flip[k]) if res.numContactPatches() else []
            if not points or not all(math.isfinite(p[3]) and np.isfinite(p[2]).all() for p in points):
                # no usable patch (should not happen after a collision): the contact point itself,
                # or the nearest points of a distance query
                points = [read_contact(gd.collisionResults[k].getContact(0), self._flip[k])]
                if not (math.isfinite(points[0][3]) and np.isfinite(points[0][2]).all()):
                    points = [self._nearest(k, gd)]
            out += [self._gap(k, data, p, cache) for p in points]
        return out

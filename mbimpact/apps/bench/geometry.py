"""Bench of collision geometry: what a gap query costs per contact pair, against one rough-law impact.

Measured on the mechanism's own collision objects (coal through Pinocchio) in the same run as
one :func:`mbimpact.impact` with ``RoughLaw(Cone(0.3), 0.5)``:

* ``distances`` — signed distances only (the simulator's event detection);
* ``rates`` — distances and their rates ḟ (one forward pass with v, no Jacobian);
* ``evaluate`` — distances, witness points, Jacobians and gradients ∇f of every pair;
* ``contact_points`` — whole contact patches (a box lying flat: its four corners).
"""

from __future__ import annotations

import numpy as np

from ...geometry import GapModel, GeometryContact, HalfSpace
from ...laws import RoughLaw
from ...mechanism import Mechanism, PointContact
from ...pipeline import impact
from ...roughness import Cone
from ..progress import Progress
from .common import BenchRow, per_call

__all__ = ["gap_queries"]


def _cases() -> list[tuple[str, Mechanism, np.ndarray, GapModel, str]]:
    """(label, mechanism, q, gap model against the ground, a body of it for one GeometryContact)."""
    out = []
    box = Mechanism.from_model("box")
    q = box.neutral()
    q[2] = 0.05  # lying flat on the ground
    out.append(("box (1 box)", box, q, GapModel(box, [HalfSpace()]), "box_0"))
    solo = Mechanism.from_robot("solo12")
    q = solo.neutral()
    q[2] = 0.4
    out.append(("solo12 (17 convex hulls)", solo, q, GapModel(solo, [HalfSpace()]), "FL_FOOT_0"))
    ur5 = Mechanism.from_robot("ur5")
    q = np.array([0.0, -0.6, 0.6, -1.57, 0.0, 0.0])
    out.append(("ur5 (7 hulls and a box)", ur5, q, GapModel(ur5, [HalfSpace(offset=-0.1)]), "forearm_link_0"))
    return out


def gap_queries(min_time: float, progress: Progress) -> list[BenchRow]:
    """Per-pair cost of each query; ``ratio`` is that cost over one rough-law impact of the same mechanism."""
    rows: list[BenchRow] = []
    rng = np.random.default_rng(5)
    law = RoughLaw(Cone(0.3), 0.5)
    for label, mech, q, gm, body in _cases():
        pairs = len(gm)
        v = rng.normal(size=mech.nv)
        geo = GeometryContact(body, obstacle=HalfSpace(offset=-0.5))
        # the rough impact of the witness point, struck from above (v chosen to approach)
        J, R = geo.jacobian(mech, q)
        n = R[:, 2]
        v_hit = v - (float(n @ J @ v) + 1.0) * np.linalg.pinv(J) @ n
        t_rough = per_call(lambda: impact(mech, q, v_hit, geo, law), min_time)
        rows.append(BenchRow("geometry", label, "one impact, RoughLaw(Cone(0.3)) on a GeometryContact", pairs, 0.0,
                             t_rough, 1.0))
        frame = mech.frame_names[-1]
        point = PointContact(frame)
        Jp = mech.point_jacobian(q, frame)
        if np.linalg.norm(Jp[2]) > 1e-9:
            v_pt = v - (float(Jp[2] @ v) + 1.0) * np.linalg.pinv(Jp) @ np.array([0.0, 0.0, 1.0])
            t = per_call(lambda: impact(mech, q, v_pt, point, law), min_time)
            rows.append(BenchRow("geometry", label, "one impact, RoughLaw(Cone(0.3)) on a PointContact", pairs, 0.0,
                                 t, t / t_rough))
        for name, call in (("distances", lambda: gm.distances(q)), ("rates (f and ḟ)", lambda: gm.rates(q, v)),
                           ("evaluate (f, points, J, ∇f)", lambda: gm.evaluate(q)),
                           ("contact_points (patches)", lambda: gm.contact_points(q, margin=1e-3))):
            t = per_call(call, min_time) / pairs
            rows.append(BenchRow("geometry", label, f"{name}, per pair", pairs, 0.0, t, t / t_rough))
        progress.step(label)
    return rows

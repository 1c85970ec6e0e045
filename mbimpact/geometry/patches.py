"""Several witness points per pair: coal's contact patches read in mbimpact's conventions.

A box lying flat touches a plane along a face and on an edge along a segment: the single pair of
nearest points coal's distance returns is then one arbitrary point of that set. After a collision
query with a security margin (so that touching and nearly touching pairs count), coal's
``computeContactPatch`` returns the contact polygon: the support sets of both shapes along the
contact normal, within ``patch_tolerance`` of the deepest point, clipped against each other. A
flat box gives its 4 corners, a box on an edge the 2 ends of the edge, a box on a corner or a
sphere 1 point, a cylinder standing on its base a 12-gon, a convex mesh its facet's vertices.

The patch points lie in the patch plane: every point of a patch has the patch's signed distance,
and a point is at most ``patch_tolerance`` from the true surface of a slightly tilted face.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["PatchPoint", "read_patch", "read_contact"]

#: (point on the body, point on the other object, unit normal from the other towards the body,
#: signed distance) in the world frame.
PatchPoint = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float]


def read_patch(patch: Any, flip: bool) -> list[PatchPoint]:
    """The points of a ``coal.ContactPatch``.

    Parameters
    ----------
    patch : coal.ContactPatch
        Computed for the ordered pair (o1, o2); its normal points from o1 to o2.
    flip : bool
        False when the body is o1 (the normal is negated), True when the body is o2.
    """
    n = np.array(patch.getNormal(), dtype=float)
    n = n if flip else -n
    n /= np.linalg.norm(n)
    out: list[PatchPoint] = []
    for k in range(patch.size()):
        a, b = np.array(patch.getPointShape1(k)), np.array(patch.getPointShape2(k))
        pb, po = (b, a) if flip else (a, b)
        out.append((pb, po, n, float(n @ (pb - po))))
    return out


def read_contact(contact: Any, flip: bool) -> PatchPoint:
    """The single point of a ``coal.Contact`` (a collision result without a patch)."""
    n = np.array(contact.normal, dtype=float)
    n = n if flip else -n
    n /= np.linalg.norm(n)
    a, b = np.array(contact.getNearestPoint1()), np.array(contact.getNearestPoint2())
    pb, po = (b, a) if flip else (a, b)
    return pb, po, n, float(contact.penetration_depth)

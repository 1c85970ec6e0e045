"""The pairs a :class:`~mbimpact.geometry.GapModel` evaluates: collision objects of the mechanism
against obstacles, or against each other (all non-adjacent ones, or those an SRDF leaves enabled)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path

import pinocchio as pin

from ..errors import GeometryError, ParameterError
from .collision_model import CollisionModel

__all__ = ["Pair", "object_names", "self_pair_indices", "srdf_pairs", "unique_label"]

#: A pair of names: (collision object of the mechanism, obstacle or other collision object).
Pair = tuple[str, str]


def unique_label(label: str, taken: set[str]) -> str:
    """``label``, or ``label_1``, ``label_2``, ... whichever is not taken."""
    if label not in taken:
        return label
    k = 1
    while f"{label}_{k}" in taken:
        k += 1
    return f"{label}_{k}"


def object_names(cm: CollisionModel, names: Iterable[str], what: str) -> list[str]:
    """``names`` as a list, each the name of a collision object of ``cm`` (``what`` names the argument)."""
    if isinstance(names, str):
        raise ParameterError(f"{what} must be a sequence of collision object names, not one string "
                             f"(write [{names!r}])")
    out = list(names)
    for n in out:
        cm.index(n)  # raises CollisionNotFoundError with close matches
    return out


def self_pair_indices(cm: CollisionModel, self_pairs: Sequence[Pair] | str | None,
                      srdf: str | Path | None) -> list[tuple[int, int]]:
    """The (i, j) indices of the mechanism's own pairs: none, those given by name, or ``"all"`` pairs of
    objects on different, non-adjacent joints (those an SRDF leaves enabled, if one is given)."""
    if self_pairs is None:
        if srdf is not None:
            raise ParameterError("srdf filters self_pairs='all'; give self_pairs='all' with it")
        return []
    model = cm.model
    if isinstance(self_pairs, str):
        if self_pairs != "all":
            raise ParameterError(f"self_pairs must be 'all' or a sequence of (body, other) names, got {self_pairs!r}")
        allowed = srdf_pairs(cm, srdf)
        out = []
        objs = list(cm.geometry_model.geometryObjects)
        for i in range(len(objs)):
            for j in range(i + 1, len(objs)):
                ji, jj = int(objs[i].parentJoint), int(objs[j].parentJoint)
                if ji == jj or (ji == 0 and jj == 0):
                    continue
                if model.parents[ji] == jj or model.parents[jj] == ji:
                    continue
                if allowed is not None and (i, j) not in allowed:
                    continue
                out.append((i, j))
        return out
    if srdf is not None:
        raise ParameterError("srdf filters self_pairs='all' only; with explicit pairs, leave the unwanted ones out")
    out = []
    for k, p in enumerate(self_pairs):
        if isinstance(p, str) or len(p) != 2:
            raise ParameterError(f"self_pairs[{k}] must be a (body, other) pair of names, got {p!r}")
        a, b = cm.index(p[0]), cm.index(p[1])
        if a == b:
            raise ParameterError(f"self_pairs[{k}] pairs {p[0]!r} with itself")
        out.append((a, b))
    return out


def srdf_pairs(cm: CollisionModel, srdf: str | Path | None) -> set[tuple[int, int]] | None:
    """The (i, j), i < j, pairs an SRDF leaves enabled, or None without SRDF."""
    if srdf is None:
        return None
    path = Path(srdf)
    if not path.is_file():
        raise GeometryError(f"SRDF file {str(path)!r} not found")
    gm = pin.GeometryModel()
    for go in cm.geometry_model.geometryObjects:
        gm.addGeometryObject(go)
    gm.addAllCollisionPairs()
    try:
        pin.removeCollisionPairs(cm.model, gm, str(path))
    except (RuntimeError, ValueError) as exc:
        raise GeometryError(f"could not read the SRDF {str(path)!r}: {exc}") from exc
    return {(min(cp.first, cp.second), max(cp.first, cp.second)) for cp in gm.collisionPairs}

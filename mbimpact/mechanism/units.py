"""The physical unit of each configuration and velocity coordinate, from the joint it belongs to."""

from __future__ import annotations

from typing import Any

__all__ = ["state_units"]

# Units of the coordinates of each Pinocchio joint type (its shortname without "JointModel"):
# (q units, v units). Translations in m and m/s; rotation angles in rad and rad/s; the components of
# a unit quaternion, or the (cos θ, sin θ) of an unbounded revolute joint, have none ("1").
_M, _RAD, _MS, _RADS, _ONE = "m", "rad", "m/s", "rad/s", "1"
_FIXED: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "FreeFlyer": ((_M,) * 3 + (_ONE,) * 4, (_MS,) * 3 + (_RADS,) * 3),
    "Planar": ((_M, _M, _ONE, _ONE), (_MS, _MS, _RADS)),
    "Translation": ((_M,) * 3, (_MS,) * 3),
    "Spherical": ((_ONE,) * 4, (_RADS,) * 3),
    "SphericalZYX": ((_RAD,) * 3, (_RADS,) * 3),
    "Ellipsoid": ((_RAD,) * 3, (_RADS,) * 3),
    "Universal": ((_RAD,) * 2, (_RADS,) * 2),
    "PrismaticUnaligned": ((_M,), (_MS,)),
    "RevoluteUnaligned": ((_RAD,), (_RADS,)),
    "RevoluteUnboundedUnaligned": ((_ONE, _ONE), (_RADS,)),
    "HelicalUnaligned": ((_RAD,), (_RADS,)),
}
for _axis in "XYZ":
    _FIXED["P" + _axis] = ((_M,), (_MS,))
    _FIXED["R" + _axis] = ((_RAD,), (_RADS,))
    _FIXED["RUB" + _axis] = ((_ONE, _ONE), (_RADS,))
    _FIXED["H" + _axis] = ((_RAD,), (_RADS,))


def state_units(model: Any) -> tuple[list[str], list[str]]:
    """The unit of every configuration and velocity coordinate of a Pinocchio model.

    Parameters
    ----------
    model : pinocchio.Model

    Returns
    -------
    q_units : list of str, length nq
        ``"m"`` (translation), ``"rad"`` (angle), ``"1"`` (a quaternion component, or the cosine or sine
        of an unbounded revolute joint), ``""`` for a joint type not known here.
    v_units : list of str, length nv
        ``"m/s"`` or ``"rad/s"`` (``""`` likewise).
    """
    q_units, v_units = [""] * int(model.nq), [""] * int(model.nv)
    for joint in model.joints[1:]:
        _fill(joint, int(joint.idx_q), int(joint.idx_v), q_units, v_units)
    return q_units, v_units


def _fill(joint: Any, iq: int, iv: int, q_units: list[str], v_units: list[str]) -> None:
    kind = joint.shortname().removeprefix("JointModel")
    if kind == "Composite":  # its joints in order, each after the previous one's coordinates
        for part in joint.extract().joints:
            _fill(part, iq, iv, q_units, v_units)
            iq, iv = iq + int(part.nq), iv + int(part.nv)
        return
    units = _FIXED.get(kind)
    if units is None or len(units[0]) != joint.nq or len(units[1]) != joint.nv:
        return  # a joint type not known here (a mimic joint has no coordinates of its own)
    q_units[iq:iq + joint.nq] = units[0]
    v_units[iv:iv + joint.nv] = units[1]

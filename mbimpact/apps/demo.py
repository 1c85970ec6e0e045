"""The main job: a UR5 tool striking a table, Newton's law beside the rough law.

For two incidence angles β and a few roughness levels (cone tilt α), the UR5's
``tool0`` point hits the plane z = const with contact speed 1 m/s
(:func:`mbimpact.compare.compare_laws`).
"""

from __future__ import annotations

import numpy as np

from .compare import CompareRow, compare_laws
from ..mechanism import PointContact
from ..laws import ImpactLaw, NewtonLaw
from ..mechanism import Mechanism
from ..laws import RoughLaw
from ..roughness import Cone

__all__ = ["UR5_POSTURE", "demo_rows"]

#: UR5 posture with the tool above the table.
UR5_POSTURE = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])


def demo_rows(
    e: float = 0.8,
    alphas: tuple[float, ...] = (0.1, 0.2, 0.4),
    betas_deg: tuple[float, ...] = (20.0, 60.0),
    speed: float = 1.0,
) -> list[CompareRow]:
    """Newton's law and the rough law per roughness level, at each incidence angle."""
    laws: dict[str, ImpactLaw] = {"Newton (frictionless)": NewtonLaw(e)}
    laws |= {f"rough, cone alpha={a:g}": RoughLaw(Cone(a), e) for a in alphas}
    contact = PointContact("tool0", normal=np.array([0.0, 0.0, 1.0]), tangent=np.array([1.0, 0.0, 0.0]))
    return compare_laws(Mechanism.from_robot("ur5"), UR5_POSTURE, contact, laws, betas_deg, speed)

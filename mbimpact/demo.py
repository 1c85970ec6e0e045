"""The main job: a UR5 tool striking a table, Newton's law beside the rough law.

For two incidence angles β (between the approach velocity and the table's
normal) and a few roughness levels (cone tilt α), the UR5's ``tool0`` point hits
the plane z = const with contact speed 1 m/s. The joint velocity producing that
contact velocity is the kinetic-energy-minimising one, v = A⁻¹Jᵀ W⁻¹ u.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .contact import PointContact, impact
from .laws import ImpactLaw, NewtonLaw, RoughLaw
from .mechanism import Mechanism
from .roughness import Cone

__all__ = ["DemoRow", "demo_rows", "format_table", "write_csv"]

#: UR5 posture with the tool pointing down over the table.
UR5_POSTURE = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])


@dataclass(frozen=True)
class DemoRow:
    """One line of the demo table."""

    law: str
    beta_deg: float
    u_t_plus: float
    u_n_plus: float
    kappa: float
    mu: float
    energy_loss: float


def demo_rows(
    e: float = 0.8,
    alphas: tuple[float, ...] = (0.1, 0.2, 0.4),
    betas_deg: tuple[float, ...] = (20.0, 60.0),
    speed: float = 1.0,
) -> list[DemoRow]:
    """Compute the demo table: Newton's law and the rough law per roughness level."""
    mech = Mechanism.from_robot("ur5")
    contact = PointContact("tool0", normal=(0.0, 0.0, 1.0), tangent=(1.0, 0.0, 0.0))
    q = UR5_POSTURE
    J = mech.point_jacobian(q, contact.frame)
    A = mech.mass_matrix(q)
    AinvJt = np.linalg.solve(A, J.T)
    laws: list[tuple[str, ImpactLaw]] = [("Newton (frictionless)", NewtonLaw(e))]
    laws += [(f"rough, cone alpha={a:g}", RoughLaw(Cone(a), e)) for a in alphas]
    rows = []
    for beta_deg in betas_deg:
        beta = math.radians(beta_deg)
        u = speed * np.array([math.sin(beta), 0.0, -math.cos(beta)])
        v = AinvJt @ np.linalg.solve(J @ AinvJt, u)
        for label, law in laws:
            res = impact(mech, q, v, contact, law)
            rows.append(
                DemoRow(
                    law=label,
                    beta_deg=beta_deg,
                    u_t_plus=float(np.linalg.norm(res.u_plus[:2])),
                    u_n_plus=float(res.u_plus[2]),
                    kappa=res.kappa,
                    mu=res.mu,
                    energy_loss=res.energy_loss,
                )
            )
    return rows


_HEADER = ("law", "beta [deg]", "|u_t+| [m/s]", "u_n+ [m/s]", "kappa", "mu", "energy loss [J]")


def format_table(rows: list[DemoRow]) -> str:
    """Markdown table of the demo rows."""
    lines = ["| " + " | ".join(_HEADER) + " |", "|" + "---|" * len(_HEADER)]
    for r in rows:
        cells = (r.law, f"{r.beta_deg:g}", f"{r.u_t_plus:.4f}", f"{r.u_n_plus:.4f}",
                 f"{r.kappa:.4f}", f"{r.mu:.4f}", f"{r.energy_loss:.5f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_csv(rows: list[DemoRow], path: str | Path) -> Path:
    """Write the rows as CSV (one header line)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["law", "beta_deg", "u_t_plus", "u_n_plus", "kappa", "mu", "energy_loss"])
        for r in rows:
            writer.writerow([r.law, r.beta_deg, r.u_t_plus, r.u_n_plus, r.kappa, r.mu, r.energy_loss])
    return path

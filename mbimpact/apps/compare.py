"""Compare impact laws on one mechanism and contact over the incidence angle β.

The contact point approaches the surface with speed ``speed`` at angle β from
the normal, in the plane of n⁰ and the contact's first tangent t₁. The joint
velocity producing it is the kinetic-energy-minimising one, v = A⁻¹Jᵀ W⁻¹ u.
"""

from __future__ import annotations

import csv
import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..mechanism import PointContact, impact
from ..laws import ImpactLaw
from ..mechanism import Mechanism

__all__ = ["CompareRow", "approach_velocity", "compare_laws", "format_table", "write_csv", "plot"]


@dataclass(frozen=True)
class CompareRow:
    """One law at one incidence angle: post-impact contact velocity, κ, μ, energy loss."""

    law: str
    beta_deg: float
    u_t_plus: float
    u_n_plus: float
    kappa: float
    mu: float
    energy_loss: float


def approach_velocity(mech: Mechanism, q: ArrayLike, contact: PointContact, beta: float, speed: float = 1.0) -> np.ndarray:
    """Generalised velocity (nv,) whose contact velocity is speed·(sin β t₁ − cos β n⁰).

    The least-kinetic-energy solution v = A⁻¹Jᵀ W⁻¹ u (least squares if W is singular).
    """
    q = np.asarray(q, dtype=float)
    J = mech.point_jacobian(q, contact.frame, contact.point)
    R = contact.basis()
    u = speed * (math.sin(beta) * R[:, 0] - math.cos(beta) * R[:, 2])
    AinvJt = np.linalg.solve(mech.mass_matrix(q), J.T)
    return AinvJt @ np.linalg.lstsq(J @ AinvJt, u, rcond=None)[0]


def compare_laws(
    mech: Mechanism,
    q: ArrayLike,
    contact: PointContact,
    laws: dict[str, ImpactLaw],
    betas_deg: ArrayLike,
    speed: float = 1.0,
) -> list[CompareRow]:
    """Apply every law at every incidence angle; rows ordered by β, then law."""
    rows = []
    for beta_deg in np.asarray(betas_deg, dtype=float):
        v = approach_velocity(mech, q, contact, math.radians(beta_deg), speed)
        for label, law in laws.items():
            res = impact(mech, q, v, contact, law)
            # tangential velocity along t₁ (signed), in world coordinates of the result
            t1 = contact.basis()[:, 0] if res.P.shape[0] == 3 else np.array([1.0, 0.0])
            n0 = res.n0
            rows.append(CompareRow(label, float(beta_deg), float(res.u_plus @ t1), float(res.u_plus @ n0),
                                   res.kappa, res.mu, res.energy_loss))
    return rows


_HEADER = ("law", "beta [deg]", "u_t+ [m/s]", "u_n+ [m/s]", "kappa", "mu", "energy loss [J]")


def format_table(rows: list[CompareRow]) -> str:
    """Markdown table of the rows."""
    lines = ["| " + " | ".join(_HEADER) + " |", "|" + "---|" * len(_HEADER)]
    for r in rows:
        cells = (r.law, f"{r.beta_deg:g}", f"{r.u_t_plus:.4f}", f"{r.u_n_plus:.4f}",
                 f"{r.kappa:.4f}", f"{r.mu:.4f}", f"{r.energy_loss:.5f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_csv(rows: list[CompareRow], path: str | Path) -> Path:
    """Write the rows as CSV (one header line)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=[f.name for f in fields(CompareRow)])
        writer.writeheader()
        for r in rows:
            writer.writerow(asdict(r))
    return path


def plot(rows: list[CompareRow], path: str | Path, title: str = "") -> Path:
    """Five panels against β: u_t+, u_n+, κ, μ = |P_t|/P_n, energy loss."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    quantities = [("u_t_plus", "tangential u+ [m/s]"), ("u_n_plus", "normal u+ [m/s]"), ("kappa", "κ"),
                  ("mu", "μ = |P_t| / P_n"), ("energy_loss", "energy loss [J]")]
    fig, axes = plt.subplots(1, 5, figsize=(20, 4))
    for law in dict.fromkeys(r.law for r in rows):
        sel = [r for r in rows if r.law == law]
        for ax, (attr, label) in zip(axes, quantities):
            ax.plot([r.beta_deg for r in sel], [getattr(r, attr) for r in sel], label=law)
            ax.set(xlabel="incidence β [deg]", ylabel=label)
    axes[0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path

"""Compare impact laws on one mechanism and contact over the incidence angle β.

The contact point approaches the surface with speed ``speed`` at angle β from
the normal, in the plane of n⁰ and the contact's first tangent t₁. The joint
velocity producing it is the kinetic-energy-minimising one, v = A⁻¹Jᵀ W⁻¹ u.
"""

from __future__ import annotations

import csv
import math
import numbers
import os
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..common.validation import as_array, as_scalar
from ..errors import NotPositiveDefiniteError, ParameterError
from ..mechanism import PointContact
from ..pipeline import impact
from ..laws import ImpactLaw
from ..mechanism import Mechanism
from ..metric.delassus import ContactMetric

__all__ = ["CompareRow", "approach_velocity", "compare_laws", "format_table", "write_csv", "plot"]

#: Largest approach speed (m/s), as ``mbimpact compare --speed``: the impact solvers refuse faster velocities.
MAX_SPEED = 1e100


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

    Parameters
    ----------
    mech : Mechanism
    q : array_like, shape (nq,)
        Configuration.
    contact : PointContact
        The contact point and its basis (t₁, t₂, n⁰).
    beta : float
        Incidence from the normal (rad).
    speed : float
        Approach speed of the contact point, in (0, :data:`MAX_SPEED`] (m/s).

    Returns
    -------
    ndarray, shape (nv,)

    Raises
    ------
    ParameterError
        ``mech`` or ``contact`` of the wrong kind, ``speed`` out of range.
    ShapeError, NonFiniteError
        An invalid ``q``, a non-finite ``beta``, a W that overflows.
    NotPositiveDefiniteError
        A(q) is singular (massless links) or not positive definite: v needs A⁻¹.
    """
    _check_parts(mech, contact)
    beta = as_scalar("beta", beta, -math.inf, math.inf)
    speed = as_scalar("speed", speed, 0.0, MAX_SPEED, lo_open=True)
    q = as_array("q", q, 1)  # real and finite: a complex q would warn when cast (the mechanism checks the rest)
    J = mech.point_jacobian(q, contact.frame, contact.point)
    R = contact.basis()
    u = speed * (math.sin(beta) * R[:, 0] - math.cos(beta) * R[:, 2])
    # Cholesky of A, as impact() does: a singular A(q) becomes the library's named error, not numpy's LinAlgError
    try:
        metric = ContactMetric.from_arrays(mech.mass_matrix(q), J)
    except NotPositiveDefiniteError as exc:
        raise NotPositiveDefiniteError(
            f"the mass matrix of {mech.name} at this q: {exc}; its URDF may have massless links or joints "
            "without inertia (the approach velocity solves with A(q), which must be positive definite)"
        ) from None
    return metric.AinvJt @ np.linalg.lstsq(metric.W, u, rcond=None)[0]


def compare_laws(
    mech: Mechanism,
    q: ArrayLike,
    contact: PointContact,
    laws: dict[str, ImpactLaw],
    betas_deg: ArrayLike,
    speed: float = 1.0,
) -> list[CompareRow]:
    """Apply every law at every incidence angle; rows ordered by β, then law.

    Parameters
    ----------
    mech : Mechanism
    q : array_like, shape (nq,)
    contact : PointContact
    laws : mapping of str to ImpactLaw
        The laws by label.
    betas_deg : float or array_like, shape (B,)
        Incidences from the normal (deg).
    speed : float
        Approach speed (m/s), in (0, :data:`MAX_SPEED`].

    Returns
    -------
    list of CompareRow

    Raises
    ------
    ParameterError
        Arguments of the wrong kind (``laws`` not a mapping of impact laws), ``speed`` out of range.
    ShapeError, NonFiniteError
        Invalid ``q`` or ``betas_deg``.
    NotPositiveDefiniteError
        A(q) is singular (massless links) or not positive definite.
    NoImpactError, NoFacingFacetError
        An incidence at which the contact does not approach the surface, or no facet faces it.
    """
    _check_parts(mech, contact)
    if not isinstance(laws, Mapping) or not all(isinstance(law, ImpactLaw) for law in laws.values()):
        raise ParameterError("laws must be a mapping of label to impact law (NewtonLaw, RoughLaw, CoulombLaw, ...), "
                             f"got {laws!r}")
    if isinstance(betas_deg, (numbers.Real, np.floating, np.integer)) and not isinstance(betas_deg, bool):
        betas_deg = [betas_deg]  # one incidence
    rows = []
    for beta_deg in as_array("betas_deg", betas_deg, 1):
        v = approach_velocity(mech, q, contact, math.radians(beta_deg), speed)
        for label, law in laws.items():
            res = impact(mech, q, v, contact, law)
            # tangential velocity along t₁ (signed), in world coordinates of the result
            t1 = contact.basis()[:, 0] if res.P.shape[0] == 3 else np.array([1.0, 0.0])
            n0 = res.n0
            rows.append(CompareRow(label, float(beta_deg), float(res.u_plus @ t1), float(res.u_plus @ n0),
                                   res.kappa, res.mu, res.energy_loss))
    return rows


def _check_parts(mech: object, contact: object) -> None:
    """Name a mechanism or contact of the wrong kind (its missing methods would raise AttributeError)."""
    if not isinstance(mech, Mechanism):
        raise ParameterError(f"mech must be an mbimpact.Mechanism, got {type(mech).__name__}")
    if not isinstance(contact, PointContact):
        raise ParameterError(f"contact must be an mbimpact.PointContact, got {type(contact).__name__}")


def _check_rows(rows: object) -> list[CompareRow]:
    """``rows`` as a list of :class:`CompareRow` (what :func:`compare_laws` returns), else a ParameterError."""
    out = list(rows) if isinstance(rows, Iterable) and not isinstance(rows, (str, bytes)) else None
    if out is None or not all(isinstance(r, CompareRow) for r in out):
        raise ParameterError(f"rows must be a list of CompareRow, as compare_laws returns; got {type(rows).__name__}")
    return out


def _check_path(path: object) -> Path:
    """``path`` as a Path; anything else (None, a number) would raise a bare TypeError."""
    if not isinstance(path, (str, os.PathLike)) or "\x00" in str(path):
        raise ParameterError(f"path must be a file path (str or Path, no null byte), got {path!r}")
    return Path(path)


_HEADER = ("law", "beta [deg]", "u_t+ [m/s]", "u_n+ [m/s]", "kappa", "mu", "energy loss [J]")


def format_table(rows: list[CompareRow]) -> str:
    """Markdown table of the rows."""
    rows = _check_rows(rows)
    lines = ["| " + " | ".join(_HEADER) + " |", "|" + "---|" * len(_HEADER)]
    for r in rows:
        cells = (r.law, f"{r.beta_deg:g}", f"{r.u_t_plus:.4f}", f"{r.u_n_plus:.4f}",
                 f"{r.kappa:.4f}", f"{r.mu:.4f}", f"{r.energy_loss:.5f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_csv(rows: list[CompareRow], path: str | Path) -> Path:
    """Write the rows as CSV (one header line)."""
    rows, path = _check_rows(rows), _check_path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=[f.name for f in fields(CompareRow)])
        writer.writeheader()
        for r in rows:
            writer.writerow(asdict(r))
    return path


def plot(rows: list[CompareRow], path: str | Path, title: str = "") -> Path:
    """Five panels against β: u_t+, u_n+, κ, μ = |P_t|/P_n, energy loss.

    Raises
    ------
    ParameterError
        ``rows`` not a list of :class:`CompareRow`; a ``path`` that is not one, or whose suffix is not an
        image format matplotlib writes.
    """
    rows, path = _check_rows(rows), _check_path(path)
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
    fig.suptitle(str(title))
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fig.savefig(path, dpi=100)
    except ValueError as exc:  # matplotlib's: an unknown format (suffix); its message lists the valid ones
        raise ParameterError(f"cannot write the plot {str(path)!r}: {exc}") from None
    finally:
        plt.close(fig)
    return path

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
from ..errors import NotPositiveDefiniteError, ParameterError, UnreachableVelocityError
from ..laws import ImpactLaw
from ..mechanism import Mechanism, PointContact, joint_velocity
from ..pipeline import impact

__all__ = ["CompareRow", "approach_velocity", "compare_laws", "format_table", "write_csv", "plot"]

#: Largest approach speed (m/s), as ``mbimpact compare --speed``: the impact solvers refuse faster velocities.
MAX_SPEED = 1e100


@dataclass(frozen=True)
class CompareRow:
    """One law at one incidence angle: post-impact contact velocity, κ, μ, energy loss (and the approach
    speed [m/s] of the contact point)."""

    law: str
    beta_deg: float
    u_t_plus: float
    u_n_plus: float
    kappa: float
    mu: float
    energy_loss: float
    speed: float = 1.0


def approach_velocity(mech: Mechanism, q: ArrayLike, contact: PointContact, beta: float, speed: float = 1.0) -> np.ndarray:
    """Generalised velocity (nv,) whose contact velocity is speed·(sin β t₁ − cos β n⁰).

    The least-kinetic-energy solution v = A⁻¹Jᵀ W⁻¹ u (:func:`mbimpact.mechanism.joint_velocity`).

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
    UnreachableVelocityError
        The posture cannot give the contact that velocity (a singular posture, too few joints).
    """
    _check_parts(mech, contact)
    beta = as_scalar("beta", beta, -math.inf, math.inf)
    speed = as_scalar("speed", speed, 0.0, MAX_SPEED, lo_open=True)
    q = as_array("q", q, 1)  # real and finite: a complex q would warn when cast (the mechanism checks the rest)
    J = mech.point_jacobian(q, contact.frame, contact.point)
    R = contact.basis()
    u = speed * (math.sin(beta) * R[:, 0] - math.cos(beta) * R[:, 2])
    # a singular A(q) becomes the library's named error, not numpy's LinAlgError
    try:
        return joint_velocity(mech.mass_matrix(q), J, u)
    except NotPositiveDefiniteError as exc:
        raise NotPositiveDefiniteError(
            f"the mass matrix of {mech.name} at this q: {exc}; its URDF may have massless links or joints "
            "without inertia (the approach velocity solves with A(q), which must be positive definite)"
        ) from None
    except UnreachableVelocityError as exc:
        raise UnreachableVelocityError(
            f"{mech.name} {contact.frame}, approach at β = {math.degrees(beta):g}°: {exc}"
        ) from None


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
    UnreachableVelocityError
        An incidence the posture cannot produce (a singular posture, too few joints).
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
                                   res.kappa, res.mu, res.energy_loss, speed))
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
        cells = (r.law, _fixed(r.beta_deg, None), _fixed(r.u_t_plus, 4), _fixed(r.u_n_plus, 4),
                 _fixed(r.kappa, 4), _fixed(r.mu, 4), _fixed(r.energy_loss, 5))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _fixed(x: float, digits: int | None) -> str:
    """``x`` with ``digits`` decimals (``None``: shortest), never a negative zero ("-0.0000" is "0.0000")."""
    text = f"{x:g}" if digits is None else f"{x:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


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
    """Five panels against β: u_t+, u_n+, κ, μ = |P_t|/P_n, energy loss; a sixth holds the legend.

    Each law has its own line style and markers; curves of two laws that coincide in a panel are named in
    the legend. A κ that runs away near grazing incidence (the rough law's κ grows without bound there) is
    drawn on a log axis (or, with a κ ≤ 0, clipped to the range of the rest), with a note. The title gives ``title`` (the
    mechanism and frame), the approach speed and the laws with their parameters (their labels).

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

    quantities = [("u_t_plus", "tangential velocity u_t+ [m/s]"), ("u_n_plus", "normal velocity u_n+ [m/s]"),
                  ("kappa", "restitution κ = −u_n+ / u_n− [1]"), ("mu", "friction ratio μ = |P_t| / P_n [1]"),
                  ("energy_loss", "energy loss [J]")]
    laws = list(dict.fromkeys(r.law for r in rows))
    series = {law: [r for r in rows if r.law == law] for law in laws}
    fig, axes = plt.subplots(2, 3, figsize=(15, 8.4))
    flat = list(axes.ravel())
    notes: list[str] = []
    for ax, (attr, label) in zip(flat, quantities):
        values = {law: np.array([getattr(r, attr) for r in series[law]], dtype=float) for law in laws}
        for k, law in enumerate(laws):
            beta = [r.beta_deg for r in series[law]]
            n = max(1, len(beta))
            ax.plot(beta, values[law], ls=_STYLES[k % len(_STYLES)], marker=_MARKERS[k % len(_MARKERS)],
                    ms=5, markevery=(k * max(1, n // 8) // max(1, len(laws)), max(1, n // 8)),
                    lw=2.2 - 0.4 * (k % 3), color=f"C{k}", label=law)
        short = label.split(" [")[0].split(" = ")[0]
        every = np.concatenate(list(values.values())) if values else np.zeros(0)
        span = float(np.ptp(every[np.isfinite(every)])) if np.isfinite(every).any() else 0.0
        notes += [f"{short}: {a} and {b} coincide" for i, a in enumerate(laws) for b in laws[i + 1:]
                  if values[a].shape == values[b].shape and _coincide(values[a], values[b], span)]
        if attr == "kappa":
            note = _clip_outliers(ax, every)
            if note:
                notes.append(note)
        ax.set_title(label, fontsize=10)
        ax.set(xlabel="incidence β [deg]")
        ax.grid(alpha=0.3)
    legend = flat[5]
    legend.axis("off")
    handles, labels = flat[0].get_legend_handles_labels()
    legend.legend(handles, labels, loc="upper left", fontsize=9, title="laws", frameon=False)
    if notes:
        legend.text(0.0, 0.35, "\n".join(_wrap(n, 60) for n in notes), transform=legend.transAxes, fontsize=8,
                    va="top")
    speeds = sorted({r.speed for r in rows})
    head = str(title) + (": " if title else "") + "approach speed " + ", ".join(f"{v:g}" for v in speeds) + " m/s"
    fig.suptitle(head + "\n" + _wrap("; ".join(laws), 150), fontsize=11)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fig.savefig(path, dpi=100)
    except ValueError as exc:  # matplotlib's: an unknown format (suffix); its message lists the valid ones
        raise ParameterError(f"cannot write the plot {str(path)!r}: {exc}") from None
    finally:
        plt.close(fig)
    return path


_STYLES = ("-", "--", "-.", ":")
_MARKERS = ("o", "s", "^", "D", "v", "x", "+")


def _coincide(a: np.ndarray, b: np.ndarray, span: float) -> bool:
    """Whether two curves are indistinguishable on a panel whose values span ``span``: within 0.5 % of it
    everywhere (of their size, for a flat panel)."""
    scale = max(span, 1e-3 * float(np.max(np.abs(np.concatenate([a, b])), initial=0.0)), 1e-12)
    return bool(np.all(np.abs(a - b) <= 5e-3 * scale))


def _clip_outliers(ax: object, y: np.ndarray) -> str:
    """Keep a runaway tail of ``y`` (κ near grazing incidence) from flattening the panel: a log axis when
    every value is positive (nothing hidden), else the axis clipped to the bulk. Returns the note for it."""
    y = y[np.isfinite(y)]
    if y.size < 4:
        return ""
    lo, mid, hi = (float(v) for v in np.percentile(y, [0.0, 75.0, 100.0]))
    if hi <= mid + 3.0 * max(mid - lo, 1e-12):
        return ""
    if lo > 0.0:
        from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

        ax.set_yscale("log")  # type: ignore[attr-defined]
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))  # type: ignore[attr-defined]
        ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))  # type: ignore[attr-defined]
        ax.yaxis.set_minor_formatter(NullFormatter())  # type: ignore[attr-defined]
        return f"κ on a log axis: it runs from {lo:.3g} to {hi:.3g} (near grazing incidence)"
    top = float(np.percentile(y, 90.0))
    top += 0.1 * max(top - lo, 1e-9)
    ax.set_ylim(lo - 0.05 * (top - lo), top)  # type: ignore[attr-defined]
    return f"κ axis clipped at {top:.3g}: κ reaches {hi:.3g} near grazing incidence (see compare.csv)"


def _wrap(text: str, width: int) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width)) or text

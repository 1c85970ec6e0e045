"""``mbimpact fit DATA.csv``: fit impact laws to a data table and compare them side by side.

Every law family asked for (:data:`mbimpact.calibration.FAMILIES`; by default Newton's, Coulomb's,
and the rough law with Newton, Coulomb and compliant facets, plus plain compliant
facets) is fitted to the table by :func:`mbimpact.fit`; the command prints each law's
parameters ± standard errors and its RMS per column, and with ``--out DIR`` writes

* ``<table>_fit.csv`` — one row per law and parameter (value, error) and per column (RMS);
* ``<table>_predictions.csv`` — every law's predictions on a fine grid of incidences;
* ``<table>_fit.png`` — the data against the fitted laws, one panel per column, plus the
  contact point's tangential restitution (where only compliance produces a reversal).

Wiring (in :mod:`mbimpact.apps.cli`): ``add_parser(subparsers)``; the parser's default
``func`` is :func:`run`.
"""

from __future__ import annotations

import argparse
import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError

__all__ = ["DEFAULT_LAWS", "Skipped", "fit_laws", "format_report", "best_per_column", "write_csv",
           "write_predictions", "fit_figure", "plot", "add_parser", "run"]

#: The families compared when ``--law`` is not given.
DEFAULT_LAWS = ("newton", "coulomb", "rough-newton", "rough-coulomb", "compliant", "rough-compliant")


@dataclass(frozen=True)
class Skipped:
    """A law family that could not be fitted to the table, and why."""

    label: str
    reason: str


def fit_laws(table: Any, laws: tuple[str, ...], body: Any = None, speed: float | None = None,
             starts: int | None = None, seed: int | None = 0, progress: bool = False) -> list[Any]:
    """:func:`mbimpact.fit` of every family in ``laws``.

    Parameters
    ----------
    table : ImpactTable
    laws : tuple of str
        Family names (:data:`mbimpact.calibration.FAMILIES`).
    body, speed, starts, seed
        As for :func:`mbimpact.fit`.
    progress : bool
        Draw a progress bar (per law and starting point) on stderr when it is a terminal.

    Returns
    -------
    list
        A :class:`~mbimpact.calibration.Fit` or a :class:`Skipped` per law, in the order of ``laws``.
    """
    from ..calibration import FitError, fit
    from .progress import Progress

    # each law gets the same share of the bar, split evenly between its starting points
    share = 12
    bar = Progress(share * len(laws), f"fitting {len(laws)} law(s)", enabled=progress)
    out: list[Any] = []
    try:
        for k, name in enumerate(laws):
            def advance(done: int, total: int, k: int = k, name: str = name) -> None:
                target = k * share + (share * done) // total
                while bar.done < target:
                    bar.step(f"{name} {done}/{total}")

            try:
                out.append(fit(table, name, body, speed=speed, starts=starts, seed=seed, progress=advance))
            except FitError as exc:
                if "speed" in str(exc):  # a speed-dependent law on a table without speeds: say so, go on
                    out.append(Skipped(name, str(exc)))
                else:
                    raise
            advance(1, 1)
    finally:
        bar.close()
    return out


def format_report(table: Any, fits: list[Any]) -> str:
    """Each law's parameters ± errors and RMS per column, then a side-by-side RMS table."""
    lines = [f"{table.name}: {len(table)} rows, columns {', '.join(table.quantities)}"]
    if table.source():
        lines.append(f"source: {table.source()}")
    lines.append("")
    done = [f for f in fits if not isinstance(f, Skipped)]
    for f in fits:
        lines.append(f"{f.label}: skipped — {f.reason}" if isinstance(f, Skipped) else f.summary())
        lines.append("")
    if done:
        cols = done[0].quantities
        head = f"{'law':22s}" + "".join(f"{'rms ' + q:>18s}" for q in cols) + f"{'rms (all)':>12s}"
        lines += [head, "-" * len(head)]
        for f in done:
            lines.append(f"{f.label:22s}" + "".join(f"{f.quantity_rms[q]:18.4g}" for q in cols) + f"{f.rms:12.4g}")
        lines += ["", best_per_column(fits)]
    return "\n".join(lines)


def write_csv(fits: list[Any], path: Path) -> Path:
    """One row per law and parameter (kind ``param``: value, stderr) and per column (kind ``rms``)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["law", "kind", "name", "value", "stderr", "note"])
        for f in fits:
            if isinstance(f, Skipped):
                w.writerow([f.label, "skipped", "", "", "", f.reason])
                continue
            for name, value in f.params.items():
                free = name in f.free
                w.writerow([f.label, "param", name, f"{value:.8g}", f"{f.stderr[name]:.3g}" if free else "",
                            "on its bound" if name in f.at_bound else ("" if free else "fixed")])
            for q, r in f.quantity_rms.items():
                w.writerow([f.label, "rms", q, f"{r:.6g}", "", ""])
            w.writerow([f.label, "rms", "all (dimensionless)", f"{f.rms:.6g}", "", ""])
    return path


def _grid(table: Any) -> np.ndarray:
    top = min(88.0, float(np.max(table.theta_deg)) + 3.0)
    return np.linspace(0.5, max(top, 10.0), 120)


def write_predictions(table: Any, fits: list[Any], path: Path) -> Path:
    """Every fitted law's predictions on a grid of incidences (columns ``<law>:<quantity>``)."""
    grid = _grid(table)
    done = [f for f in fits if not isinstance(f, Skipped)]
    preds = [f.predict(grid) for f in done]
    names = [(f.label, q) for f, p in zip(done, preds) for q in p]
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["theta_deg"] + [f"{label}:{q}" for label, q in names])
        for i, theta in enumerate(grid):
            row = [f"{theta:.6g}"]
            for p in preds:
                row += [f"{p[q][i]:.8g}" for q in p]
            w.writerow(row)
    return path


#: Line styles of the fitted laws: colour, dash pattern and marker all differ, so that laws whose
#: curves coincide stay visible (their markers are placed at different incidences).
STYLES = (("C0", "-", "o"), ("C1", "--", "s"), ("C2", "-.", "^"), ("C3", ":", "v"), ("C4", (0, (5, 1)), "D"),
          ("C5", (0, (3, 1, 1, 1)), "P"), ("C6", (0, (1, 1)), "X"), ("C7", "-", "*"), ("C8", "--", "h"))


def _coinciding(labels: list[str], curves: list[np.ndarray], tol: float) -> list[list[str]]:
    """Groups (two or more) of laws whose curves differ by at most ``tol`` everywhere."""
    groups: list[list[int]] = []
    for i, c in enumerate(curves):
        for g in groups:
            ref = curves[g[0]]
            both = np.isfinite(c) & np.isfinite(ref)
            if both.any() and np.array_equal(np.isfinite(c), np.isfinite(ref)) and np.max(np.abs(c - ref)[both]) <= tol:
                g.append(i)
                break
        else:
            groups.append([i])
    return [[labels[i] for i in g] for g in groups if len(g) > 1]


def _describe(table: Any, body: Any) -> str:
    """The conditions of the table for a title: body and impact speed."""
    from ..calibration import Ball

    if isinstance(body, Ball):
        what = f"ball of radius {body.radius * 1e3:.4g} mm and mass {body.mass * 1e3:.4g} g"
    else:
        what = "point mass"
    speeds = np.unique(np.asarray(table.speed, dtype=float)) if table.speed is not None else np.array([])
    speeds = speeds[np.isfinite(speeds)]
    if speeds.size == 1:
        what += f", impact speed {speeds[0]:.3g} m/s"
    elif speeds.size > 1:
        what += f", impact speeds {speeds.min():.3g} to {speeds.max():.3g} m/s"
    return what + ", no initial spin"


def fit_figure(table: Any, fits: list[Any]) -> Any:
    """Data against the fitted laws: one panel per column, plus the contact point's tangential
    restitution; one legend for all panels (every law with its RMS per column).

    Returns
    -------
    matplotlib.figure.Figure
        Each panel's title names the laws whose curves coincide there and those that leave its axes.
    """
    from matplotlib.figure import Figure

    from ..calibration import QUANTITIES, Ball

    done = [f for f in fits if not isinstance(f, Skipped)]
    panels = list(table.quantities) + (["et_cp"] if "et_cp" not in table.quantities else [])
    grid = _grid(table)
    preds = [f.predict(grid) for f in done]
    ncol = min(3, len(panels))
    nrow = math.ceil(len(panels) / ncol)
    fig = Figure(figsize=(5.6 * ncol, 4.2 * nrow + 1.4), layout="constrained")
    axes = fig.subplots(nrow, ncol, squeeze=False)
    body = done[0].body if done else table.body()
    for ax, q in zip(axes.flat, panels):
        unit = QUANTITIES[q].unit
        notes = []
        drawn = [(f, p[q]) for f, p in zip(done, preds) if q in p]
        for k, (f, y) in enumerate(drawn):
            color, dash, marker = STYLES[done.index(f) % len(STYLES)]
            ax.plot(grid, y, color=color, linestyle=dash, lw=1.5, marker=marker, ms=5, mfc="none",
                    markevery=(3 * done.index(f) % 18, 18), label=f.label)
        if q in table.quantities:
            y = table.values(q)
            ok = ~np.isnan(y)
            ax.plot(table.theta_deg[ok], y[ok], "ko", ms=5, label="data", zorder=5)
            # the data set the scale: predictions may leave it (κ of a rough law near grazing), up to twice its span
            lo, hi = float(np.min(y[ok])), float(np.max(y[ok]))
            span = max(hi - lo, 0.05 * max(abs(lo), abs(hi)), 1e-3)
            inside = (grid >= table.theta_deg[ok].min()) & (grid <= table.theta_deg[ok].max())
            shown = [v[inside] for _, v in drawn if inside.any()]
            plo = min([lo] + [float(np.nanmin(v)) for v in shown if np.isfinite(v).any()])
            phi = max([hi] + [float(np.nanmax(v)) for v in shown if np.isfinite(v).any()])
            ax.set_ylim(max(plo, lo - 2 * span) - 0.08 * span, min(phi, hi + 2 * span) + 0.08 * span)
            bottom, top = ax.get_ylim()
            for f, v in drawn:
                part = v[inside & np.isfinite(v)]
                if part.size and (part.min() < bottom or part.max() > top):
                    notes.append(f"{f.label} leaves the axes: {part.min():.3g} to {part.max():.3g}"
                                 f"{' ' + unit if unit else ''} over the data's θ")
        if q in ("et", "et_cp") and isinstance(body, Ball):
            if q == "et":  # angular momentum about the contact point: v_t+ = v_t- m R² / (m R² + I)
                roll = body.mass * body.radius**2 / (body.mass * body.radius**2 + float(body.inertia or 0.0))
                ax.axhline(roll, color="0.4", lw=0.9, ls=":",
                           label=f"{roll:.3g}{' = 5/7' if abs(roll - 5 / 7) < 1e-9 else ''}: the ball ends rolling")
            else:
                ax.axhline(0.0, color="0.4", lw=0.9, ls=":", label="0: the contact point ends at rest (rolling)")
        span = float(np.subtract(*ax.get_ylim()[::-1]))
        groups = _coinciding([f.label for f, _ in drawn], [v for _, v in drawn], 0.01 * span)
        notes = [" = ".join(g) + " coincide" for g in groups] + notes
        ax.set_title("\n".join([f"{q}: {QUANTITIES[q].description}" + ("" if q in table.quantities else " (no data)")]
                               + notes), fontsize=9)
        ax.set_xlabel("incidence from the normal θ [deg]")
        ax.set_ylabel(f"{q} [{unit or '–'}]")
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(panels):]:
        ax.set_visible(False)
    handles: dict[str, Any] = {}
    for ax in axes.flat:
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    rms = {f.label: ", ".join(f"{q} {r:.3g}" for q, r in f.quantity_rms.items()) for f in done}
    names = [f"{label} (rms: {rms[label]})" if label in rms else label for label in handles]
    fig.legend(list(handles.values()), names, loc="outside lower center", ncols=min(3, len(names)), fontsize=8)
    fig.suptitle(f"{table.name}: impact laws fitted by least squares ({_describe(table, body)})\n"
                 + best_per_column(fits), fontsize=10)
    return fig


def plot(table: Any, fits: list[Any], path: Path) -> Path:
    """Write :func:`fit_figure` to ``path`` (PNG)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fit_figure(table, fits).savefig(path, dpi=130)
    return path


def best_per_column(fits: list[Any]) -> str:
    """The line that names the best law per column, e.g. ``kappa: rough-coulomb (rms 0.091); et: compliant ...``."""
    done = [f for f in fits if not isinstance(f, Skipped)]
    if not done:
        return ""
    parts = []
    for q in done[0].quantities:
        best = min(done, key=lambda f: f.quantity_rms[q])
        parts.append(f"{q}: {best.label} (rms {best.quantity_rms[q]:.3g})")
    overall = min(done, key=lambda f: f.rms)
    return "best fit per column — " + "; ".join(parts) + f"; all columns: {overall.label}"


def _laws(text: list[str] | None) -> tuple[str, ...]:
    from ..calibration import FAMILIES

    if not text:
        return DEFAULT_LAWS
    names = tuple(n.strip() for item in text for n in item.split(",") if n.strip())
    bad = [n for n in names if n not in FAMILIES]
    if bad:
        raise ParameterError(f"unknown law(s) {bad}; valid: {', '.join(FAMILIES)}")
    return names


def _seed(text: str) -> int:
    """An argument type: an integer ≥ 0 (numpy's generator refuses a negative seed with a bare ValueError)."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if n < 0:
        raise argparse.ArgumentTypeError(f"must be an integer ≥ 0, got {n}")
    return n


def _plain(text: str) -> str:
    """Docstring text for a terminal: ``literal`` and :role:`target` markup reduced to their words."""
    text = re.sub(r":[a-z]+:`~?([^`]+)`", r"\1", text)
    return " ".join(re.sub(r"``([^`]+)``", r"\1", text).split())


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``mbimpact fit`` on the CLI's subparsers; its ``func`` is :func:`run`."""
    from ..calibration import FAMILIES

    p = subparsers.add_parser("fit", help="fit impact laws to a data table (CSV) and compare them",
                              description=_plain(__doc__.split("\n\n")[0]) if __doc__ else None)
    p.add_argument("data", help="table CSV (see mbimpact.calibration.table), or a shipped name: kharaz2001, "
                                "grant_tabakoff1975")
    p.add_argument("--law", action="append",
                   help="law families to fit, comma-separated or repeated (default: "
                        f"{', '.join(DEFAULT_LAWS)}; all: {', '.join(FAMILIES)})")
    p.add_argument("--body", help="'sphere radius=R mass=m' or 'point' (default: the table's body line)")
    p.add_argument("--speed", type=float, help="impact speed (m/s) when the table has no speed column")
    p.add_argument("--starts", type=int, help="starting points per fit (default: 1 convex, 4 otherwise)")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the random starting points (an integer ≥ 0)")
    p.add_argument("--out", help="directory for <table>_fit.csv, <table>_predictions.csv and <table>_fit.png")
    p.add_argument("--no-progress", action="store_true", help="do not draw the progress bar")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Fit, print, and write the outputs of ``mbimpact fit``; 0 on success."""
    from ..calibration import ImpactTable

    table = ImpactTable.from_csv(args.data)
    body = None
    if args.body:
        body = ImpactTable(table.theta_deg, table.columns, table.speed, {"body": args.body}, table.name).body()
    if args.speed is not None and not (math.isfinite(args.speed) and args.speed > 0):
        raise ParameterError(f"--speed must be a positive number of m/s, got {args.speed}")
    if args.starts is not None and args.starts < 1:
        raise ParameterError(f"--starts must be ≥ 1, got {args.starts}")
    fits = fit_laws(table, _laws(args.law), body, args.speed, args.starts, args.seed,
                    progress=not getattr(args, "no_progress", False))
    print(format_report(table, fits))
    if args.out:
        out = Path(args.out)
        print()
        print(f"wrote {write_csv(fits, out / f'{table.name}_fit.csv')}")
        print(f"wrote {write_predictions(table, fits, out / f'{table.name}_predictions.csv')}")
        print(f"wrote {plot(table, fits, out / f'{table.name}_fit.png')}")
    return 0

"""``mbimpact run SCENE``: simulate a scene, summarise it, write CSV and PNG files."""

from __future__ import annotations

import csv
import math
from dataclasses import asdict, fields
from pathlib import Path

import numpy as np

from ..mechanism import state_units
from ..simulation.scene import Scene
from ..simulation.trajectory import ContactEvent, Trajectory

__all__ = ["summary", "rest_lines", "write_outputs", "state_unit"]


def summary(scene: Scene, tr: Trajectory) -> str:
    """A few lines: status, events, energy, which contacts came to rest and when, limits, what was computed."""
    impacts = [e for e in tr.events if e.kind == "impact"]
    lines = [f"scene {scene.name}: {scene.mechanism.name}, {len(scene.contacts)} contact(s), {scene.duration:g} s",
             tr.summary()]
    lines += rest_lines(scene, tr)
    if impacts:
        k = np.array([e.kappa for e in impacts])
        mu = np.array([e.mu for e in impacts])
        lines.append(f"kappa in [{k.min():.4g}, {k.max():.4g}], mu in [{mu.min():.4g}, {mu.max():.4g}]")
    lines.append("work: " + ", ".join(f"{k}={v}" for k, v in sorted(tr.work.items())))
    return "\n".join(lines)


def rest_lines(scene: Scene, tr: Trajectory) -> list[str]:
    """What came to rest: per contact, when its bounces ended in persistent contact (and until when), with
    the mechanism's fastest joint then; a contact at rest presses on its surface, and may still slide,
    while the rest of the mechanism moves on."""
    lines = []
    for i, contact in enumerate(scene.contacts):
        rests = [e.t for e in tr.events if e.kind == "rest" and e.contact == i]
        lifts = [e.t for e in tr.events if e.kind == "lift" and e.contact == i]
        spans = []
        for t in rests:
            lift = next((x for x in lifts if x > t), None)
            spans.append(f"at t = {t:.6g} s " + (f"until it lifted off at t = {lift:.6g} s" if lift is not None
                                                   else "and stayed on it to the end"))
        if spans:
            lines.append(f"contact {i} ({contact.label}) came to rest on its surface (bounces ended, Zeno tail "
                         f"included; persistent contact, it may still slide) {'; again '.join(spans)}; "
                         f"the mechanism then: {_fastest(scene, tr, rests[0])}")
    if lines:
        lines.append(f"(rest: rebound below rest_velocity = {scene.rest_velocity:g} m/s or bounces closer than "
                     f"chatter_time = {scene.chatter_time:g} s)")
        lines.append(f"the mechanism at the end (t = {tr.t[-1]:.6g} s): {_fastest(scene, tr, float(tr.t[-1]))}")
    return lines


def _fastest(scene: Scene, tr: Trajectory, t: float) -> str:
    """The fastest joint coordinate at the last sample at or before ``t`` (an event's time holds the states
    before and after it: the one after), per unit (m/s and rad/s apart)."""
    k = max(int(np.searchsorted(tr.t, t, side="right")) - 1, 0)
    _, units = state_units(scene.mechanism.model)
    parts = []
    for unit in dict.fromkeys(u for u in units if u):
        idx = [j for j, u in enumerate(units) if u == unit]
        j = idx[int(np.argmax(np.abs(tr.v[k, idx])))]
        parts.append(f"|v{j}| = {abs(float(tr.v[k, j])):.3g} {unit}")
    return "fastest joint coordinate " + ", ".join(parts) if parts else "no joint speed known"


def state_unit(scene: Scene, name: str) -> str:
    """The unit of a recorded state ``q3``/``v0``, from the type of the joint it belongs to (m or rad, m/s
    or rad/s; ``"1"`` for a quaternion component or the cosine or sine of an unbounded revolute joint)."""
    q_units, v_units = state_units(scene.mechanism.model)
    units = q_units if name[0] == "q" else v_units
    index = int(name[1:])
    return units[index] if 0 <= index < len(units) else ""


def write_outputs(scene: Scene, tr: Trajectory, out: str | Path) -> list[Path]:
    """trajectory.csv, events.csv and plots.png in ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    nq, nv, nc = scene.mechanism.nq, scene.mechanism.nv, len(scene.contacts)
    traj = out / "trajectory.csv"
    with traj.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t"] + [f"q{i}" for i in range(nq)] + [f"v{i}" for i in range(nv)] + ["energy"]
                   + [f"gap{i}" for i in range(nc)] + [f"gap_rate{i}" for i in range(nc)]
                   + [f"active{i}" for i in range(nc)] + [f"force{i}_{a}" for i in range(nc) for a in "xyz"])
        for k in range(len(tr.t)):
            w.writerow([tr.t[k], *tr.q[k], *tr.v[k], tr.energy[k], *tr.gaps[k], *tr.gap_rates[k],
                        *(int(a) for a in tr.active[k]), *tr.forces[k].ravel()])
    log = out / "events.csv"
    with log.open("w", newline="") as fh:
        names = [f.name for f in fields(ContactEvent) if f.name != "point"]
        dw = csv.DictWriter(fh, fieldnames=names + ["point_x", "point_y", "point_z"])
        dw.writeheader()
        for e in tr.events:
            row = {k: v for k, v in asdict(e).items() if k != "point"}
            point = e.point if e.point is not None else (math.nan,) * 3
            row.update(point_x=point[0], point_y=point[1], point_z=point[2])
            dw.writerow(row)
    png = plot(scene, tr, out / "plots.png")
    return [traj, log, png]


# what a recorded coordinate of each unit is, for the panel titles
_KIND = {"m": "positions", "rad": "angles", "1": "quaternion / cos-sin components", "m/s": "linear velocities",
         "rad/s": "angular velocities", "": "coordinates of unknown unit"}
_STYLES = ("-", "--", "-.", ":")
_MARKERS = ("", "o", "s", "^", "v", "D", "x", "+")


def plot(scene: Scene, tr: Trajectory, path: Path) -> Path:
    """The run's panels: the energy against its initial value, the contacts' normal velocities and gaps,
    one panel per unit of the recorded states. Curves that coincide are drawn once, their labels joined."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nc = len(scene.contacts)
    groups: dict[str, list[str]] = {}
    for name in scene.record:
        groups.setdefault(state_unit(scene, name), []).append(name)
    # the contacts that took part in an event (a robot paired with the ground by "all" has many contacts that
    # never do), at most eight
    shown = [i for i in range(nc) if any(e.contact == i for e in tr.events)][:8] or list(range(min(nc, 8)))
    panels = 1 + 2 * bool(shown) + len(groups)
    cols = min(panels, 3)
    rows = -(-panels // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.8 * cols, 3.8 * rows), squeeze=False)
    flat = list(axes.ravel())
    e0 = float(tr.energy[0])
    what = "kinetic + gravitational potential (zero at world z = 0)" if scene.gravity else "kinetic"
    flat[0].plot(tr.t, tr.energy - e0)
    flat[0].set(xlabel="t [s]", ylabel="E(t) − E(0) [J]",
                title=f"energy relative to its initial value\nE(0) = {e0:.4g} J, {what}")
    slot = 1
    if shown:
        labels = [f"{i}: {scene.contacts[i].label}" for i in shown]
        _curves(flat[1], tr.t, [tr.gap_rates[:, i] for i in shown], labels)
        flat[1].set(xlabel="t [s]", ylabel="normal velocity [m/s]",
                    title="relative normal velocity of the contacts\n(< 0 approaching)")
        ax = flat[2]
        _curves(ax, tr.t, [tr.gaps[:, i] for i in shown], labels)
        ax.axhline(-tr.tolerance, color="C3", lw=0.6, ls=":", label=f"−tolerance ({tr.tolerance:g} m)")
        hits = [e.t for e in tr.events if e.kind == "impact" and e.contact in shown]
        if hits:
            ax.plot(hits, np.zeros(len(hits)), "|", color="k", ms=8, label="impacts")
        ax.set(xlabel="t [s]", ylabel="gap [m]", title="gaps of the contacts")
        ax.legend(fontsize=7)
        slot = 3
    for k, (unit, names) in enumerate(groups.items()):
        ax = flat[slot + k]
        series = [tr.q[:, int(n[1:])] if n[0] == "q" else tr.v[:, int(n[1:])] for n in names]
        _curves(ax, tr.t, series, [_describe(scene, n) for n in names])
        ax.set(xlabel="t [s]", ylabel=f"[{unit}]" if unit else "", title=f"recorded {_KIND.get(unit, unit)}")
    for ax in flat[panels:]:
        ax.axis("off")
    fig.suptitle(f"{scene.name}: {scene.mechanism.name}, {nc} contact(s), {tr.status}")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def _describe(scene: Scene, name: str) -> str:
    """``q7 (FL_HFE)``: a recorded coordinate and the joint it belongs to."""
    model = scene.mechanism.model
    index = int(name[1:])
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        start, size = (joint.idx_q, joint.nq) if name[0] == "q" else (joint.idx_v, joint.nv)
        if start <= index < start + size:
            part = f"[{index - start}]" if size > 1 else ""
            return f"{name} ({model.names[jid]}{part})"
    return name


def _curves(ax: object, t: np.ndarray, series: list[np.ndarray], labels: list[str]) -> None:
    """Draw each distinct curve once, with its own line style and markers; the labels of curves that
    coincide (to 0.1 % of the panel's range) are joined, marked "coincide"."""
    span = max((float(np.ptp(y)) for y in series), default=0.0)
    tol = 1e-3 * span if span > 0 else 1e-12
    drawn: list[tuple[np.ndarray, list[str]]] = []
    for y, label in zip(series, labels):
        for y0, names in drawn:
            if float(np.max(np.abs(y - y0))) <= tol:
                names.append(label)
                break
        else:
            drawn.append((y, [label]))
    every = max(1, len(t) // 12)
    for k, (y, names) in enumerate(drawn):
        text = ", ".join(names) + (" (coincide)" if len(names) > 1 else "")
        ax.plot(t, y, ls=_STYLES[k % len(_STYLES)], marker=_MARKERS[k % len(_MARKERS)],  # type: ignore[attr-defined]
                markevery=(k * every // max(len(drawn), 1), every), ms=4, label=text)
    ax.legend(fontsize=7)  # type: ignore[attr-defined]

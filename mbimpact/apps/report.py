"""``mbimpact run SCENE``: simulate a scene, summarise it, write CSV and PNG files."""

from __future__ import annotations

import csv
import math
from dataclasses import asdict, fields
from pathlib import Path

import numpy as np

from ..simulation.scene import Scene
from ..simulation.trajectory import ContactEvent, Trajectory

__all__ = ["summary", "write_outputs", "state_unit"]


def summary(scene: Scene, tr: Trajectory) -> str:
    """A few lines: status, events, energy, rest, limits, what was computed."""
    impacts = [e for e in tr.events if e.kind == "impact"]
    lines = [f"scene {scene.name}: {scene.mechanism.name}, {len(scene.contacts)} contact(s), {scene.duration:g} s",
             tr.summary()]
    rest = tr.first_rest_time()
    if rest is not None:
        lines.append(f"came to rest at t = {rest:.9g} s (Zeno tail included; rebound below rest_velocity = "
                     f"{scene.rest_velocity:g} m/s or bounces closer than chatter_time = {scene.chatter_time:g} s)")
    if impacts:
        k = np.array([e.kappa for e in impacts])
        mu = np.array([e.mu for e in impacts])
        lines.append(f"kappa in [{k.min():.4g}, {k.max():.4g}], mu in [{mu.min():.4g}, {mu.max():.4g}]")
    lines.append("work: " + ", ".join(f"{k}={v}" for k, v in sorted(tr.work.items())))
    return "\n".join(lines)


def state_unit(scene: Scene, name: str) -> str:
    """The unit of a recorded state ``q3``/``v0``: m or rad (m/s or rad/s), from the joint it belongs to
    (a quaternion component has none)."""
    model = scene.mechanism.model
    kind, index = name[0], int(name[1:])
    for joint in model.joints[1:]:
        start, size = (joint.idx_q, joint.nq) if kind == "q" else (joint.idx_v, joint.nv)
        if start <= index < start + size:
            short = joint.shortname()
            offset = index - start
            if "Prismatic" in short or "Translation" in short:
                linear = True
            elif "FreeFlyer" in short or "Planar" in short:
                linear = offset < (3 if "FreeFlyer" in short else 2)
                if kind == "q" and not linear and "FreeFlyer" in short:
                    return "1"  # quaternion
            else:
                linear = False
            return ("m" if linear else "rad") + ("" if kind == "q" else "/s")
    return ""


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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups: dict[str, list[str]] = {}
    for name in scene.record:
        groups.setdefault(state_unit(scene, name), []).append(name)
    # a gap panel per contact that took part in an event (a robot paired with the ground by "all" has many
    # contacts that never do), at most eight
    shown = [i for i in range(nc) if any(e.contact == i for e in tr.events)][:8] or list(range(min(nc, 8)))
    panels = 2 + len(shown) + len(groups)
    cols = min(panels, 3)
    rows = -(-panels // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.5 * cols, 3.4 * rows), squeeze=False)
    flat = list(axes.ravel())
    flat[0].plot(tr.t, tr.energy)
    flat[0].set(xlabel="t [s]", ylabel="energy [J]", title="mechanical energy")
    for i in shown:
        flat[1].plot(tr.t, tr.gap_rates[:, i], label=f"{i}: {scene.contacts[i].label}")
    flat[1].set(xlabel="t [s]", ylabel="[m/s]", title="relative normal velocity of the contacts")
    flat[1].legend(fontsize=7)
    for slot, i in enumerate(shown):
        ax = flat[2 + slot]
        ax.plot(tr.t, tr.gaps[:, i])
        ax.axhline(-tr.tolerance, color="C3", lw=0.6, ls=":")
        for e in tr.events:
            if e.contact == i and e.kind == "impact":
                ax.axvline(e.t, color="0.8", lw=0.5)
        ax.set(xlabel="t [s]", ylabel="gap [m]", title=f"contact {i} ({scene.contacts[i].label}): gap")
    for k, (unit, names) in enumerate(groups.items()):
        ax = flat[2 + len(shown) + k]
        for name in names:
            series = tr.q[:, int(name[1:])] if name[0] == "q" else tr.v[:, int(name[1:])]
            ax.plot(tr.t, series, label=name)
        ax.set(xlabel="t [s]", ylabel=f"[{unit}]" if unit else "", title="recorded states")
        ax.legend(fontsize=7)
    for ax in flat[panels:]:
        ax.axis("off")
    fig.suptitle(f"{scene.name}: {tr.status}")
    fig.tight_layout()
    png = out / "plots.png"
    fig.savefig(png, dpi=90)
    plt.close(fig)
    return [traj, log, png]

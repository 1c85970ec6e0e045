"""``mbimpact run SCENE``: simulate a scene, summarise, write CSV and PNG files."""

from __future__ import annotations

import csv
from dataclasses import asdict, fields
from pathlib import Path

import numpy as np

from ..simulation.scene import Scene
from ..simulation.simulator import ImpactRecord, Trajectory

__all__ = ["summary", "write_outputs"]


def summary(scene: Scene, tr: Trajectory) -> str:
    """A few lines: duration, impacts, energy, rest, what was computed."""
    lines = [
        f"scene {scene.name}: {scene.mechanism.name}, {len(scene.contacts)} contact(s), {scene.duration:g} s, status {tr.status}",
        f"impacts: {len(tr.impacts)}; energy {tr.energy[0]:.6g} J → {tr.energy[-1]:.6g} J",
    ]
    rest = tr.first_rest_time()
    if rest is not None:
        lines.append(f"came to rest at t = {rest:.6g} s (rebound below rest_velocity = {scene.rest_velocity:g} m/s)")
    if tr.impacts:
        k = np.array([r.kappa for r in tr.impacts if r.kappa != 0.0] or [0.0])
        mu = np.array([r.mu for r in tr.impacts])
        lines.append(f"kappa in [{k.min():.4g}, {k.max():.4g}], mu in [{mu.min():.4g}, {mu.max():.4g}]")
    lines.append("work: " + ", ".join(f"{k}={v}" for k, v in sorted(tr.work.items())))
    return "\n".join(lines)


def write_outputs(scene: Scene, tr: Trajectory, out: str | Path) -> list[Path]:
    """trajectory.csv, impacts.csv and plots.png in ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    nq, nv, nc = scene.mechanism.nq, scene.mechanism.nv, len(scene.contacts)
    traj = out / "trajectory.csv"
    with traj.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t"] + [f"q{i}" for i in range(nq)] + [f"v{i}" for i in range(nv)] + ["energy"]
                   + [f"gap{i}" for i in range(nc)] + [f"gap_rate{i}" for i in range(nc)])
        for row in zip(tr.t, tr.q, tr.v, tr.energy, tr.gaps, tr.gap_rates):
            w.writerow([row[0], *row[1], *row[2], row[3], *row[4], *row[5]])
    log = out / "impacts.csv"
    with log.open("w", newline="") as fh:
        dw = csv.DictWriter(fh, fieldnames=[f.name for f in fields(ImpactRecord)])
        dw.writeheader()
        for r in tr.impacts:
            dw.writerow(asdict(r))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = 2 + (1 if scene.record else 0)
    fig, axes = plt.subplots(1, panels, figsize=(6 * panels, 4))
    axes[0].plot(tr.t, tr.energy)
    axes[0].set(xlabel="t [s]", ylabel="energy [J]", title="mechanical energy")
    for i in range(nc):
        axes[1].plot(tr.t, tr.gap_rates[:, i], label=f"contact {i} ({scene.contacts[i].frame})")
    axes[1].set(xlabel="t [s]", ylabel="normal velocity [m/s]", title="contact-normal velocity")
    axes[1].legend(fontsize=8)
    if scene.record:
        for name in scene.record:
            series = tr.q[:, int(name[1:])] if name[0] == "q" else tr.v[:, int(name[1:])]
            axes[2].plot(tr.t, series, label=name)
        axes[2].set(xlabel="t [s]", title="recorded states")
        axes[2].legend(fontsize=8)
    fig.tight_layout()
    png = out / "plots.png"
    fig.savefig(png, dpi=100)
    plt.close(fig)
    return [traj, log, png]

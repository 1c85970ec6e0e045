"""The bench's report: markdown tables, CSV, and the figure."""

from __future__ import annotations

import csv
import re
from dataclasses import asdict
from pathlib import Path

from .common import BenchRow, machine_summary

__all__ = ["format_report", "write_csv", "plot"]


def _table(title: str, header: str, lines: list[str]) -> list[str]:
    """A markdown section: title, header row with its separator, then the lines."""
    cols = header.count("|") - 1
    return ["", title, "", header, "|" + "---|" * cols, *lines]


def format_report(rows: list[BenchRow]) -> str:
    """Markdown tables of the parts that ran: accuracy, overhead ratios, compliant route, batches,
    geometry, scenes and MuJoCo."""
    def part(name: str) -> list[BenchRow]:
        return [r for r in rows if r.part == name]

    def blank0(x: float) -> str:
        return "" if x == 0 else f"{x:g}"

    out = [f"Machine: {machine_summary()}"]
    if part("accuracy"):
        out += _table("## Accuracy vs time (cone alpha=0.4, e=0.5; relative error of Δu = W P against a 1024-node "
                      "exact-arc quadrature, graded for the near-singular posture; Gaussian slopes against the "
                      "graded rule with 128 nodes)",
                      "| case | method | nodes/samples | rel. error | µs/impact |",
                      [f"| {r.case} | {r.method} | {blank0(r.param)} | {r.error:.2e} | {r.seconds * 1e6:.1f} |"
                       for r in part("accuracy")])
    if part("overhead"):
        out += _table("## Per-call cost against Pinocchio (same q, v, one run)",
                      "| robot | nv | call | µs | ratio to Jacobian + impulseDynamics |",
                      [f"| {r.case} | {r.param:g} | {r.method} | {r.seconds * 1e6:.1f} | {r.ratio:.1f} |"
                       for r in part("overhead")])
    if part("compliant"):
        out += _table("## Compliant route: resolved Kelvin–Voigt impact vs the closed law (UR5, one facet, e=0.5)",
                      "| tolerance | method | M | rel. error vs closed law | µs | time / closed law (batched) |",
                      [f"| {r.case} | {r.method} | {blank0(r.param)} | {r.error:.2e} | {r.seconds * 1e6:.3g} | {r.ratio:.3g} |"
                       for r in part("compliant")])
    if part("batch"):
        out += _table("## Batch throughput (apply_batch, one configuration)",
                      "| robot | law | nodes | impacts/s | µs/impact |",
                      [f"| {r.case} | {r.method} | {blank0(r.param)} | {r.ratio:.3g} | {r.seconds * 1e6:.2f} |"
                       for r in part("batch")])
    if part("configurations"):
        out += _table("## Batches across configurations (impact_batch, one velocity per configuration)",
                      "| case | call | threads | impacts/s | µs/impact | time / Pinocchio loop |",
                      [f"| {r.case} | {r.method} | {r.param:g} | {1.0 / r.seconds:.3g} | {r.seconds * 1e6:.2f} | "
                       f"{r.ratio:.2f} |" for r in part("configurations")])
    if part("coulomb"):
        out += _table("## Coulomb impact against Pinocchio's conic solvers (UR5, plastic, same q and v)",
                      "| case | call | µs | ratio to Jacobian + impulseDynamics | relative difference of P from ours |",
                      [f"| {r.case} | {r.method} | {r.seconds * 1e6:.1f} | {r.ratio:.1f} | {blank0(r.error)} |"
                       for r in part("coulomb") if not r.case.startswith("JIT")])
        out += _table("## Compiled kernels: first calls of a process (fresh interpreter)", "| case | what | s |",
                      [f"| {r.case} | {r.method} | {r.seconds:.2f} |" for r in part("coulomb") if r.case.startswith("JIT")])
    if part("threads"):
        out += _table("## Batches under both BLAS thread settings (UR5, one configuration, fresh interpreters)",
                      "| setting | call | rows | impacts/s |",
                      [f"| {r.case} | {r.method} | {r.param:g} | {r.ratio:.3g} |" for r in part("threads")])
    if part("import"):
        out += _table("## Import", "| case | call | s |",
                      [f"| {r.case} | {r.method} | {r.seconds:.3f} |" for r in part("import")])
    if part("geometry"):
        out += _table("## Collision geometry: cost of a gap query per contact pair against one rough-law impact",
                      "| mechanism | query | pairs | µs | ratio to one rough impact |",
                      [f"| {r.case} | {r.method} | {r.param:g} | {r.seconds * 1e6:.2f} | {r.ratio:.3f} |"
                       for r in part("geometry")])
    if part("scenes"):
        out += _table("## Shipped scenes (full simulation of each)",
                      "| scene | simulator (status) | impacts | wall s | simulated s per wall s | impacts per wall s "
                      "| deepest penetration [m] |",
                      [f"| {r.case} | {r.method} | {r.param:g} | {r.seconds:.3g} | {r.ratio:.3g} | "
                       f"{r.param / r.seconds:.3g} | {r.error:.2g} |" for r in part("scenes")])
    if part("mujoco"):
        from .mujoco import format_rows

        out += ["", format_rows(rows)]
    from .speed import goals

    measured = goals(rows)
    if measured:
        out += _table("## Speed goals", "| goal | target | measured | met | missed by |",
                      [f"| {g.what} | {'≤' if g.below else '≥'} {g.target:g} {g.unit} | {g.measured:.3g} {g.unit} | "
                       f"{'yes' if g.met else 'no'} | {'' if g.met else f'{g.factor:.1f}×'} |" for g in measured])
    return "\n".join(out)


def write_csv(rows: list[BenchRow], path: Path) -> Path:
    """All rows as CSV (columns of :class:`BenchRow`)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(asdict(rows[0])))
        writer.writeheader()
        for r in rows:
            writer.writerow(asdict(r))
    return path


def plot(rows: list[BenchRow], path: Path) -> Path:
    """Error vs time per method, and batch cost per impact vs nv."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(15, 5.2))
    acc = [r for r in rows if r.part == "accuracy"]
    for method, slopes in dict.fromkeys((r.method, "Slopes" in r.case) for r in acc):
        pts = [(r.seconds * 1e6, max(r.error, 1e-17)) for r in acc if (r.method, "Slopes" in r.case) == (method, slopes)]
        ax1.scatter(*zip(*pts), label=method + (", Gaussian slopes" if slopes else ""), s=18,
                    marker="x" if slopes else "o")
    ax1.set(xscale="log", yscale="log", xlabel="µs per impact", ylabel="relative error of Δu = W P",
            title="Accuracy vs time: cone α = 0.4 (all β, all cases); x: Gaussian slopes, near-singular UR5")
    if acc:  # a run of other parts only has nothing to label (matplotlib would warn)
        ax1.legend(fontsize=8)
    # the batch rows over mechanism size name nv as "robot (n=6)"; other batch rows are not on this axis
    sized = [(r, re.search(r"\(n=(\d+)\)", r.case)) for r in rows if r.part == "batch"]
    bat = [(r, int(m.group(1))) for r, m in sized if m]
    for name, param in dict.fromkeys((r.method, r.param) for r, _ in bat):
        series = sorted((nv, r.seconds * 1e6) for r, nv in bat if (r.method, r.param) == (name, param))
        ax2.plot(*zip(*series), marker="o", label=name + (f" {param:g}" if param else ""))
    ax2.set(xscale="log", yscale="log", xlabel="nv", ylabel="µs per impact (batch)", title="Batch cost vs mechanism size")
    if bat:
        ax2.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path

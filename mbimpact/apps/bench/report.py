"""The bench's report: markdown tables, CSV, and the figure."""

from __future__ import annotations

import csv
import datetime
import re
from dataclasses import asdict
from importlib import metadata
from pathlib import Path

from .common import BenchRow, machine_summary

__all__ = ["format_report", "summary", "versions", "write_csv", "plot", "SUMMARY", "SUMMARY_HEADER"]

#: The packages whose versions head a report.
_PACKAGES = ("mbimpact", "numpy", "scipy", "pin", "coal", "numba", "mujoco")

#: The header row of :func:`summary`'s table (the README quotes that table).
SUMMARY_HEADER = "| measurement | mbimpact | reference | ratio |"

#: The rows of :func:`summary`: (part, case or its start, method, what it is, the reference's method:
#: "" for the row of the part whose ratio is 1 in the same case, None for no reference).
SUMMARY: tuple[tuple[str, str, str, str, str | None], ...] = (
    ("overhead", "ur5", "impact, NewtonLaw", "UR5 Newton impact, per call", ""),
    ("overhead", "ur5", "impact, RoughLaw(Cone)", "UR5 rough impact, Cone(0.3), per call", ""),
    ("overhead", "ur5", "impact, RoughLaw(GaussianSlopes(0.3))", "UR5 rough impact, GaussianSlopes(0.3), per call", ""),
    ("overhead", "solo12", "impact, RoughLaw(Cone)", "Solo12 rough impact, Cone(0.3), per call", ""),
    ("coulomb", "ur5, sliding (mu=0.2)", "impact, CoulombLaw", "UR5 Coulomb impact, sliding, per call",
     "Pinocchio PGS (J, W, solve)"),
    ("batch", "ur5 (n=6)", "NewtonLaw", "UR5 apply_batch, Newton, one configuration", None),
    ("batch", "ur5 (n=6)", "RoughLaw(Cone), adaptive", "UR5 apply_batch, Cone(0.3), one configuration", None),
    ("configurations", "ur5 (n=6), ", "impact_batch, RoughLaw(Cone)",
     "UR5 impact_batch, Cone(0.3), one velocity per configuration", ""),
    ("import", "fresh interpreter, bytecode cached", "import mbimpact", "import mbimpact", None),
    ("first-run", "first mbimpact demo", "empty kernel cache", "first mbimpact demo, empty kernel cache", None),
    ("first-run", "first mbimpact demo", "kernels cached", "mbimpact demo, kernels cached", None),
)


# the references' names in the summary, where the part's own table gives them in full
_SHORT = {"Jacobian + pin.impulseDynamics": "Pinocchio", "Pinocchio PGS (J, W, solve)": "Pinocchio PGS",
          "loop of Jacobian + pin.impulseDynamics": "Pinocchio loop"}


def versions() -> dict[str, str]:
    """Installed versions of mbimpact and the packages its figures depend on ("not installed" where absent)."""
    out = {}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def _value(r: BenchRow) -> str:
    """A row's measurement with its unit: a rate for batches, seconds or microseconds otherwise."""
    if r.part in ("batch", "threads"):
        return f"{r.ratio:.3g} impacts/s"
    if r.part == "configurations":
        return f"{1.0 / r.seconds:.3g} impacts/s"
    if r.part in ("import", "first-run"):
        return f"{r.seconds:.2f} s"
    return f"{r.seconds * 1e6:.3g} µs"


def summary(rows: list[BenchRow]) -> list[str]:
    """The headline table of a run: each law's per-call cost against Pinocchio's own impact, the batch
    rates, the import and a new user's first command, for the rows of :data:`SUMMARY` that ran
    (markdown lines)."""
    lines = []
    for part, case, method, what, reference in SUMMARY:
        found = [r for r in rows if (r.part, r.method) == (part, method) and r.case.startswith(case)]
        if not found:
            continue
        r = found[0]
        if reference is None:
            refs = []
        elif reference:
            refs = [x for x in rows if (x.part, x.case, x.method) == (part, r.case, reference)]
        else:
            refs = [x for x in rows if x.part == part and x.case == r.case and x.ratio == 1.0 and x is not r]
        ref, ratio = ((f"{_SHORT.get(refs[0].method, refs[0].method)}: {_value(refs[0])}",
                       f"{r.seconds / refs[0].seconds:.2f}×") if refs else ("", ""))
        lines.append(f"| {what} | {_value(r)} | {ref} | {ratio} |")
    return ["", "## Summary", "", SUMMARY_HEADER, "|---|---|---|---|", *lines] if lines else []


def _missed(factor: float) -> str:
    """How far a goal is missed: a percentage below 2×, where a ratio would round it away."""
    return f"{(factor - 1.0) * 100:.0f} %" if factor < 2.0 else f"{factor:.1f}×"


def _table(title: str, header: str, lines: list[str]) -> list[str]:
    """A markdown section: title, header row with its separator, then the lines."""
    cols = header.count("|") - 1
    return ["", title, "", header, "|" + "---|" * cols, *lines]


def format_report(rows: list[BenchRow], command: str = "mbimpact bench",
                  when: datetime.datetime | None = None) -> str:
    """The report of a run, in markdown: the command, date, machine and versions, the :func:`summary`,
    then the tables of the parts that ran (accuracy, overhead ratios, compliant route, batches, geometry,
    scenes, MuJoCo) and the speed goals."""
    def part(name: str) -> list[BenchRow]:
        return [r for r in rows if r.part == name]

    def blank0(x: float) -> str:
        return "" if x == 0 else f"{x:g}"

    when = when or datetime.datetime.now(datetime.timezone.utc)
    out = ["# mbimpact bench", "", f"* Command: `{command}`", f"* Date: {when:%Y-%m-%d %H:%M} UTC",
           f"* Machine: {machine_summary()}",
           "* Versions: " + ", ".join(f"{k} {v}" for k, v in versions().items()),
           "* Ratios are taken within this run; absolute times move with the machine's load."]
    out += summary(rows)
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
                      "| resolve's rtol | method | M | rel. error vs closed law | µs | time / closed law (batched) |",
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
    if part("first-run"):
        out += _table("## A new user's first command (fresh interpreter, whole command)", "| command | kernels | s |",
                      [f"| {r.case} | {r.method} | {r.seconds:.2f} |" for r in part("first-run")])
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
                       f"{'yes' if g.met else 'no'} | {'' if g.met else _missed(g.factor)} |" for g in measured])
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
    import matplotlib.ticker

    from itertools import cycle

    # up to 20 series per panel, each with its own colour and marker, so that none share a look
    def looks() -> cycle[tuple[tuple[float, ...], str]]:
        cmap = plt.get_cmap("tab20")
        markers = "osD^vP*Xh<>"
        return cycle([(tuple(cmap(i)), markers[i % len(markers)]) for i in range(20)])

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(14, 6.5))
    acc = [r for r in rows if r.part == "accuracy"]
    style = looks()
    for method, slopes in dict.fromkeys((r.method, "Slopes" in r.case) for r in acc):
        pts = [(r.seconds * 1e6, max(r.error, 1e-17)) for r in acc if (r.method, "Slopes" in r.case) == (method, slopes)]
        colour, marker = next(style)
        ax1.scatter(*zip(*pts), label=method + (" (Gaussian slopes)" if slopes else " (cone)"), s=22, color=colour,
                    marker=marker, alpha=0.85)
    ax1.set(xscale="log", yscale="log", xlabel="time per impact [µs]", ylabel="relative error of Δu = W P",
            title="Accuracy vs time per averaging method\n"
                  "cone α = 0.4, e = 0.5, every incidence and posture; Gaussian slopes σ = 0.3, near-singular UR5")
    ax1.title.set_fontsize(10)
    if acc:  # a run of other parts only has nothing to label (matplotlib would warn)
        ax1.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, frameon=False)
    # the batch rows over mechanism size name nv as "robot (n=6)"; other batch rows are not on this axis
    sized = [(r, re.search(r"\(n=(\d+)\)", r.case)) for r in rows if r.part == "batch"]
    bat = [(r, int(m.group(1))) for r, m in sized if m]
    style = looks()
    for name, param in dict.fromkeys((r.method, r.param) for r, _ in bat):
        series = sorted((nv, r.seconds * 1e6) for r, nv in bat if (r.method, r.param) == (name, param))
        colour, marker = next(style)
        label = name if not param or f"{param:g}" in name else f"{name}, {param:g}"
        ax2.plot(*zip(*series), marker=marker, color=colour, label=label)
    ax2.set(xscale="log", yscale="log", xlabel="degrees of freedom nv", ylabel="time per impact in a batch [µs]",
            title="Batch cost against mechanism size\n(apply_batch at one configuration, e = 0.5)")
    ax2.title.set_fontsize(10)
    sizes = sorted({nv for _, nv in bat})
    if sizes:  # the robots' own nv as ticks, not powers of ten
        ax2.set_xticks(sizes, [str(nv) for nv in sizes])
        ax2.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
    if bat:
        ax2.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, frameon=False)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path

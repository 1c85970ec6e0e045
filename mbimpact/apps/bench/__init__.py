"""``mbimpact bench``: what accuracy costs in time, measured side by side in one run.

The parts (``run_bench(parts=...)``), each a module:

* ``accuracy``, ``compliant``, ``overhead``, ``batch`` — the impact laws
  (:mod:`~mbimpact.apps.bench.laws`): error against time per averaging method, cost per call
  against Pinocchio's own impact, batch throughput, the compliant route;
* ``configurations``, ``coulomb``, ``threads``, ``import`` — the everyday paths against their speed goals
  (:mod:`~mbimpact.apps.bench.speed`): batches across configurations, the Coulomb law against
  Pinocchio's PGS and ADMM, batches under both BLAS thread settings, the package import; the report ends with the goals and by how
  much each is missed;
* ``first-run`` — a new user's first command, ``mbimpact demo`` in a fresh interpreter, on an empty
  kernel cache and on the cache it wrote (:mod:`~mbimpact.apps.bench.firstrun`);
* ``geometry`` — gap queries per contact pair against one rough-law impact
  (:mod:`~mbimpact.apps.bench.geometry`);
* ``scenes`` — simulated seconds and impacts per wall second of the shipped scenes
  (:mod:`~mbimpact.apps.bench.scenes`);
* ``mujoco`` — the same scenes in MuJoCo where it can express them, when the optional
  ``mujoco`` package is installed (:mod:`~mbimpact.apps.bench.mujoco`).

Ratios are taken within one run, never against absolute times from elsewhere.
"""

from __future__ import annotations

import warnings

from ...errors import AccuracyWarning, NoSeparationWarning, ParameterError
from ..progress import Progress
from .common import BenchRow, machine_summary, moving_frame, per_call
from .firstrun import first_run
from .geometry import gap_queries
from .laws import BATCH_ROBOTS, OVERHEAD_ROBOTS, accuracy, batch, compliant, overhead
from .report import format_report, plot, write_csv
from .scenes import QUICK_SCENES, scene_throughput
from .speed import CACHED_IMPORT, configurations, coulomb, goals, import_time, threads

__all__ = ["BenchRow", "PARTS", "run_bench", "format_report", "write_csv", "plot", "machine_summary",
           "moving_frame", "per_call", "goals", "CACHED_IMPORT"]

#: The parts of the bench, in the order they run.
PARTS = ("accuracy", "compliant", "overhead", "batch", "configurations", "coulomb", "threads", "import", "first-run",
         "geometry", "scenes", "mujoco")


def run_bench(quick: bool = False, show_progress: bool = True, parts: tuple[str, ...] = PARTS) -> list[BenchRow]:
    """Run the parts asked for; ``quick`` trims grids, repetitions and scenes.

    Raises
    ------
    ParameterError
        An unknown part (the valid ones are listed).
    """
    bad = [p for p in parts if p not in PARTS]
    if bad:
        raise ParameterError(f"unknown bench part(s) {bad}; valid: {', '.join(PARTS)}")
    min_time = 0.005 if quick else 0.05
    acc_steps = 7 if quick else 17  # cone cases × incidences, then the graded slopes case
    robots = OVERHEAD_ROBOTS if not quick else ("ur5", "solo12")
    batch_robots = BATCH_ROBOTS if not quick else ("ur5", "talos")
    scenes = QUICK_SCENES if quick else None
    steps = {"accuracy": acc_steps, "compliant": 1, "overhead": len(robots), "batch": len(batch_robots),
             "configurations": 1, "coulomb": 1, "threads": 1, "import": 1, "first-run": 1, "geometry": 3, "scenes": len(scenes) if scenes else 13, "mujoco": 3}
    progress = Progress(sum(steps[p] for p in parts), "bench", enabled=show_progress)
    rows: list[BenchRow] = []
    for part in parts:
        if part == "accuracy":
            with warnings.catch_warnings():
                # the table reports every method's true error; a rounding-limited adaptive result need not warn
                # too, and the near-singular cases are accuracy tests at incidences where κ < 0 on purpose
                warnings.simplefilter("ignore", AccuracyWarning)
                warnings.simplefilter("ignore", NoSeparationWarning)
                rows += accuracy(quick, min_time, progress)
        elif part == "compliant":
            rows += compliant(quick, min_time, progress)
        elif part == "overhead":
            rows += overhead(robots, min_time, progress)
        elif part == "batch":
            rows += batch(batch_robots, 5_000 if quick else 100_000, progress)
        elif part in ("configurations", "geometry"):
            with warnings.catch_warnings():
                # random configurations and velocities: the cone leaves some contacts approaching (κ < 0),
                # which is physics to report in an impact, and noise in a timing table
                warnings.simplefilter("ignore", NoSeparationWarning)
                rows += configurations(quick, progress) if part == "configurations" else gap_queries(min_time, progress)
        elif part == "coulomb":
            rows += coulomb(min_time, progress, quick)
        elif part == "threads":
            rows += threads(quick, progress)
        elif part == "import":
            rows += import_time(progress)
        elif part == "first-run":
            rows += first_run(progress)
        elif part == "scenes":
            rows += scene_throughput(scenes, progress)
        elif part == "mujoco":
            from .mujoco import UNAVAILABLE, available, mujoco_rows

            if available():
                rows += mujoco_rows(quick, progress)
            else:
                print(UNAVAILABLE)
    return rows

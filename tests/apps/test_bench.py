"""``mbimpact bench --quick``: report, CSV and PNG, with measurements that make sense."""

import csv
import os
import time

import pytest

import mbimpact as mbi
from mbimpact.apps.bench import CACHED_IMPORT
from mbimpact.apps.cli import main


def test_bench_quick_writes_report_csv_and_png(tmp_path, capsys):
    from mbimpact.apps.bench import PARTS

    # every part but the first run's, which compiles the kernels afresh (its own test below)
    parts = [arg for p in PARTS if p != "first-run" for arg in ("--part", p)]
    assert main(["bench", "--quick", "--no-progress", "--out", str(tmp_path), *parts]) == 0
    text = capsys.readouterr().out
    report = (tmp_path / "report.md").read_text()
    assert report.strip() in text  # the same report, printed and written
    for line in ("* Command: `mbimpact bench --quick --part accuracy", "* Date: 20", "* Machine: ",
                 f"* Versions: mbimpact {mbi.__version__}, numpy ", "## Summary", "| UR5 Newton impact, per call | "):
        assert line in report
    for heading in ("Accuracy vs time", "Per-call cost against Pinocchio", "Batch throughput", "Compliant route"):
        assert heading in text
    assert (tmp_path / "bench.png").stat().st_size > 10_000
    with (tmp_path / "bench.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    acc = [r for r in rows if r["part"] == "accuracy"]
    # the exact-arc rule reaches 1e-12 with 64 nodes in every regime, uniform sampling does not
    regular = [r for r in acc if "singular" not in r["case"]]
    at64 = [r for r in regular if r["method"] == "exact-arc quadrature" and float(r["param"]) == 64]
    assert at64 and all(float(r["error"]) <= 1e-12 for r in at64)
    truncated = [r for r in regular if "beta=75" in r["case"] and r["method"] == "uniform sampling"]
    assert truncated and all(float(r["error"]) > 1e-9 for r in truncated)
    mc = [r for r in regular if r["method"] == "Monte Carlo"]
    assert all(1e-5 < float(r["error"]) < 0.2 for r in mc)
    # near-singular posture: the graded rule converges (to rounding amplified by cond W), sampling does not
    singular = [r for r in acc if "singular" in r["case"]]
    at64 = [r for r in singular if r["method"] == "exact-arc quadrature" and float(r["param"]) == 64]
    assert at64 and all(float(r["error"]) <= 1e-10 for r in at64)
    sampled = [float(r["error"]) for r in singular if r["method"] in ("uniform sampling", "Monte Carlo")]
    assert sampled and min(sampled) > 1e6 * max(float(r["error"]) for r in at64)
    # Gaussian slopes there: graded in tilt and azimuth, and the Laplace reduction, reach ~1e-11; Monte Carlo does not
    slopes = {(r["method"], float(r["param"])): float(r["error"]) for r in acc if "GaussianSlopes" in r["case"]}
    graded = [slopes["graded tilt x azimuth", n] for n in (8, 16, 32)]
    assert graded == sorted(graded, reverse=True) and graded[-1] < 1e-10
    assert slopes["laplace (rtol=1e-12)", 0] < 1e-10 and slopes["graded, compiled (rtol=1e-12)", 0] < 1e-10
    assert slopes["Monte Carlo", 100_000] > 1e-3
    over = [r for r in rows if r["part"] == "overhead"]
    assert {r["case"] for r in over} >= {"ur5", "solo12"}
    assert all(float(r["ratio"]) > 0 for r in over)
    for robot in ("ur5", "solo12"):  # the floor and the Pinocchio calls are parts of the Newton impact's cost
        t = {r["method"]: float(r["seconds"]) for r in over if r["case"] == robot}
        assert t["validation + result object only (no physics)"] < t["impact, NewtonLaw"]
        assert t["Pinocchio calls inside impact(NewtonLaw) only"] < t["impact, NewtonLaw"]
    assert all(float(r["ratio"]) > 0 for r in rows if r["part"] == "batch")
    facet_rows = {r["method"] for r in rows if r["part"] == "batch" and r["method"].endswith(" facets, adaptive")}
    assert facet_rows == {f"RoughLaw(Cone), {f} facets, adaptive" for f in ("coulomb", "compliant", "hunt-crossley")}
    comp = [r for r in rows if r["part"] == "compliant" and r["method"].startswith("resolve")]
    errs = [float(r["error"]) for r in sorted(comp, key=lambda r: float(r["param"]))]
    assert errs == sorted(errs, reverse=True) and errs[-1] < 1e-4  # O(1/M) towards the closed law
    assert all(float(r["ratio"]) > 1e3 for r in comp)  # against the batched closed law

    geo = [r for r in rows if r["part"] == "geometry"]
    assert {r["case"].split(" (")[0] for r in geo} == {"box", "solo12", "ur5"}
    for r in geo:  # a distance per pair is a small fraction of one rough impact
        if r["method"].startswith("distances"):
            assert 0 < float(r["ratio"]) < 0.2
    scenes = [r for r in rows if r["part"] == "scenes"]
    assert len(scenes) == 4 and all(r["method"] == "mbimpact (completed)" for r in scenes)
    assert all(float(r["error"]) <= 1e-8 and float(r["ratio"]) > 0 for r in scenes)
    # the speed parts: Pinocchio's conic solvers agree with the integrated Coulomb law where it sticks
    # (one cone, one answer); sliding, they solve another model (one step, not the slip along the impact)
    coul = {(r["case"], r["method"]): r for r in rows if r["part"] == "coulomb"}
    for solver in ("PGS", "ADMM"):
        assert float(coul["ur5, sticking (mu=3)", f"Pinocchio {solver} (J, W, solve)"]["error"]) < 1e-8
        assert 0.0 < float(coul["ur5, sliding (mu=0.2)", f"Pinocchio {solver} (J, W, solve)"]["error"]) < 0.05
    # --quick: the warm first calls only (numba's import dominates), a row per kernel module and their total
    jit = {r["method"]: float(r["seconds"]) for r in rows if r["part"] == "coulomb" and r["case"].startswith("JIT")}
    modules = {m: t for m, t in jit.items() if m.startswith("import + load")}
    assert len(modules) == len(mbi.compile_kernels()) and all(0.0 < t < 60.0 for t in modules.values())
    assert jit["all compiled kernels (mbimpact.compile_kernels())"] == pytest.approx(sum(modules.values()))
    conf = {r["method"]: r for r in rows if r["part"] == "configurations"}
    laws = ("NewtonLaw", "RoughLaw(Cone)", "CoulombLaw")
    threads = mbi.kernel_threads()
    assert set(conf) == ({"loop of Jacobian + pin.impulseDynamics"} | {f"impact_batch, {law}" for law in laws}
                         | ({f"impact_batch, {law}, 1 kernel thread" for law in laws[1:]} if threads > 1 else set()))
    assert [float(conf[f"impact_batch, {law}"]["param"]) for law in laws] == [threads] * 3
    # every batch has its goal (≥ 1e5 impacts/s); the cone's and Coulomb's run the single impact's compiled
    # call once for all rows, so they cost about what Newton's does (their order is this machine's noise)
    assert all(float(conf[f"impact_batch, {law}"]["ratio"]) > 0.0 for law in laws)
    assert all(f"2000 configurations: impact_batch, {law} |" in text for law in laws)
    # batches in fresh interpreters under both BLAS settings (the thread limit itself: tests/common/test_threads.py)
    thr = {(r["case"], r["method"]): float(r["ratio"]) for r in rows if r["part"] == "threads"}
    assert set(thr) == {(f"ur5, BLAS threads{s}", f"apply_batch, {law}") for s in (" = 1", ": default")
                        for law in ("NewtonLaw", "RoughLaw(Cone)")}
    assert all(rate > 0 for rate in thr.values())
    assert "## Speed goals" in text and "| import mbimpact |" in text
    # the import twice: bytecode cached (the goal's, as pip installs a package) and this environment as it is
    imports = {(r["case"], r["method"]): float(r["seconds"]) for r in rows if r["part"] == "import"}
    flag = "set" if os.environ.get("PYTHONDONTWRITEBYTECODE") else "unset"
    assert set(imports) == {(CACHED_IMPORT, "import mbimpact"),
                            (CACHED_IMPORT, "import numpy, pinocchio (what it imports first)"),
                            (f"fresh interpreter, this environment (PYTHONDONTWRITEBYTECODE {flag})",
                             "import mbimpact")}
    assert all(t > 0.0 for t in imports.values())
    assert "| ur5, BLAS threads: default: apply_batch, RoughLaw(Cone), one configuration |" in text


def test_speed_goals_say_by_how_much_they_are_missed():
    from mbimpact.apps.bench import BenchRow, goals

    rows = [BenchRow("overhead", "ur5", "impact, NewtonLaw", 6, 0.0, 3e-5, 6.0),
            BenchRow("batch", "ur5 (n=6)", "NewtonLaw", 0, 0.0, 2e-7, 5e6),
            BenchRow("import", CACHED_IMPORT, "import mbimpact", 0, 0.0, 0.2),
            # the environment as it is (here compiling from source) is reported, not held to the goal
            BenchRow("import", "fresh interpreter, this environment (PYTHONDONTWRITEBYTECODE set)", "import mbimpact",
                     0, 0.0, 0.45)]
    out = {g.what: g for g in goals(rows)}
    newton = out["ur5: impact, NewtonLaw per call (× Jacobian + impulseDynamics)"]
    assert not newton.met and newton.factor == 4.0  # 6× against ≤ 1.5×
    batch = out["ur5: apply_batch, NewtonLaw, one configuration"]
    assert not batch.met and batch.factor == 2.0  # 5e6/s against ≥ 1e7/s
    assert out["import mbimpact"].met and out["import mbimpact"].factor == 1.0


def test_the_cli_offers_every_bench_part():
    """The CLI lists the parts without importing the bench (start-up time): the lists must agree."""
    import contextlib
    import io

    from mbimpact.apps.bench import PARTS

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.suppress(SystemExit):
        main(["bench", "--part", "nope"])
    choices = err.getvalue().split("choose from")[1]
    assert all(f"'{p}'" in choices for p in PARTS)


def test_a_warning_in_a_timed_call_names_the_timing_loop_as_a_users_loop():
    """The bench times calls from a loop outside the package, where a user's loop stands: a warning is
    attributed there (mbimpact.errors.warn walks up to the first frame outside the package), not after a
    walk through the bench's own frames."""
    import functools
    import warnings

    from mbimpact.apps.bench.common import per_call_together
    from mbimpact.errors import NoSeparationWarning, warn

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        per_call_together({"warns": functools.partial(warn, NoSeparationWarning, "timed")}, 1e-4, rounds=1)
    assert caught and {w.filename for w in caught} == {"<the caller's loop>"}


def test_functions_timed_together_each_keep_their_best_round():
    from mbimpact.apps.bench.common import per_call_together

    calls = {"short": 0, "long": 0}

    def spin(label: str, seconds: float):
        def fn():
            calls[label] += 1
            end = time.perf_counter() + seconds
            while time.perf_counter() < end:
                pass
        return fn

    times = per_call_together({"short": spin("short", 2e-4), "long": spin("long", 8e-4)}, 2e-3, rounds=3)
    assert list(times) == ["short", "long"]
    assert 2e-4 <= times["short"] < 6e-4 and 8e-4 <= times["long"] < 2.4e-3  # each call at least its spin
    assert times["long"] > 1.5 * times["short"]
    assert calls["short"] >= 1 + 3 * 5 and calls["long"] >= 1 + 3 * 2  # warmed, then ≥ min_time a round


def test_the_first_run_part_times_a_new_users_first_demo_on_an_empty_cache():
    from mbimpact.apps.bench import BenchRow, format_report, goals
    from mbimpact.apps.bench.firstrun import FIRST_DEMO, first_run
    from mbimpact.apps.progress import Progress

    rows = first_run(Progress(1, "first run", enabled=False))
    t = {r.method: r.seconds for r in rows}
    assert set(t) == {"empty kernel cache", "kernels cached"}
    # the empty cache compiles what the demo needs; the second run loads it from the disk cache
    assert t["empty kernel cache"] > t["kernels cached"] > 0.2
    goal = {g.what: g for g in goals(rows)}[f"{FIRST_DEMO}, empty kernel cache"]
    assert goal.target == 10.0 and goal.measured == t["empty kernel cache"]
    assert "| first mbimpact demo, empty kernel cache | " in format_report(rows)
    # a miss below 2× is given in percent, which a ratio rounded to 1.0× would hide
    slow = [BenchRow("first-run", FIRST_DEMO, "empty kernel cache", 0, 0.0, 10.3)]
    assert "| no | 3 % |" in format_report(slow)

"""The README's commands and example do what it says."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import mbimpact as mbi

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text()


def test_ci_runs_the_readme_test_line_verbatim():
    lines = [ln.strip() for ln in README.splitlines() if "pytest" in ln and ln.startswith("    ")]
    assert lines, "the README has no indented test command"
    ci = (ROOT / ".ci" / "run").read_text()
    assert lines[0] in ci


def test_the_main_job_line_installs_and_runs_the_demo():
    line = next(ln.strip() for ln in README.splitlines() if ln.strip().endswith("mbimpact demo"))
    assert line.startswith("python3 -m venv .venv && .venv/bin/pip install . &&")


def test_the_python_example_runs_and_its_comments_hold(capsys: pytest.CaptureFixture[str]):
    code = re.search(r"```python\n(.*?)```", README, re.S).group(1)  # type: ignore[union-attr]
    ns: dict[str, object] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)  # the example shows it on purpose
        exec(compile(code, "README.md", "exec"), ns)
    rough, newton, res, gap, fit = (ns[k] for k in ("rough", "newton", "res", "gap", "fit"))
    assert newton.kappa == pytest.approx(0.8) and newton.mu == pytest.approx(0.0, abs=1e-12)  # type: ignore[attr-defined]
    assert rough.energy_loss > newton.energy_loss > 0 and rough.separates  # type: ignore[attr-defined]
    np.testing.assert_allclose(rough.I, rough.A @ rough.dv, atol=1e-12)  # (1.1)  # type: ignore[attr-defined]
    assert abs(gap.distance) < 1e-4 and gap.gradient.shape == (18,)  # type: ignore[attr-defined]
    assert res.separates and res.kappa >= 0  # type: ignore[attr-defined]
    # Kharaz et al.: sliding mu = 0.092 stated by the authors, e_n about 0.98
    assert fit.params["mu"] == pytest.approx(0.092, abs=0.01)  # type: ignore[attr-defined]
    assert fit.params["e"] == pytest.approx(0.98, abs=0.02)  # type: ignore[attr-defined]
    assert "False" in capsys.readouterr().out


def test_the_readme_carries_the_scene_reference_as_the_cli_prints_it():
    from mbimpact.simulation.schema import reference

    assert reference().rstrip() in README


def test_the_readme_is_for_users_and_short():
    assert len(README.encode()) <= 20_000
    for section in ("## Requirements", "## Install", "## Quick start", "## The model in brief", "## Commands",
                    "## Simulation", "### Scene file reference", "## Calibration", "## Performance", "## Errors",
                    "## How to cite"):
        assert section in README
    assert "Python ≥ 3.11" in README  # the version pyproject.toml requires
    assert 'requires-python = ">=3.11"' in (ROOT / "pyproject.toml").read_text()


# phrases that speak of the project's own development, which no user can act on
HISTORY = re.compile(r"\bsessions?\b|earlier run|of the day|slow stretch|before the front end|changed figures|"
                     r"the (first|second|third|fourth|fifth|sixth|\w+th) run\b", re.I)


def test_no_text_speaks_of_development_history():
    texts = {"README.md": README}
    for path in sorted((ROOT / "mbimpact").rglob("*")):
        if path.suffix in (".py", ".cpp", ".pyi"):
            texts[str(path.relative_to(ROOT))] = path.read_text()
    found = {name: m.group(0) for name, text in texts.items() if (m := HISTORY.search(text))}
    assert not found, found
    assert HISTORY.search("measured in the twelfth session's run")  # the check itself can fail


def test_every_documented_name_works_after_import_mbimpact_as_mbi():
    names = set(re.findall(r"\bmbi((?:\.[A-Za-z_][A-Za-z0-9_]*)+)", README))
    assert len(names) > 30
    for dotted in sorted(names):
        obj: object = mbi
        for part in dotted.strip(".").split("."):
            obj = getattr(obj, part)  # AttributeError names what the README promised
    for module in re.findall(r"help\((mbimpact[\w.]*)\)", README):
        __import__(module)
        assert (__import__("sys").modules[module].__doc__ or "").strip()


def test_the_files_the_readme_names_are_the_ones_the_commands_write(tmp_path):
    from mbimpact.apps.cli import main

    commands = README[README.index("## Commands"):README.index("## Simulation")]
    run = next(ln for ln in commands.splitlines() if ln.startswith("| `mbimpact run"))
    named = set(re.findall(r"`(\w+\.(?:csv|png))`", run))
    assert named == {"trajectory.csv", "events.csv", "plots.png"}
    assert main(["run", "ball_drop", "--out", str(tmp_path)]) == 0
    assert named <= {p.name for p in tmp_path.iterdir()}
    bench = next(ln for ln in commands.splitlines() if ln.startswith("| `mbimpact bench"))
    assert set(re.findall(r"`(\w+\.(?:csv|png|md))`", bench)) == {"report.md", "bench.csv", "bench.png"}
    # the data and scenes live in the installed package, not in a repository path
    assert "models/scenes" not in README and "models/data" not in README
    assert mbi.calibration.data_path("kharaz2001").is_file()


def test_the_performance_section_is_a_table_the_bench_writes():
    from mbimpact.apps.bench.report import SUMMARY, SUMMARY_HEADER, summary

    section = README[README.index("## Performance"):README.index("## Errors")]
    lines = [ln for ln in section.splitlines() if ln.startswith("|")]
    assert lines[0] == SUMMARY_HEADER and len(lines) > 8
    assert "mbimpact bench --quick --out DIR" in section and "report.md" in section
    # every row is one the bench's summary writes: its first cell is one of the summary's measurements
    known = {spec[3] for spec in SUMMARY}
    for ln in lines[2:]:
        first = ln.split("|")[1].strip()
        assert first in known, first
    assert summary([]) == []


def test_the_shipped_scenes_numbers_in_the_readme_follow_from_their_formulas():
    import math

    g = 9.81
    zeno = math.sqrt(2 * 1.0 / g) * (1 + 0.8) / (1 - 0.8)  # ball_drop: h = 1 m, e = 0.8
    assert f"= {zeno:.4f} s" in README
    # rimless wheel: 10 spokes of 0.5 m, hub 1 kg, inertia 0.01 kg m², slope 0.1 rad (McGeer's fixed point)
    a, L, inertia, m, gamma = math.pi / 10, 0.5, 0.01, 1.0, 0.1
    eta = (inertia + m * L * L * math.cos(2 * a)) / (inertia + m * L * L)
    K = 4 * m * g * L * math.sin(a) * math.sin(gamma) / (inertia + m * L * L)
    assert f"ω₋ = {math.sqrt(K / (1 - eta**2)):.4f} rad/s" in README
    import tomllib

    scene = tomllib.loads((mbi.models_dir() / "scenes" / "ball_on_vibrating_plate.toml").read_text())
    motion = scene["contacts"][0]["motion"]
    assert f"Γ = {motion['amplitude'] * (2 * math.pi * motion['frequency']) ** 2 / g:.3f}" in README


def test_the_scene_built_in_python_runs_as_its_toml_twin_does(capsys: pytest.CaptureFixture[str]):
    blocks = re.findall(r"```python\n(.*?)```", README, re.S)
    code = next(b for b in blocks if "mbi.Scene(" in b)
    ns: dict[str, object] = {}
    exec(compile(code, "README.md", "exec"), ns)
    tr = ns["tr"]
    twin = mbi.simulate(mbi.load_scene("ball_drop"))
    assert tr.status == "completed" == twin.status  # type: ignore[attr-defined]
    assert len(tr.events) == len(twin.events) and tr.first_rest_time() == pytest.approx(twin.first_rest_time())  # type: ignore[attr-defined]
    assert "completed" in capsys.readouterr().out

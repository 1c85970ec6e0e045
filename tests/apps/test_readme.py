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

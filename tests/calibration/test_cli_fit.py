"""``mbimpact fit``: the subcommand the CLI wires in (add_parser + run)."""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.apps import fit as fit_app
from mbimpact.calibration import Ball, predict


def _parse(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="mbimpact")
    sub = parser.add_subparsers(dest="command", required=True)
    fit_app.add_parser(sub)
    return parser.parse_args(argv)


def _table(tmp_path: Path) -> Path:
    """Synthetic sphere data from Coulomb's law (e = 0.8, μ = 0.2), no noise."""
    theta = np.array([5.0, 15.0, 30.0, 45.0, 60.0, 75.0])
    ball = Ball(0.01, 0.01)
    p = predict(mbi.CoulombLaw(0.8, 0.2), theta, ball, 2.0)
    path = tmp_path / "synthetic.csv"
    lines = ["# source: synthetic (Coulomb e=0.8 mu=0.2)", "# body: sphere radius=0.01 mass=0.01",
             "theta_deg,speed,kappa,et,spin"]
    lines += [f"{t},2.0,{k},{e},{w}" for t, k, e, w in zip(theta, p["kappa"], p["et"], p["spin"])]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_fit_command_prints_and_writes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = _parse(["fit", str(_table(tmp_path)), "--law", "newton,coulomb", "--law", "rough-hunt-crossley",
                   "--out", str(tmp_path / "out")])
    assert args.func(args) == 0
    text = capsys.readouterr().out
    assert "source: synthetic" in text and "coulomb: rms" in text and "mu     = 0.2" in text
    assert "rough-hunt-crossley: rms" in text  # the table has speeds: the speed-dependent law runs
    rows = list(csv.DictReader((tmp_path / "out" / "synthetic_fit.csv").open()))
    coulomb = {r["name"]: r for r in rows if r["law"] == "coulomb"}
    assert float(coulomb["e"]["value"]) == pytest.approx(0.8, abs=1e-4)
    assert float(coulomb["mu"]["value"]) == pytest.approx(0.2, abs=1e-4)
    assert float(coulomb["et"]["value"]) < 1e-6  # exact data: the RMS vanishes
    newton_et = next(r for r in rows if r["law"] == "newton" and r["name"] == "et")
    assert float(newton_et["value"]) > 0.05  # Newton's law cannot slow the tangential motion
    preds = list(csv.DictReader((tmp_path / "out" / "synthetic_predictions.csv").open()))
    assert len(preds) == 120 and "coulomb:et" in preds[0]
    assert (tmp_path / "out" / "synthetic_fit.png").stat().st_size > 10_000


def test_fit_command_skips_what_needs_a_speed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "nospeed.csv"
    path.write_text("theta_deg,kappa\n10,0.5\n30,0.55\n60,0.7\n")
    args = _parse(["fit", str(path), "--law", "newton,rough-hunt-crossley"])
    assert args.func(args) == 0
    assert "rough-hunt-crossley: skipped" in capsys.readouterr().out


def test_fit_command_errors(tmp_path: Path) -> None:
    with pytest.raises(mbi.ParameterError, match="unknown law"):
        args = _parse(["fit", str(_table(tmp_path)), "--law", "stronge"])
        args.func(args)
    with pytest.raises(mbi.ImpactError, match="no data file"):
        args = _parse(["fit", "nothing.csv"])
        args.func(args)
    with pytest.raises(mbi.ImpactError, match="unknown body"):
        args = _parse(["fit", str(_table(tmp_path)), "--law", "newton", "--body", "cube side=1"])
        args.func(args)

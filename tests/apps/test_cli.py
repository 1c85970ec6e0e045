"""The main job, ``mbimpact demo``."""

import csv
import subprocess
import sys

import pytest

import mbimpact as mbi
from mbimpact.apps.cli import main
from mbimpact.apps.demo import demo_rows


def test_demo_prints_table_and_writes_csv(tmp_path, capsys):
    out = tmp_path / "demo.csv"
    assert main(["demo", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "| Newton (frictionless) | 20 |" in text and "rough, cone alpha=0.4" in text
    with out.open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 8
    newton = [r for r in rows if r["law"].startswith("Newton")]
    assert all(float(r["kappa"]) == pytest.approx(0.8) and float(r["mu"]) == 0.0 for r in newton)


def test_demo_physics():
    """Rough rows: friction grows with roughness; at 60° the restitution exceeds Newton's (4°)."""
    rows = demo_rows()
    for beta in (20.0, 60.0):
        rough = [r for r in rows if r.beta_deg == beta and r.law.startswith("rough")]
        assert all(r.u_t_plus > 0 for r in rough)
        mus = [r.mu for r in rough]
        assert mus == sorted(mus) and mus[0] > 0
        assert all(r.energy_loss > 0 for r in rows if r.beta_deg == beta)
    steep = [r for r in rows if r.beta_deg == 60.0 and r.law.endswith("0.4")][0]
    assert steep.kappa > 1.0


def test_python_m_mbimpact_demo():
    done = subprocess.run([sys.executable, "-m", "mbimpact", "demo"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "UR5 tool0" in done.stdout


def test_models_are_shipped_with_the_package():
    assert {"point_mass_2d", "point_mass_3d", "planar_rod", "double_pendulum"} <= set(mbi.model_names())
    for name in mbi.model_names():
        assert mbi.Mechanism.from_model(name).nv >= 2  # the solids float by default


def test_compare_runs_every_facet_law_and_facet_friction_adds_friction(tmp_path):
    """``mbimpact compare --facet ...``: the rough law with Coulomb or compliant facets gives more
    friction and dissipates more than with frictionless (Newton) facets at every incidence, and
    Hunt–Crossley facets tuned to e at the approach speed stay close to Newton facets."""
    import csv

    from mbimpact.apps.cli import main

    assert main(["compare", "--steps", "4", "--facet", "coulomb", "--facet", "compliant",
                 "--facet", "hunt-crossley", "--out", str(tmp_path)]) == 0
    rows = list(csv.DictReader((tmp_path / "compare.csv").open()))
    by = {}
    for r in rows:
        by.setdefault(r["law"], []).append(r)
    newton_facets = by["rough Cone alpha=0.3"]
    assert len(by) == 6 and all(len(v) == 4 for v in by.values())
    for name in ("coulomb", "compliant"):
        other = by[f"rough Cone alpha=0.3, {name} facets"]
        for a, b in zip(newton_facets, other):
            assert float(b["mu"]) > float(a["mu"]) and float(b["energy_loss"]) > float(a["energy_loss"])
    hc = by["rough Cone alpha=0.3, hunt-crossley facets"]
    assert all(abs(float(a["mu"]) - float(b["mu"])) < 0.05 for a, b in zip(newton_facets, hc))

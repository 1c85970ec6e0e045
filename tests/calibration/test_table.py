"""Impact tables: the shipped data sets, the CSV format, gaps and metadata, and bad files."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.calibration import ImpactTable, PointMass, Ball, TableError, data_names, data_path


def test_shipped_data_sets_cite_their_sources() -> None:
    assert set(data_names()) >= {"kharaz2001", "grant_tabakoff1975"}
    k = ImpactTable.from_csv(data_path("kharaz2001"))
    assert "Kharaz" in k.source() and "Powder Technology 120" in k.source()
    assert k.quantities == ("kappa", "et", "spin", "rebound_deg")
    assert len(k) == 24 and np.all(k.speed == 3.9)
    # each digitised curve keeps its own angles: the columns have gaps
    assert np.count_nonzero(~np.isnan(k.values("et"))) == 8
    assert np.count_nonzero(~np.isnan(k.values("spin"))) == 7
    assert np.count_nonzero(~np.isnan(k.values("rebound_deg"))) == 9
    i = int(np.flatnonzero(k.theta_deg == 20.08)[0])
    assert k.values("et")[i] == 0.5964 and math.isnan(k.values("spin")[i])
    body = k.body()
    assert isinstance(body, Ball) and body.radius == 0.0025
    assert body.moment == pytest.approx(0.4 * 2.611e-4 * 0.0025**2)
    g = ImpactTable.from_csv("grant_tabakoff1975")  # a shipped name works too
    assert "Tabakoff" in g.source() and "CORRELATIONS" in g.meta["note"]
    assert g.speed is None and g.quantities == ("kappa", "et")
    # the table is the correlation evaluated, b = 90° − θ in radians
    b = np.radians(90.0 - g.theta_deg)
    assert np.allclose(g.values("kappa"), 0.993 - 1.76 * b + 1.56 * b**2 - 0.49 * b**3, atol=5e-5)
    assert np.allclose(g.values("et"), 0.988 - 1.66 * b + 2.11 * b**2 - 0.67 * b**3, atol=5e-5)
    assert g.values("kappa")[0] == pytest.approx(0.18, abs=0.005)
    assert g.values("kappa")[-1] == pytest.approx(0.85, abs=0.005)


def test_reading_a_file_with_metadata_and_gaps(tmp_path: Path) -> None:
    path = tmp_path / "mine.csv"
    path.write_text("# source: a test\n#   continued here\n# body: point\n\ntheta_deg,kappa,mu\n10,0.5,\n20,,0.2\n")
    t = ImpactTable.from_csv(path)
    assert t.name == "mine" and t.meta["source"] == "a test continued here"
    assert isinstance(t.body(), PointMass)
    assert np.isnan(t.values("mu")[0]) and t.values("mu")[1] == 0.2
    with pytest.raises(TableError, match="no column 'et'"):
        t.values("et")
    assert not t.theta_deg.flags.writeable


@pytest.mark.parametrize("text,match", [
    ("theta_deg,e_t\n10,0.5\n", "unknown column 'e_t'"),
    ("angle,kappa\n10,0.5\n", "theta_deg"),
    ("theta_deg,kappa\n10,abc\n", "not a number"),
    ("theta_deg,kappa\n10,0.5,1\n", "3 cells for 2 columns"),
    ("theta_deg,kappa\n95,0.5\n", r"within \[0, 90\)"),
    ("theta_deg,kappa\n10,\n", "at least one quantity"),
    ("theta_deg,kappa,speed\n10,0.5,-1\n", "speed"),
    ("# only comments\n", "no header"),
    ("# body: sphere radius=1\ntheta_deg,kappa\n10,0.5\n", None),
])
def test_bad_files_are_named_errors(tmp_path: Path, text: str, match: str | None) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    if match is None:  # readable, but its body line is incomplete
        with pytest.raises(TableError, match="needs radius"):
            ImpactTable.from_csv(path).body()
        return
    with pytest.raises(TableError, match=match):
        ImpactTable.from_csv(path)


def test_missing_file_and_the_error_tree() -> None:
    with pytest.raises(TableError, match="shipped data sets"):
        ImpactTable.from_csv("/no/such/file.csv")
    with pytest.raises(TableError, match="valid"):
        data_path("nope")
    with pytest.raises(mbi.ImpactError):  # TableError is an ImpactError (and a ValueError)
        ImpactTable(np.array([10.0]), {"kappa": np.array([0.5, 0.6])})

"""``mbimpact fit``: its help text, its progress display, and a figure a referee can read."""

from __future__ import annotations

import argparse
import dataclasses
import io
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.apps import fit as fit_app
from mbimpact.calibration import Ball, ImpactTable, predict

UNIT = re.compile(r"\[[^\]]+\]$")


class FakeTerminal(io.StringIO):
    """A stderr that says it is a terminal, so the progress bar draws into it."""

    def isatty(self) -> bool:
        return True


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="mbimpact")
    fit_app.add_parser(parser.add_subparsers(dest="command", required=True))
    return parser


@pytest.fixture(scope="module")
def synthetic() -> ImpactTable:
    """Sphere data from Coulomb's law (e = 0.8, μ = 0.2) at 2 m/s, no noise."""
    theta = np.array([5.0, 15.0, 30.0, 45.0, 60.0, 75.0])
    p = predict(mbi.CoulombLaw(0.8, 0.2), theta, Ball(0.01, 0.01), 2.0)
    return ImpactTable(theta, {q: p[q] for q in ("kappa", "et", "spin")}, np.full(theta.size, 2.0),
                       {"body": "sphere radius=0.01 mass=0.01"}, "synthetic")


@pytest.fixture(scope="module")
def fits(synthetic: ImpactTable) -> list[object]:
    done = fit_app.fit_laws(synthetic, ("newton", "coulomb"))
    # a second law whose curves are the first's exactly: the figure must show both and say they coincide
    return done + [dataclasses.replace(done[1], label="coulomb-again")]


def test_help_is_plain_text(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        _parser().parse_args(["fit", "--help"])
    text = capsys.readouterr().out
    assert "mbimpact fit DATA.csv: fit impact laws" in text
    assert "``" not in text and ":func:" not in text and "--no-progress" in text


def test_fit_reports_each_start(synthetic: ImpactTable) -> None:
    calls: list[tuple[int, int]] = []
    mbi.fit(synthetic, "coulomb", starts=3, progress=lambda done, total: calls.append((done, total)))
    assert calls == [(1, 3), (2, 3), (3, 3)]


def test_fit_progress_is_drawn_on_a_terminal_only(synthetic: ImpactTable, monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    fit_app.fit_laws(synthetic, ("newton",), progress=True)  # stderr is not a terminal under pytest
    assert capsys.readouterr() == ("", "")
    term = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", term)
    fit_app.fit_laws(synthetic, ("newton", "coulomb"), progress=True)
    shown = term.getvalue()
    assert "fitting 2 law(s)" in shown and "100%" in shown and "24/24" in shown
    term = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", term)
    fit_app.fit_laws(synthetic, ("newton",), progress=False)
    assert term.getvalue() == ""


def test_fit_figure_shows_every_law_and_what_coincides(synthetic: ImpactTable, fits: list[object]) -> None:
    fig = fit_app.fit_figure(synthetic, fits)
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    labels = [f.label for f in fits]  # type: ignore[attr-defined]
    for label in labels:  # each law once, with its RMS per column
        assert sum(t.startswith(f"{label} (rms: kappa") for t in legend) == 1
    assert "data" in legend and any("5/7" in t for t in legend)  # the dotted line of the et panel is named
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 4  # kappa, et, spin and the contact point's et_cp
    for ax in axes:
        assert UNIT.search(ax.get_xlabel()) and UNIT.search(ax.get_ylabel()), (ax.get_xlabel(), ax.get_ylabel())
        curves = [line for line in ax.get_lines() if line.get_label() in labels]
        assert sorted(line.get_label() for line in curves) == sorted(labels)
        styles = {(line.get_color(), str(line.get_linestyle()), line.get_marker()) for line in curves}
        assert len(styles) == len(labels)  # coinciding curves stay distinguishable
        assert "coulomb = coulomb-again coincide" in ax.get_title()
        if ax.get_title().startswith(("et:", "spin:")):  # Newton's law keeps v_t and gives no spin
            assert "newton = " not in ax.get_title()
        # a curve that leaves the panel over the data's incidences is named in its title
        bottom, top = ax.get_ylim()
        for line in curves:
            x, y = (np.asarray(v, dtype=float) for v in line.get_data())
            inside = (x >= synthetic.theta_deg.min()) & (x <= synthetic.theta_deg.max()) & np.isfinite(y)
            if np.any(y[inside] < bottom) or np.any(y[inside] > top):
                assert f"{line.get_label()} leaves the axes" in ax.get_title()
    title = fig.texts[0].get_text() if fig.texts else fig._suptitle.get_text()  # noqa: SLF001
    assert "radius 10 mm" in title and "2 m/s" in title and "best fit per column" in title


def test_fit_command_writes_the_figure(synthetic: ImpactTable, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / "synthetic.csv"
    lines = ["# body: sphere radius=0.01 mass=0.01", "theta_deg,speed,kappa,et,spin"]
    lines += [f"{t},2.0,{k},{e},{w}" for t, k, e, w in zip(synthetic.theta_deg, synthetic.values("kappa"),
                                                            synthetic.values("et"), synthetic.values("spin"))]
    csv.write_text("\n".join(lines) + "\n")
    args = _parser().parse_args(["fit", str(csv), "--law", "newton", "--no-progress", "--out", str(tmp_path)])
    assert args.func(args) == 0
    assert (tmp_path / "synthetic_fit.png").stat().st_size > 20_000
    assert "wrote" in capsys.readouterr().out

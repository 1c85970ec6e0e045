"""Fig. 1, claims 1°–5°, the constructive vs axiomatic comparison, and ``mbimpact compare``."""

import csv
import functools
import io
import math
import re
import sys
import warnings
from concurrent.futures import Executor, Future

import numpy as np
import pytest

import mbimpact as mbi
import mbimpact.apps.compare
from mbimpact.apps import figures
from mbimpact.apps.cli import main


def test_fig1_library_matches_formula_and_shadowing_lowers_grazing_friction():
    d = figures.fig1_data(alpha=0.5, points=60)
    np.testing.assert_allclose(d["mu_sawtooth"], d["mu_formula"], rtol=1e-10, atol=1e-14)
    smooth = d["mu_smooth_shadowed"]
    peak = int(np.argmax(smooth))
    assert 0 < peak < len(smooth) - 1 and smooth[-1] < 0.7 * smooth[peak]
    assert np.all(smooth <= d["mu_formula"] + 1e-12)  # a sinusoid never out-rubs the sawtooth of its max slope


def test_claims_1_to_5():
    c = figures.claims_data(alpha=0.4, e=0.8)
    np.testing.assert_allclose(c["dv_over_speed"], np.broadcast_to(c["dv_over_speed"][6], c["dv_over_speed"].shape), rtol=1e-11)  # 1°
    np.testing.assert_allclose(c["angle_dvl_vl_deg"], 180.0, atol=1e-5)  # 2°
    assert np.max(c["offplane"]) < 1e-12
    np.testing.assert_allclose(c["kappa_normal"], c["kappa_4_2"], atol=1e-12)  # 3°
    assert np.all(np.diff(c["kappa_beta"]) > 0) and c["kappa_beta"][-1] > 1  # 4°
    slope = np.polyfit(np.log(c["alpha_small"][:10]), np.log(c["distance_to_newton"][:10]), 1)[0]
    assert slope == pytest.approx(2.0, abs=0.05)  # 5°: Δv → Newton like α²


def test_constructive_and_axiomatic_laws_disagree_qualitatively():
    r = figures.rough_vs_coulomb_data(alpha=0.4, e=0.8)
    assert np.all(np.diff(r["kappa_rough"]) > 0) and r["kappa_rough"][-1] > 1  # κ rises with β
    np.testing.assert_allclose(r["kappa_coulomb"], 0.8, atol=1e-8)  # Coulomb/Stronge with W ∝ I: κ = e
    mu = float(r["mu_coulomb_param"])
    tb = np.tan(np.radians(r["beta_deg"]))
    slides = tb > mu * 1.8 * (1 + 1e-6)  # point mass: slides through iff tan β > μ(1+e)
    np.testing.assert_allclose(r["mu_coulomb"][slides], mu, rtol=1e-7)  # constant while sliding
    np.testing.assert_allclose(r["mu_coulomb"][~slides], tb[~slides] / 1.8, rtol=1e-6, atol=1e-12)  # sticks
    assert r["mu_rough"][-1] > mu  # the rough law's friction keeps growing towards grazing


class Inline(Executor):
    """Runs each job at once in this process (warnings raised by the jobs are seen here)."""

    def submit(self, fn, /, *args, **kwargs):
        future = Future()
        future.set_result(fn(*args, **kwargs))
        return future


class FakeTerminal(io.StringIO):
    def isatty(self):
        return True


RATIOS = (0.0, 0.5)  # on the boundary and inside the stable band: 10 short simulations
UNIT = re.compile(r"\[[^\]]+\]$")


@pytest.fixture(scope="module")
def drawn():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = figures.build_all(RATIOS, Inline(), progress=False)
    return {d.name: d for d in out}, caught


def test_figures_command_writes_every_file(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(figures, "write_all", functools.partial(figures.write_all, ratios=[0.5], executor=Inline()))
    assert main(["figures", "--out", str(tmp_path)]) == 0
    names = {"fig1.png", "fig1.csv", "fig2.png", "claims.png", "rough_vs_coulomb.png", "stability_map.png",
             "stability_map.csv"}
    assert {p.name for p in tmp_path.iterdir()} == names
    assert {line.split("/")[-1] for line in capsys.readouterr().out.split()} >= names
    for name in names - {"fig1.csv", "stability_map.csv"}:
        assert (tmp_path / name).stat().st_size > 10_000
    with (tmp_path / "fig1.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 120 and {"tan_beta", "mu_sawtooth", "mu_formula"} <= set(rows[0])
    with (tmp_path / "stability_map.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(figures.STABILITY_CASES) and all(r["status"] == "completed" for r in rows)
    assert all(float(r["growth_simulated"]) < 0 for r in rows)  # ρ⁻¹ = B/2: inside the stable band of (4.3)


def test_figures_do_not_warn_about_their_deliberate_steep_facets(drawn):
    out, caught = drawn
    assert not [w for w in caught if issubclass(w.category, mbi.NoSeparationWarning)]
    assert figures.claims_data()["kappa_normal"].min() < -0.9  # the κ < 0 cases are still computed ...
    ax = out["claims"].figure.axes[2]
    assert any("κ < 0" in t.get_text() for t in ax.get_legend().get_texts())  # ... and shown as such
    with pytest.warns(mbi.NoSeparationWarning):  # the silencing stays inside the figures
        mbi.RoughLaw(mbi.Cone(1.2), 0.8).apply(np.eye(3), np.eye(3), [0, 0, -1.0], [0, 0, 1])


def _legend_entries(fig, ax):
    legends = [ax.get_legend()] if ax.get_legend() is not None else list(fig.legends)
    return {(t.get_text(), h) for lg in legends for t, h in zip(lg.get_texts(), lg.legend_handles)}


def _style(artist):
    return str(artist.get_color()), str(artist.get_linestyle()), float(artist.get_linewidth())


@pytest.mark.parametrize("name", ["fig1", "fig2", "claims", "rough_vs_coulomb", "stability_map"])
def test_figures_have_units_and_legends_for_every_line(drawn, name):
    fig = drawn[0][name].figure
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert axes
    for ax in axes:
        assert UNIT.search(ax.get_xlabel()) and UNIT.search(ax.get_ylabel()), (name, ax.get_xlabel(), ax.get_ylabel())
        assert ax.get_title() or fig.get_suptitle()
        lines = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 0]
        if len(lines) + len(ax.collections) <= 1:
            continue
        entries = _legend_entries(fig, ax)
        assert entries, (name, ax.get_title())
        texts = {t for t, _ in entries}
        styles = {_style(h) for _, h in entries if hasattr(h, "get_linestyle") and hasattr(h, "get_color")}
        for ln in lines:  # listed by its label, or drawn in the style of a listed entry (pieces of one curve)
            assert ln.get_label() in texts or _style(ln) in styles, (name, ax.get_title(), ln.get_label())
        for c in ax.collections:
            if len(c.get_offsets()) or c.get_label().startswith("stable"):
                assert c.get_label() in texts, (name, c.get_label())


def test_figure_titles_state_their_parameters(drawn):
    out = drawn[0]
    claims = [ax.get_title() for ax in out["claims"].figure.axes if ax.get_visible()]
    assert [t[:2] for t in claims] == ["1°", "2°", "3°", "4°", "5°"]
    assert all("e = 0.8" in t for t in claims) and all("α" in t for t in claims)
    maps = [ax.get_title() for ax in out["stability_map"].figure.axes]
    assert all(re.search(r"α = [\d.]+ rad, e = [\d.]+, m = \d", t) for t in maps)
    assert "m = period of the bouncing" in out["stability_map"].figure.get_suptitle()
    assert "e = 0.8" in out["rough_vs_coulomb"].figure.get_suptitle()
    assert "α = 0.5" in out["fig1"].figure.axes[0].get_title()
    assert all(ax.get_aspect() == 1.0 for ax in out["fig2"].figure.axes)  # approach angles drawn true


def test_stability_map_marks_boundary_points_as_neutral(drawn):
    fig = drawn[0]["stability_map"].figure
    for ax in fig.axes:
        marked = {c.get_label().split(":")[1].split(",")[0].strip(): len(c.get_offsets()) for c in ax.collections
                  if c.get_label().startswith("simulated")}
        assert marked == {"decays": 1, "neutral": 1, "grows": 0}  # ρ⁻¹ = 0 is on the boundary of (4.3)


def test_figures_progress_on_a_terminal(monkeypatch):
    term = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", term)
    figures.build_all([0.5], Inline(), progress=True)
    steps = 4 + len(figures.STABILITY_CASES)
    assert "mbimpact figures" in term.getvalue() and f"{steps}/{steps}" in term.getvalue()
    term = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", term)
    figures.build_all([0.5], Inline(), progress=False)
    assert term.getvalue() == ""


def test_compare_command(tmp_path, capsys):
    assert main(["compare", "--steps", "7", "--max-beta", "60", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "Coulomb mu=0.3 (energetic)" in text and "rough Cone alpha=0.3" in text
    with (tmp_path / "compare.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 21
    newton = [r for r in rows if r["law"].startswith("Newton")]
    assert all(float(r["kappa"]) == pytest.approx(0.8) and float(r["mu"]) == 0 for r in newton)
    assert (tmp_path / "compare.png").stat().st_size > 10_000


def test_compare_planar_mechanism_from_urdf(tmp_path):
    path = mbi.model_path("point_mass_2d")
    assert main(["compare", "--urdf", str(path), "--frame", "mass", "--planar", "--steps", "4", "--mu", "0.2"]) == 0


def test_compare_api_approach_velocity():
    mech = mbi.Mechanism.from_robot("panda")
    q = mech.neutral()
    contact = mbi.PointContact("panda_hand_tcp")
    v = mbimpact.apps.compare.approach_velocity(mech, q, contact, math.radians(30), 2.0)
    u = mech.point_jacobian(q, "panda_hand_tcp") @ v
    R = contact.basis()
    np.testing.assert_allclose(u, 2.0 * (0.5 * R[:, 0] - math.cos(math.radians(30)) * R[:, 2]), atol=1e-10)


def test_compare_errors_are_reported(capsys):
    assert main(["compare", "--frame", "tool"]) == 2
    assert "tool0" in capsys.readouterr().err


@pytest.mark.parametrize("u", [[0.7, -1.0], [-2.5, -1.0], [4.0, -1.0]])
def test_fig2_reached_parts_are_where_straight_approaches_first_meet_the_profile(u):
    """Independent check of Fig. 2's data: march 400 straight lines along u from above the profile;
    each first meets it inside a piece drawn as reached, and pieces drawn as reached are met."""
    rng = np.random.default_rng(5)
    heights = np.append(rng.uniform(0.0, 0.6, 12), 0.0)
    heights[0] = 0.0
    profile = mbi.Profile(heights, 0.1, shadowing=True, periodic=False)
    d = figures.shadowing_data(profile, u)
    x, h = d["x"], d["h"]
    pieces = [(min(a[0], b[0]), max(a[0], b[0])) for (a, b), f in zip(d["lit"], d["fraction"]) if f > 0]
    np.testing.assert_allclose([hi - lo for lo, hi in pieces], (d["fraction"] * 0.1)[d["fraction"] > 0], rtol=1e-12)
    u = np.array(u) / abs(u[1])
    t = np.linspace(0.0, 1.0, 100_001)
    hits = []
    for x_start in np.linspace(x[0] - abs(u[0]), x[-1] + abs(u[0]), 800):
        px, pz = x_start + u[0] * t, 1.0 - t
        inside = (px >= x[0]) & (px <= x[-1])
        below = inside & (pz <= np.interp(px, x, h))
        if below.any() and inside[: int(np.argmax(below))].any():  # entered over the profile, not its ends
            hits.append(px[int(np.argmax(below))])
    assert len(hits) > 100
    tol = 2.0 * abs(u[0]) * (t[1] - t[0]) + 1e-12
    assert all(any(lo - tol <= xh <= hi + tol for lo, hi in pieces) for xh in hits)
    assert all(any(lo - 0.02 <= xh <= hi + 0.02 for xh in hits) for lo, hi in pieces if hi - lo > 0.03)
    assert 0 < len(pieces) < len(d["fraction"]) or u[0] == 0.7  # grazing approaches leave parts unreached


def test_fig2_refuses_what_it_cannot_draw():
    with pytest.raises(mbi.ParameterError, match="Profile"):
        figures.shadowing_data(mbi.Sawtooth(0.3), [1.0, -1.0])  # type: ignore[arg-type]
    with pytest.raises(mbi.ParameterError, match="approach"):
        figures.shadowing_data(mbi.Profile([0.0, 1.0, 0.0], 1.0), [1.0, 1.0])

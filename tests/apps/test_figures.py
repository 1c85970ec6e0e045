"""Fig. 1, claims 1°–5°, the constructive vs axiomatic comparison, and ``mbimpact compare``."""

import csv
import math

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


def test_figures_command_writes_pngs(tmp_path, capsys):
    assert main(["figures", "--out", str(tmp_path)]) == 0
    for name in ("fig1.png", "fig2.png", "claims.png", "rough_vs_coulomb.png", "stability_map.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    with (tmp_path / "fig1.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 120 and {"tan_beta", "mu_sawtooth", "mu_formula"} <= set(rows[0])


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

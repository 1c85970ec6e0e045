"""Scenes: validation, the simulator's declared-effects-only work, hard cases, section 4."""


import math

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.apps.cli import main
from mbimpact.simulation import Scene, SceneContact, Surface


def point_scene(law, surface=None, **kw):
    mech = mbi.Mechanism.from_model("point_mass_3d")
    return Scene(mech, np.array([0.0, 0.0, 0.3]), np.array([0.5, 0.0, 0.0]),
                 (SceneContact("mass", law, surface or Surface()),), **kw)


def test_shipped_scenes_load():
    assert {"ball_on_rough_plane", "rimless_wheel_slope", "ur5_strikes_table", "double_pendulum_wall",
            "particle_vibrating_surface"} <= set(mbi.scene_names())
    for name in mbi.scene_names():
        scene = mbi.load_scene(name)
        assert scene.contacts and scene.duration > 0


def test_ball_bounces_to_rest_in_finite_time():
    """Zeno: the bounce times accumulate; below rest_velocity the ball rests and slides on."""
    tr = mbi.simulate(mbi.load_scene("ball_on_rough_plane"))
    rest = tr.first_rest_time()
    assert rest is not None and rest < 2.5 and tr.resting == (True,)
    times = np.array([r.t for r in tr.impacts])
    gaps = np.diff(times)
    assert np.all(gaps[1:10] < gaps[:9])  # bounces get shorter
    assert np.all(np.diff(tr.energy) <= 1e-9)  # energy never grows
    assert abs(tr.q[-1, 2]) < 1e-6 and tr.v[-1, 0] > 0  # on the plane, still sliding forward
    assert tr.work["facet_average"] == len(tr.impacts) - 1  # the last record is the switch to rest


def test_undeclared_effects_cost_nothing():
    newton = mbi.simulate(point_scene(mbi.RoughLaw(mbi.Smooth(), 0.5), duration=0.5))
    assert newton.work["facet_average"] == 0 and newton.work["newton_impact"] > 0  # no roughness: Newton path
    assert newton.work["surface_motion"] == 0 and newton.work["damping"] == 0  # fixed surface, no damping
    free = mbi.simulate(point_scene(mbi.NewtonLaw(0.5), gravity=False, duration=0.5))
    assert free.work["gravity"] == 0 and free.work["dynamics"] > 0 and not free.impacts  # no gravity: never falls
    np.testing.assert_allclose(free.q[-1], [0.25, 0.0, 0.3], atol=1e-9)
    rough = mbi.simulate(point_scene(mbi.RoughLaw(mbi.Cone(0.2), 0.5), duration=0.5))
    assert rough.work["facet_average"] > 0 and rough.work["gravity"] == rough.work["dynamics"]


def test_very_rough_surface_with_kappa_below_zero_does_not_loop_forever():
    law = mbi.RoughLaw(mbi.Cone(1.2), 0.0)  # κ = cos²α − 1 < 0 at normal incidence
    tr = mbi.simulate(point_scene(law, duration=1.0))
    assert tr.status == "completed" and tr.impacts[0].kappa < 0
    assert tr.resting == (True,)


def test_two_contacts_at_the_same_instant_use_the_compliant_resolution():
    rod = mbi.Mechanism.from_model("planar_rod")
    contacts = tuple(SceneContact(f, mbi.NewtonLaw(0.8), Surface(), M=1e4) for f in ("end_a", "end_b"))
    scene = Scene(rod, np.array([0.0, 0.2, 1.0, 0.0]), np.array([0.0, -1.0, 0.0]), contacts, gravity=False, duration=0.3)
    tr = mbi.simulate(scene)
    assert tr.work["resolve"] == 1 and len(tr.impacts) == 2
    assert tr.v[-1, 2] == pytest.approx(0.0, abs=1e-9) and tr.v[-1, 1] > 0  # symmetric: no rotation


def test_floating_base_scene_stays_on_the_manifold():
    solo = mbi.Mechanism.from_robot("solo12")
    q = solo.neutral()
    q[2] = 0.4
    scene = Scene(solo, q, np.zeros(solo.nv), (SceneContact("HR_FOOT", mbi.NewtonLaw(0.3), Surface()),), duration=0.3)
    tr = mbi.simulate(scene, samples=50)
    assert tr.impacts and np.allclose(np.linalg.norm(tr.q[:, 3:7], axis=1), 1.0, atol=1e-9)


def test_moving_surface_uses_the_relative_velocity():
    surface = Surface(amplitude=0.01, frequency=5.0)
    tr = mbi.simulate(point_scene(mbi.NewtonLaw(0.5), surface, duration=0.6))
    assert tr.work["surface_motion"] > 0 and tr.impacts
    for r in tr.impacts:
        assert r.un_plus == pytest.approx(-0.5 * r.un_minus, rel=1e-9)  # Newton on the relative velocity
    assert tr.gaps.min() > -1e-9  # never inside the moving surface


def test_vibro_formulas_match_the_linearised_rough_law():
    for rough in (mbi.Cone(0.3), mbi.Sawtooth(0.3), mbi.GaussianSlopes(0.3), mbi.GaussianSlopes(0.2, dim=2)):
        st = mbi.section4.stability(rough, 0.8, 1)
        d = rough.dim
        v = np.zeros(d)
        v[-1], v[0] = -1.0, 1e-7
        res = mbi.RoughLaw(rough, 0.8).apply(np.eye(d), np.eye(d), v, np.eye(d)[-1])
        assert -res.dv[0] / 1e-7 == pytest.approx(st.lam, rel=1e-6)  # (4.1)
        assert res.kappa == pytest.approx(st.kappa, rel=1e-9)  # (4.2)
    st = mbi.section4.stability(mbi.Sawtooth(0.7), 1.0, 1)
    assert 1 + st.kappa < st.lam <= 2 and st.B < 0 and st.stabilisable and st.surface == "dome"
    assert st.stable(0.5 * st.B) and not st.stable(1.5 * st.B) and not st.stable(0.01)
    assert mbi.section4.stability(mbi.Cone(0.3), 0.8, 2).B == pytest.approx(mbi.section4.stability(mbi.Cone(0.3), 0.8, 1).B / 4)
    cup = mbi.section4.stability(mbi.Cone(0.3), 0.8, 1)
    assert cup.surface == "cup" and cup.stable(0.5 * cup.B) and not cup.stable(-0.1) and not cup.stable(1.01 * cup.B)
    # the boundary of (4.3) is where the linear map's largest eigenvalue reaches the unit circle
    for st in (cup, mbi.section4.stability(mbi.Sawtooth(0.7), 1.0, 2)):
        m = 1 if st is cup else 2
        assert st.growth(0.999 * st.B, m) < 0 < st.growth(1.001 * st.B, m)


def test_section_4_refuses_a_measure_that_is_not_isotropic():
    tilted = mbi.Facets(np.array([[0.3, 0.0, math.sqrt(0.91)]]))
    with pytest.raises(mbi.RoughnessError, match="not isotropic"):
        mbi.section4.stability(tilted, 0.8, 1)
    with pytest.raises(mbi.RoughnessError, match="not isotropic"):  # a ring of 3 facets: isotropic to 2nd order? no
        mbi.section4.stability(mbi.Facets(np.array([[0.3, 0.0, math.sqrt(0.91)], [-0.3, 0.0, math.sqrt(0.91)]])), 0.8, 1)
    four = np.array([[0.3, 0.0, math.sqrt(0.91)], [-0.3, 0.0, math.sqrt(0.91)],
                     [0.0, 0.3, math.sqrt(0.91)], [0.0, -0.3, math.sqrt(0.91)]])  # square symmetry: isotropic here
    st = mbi.section4.stability(mbi.Facets(four), 0.8, 1)
    cone = mbi.section4.stability(mbi.Cone(math.asin(0.3)), 0.8, 1)
    assert st.lam == pytest.approx(cone.lam, rel=1e-12) and st.kappa == pytest.approx(cone.kappa, rel=1e-12)
    with pytest.raises(mbi.ParameterError, match="m"):
        mbi.section4.stability(mbi.Cone(0.3), 0.8, 0)


@pytest.mark.parametrize("rough, e, m", [(mbi.Cone(0.3), 0.8, 1), (mbi.Cone(0.3), 0.8, 2), (mbi.Cone(0.5), 0.8, 1),
                                          (mbi.Sawtooth(0.3), 0.8, 1)], ids=str)
def test_section_4_deviation_decays_below_B_and_grows_above(rough, e, m):
    st = mbi.section4.stability(rough, e, m)
    x0 = 1e-4
    below = mbi.section4.deviation_run(rough, e, m, 0.5 * st.B, periods=16, x0=x0)
    above = mbi.section4.deviation_run(rough, e, m, 2.0 * st.B, periods=16, x0=x0)
    assert len(below) == 16 and abs(below[-1]) < 0.5 * x0
    assert np.abs(above[:12]).max() > 10 * x0


def test_section_4_a_dome_stabilises_when_lambda_exceeds_one_plus_kappa():
    """The paper's remark says no shape does; a dome with B < ρ⁻¹ < 0 does, a cup does not."""
    rough = mbi.Sawtooth(0.7)
    st = mbi.section4.stability(rough, 1.0, 1)
    assert st.B < 0
    dome = mbi.section4.deviation_run(rough, 1.0, 1, 0.5 * st.B, periods=24, x0=1e-4)
    steep = mbi.section4.deviation_run(rough, 1.0, 1, 2.0 * st.B, periods=16, x0=1e-4)
    cup = mbi.section4.deviation_run(rough, 1.0, 1, 0.01, periods=16, x0=1e-4)
    assert abs(dome[-1]) < 0.2 * 1e-4
    assert st.growth(2.0 * st.B, 1) > 0 and np.abs(steep).max() > 10 * 1e-4
    assert st.growth(0.01, 1) > 0 and abs(cup[-1]) > 3 * 1e-4


def test_run_command_writes_csv_and_png(tmp_path, capsys):
    assert main(["run", "ball_on_rough_plane", "--no-progress", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "came to rest" in text and "work:" in text
    for name in ("trajectory.csv", "impacts.csv", "plots.png"):
        assert (tmp_path / name).stat().st_size > 100
    header = (tmp_path / "impacts.csv").read_text().splitlines()[0]
    assert header.startswith("t,contact,un_minus") and "energy_loss" in header


SCENE = """
name = "bad"
[mechanism]
model = "point_mass_3d"
[[contacts]]
frame = "mass"
e = 0.5
{extra}
"""


@pytest.mark.parametrize("extra, match", [
    ('law = "plastic"', r"contacts\[0\]\.law \(line \d+\): unknown law 'plastic'"),
    ('roughness = { kind = "cone", alpha = 2.0 }', r"contacts\[0\]\.roughness.*alpha"),
    ('surface = "sphere"', r"contacts\[0\]\.surface \(line \d+\): unknown surface"),
    ('normal = [0, 0]', r"contacts\[0\]\.normal \(line \d+\): must have 3 entries"),
    ('k = 0.1', "exactly one of e"),
    ('rest = "glue"', "unknown resting mode"),
])
def test_scene_errors_name_the_key_and_line(tmp_path, extra, match):
    path = tmp_path / "bad.toml"
    path.write_text(SCENE.format(extra=extra))
    with pytest.raises(mbi.SceneError, match=match):
        mbi.load_scene(path)


def test_scene_errors_for_tables(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('[mechanism]\nmodel = "point_mass_3d"\n[[contacts]]\nframe = "mass"\ne = 0.5\n[forcez]\ngravity = true\n')
    with pytest.raises(mbi.SceneError, match=r"forcez \(line 6\): unknown table"):
        mbi.load_scene(path)
    path.write_text('[mechanism]\nmodel = "point_mass_3d"\n[[contacts]]\nframe = "massx"\ne = 0.5\n')
    with pytest.raises(mbi.ImpactError, match="massx"):
        mbi.load_scene(path)
    with pytest.raises(mbi.SceneError, match="shipped scenes"):
        mbi.load_scene("no_such_scene")


def test_rimless_wheel_rolls_down_the_slope_without_entering_it():
    tr = mbi.simulate(mbi.load_scene("rimless_wheel_slope"), samples=300)
    assert tr.status == "completed" and len(tr.impacts) > 10
    assert tr.q[-1, 0] > 1.0 and tr.q[-1, 1] < tr.q[0, 1] - 0.1  # down the slope (towards +x, −z)
    assert tr.gaps.min() > -1e-9
    assert np.all(np.diff(tr.energy) <= 1e-8)


def test_grazing_touch_down():
    """Released on the plane sliding, no normal velocity: the first impact is grazing.

    On a smooth plane the point comes to rest at once and slides on; on a rough one
    the facets facing the motion throw it up (κ ≫ 1, property 4°), and it hops along,
    losing energy at every impact."""
    mech = mbi.Mechanism.from_model("point_mass_3d")

    def run(law):
        scene = Scene(mech, np.zeros(3), np.array([1.0, 0.0, 0.0]), (SceneContact("mass", law, Surface()),), duration=0.5)
        return mbi.simulate(scene, samples=50)

    smooth = run(mbi.NewtonLaw(0.5))
    assert smooth.resting == (True,) and len(smooth.impacts) <= 2
    assert smooth.q[-1, 0] == pytest.approx(0.5, rel=1e-6) and smooth.gaps.min() > -1e-9
    rough = run(mbi.RoughLaw(mbi.Cone(0.3), 0.5))
    assert rough.impacts[0].kappa > 100 and rough.impacts[0].un_plus > 0.1
    assert rough.gaps.min() > -1e-9 and np.all(np.diff(rough.energy) <= 1e-9)
    assert rough.v[-1, 0] < 0.1  # the hops brake the sliding

"""``mbimpact bench --part mujoco``: mbimpact and MuJoCo on the same scenes, in one run.

Physics, not "it ran": the clipped spring-dashpot's damping gives the declared restitution (against
an independent integration of it) and MuJoCo's ball converges to it; mbimpact's outcomes are the
rigid ones (the ball's apex e²h, κ = e, the sticking sphere's 5/7); MuJoCo's come within stated
tolerances of them; the standing robot's feet agree; ratios are measured in the same run.
"""

from __future__ import annotations

import math
import re
import sys
from functools import partial
from types import SimpleNamespace

import pytest

mujoco = pytest.importorskip("mujoco")

from scipy.integrate import solve_ivp  # noqa: E402

from mbimpact.apps.bench import format_report, run_bench  # noqa: E402
from mbimpact.apps.bench import mujoco as mj  # noqa: E402
from mbimpact.apps.bench import mujoco_contact as mc  # noqa: E402
from mbimpact.apps.bench import mujoco_models as mm  # noqa: E402
from mbimpact.apps.bench import mujoco_runs as mr  # noqa: E402
from mbimpact.apps.bench import mujoco_scenes as ms  # noqa: E402
from mbimpact.simulation import load_scene, simulate  # noqa: E402

E, H = 0.8, 1.0  # ball_drop: Newton e, drop height [m]


@pytest.fixture(scope="module")
def rows():
    return run_bench(quick=True, show_progress=False, parts=("mujoco",))


def _scene(rows, name):
    return [r for r in rows if r.case.startswith(name + " ") and not r.method.startswith("at equal accuracy")]


def _range(method, name):
    """The (low, high) range a MuJoCo row prints for its κ or restitution over the phases."""
    low, high = re.search(re.escape(name) + r" ([-\d.]+)–([-\d.]+)", method).groups()
    return float(low), float(high)


def _clipped_bounce(zeta, omega0=1.0, v0=1.0):
    """Restitution and duration of the clipped linear spring-dashpot, integrated by scipy (DOP853)."""
    k, b = omega0 * omega0, 2 * zeta * omega0

    def force(t, y):  # k x + b ẋ: the contact pushes while it is positive
        return k * y[0] + b * y[1]

    force.terminal, force.direction = True, -1
    sol = solve_ivp(lambda t, y: [y[1], -b * y[1] - k * y[0]], (0, 10 / omega0), [0.0, v0], method="DOP853",
                    events=force, rtol=1e-13, atol=1e-15)
    (t_end,), (y_end,) = sol.t_events[0], sol.y_events[0]
    return -y_end[1] / v0, t_end


@pytest.mark.parametrize("e", [0.2, 0.5, 0.8, 0.95])
def test_clipped_dashpot_gives_the_declared_restitution(e):
    zeta = mc.damping_ratio(e)
    restitution, duration = _clipped_bounce(zeta, omega0=math.sqrt(mc.STIFFNESS), v0=3.0)
    assert restitution == pytest.approx(e, abs=1e-6)  # independent of ω₀ and v₀
    assert mc.clipped_restitution(zeta) == pytest.approx(e, abs=1e-14)
    assert duration == pytest.approx(mc.contact_duration(e), rel=1e-6)
    k, b = mc.contact_solref(e)
    assert (-k, -b) == pytest.approx((mc.STIFFNESS, 2 * zeta * math.sqrt(mc.STIFFNESS)))


def test_the_unclipped_damping_overshoots_the_restitution():
    # ζ from e = exp(−ζπ/√(1−ζ²)) assumes a contact that can pull; clipped at zero force it restitutes more
    for e, clipped in ((0.8, 0.808), (0.5, 0.550), (0.2, 0.325)):
        log = math.log(e)
        zeta = -log / math.sqrt(math.pi**2 + log * log)
        assert mc.clipped_restitution(zeta) == pytest.approx(clipped, abs=6e-4)
        assert _clipped_bounce(zeta)[0] == pytest.approx(clipped, abs=6e-4)
    assert mc.clipped_restitution(1.0) == pytest.approx(_clipped_bounce(1.0 - 1e-9)[0], abs=1e-6)  # e⁻², ζ = 1
    with pytest.raises(ValueError):
        mc.damping_ratio(0.1)  # below e⁻²: a clipped linear dashpot would have to be overdamped


def _mujoco_bounce(e, dt, integrator, v0=1.0):
    """MuJoCo's restitution of a ball striking a plane without gravity, tuned from e as the bench tunes it."""
    k, b = mc.contact_solref(e)
    xml = f"""<mujoco><option timestep="{dt}" gravity="0 0 0" integrator="{integrator}" cone="elliptic"/>
      <default><geom contype="0" conaffinity="0"/></default>
      <worldbody><geom name="plane" type="plane" size="0 0 1"/>
        <body pos="0 0 0.05"><freejoint/><geom name="ball" type="sphere" size="0.05" mass="2"/></body></worldbody>
      <contact><pair geom1="plane" geom2="ball" condim="1" solref="{k!r} {b!r}"
        solimp="{' '.join(map(str, mc.SOLIMP))}"/></contact></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qvel[2] = -v0
    touched = False
    while d.time < 0.1:
        mujoco.mj_step(m, d)
        touched = touched or d.ncon > 0
        if touched and not d.ncon:
            return d.qvel[2] / v0
    raise AssertionError("never left the contact")  # pragma: no cover


@pytest.mark.parametrize("integrator", ms.INTEGRATORS)
def test_mujoco_ball_converges_to_the_declared_restitution(integrator):
    for e in (0.8, 0.5, 0.2):
        coarse, fine = (_mujoco_bounce(e, dt, integrator) - e for dt in (1e-5, 1e-6))
        assert abs(fine) < 5e-4 and abs(fine) < abs(coarse) / 5  # first order in dt, towards e
        # Richardson's limit dt → 0: e itself, not the 0.808, 0.550, 0.325 of the unclipped damping
        assert abs(fine - (coarse - fine) / 9) < 5e-5


def test_ball_apex_exact_in_mbimpact_and_close_in_mujoco(rows):
    ball = _scene(rows, "ball_drop")
    mbi, *mjc = ball
    assert mbi.method.startswith("mbimpact rtol=1e-10 (completed)") and mbi.ratio == 1.0
    assert [r.method.split(",")[0].split(" ")[-1] for r in mjc] == list(ms.INTEGRATORS)
    scene = load_scene("ball_drop")
    assert scene.contacts[0].law.e == E and scene.q0[-1] == H
    assert abs(mbi.error) <= 1e-6 and mbi.param <= 1e-8  # apex e²h, within the tolerance of the surface
    v0 = math.sqrt(2 * 9.81 * H)
    omega0 = math.sqrt(mc.STIFFNESS)
    zeta = mc.damping_ratio(E)
    wd = omega0 * math.sqrt(1 - zeta * zeta)
    t_max = math.atan(wd / (zeta * omega0)) / wd  # deepest point of the damped oscillation
    depth = v0 / wd * math.exp(-zeta * omega0 * t_max) * math.sin(wd * t_max)
    for r in mjc:
        # dt = 1e-4 s resolves a 1 ms contact in ~10 steps: a few per cent at the worst onset phase, mean < 1 %
        mean = float(re.search(r"mean error ([-+.\de]+)", r.method).group(1))
        assert abs(r.error) < 0.06 and abs(mean) < 0.01 and abs(mean) <= abs(r.error)
        low, high = _range(r.method, "restitution")
        assert low < E + 0.03 and high > E - 0.03 and high - low < 0.05
        assert r.param == pytest.approx(depth, rel=0.15)  # the spring-dashpot's deepest penetration
        assert r.ratio == pytest.approx(r.seconds / mbi.seconds)


def test_oblique_sphere_sticks_as_the_rigid_prediction(rows):
    mbi, *mjc = _scene(rows, ms.OBLIQUE)
    # mbimpact's CoulombLaw: tangential centre velocity 5/7 of before, normal −e (diagonal Delassus matrix)
    assert abs(mbi.error) <= 1e-9
    assert "v_t⁺/v_t⁻ = 0.714286" in mbi.method and "v_n⁺/v_n⁻ = -0.800000" in mbi.method
    assert ms.OBLIQUE_RATIO <= 3.5 * ms.OBLIQUE_MU * (1 + ms.OBLIQUE_E)  # within the sticking range
    for r in mjc:
        low, high = _range(r.method, "v_t⁺/v_t⁻")
        assert 5 / 7 * (1 - 3e-3) < low <= high < 5 / 7 * (1 + 3e-3)  # sticks: its friction resolves the slip
        assert abs(r.error) < 0.06  # the normal restitution, to a few per cent at dt = 1e-4 s


def test_oblique_sphere_in_mujoco_converges_to_sticking(tmp_path):
    scene, radius = ms.oblique_scene(tmp_path)
    t_touch = ms.first_impact_time(simulate(scene))
    for integrator in ms.INTEGRATORS:
        xml, init = mm.sphere_xml(scene, radius, 1e-5, integrator, mc.STIFFNESS)
        m = mujoco.MjModel.from_xml_string(xml)
        c = mr.through_contact(mujoco, m, init, t_touch, 0.5, t_touch + 0.1)
        vt, vn = ms.OBLIQUE_RATIO * ms.OBLIQUE_SPEED, ms.OBLIQUE_SPEED
        assert c.qvel_after[0] / vt == pytest.approx(5 / 7, rel=1e-3)
        assert c.qvel_after[4] * radius / vt == pytest.approx(5 / 7, rel=2e-3)  # rolling: ω r = v_t⁺
        # MuJoCo's elliptic cone couples the friction to the normal: its restitution stays ~1 % below e
        assert c.qvel_after[2] / vn == pytest.approx(ms.OBLIQUE_E, rel=0.02)


def test_robot_scenes(rows):
    ur5 = _scene(rows, "ur5_forearm_box")
    assert ur5[0].method.startswith("mbimpact rtol=1e-10 (completed)")
    assert abs(ur5[0].error) < 1e-3 and ur5[0].param <= 1e-8  # κ = e at the first impact, no penetration
    for r in ur5[1:]:
        low, high = _range(r.method, "κ (worst object)")
        assert 0.4 < low <= high < 0.6  # a rebound near e = 0.5; at dt = 1e-4 s up to ~15 % off at the worst phase
        assert abs(r.error) < 0.2 and 0 < r.param < 1e-3
    solo = _scene(rows, "solo12_geometry_landing")
    assert solo[0].method.startswith("mbimpact rtol=1e-10 (completed)") and solo[0].error == 0.0
    for r in solo[1:]:
        assert 0 < r.error < 0.05  # the base's vertical velocity 1–20 ms after landing, against mbimpact's
        assert 0 < r.param < 1e-3


@pytest.mark.parametrize("integrator", ms.INTEGRATORS)
def test_ur5_kappa_converges_at_a_fixed_stiffness(integrator, tmp_path):
    scene = load_scene("ur5_forearm_box")
    measure = ms.Measure(scene, simulate(scene))
    xml = mm.robot_xml(mujoco, scene, 1e-5, integrator, mc.STIFFNESS, tmp_path)
    m = mujoco.MjModel.from_xml_string(xml)
    errors, penetration, kappas = ms.measure(mujoco, m, partial(mm.initial_state, scene=scene), measure.mujoco)
    # 100 steps per contact: κ = 0.500 ± 1 % at every onset phase, ± 0.5 % on average over them
    assert max(map(abs, errors)) < 1e-2 and abs(sum(errors) / len(errors)) < 5e-3
    assert 0 < penetration < 1e-3


def test_standing_feet_agree(rows):
    mbi, *mjc = [r for r in rows if r.case.startswith(mj.STANDING)]
    assert mbi.method.startswith("mbimpact (completed")
    for r in [mbi, *mjc]:
        assert r.param == pytest.approx(float(re.search(r"\((\d+) s", r.case).group(1)) / r.seconds)
        assert r.ratio == pytest.approx(r.seconds / mbi.seconds)
    for r in mjc:
        feet = [float(x) for x in re.search(r"feet z \(([^)]*)\) mm", r.method).group(1).split(", ")]
        assert all(-0.05 < z <= 0.0 for z in feet)  # resting on the ground: MuJoCo's spheres sink a little
        assert 0 < r.error < 5e-5  # its feet within 0.05 mm of mbimpact's (at z = 0)


def test_equal_accuracy_rows(rows):
    equal = [r for r in rows if r.method.startswith("at equal accuracy")]
    cases = {r.case for r in equal}
    assert len(cases) == 3 and not any(c.startswith("solo12") for c in cases)
    for r in equal:
        assert r.param in mj.TOLERANCES
        if math.isfinite(r.error):  # MuJoCo reached it: its cheapest setting within the tolerance
            assert abs(r.error) <= r.param and r.seconds > 0
        if math.isfinite(r.ratio):
            assert r.ratio > 0
    text = mj.format_rows(rows)
    assert "Wall time at equal accuracy" in text and "Contact phase" in text
    assert text.count("\n| ") == len(rows) + 3  # one header per table
    assert "Against MuJoCo" in format_report(rows)


def test_timings_are_measured_in_the_same_run(rows):
    for r in rows:
        assert r.part == "mujoco"
        if "skipped" in r.method or r.method.startswith("at equal accuracy"):
            continue
        assert math.isfinite(r.seconds) and r.seconds > 0 and math.isfinite(r.ratio) and r.ratio > 0


def test_skipped_rows_carry_a_reason(tmp_path):
    # a rough law has no MuJoCo counterpart: one row, the reason, no numbers (and nothing simulated)
    (row,) = ms.scene_rows(mujoco, "ur5_strikes_table", True)
    assert re.fullmatch(r"MuJoCo: skipped \(.*rough.*\)", row.method)
    assert all(math.isnan(x) for x in (row.param, row.error, row.seconds, row.ratio))

    def refuse(path):  # a URDF MuJoCo cannot load: the compiler's message is the reason
        raise ValueError("Error: mesh file not found\nElement 'mesh'")

    refusing = SimpleNamespace(MjModel=SimpleNamespace(from_xml_path=refuse), mj_saveLastXML=mujoco.mj_saveLastXML)
    with pytest.raises(mm.Unsupported, match=r"cannot load ur5_robot\.urdf: Error: mesh file not found$"):
        mm.robot_xml(refusing, load_scene("ur5_forearm_box"), 1e-4, "Euler", mc.STIFFNESS, tmp_path)


def test_available_says_when_mujoco_is_missing(monkeypatch):
    assert mj.available()
    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco now raises ImportError
    assert not mj.available()
    assert "mujoco" in mj.UNAVAILABLE and "\n" not in mj.UNAVAILABLE

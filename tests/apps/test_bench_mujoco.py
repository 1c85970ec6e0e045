"""``mbimpact bench --part mujoco``: mbimpact and MuJoCo on the same scenes, in one run.

Physics, not "it ran": the ball's apex after its first bounce is e²h exactly in mbimpact and
within a stated tolerance in MuJoCo with its contact tuned from e; the robots' first impacts give
κ = e in mbimpact; ratios are measured, positive and finite; a scene MuJoCo cannot express says why.
"""

from __future__ import annotations

import math
import re
import sys
from types import SimpleNamespace

import pytest

mujoco = pytest.importorskip("mujoco")

from mbimpact.apps.bench import format_report, run_bench  # noqa: E402
from mbimpact.apps.bench import mujoco as mj  # noqa: E402
from mbimpact.simulation import load_scene  # noqa: E402

E, H = 0.8, 1.0  # ball_drop: Newton e, drop height [m]
#: MuJoCo's apex against e²h, relative, with solref set from e and 10 time steps per contact
#: (measured −0.56 % at dt = 1e-4 s: a restitution of 0.798 instead of 0.8).
MUJOCO_APEX_RTOL = 0.02


@pytest.fixture(scope="module")
def rows():
    return run_bench(quick=True, show_progress=False, parts=("mujoco",))


def _scene(rows, name):
    return [r for r in rows if r.case.startswith(name + " ")]


def test_damping_ratio_gives_the_restitution():
    for e in (0.2, 0.5, 0.8, 1.0):
        z = mj.damping_ratio(e)
        assert math.exp(-z * math.pi / math.sqrt(1 - z * z)) == pytest.approx(e, rel=1e-12)
    k, b = mj.contact_solref(0.8, 1e-4)
    z = mj.damping_ratio(0.8)
    w0 = math.sqrt(-k)
    assert -b == pytest.approx(2 * z * w0)
    assert math.pi / (w0 * math.sqrt(1 - z * z)) == pytest.approx(mj.CONTACT_STEPS * 1e-4)  # contact duration


def test_ball_apex_exact_in_mbimpact_and_close_in_mujoco(rows):
    ball = _scene(rows, "ball_drop")
    assert [r.method.split(" ")[0] for r in ball] == ["mbimpact", "MuJoCo"]
    mbi, mjc = ball
    exact = E * E * H
    assert load_scene("ball_drop").contacts[0].law.e == E and load_scene("ball_drop").q0[-1] == H
    # error is apex/(e²h) − 1; the apex is also printed in the method
    assert abs(mbi.error * exact) <= 1e-6
    assert float(re.search(r"apex ([\d.]+) m", mbi.method).group(1)) == pytest.approx(exact, abs=1e-6)
    assert mbi.param <= 1e-8  # mbimpact's penetration: within its tolerance
    apex = float(re.search(r"apex ([\d.]+) m", mjc.method).group(1))
    assert abs(apex / exact - 1) <= MUJOCO_APEX_RTOL
    assert mjc.error == pytest.approx(apex / exact - 1, abs=1e-6)
    restitution = float(re.search(r"restitution ([\d.]+)", mjc.method).group(1))
    assert restitution == pytest.approx(E, abs=0.01)
    # a soft contact penetrates: about v/ω₀ = √(2gh)·CONTACT_STEPS·dt/π ≈ 1.4 mm here
    assert 2e-4 < mjc.param < 5e-3


def test_robot_scenes_first_impact(rows):
    for name, e in (("ur5_forearm_box", 0.5), ("solo12_geometry_landing", 0.2)):
        scene_rows = _scene(rows, name)
        mbi = scene_rows[0]
        assert mbi.method.startswith("mbimpact (completed)")
        assert abs(mbi.error) < 1e-3 and mbi.param <= 1e-8  # κ = e at the first impact, no penetration
        for r in scene_rows[1:]:
            if "skipped" in r.method:
                continue
            kappas = [float(k) for k in re.search(r"κ = ([\d., ]+)", r.method).group(1).split(", ")]
            assert kappas and all(0 < k < 1 for k in kappas)  # a rebound, with a loss
            worst = max((k / e - 1 for k in kappas), key=abs)  # κ printed to 3 decimals
            assert math.isfinite(r.error) and r.error == pytest.approx(worst, abs=0.0005 / e)
            assert 0 < r.param < 0.01  # penetrates, but less than a centimetre


def test_ratios_are_measured_in_the_same_run(rows):
    assert len({r.case for r in rows}) == len(mj.SCENES)
    for r in rows:
        assert r.part == "mujoco"
        if "skipped" in r.method:
            continue
        assert math.isfinite(r.seconds) and r.seconds > 0
        assert math.isfinite(r.ratio) and r.ratio > 0
        if r.method.startswith("mbimpact"):
            assert r.ratio == 1.0
        else:  # MuJoCo's wall time over mbimpact's on the same scene
            mbi = next(m for m in rows if m.case == r.case and m.method.startswith("mbimpact"))
            assert r.ratio == pytest.approx(r.seconds / mbi.seconds)
    text = mj.format_rows(rows)
    assert text.count("\n| ") == len(rows) + 1 and "wall s / mbimpact's" in text
    assert "Against MuJoCo" in format_report(rows)


def test_skipped_rows_carry_a_reason(tmp_path):
    # a rough law has no MuJoCo counterpart: one row, the reason, no numbers (and nothing simulated)
    (row,) = mj._scene_rows(mujoco, "ur5_strikes_table", (1e-4,))
    assert re.fullmatch(r"MuJoCo: skipped \(.*rough.*\)", row.method)
    assert all(math.isnan(x) for x in (row.param, row.error, row.seconds, row.ratio))
    # a URDF MuJoCo cannot load: the compiler's message is the reason
    def refuse(path):
        raise ValueError("Error: mesh file not found\nElement 'mesh'")

    refusing = SimpleNamespace(MjModel=SimpleNamespace(from_xml_path=refuse), mj_saveLastXML=mujoco.mj_saveLastXML)
    with pytest.raises(mj._Unsupported, match=r"cannot load ur5_robot\.urdf: Error: mesh file not found$"):
        mj._robot_model(refusing, load_scene("ur5_forearm_box"), 1e-4, tmp_path)


def test_available_says_when_mujoco_is_missing(monkeypatch):
    assert mj.available()
    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco now raises ImportError
    assert not mj.available()
    assert "mujoco" in mj.UNAVAILABLE and "\n" not in mj.UNAVAILABLE

"""The contact-phase cases of the MuJoCo bench beyond Solo12: Talos on its sole corners, a UR5 resting on a table.

Physics, not timing: each robot comes to rest on its contact points, on their surfaces, in mbimpact and
in MuJoCo; MuJoCo's spheres sit where mbimpact's points are.
"""

from __future__ import annotations

import re
import tempfile
from functools import partial
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from mbimpact.apps.bench import mujoco_models as mm  # noqa: E402
from mbimpact.apps.bench import mujoco_poses as mp  # noqa: E402
from mbimpact.apps.bench import mujoco_standing as st  # noqa: E402
from mbimpact.apps.bench.mujoco_runs import timed_run, unstable  # noqa: E402
from mbimpact.simulation import simulate  # noqa: E402

TALOS = partial(mp.talos_scene, drop=st.DROP, step=st.STEP)
UR5 = partial(mp.ur5_scene, drop=st.DROP, step=st.STEP)


def _mujoco(scene, integrator="Euler"):
    with tempfile.TemporaryDirectory() as tmp:
        m = mujoco.MjModel.from_xml_string(mm.standing_xml(mujoco, scene, st.STEP, integrator, Path(tmp)))
    init = partial(mm.initial_state, scene=scene)
    return m, init


@pytest.mark.parametrize("build", [TALOS, UR5], ids=["talos", "ur5"])
def test_mujoco_spheres_start_at_the_contact_points(build):
    scene = build(0.1)
    m, init = _mujoco(scene)
    d = mujoco.MjData(m)
    init(m, d)
    heights = st.contact_heights(scene, scene.q0)
    assert heights.min() == pytest.approx(st.DROP, abs=1e-12)
    np.testing.assert_allclose(mm.point_heights(m, d, scene), heights, atol=1e-9)


def test_talos_stands_on_its_eight_sole_corners():
    scene = TALOS(1.0)
    assert len(scene.contacts) == 8 and {c.frame for c in scene.contacts} == set(mp.SOLES)
    tr = simulate(scene)
    assert tr.status == "completed"
    assert tr.min_gap >= -scene.tolerance
    np.testing.assert_allclose(st.contact_heights(scene, tr.q[-1]), 0.0, atol=1e-6)  # flat on both soles
    assert abs(tr.q[-1, 2] - scene.q0[2]) < 5e-3  # the base stays up: it stands
    m, init = _mujoco(scene)
    _, d = timed_run(mujoco, m, init, scene.duration)
    assert not unstable(mujoco, d)
    np.testing.assert_allclose(mm.point_heights(m, d, scene), 0.0, atol=5e-5)  # MuJoCo's spheres sink a little
    assert d.qpos[2] == pytest.approx(tr.q[-1, 2], abs=1e-3)


def test_ur5_rests_its_tool_on_the_table():
    scene = UR5(1.0)
    tr = simulate(scene)
    assert tr.status == "completed" and tr.min_gap >= -scene.tolerance
    assert any(e.kind == "rest" for e in tr.events)
    assert abs(st.contact_heights(scene, tr.q[-1])[0]) < 1e-6
    assert np.abs(tr.v[-1]).max() < 1e-3  # at rest, pressed on the table
    for integrator in ("Euler", "RK4"):
        m, init = _mujoco(scene, integrator)
        _, d = timed_run(mujoco, m, init, scene.duration)
        assert not unstable(mujoco, d)
        assert -5e-5 < mm.point_heights(m, d, scene)[0] <= 0.0
        # the tool sticks where its impact left it: Newton's impact has no friction, MuJoCo's contact has
        tool = d.geom_xpos[m.geom("point0").id]
        np.testing.assert_allclose(tool, scene.mechanism.frame_position(tr.q[-1], mp.TABLE_FRAME), atol=1e-3)
        np.testing.assert_allclose(d.qpos, tr.q[-1], atol=5e-3)


def test_case_rows_time_mbimpact_with_two_samples():
    rows = st.case_rows(mujoco, st.UR5, UR5(0.2), True)
    assert [r.method.split(" ")[0] for r in rows] == ["mbimpact", "MuJoCo", "MuJoCo"]
    assert rows[0].method.startswith("mbimpact (completed") and f"{st.TIMED_SAMPLES} output samples" in rows[0].method
    for r in rows:
        assert r.case.startswith(st.STANDING)
        assert r.seconds > 0 and r.param == pytest.approx(0.2 / r.seconds)
        tool = float(re.search(r"tool z \(([^)]*)\) mm", r.method).group(1))
        assert -0.05 < tool <= 1e-3

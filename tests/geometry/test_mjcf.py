"""MJCF through Pinocchio: kinematics, collision geoms as coal primitives, and the parser's limits in 4.1."""

from __future__ import annotations

import coal
import numpy as np
import pytest

import mbimpact as mbi
from mbimpact import geometry as G


def test_mjcf_mechanism_and_its_collision_geoms(tiny_mjcf):
    mech = mbi.Mechanism.from_mjcf(tiny_mjcf)
    assert (mech.nq, mech.nv, mech.name) == (8, 7, "tiny")
    assert mech.collision_names() == ["floor", "box_geom", "ball_geom", "stick"]
    cm = mech.collision_model()
    assert isinstance(cm.geometry("floor"), coal.Halfspace) and cm.joint("floor") == 0
    np.testing.assert_allclose(cm.geometry("box_geom").halfSide, [0.2, 0.15, 0.1])  # MJCF sizes are half sizes
    assert isinstance(cm.geometry("stick"), coal.Capsule)
    assert cm.moving == ["box_geom", "ball_geom", "stick"]


def test_mjcf_distances_at_qpos0(tiny_mjcf):
    """The free body's MJCF pos lives in referenceConfigurations['qpos0'] only, not in the neutral q."""
    mech = mbi.Mechanism.from_mjcf(tiny_mjcf)
    q0 = mech.model.referenceConfigurations["qpos0"]
    gm = G.GapModel(mech, [G.HalfSpace()])
    np.testing.assert_allclose(gm.distances(q0), [0.4, 0.45, 0.28], atol=1e-12)
    # the MJCF floor itself, a collision object on the universe, pairs like an obstacle
    floor = G.GapModel(mech, self_pairs=[("box_geom", "floor"), ("stick", "floor")])
    np.testing.assert_allclose(floor.distances(q0), [0.4, 0.28], atol=1e-12)
    np.testing.assert_allclose(gm.distances(mech.neutral())[0], -0.1, atol=1e-12)
    g = G.GeometryContact(body="box_geom", other="floor").gap(mech, q0)
    np.testing.assert_allclose(g.normal, [0, 0, 1], atol=1e-12)


def test_mjcf_impact(tiny_mjcf):
    mech = mbi.Mechanism.from_mjcf(tiny_mjcf)
    q0 = mech.model.referenceConfigurations["qpos0"].copy()
    q0[2] = 0.1  # box bottom on the floor
    v = np.zeros(7)
    v[2] = -1.0
    res = mbi.impact(mech, q0, v, G.GeometryContact(body="box_geom", other="floor"), mbi.NewtonLaw(0.0))
    assert res.u_plus[2] == pytest.approx(0.0, abs=1e-12)


def test_pinocchio_41_reads_only_the_first_top_level_body(tmp_path):
    """Known limit of Pinocchio 4.1's MJCF parser: later top-level bodies are dropped silently;
    wrapping them in one jointless root body works."""
    b1 = '<body name="b1" pos="0 0 1"><freejoint/><geom name="g1" type="box" size=".1 .1 .1"/></body>'
    b2 = '<body name="b2" pos="1 0 1"><freejoint/><geom name="g2" type="sphere" size=".1"/></body>'
    two = tmp_path / "two.xml"
    two.write_text(f"<mujoco><worldbody>{b1}{b2}</worldbody></mujoco>")
    mech = mbi.Mechanism.from_mjcf(two)
    assert mech.nq == 7 and mech.collision_names() == ["g1"]
    wrapped = tmp_path / "wrapped.xml"
    wrapped.write_text(f'<mujoco><worldbody><body name="root">{b1}{b2}</body></worldbody></mujoco>')
    mech = mbi.Mechanism.from_mjcf(wrapped)
    assert mech.nq == 14 and mech.collision_names() == ["g1", "g2"]


def test_mjcf_errors(tmp_path):
    with pytest.raises(mbi.RobotNotFoundError, match="not found"):
        mbi.Mechanism.from_mjcf(tmp_path / "missing.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body")
    with pytest.raises(mbi.RobotNotFoundError, match="could not parse"):
        mbi.Mechanism.from_mjcf(bad)
    with pytest.raises(mbi.ParameterError, match="floating"):
        mbi.Mechanism.from_mjcf(bad, floating="yes")  # type: ignore[arg-type]


def test_mjcf_mesh_geoms_and_a_floating_root(tmp_path):
    """A jointless MJCF body made floating by from_mjcf(floating=True); its mesh geom becomes a hull."""
    from mbimpact.mechanism.robots import robots_dir

    foot = robots_dir() / "solo_description/meshes/stl/with_foot/solo_foot.stl"
    path = tmp_path / "mesh.xml"
    path.write_text(f"""<mujoco><asset><mesh name="foot" file="{foot}" scale="3 3 3"/></asset><worldbody>
      <body name="b"><geom name="foot_geom" type="mesh" mesh="foot" mass="1"/>
        <geom name="cyl" type="cylinder" size="0.05 0.1" pos="0.3 0 0" mass="1"/></body>
    </worldbody></mujoco>""")
    mech = mbi.Mechanism.from_mjcf(path, floating=True)
    assert mech.nq == 7
    cm = mech.collision_model()
    assert isinstance(cm.geometry("foot_geom"), coal.ConvexBase) and isinstance(cm.geometry("cyl"), coal.Cylinder)
    zmin = 3 * coal.MeshLoader().load(str(foot), np.ones(3)).vertices()[:, 2].min()
    q = mech.neutral()
    q[2] = 0.5
    np.testing.assert_allclose(G.GapModel(mech, [G.HalfSpace()]).distances(q), [0.5 + zmin, 0.4], atol=1e-9)

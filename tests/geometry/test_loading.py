"""A mechanism's collision objects: loaded on first use from URDF, with meshes as hulls; named errors."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

import mbimpact as mbi
from mbimpact import geometry as G
from mbimpact.geometry.cache import mechanism_cache

from tests.geometry.helpers import model


def test_urdf_collision_elements():
    assert mbi.Mechanism.from_model("sphere").collision_names() == ["sphere_0"]
    box = mbi.Mechanism.from_urdf(mbi.model_path("box"), floating=True)
    assert box.collision_names() == ["box_0"]
    np.testing.assert_allclose(box.collision_model().geometry("box_0").halfSide, [0.1, 0.1, 0.05])
    assert box.collision_model().joint("box_0") == 1


def test_robot_meshes_become_hulls():
    solo = model("solo12")
    names = solo.collision_names()
    assert len(names) == 17 and "FL_FOOT_0" in names
    cm = solo.collision_model()
    assert all(isinstance(cm.geometry(n), coal.ConvexBase) for n in names)
    assert cm.moving == names  # every link of a floating robot moves
    ur5 = model("ur5")
    assert isinstance(ur5.collision_model().geometry("ee_link_0"), coal.Box)  # a URDF <box> stays a box
    assert ur5.collision_model().joint("base_link_0") == 0
    assert "base_link_0" not in ur5.collision_model().moving


def test_geometry_is_loaded_only_when_asked():
    """Frame contacts never pay for collision geometry."""
    mech = mbi.Mechanism.from_robot("solo12")
    q = mech.neutral()
    v = -mech.point_jacobian(q, "FL_FOOT")[2]
    mbi.impact(mech, q, v, mbi.PointContact("FL_FOOT"), mbi.NewtonLaw(0.0))
    assert "collision_model" not in mech.__dict__.get("_mbimpact_geometry", {})
    cm = mech.collision_model()
    assert mech.collision_model() is cm  # cached with the mechanism
    assert mechanism_cache(mech)["collision_model"] is cm


def test_pickled_mechanism_reloads_its_geometry():
    import pickle

    mech = mbi.Mechanism.from_model("sphere")
    mech.collision_model()
    clone = pickle.loads(pickle.dumps(mech))
    assert clone.collision_names() == ["sphere_0"]


def test_unknown_collision_name_lists_close_matches():
    solo = model("solo12")
    with pytest.raises(G.CollisionNotFoundError, match="FL_FOOT_0") as info:
        G.gaps(solo, solo.neutral(), [G.HalfSpace()], bodies=["FL_FOOT"])
    assert isinstance(info.value, mbi.NameNotFoundError) and isinstance(info.value, mbi.ImpactError)
    with pytest.raises(G.CollisionNotFoundError, match="close matches"):
        G.GeometryContact(body="FL_FOT_0", obstacle=G.HalfSpace()).gap(solo, solo.neutral())
    with pytest.raises(G.CollisionNotFoundError, match="string"):
        solo.collision_model().index(3)  # type: ignore[arg-type]


def test_mechanism_without_file_gets_an_empty_model_to_fill():
    m = pin.Model()
    j = m.addJoint(0, pin.JointModelPZ(), pin.SE3.Identity(), "slider")
    m.appendBodyToJoint(j, pin.Inertia.FromSphere(1.0, 0.1), pin.SE3.Identity())
    m.addBodyFrame("puck", j, pin.SE3.Identity(), m.addJointFrame(j, 0))
    mech = mbi.Mechanism(m, "slider")
    assert mech.collision_names() == []
    with pytest.raises(G.CollisionNotFoundError, match="no collision objects"):
        mech.collision_model().index("puck")
    with pytest.raises(G.GeometryError, match="no moving collision object"):
        G.GapModel(mech, [G.HalfSpace()])
    cm = mech.collision_model()
    assert cm.add("puck_0", "puck", G.Cylinder(0.1, 0.02)) == 0
    assert cm.version == 1
    g = G.gaps(mech, np.array([0.5]), [G.HalfSpace()])[0]
    assert g.distance == pytest.approx(0.49) and g.gradient == pytest.approx([1.0])


def test_attaching_shapes_checks_names_and_frames():
    mech = mbi.Mechanism.from_model("box")
    cm = mech.collision_model()
    with pytest.raises(G.GeometryError, match="already has"):
        cm.add("box_0", "box", G.Sphere(0.1))
    with pytest.raises(mbi.FrameNotFoundError, match="corner0"):
        cm.add("ball", "corner", G.Sphere(0.1))
    with pytest.raises(mbi.ParameterError, match="shape"):
        cm.add("ball", "corner0", "sphere")  # type: ignore[arg-type]
    # a shape fixed to a frame: its pose is read in the frame (corner0 is at (-0.1, -0.1, -0.05))
    cm.add("nub", "corner0", G.Sphere(0.01, position=(0, 0, -0.01)))
    q = mech.neutral()
    q[2] = 1.0
    g = G.gaps(mech, q, [G.HalfSpace()], bodies=["nub"])[0]
    assert g.distance == pytest.approx(1.0 - 0.05 - 0.01 - 0.01)
    np.testing.assert_allclose(g.point, [-0.1, -0.1, 1.0 - 0.07], atol=1e-12)


def test_urdf_meshes_resolve_relative_and_package_paths(tmp_path):
    """A mesh given relative to the URDF, and one as package://<folder>/... next to it."""
    import shutil

    from mbimpact.mechanism.robots import robots_dir

    pkg = tmp_path / "my_robot"
    (pkg / "meshes").mkdir(parents=True)
    (pkg / "urdf").mkdir()
    shutil.copy(robots_dir() / "solo_description/meshes/stl/with_foot/solo_foot.stl", pkg / "meshes" / "foot.stl")
    inertial = '<inertial><mass value="1"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>'
    (pkg / "urdf" / "r.urdf").write_text(f"""<robot name="r">
      <link name="a">{inertial}<collision><geometry><mesh filename="../meshes/foot.stl"/></geometry></collision></link>
      <link name="b">{inertial}<collision><geometry><mesh filename="package://my_robot/meshes/foot.stl"/></geometry>
      </collision></link>
      <joint name="j" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    </robot>""")
    mech = mbi.Mechanism.from_urdf(pkg / "urdf" / "r.urdf", floating=True)
    assert mech.collision_names() == ["a_0", "b_0"]
    assert all(isinstance(mech.collision_model().geometry(n), coal.ConvexBase) for n in mech.collision_names())


def test_missing_mesh_is_a_geometry_error(tmp_path):
    urdf = tmp_path / "r.urdf"
    urdf.write_text("""<robot name="r"><link name="a"><inertial><mass value="1"/>
      <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
      <collision><geometry><mesh filename="package://nowhere/foot.stl"/></geometry></collision></link></robot>""")
    mech = mbi.Mechanism.from_urdf(urdf, floating=True)  # kinematics load; the geometry only on demand
    with pytest.raises(G.GeometryError, match="could not load the collision geometry"):
        mech.collision_names()

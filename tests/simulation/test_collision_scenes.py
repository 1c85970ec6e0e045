"""Scenes whose contacts are the mechanism's own collision geometry, checked by their physics."""

from __future__ import annotations

import functools

import numpy as np
import pinocchio as pin
import pytest

import mbimpact as mbi


@functools.lru_cache(maxsize=None)
def run(name: str) -> mbi.Trajectory:
    return mbi.simulate(mbi.load_scene(name))


def impacts(tr):
    return [e for e in tr.events if e.kind == "impact"]


def energy_never_grows(tr, tol=1e-9):
    """Energy increments ≤ tol [J] between samples. A persistent contact stepped at h and struck inside a
    step may gain O(m g h²) (Moreau's scheme is first order); free flight and impacts gain nothing."""
    assert np.all(np.diff(tr.energy) <= tol)


def angular_momentum_about(model, q, v, p):
    """World angular momentum (3,) of the whole mechanism about the world point p."""
    data = model.createData()
    pin.computeCentroidalMomentum(model, data, q, v)
    return data.hg.angular + np.cross(data.com[0] - p, data.hg.linear)


# ---------------------------------------------------------------------------------- the sphere
def test_spinning_sphere_strikes_below_its_centre_wherever_it_has_rolled():
    tr = run("sphere_spin_rough_plane")
    assert tr.status == "completed" and tr.min_gap >= -tr.tolerance
    hits = impacts(tr)
    assert len(hits) >= 5
    for e in hits:
        k = tr.before(e.t)
        centre = tr.q[k, :3]
        np.testing.assert_allclose(e.point, centre - [0.0, 0.0, 0.05], atol=1e-9)
    xs = [e.point[0] for e in hits]
    assert np.ptp(xs) > 0.05  # the contact point follows the sphere along the plane


def test_spinning_sphere_keeps_its_angular_momentum_about_each_contact_point():
    """The impulse of an impact acts at the witness point: the angular momentum about it is kept."""
    tr = run("sphere_spin_rough_plane")
    model = mbi.load_scene("sphere_spin_rough_plane").mechanism.model
    for e in impacts(tr):
        k = tr.before(e.t)
        assert tr.t[k] == e.t and tr.t[k + 1] == e.t
        before = angular_momentum_about(model, tr.q[k], tr.v[k], e.point)
        after = angular_momentum_about(model, tr.q[k + 1], tr.v[k + 1], e.point)
        np.testing.assert_allclose(after, before, atol=1e-12 * (1 + np.abs(before).max()))
        assert e.kappa > 0 and e.mu > 0  # the roughness takes slip and gives rebound


def test_spinning_sphere_ends_rolling_without_slip():
    tr = run("sphere_spin_rough_plane")
    energy_never_grows(tr)
    assert tr.resting == (True,)
    q, v = tr.q[-1], tr.v[-1]
    R = pin.Quaternion(q[3:7]).matrix()
    centre_velocity, omega = R @ v[:3], R @ v[3:]  # the free flyer's velocity is in its own frame
    slip = centre_velocity + np.cross(omega, [0.0, 0.0, -0.05])
    assert np.linalg.norm(centre_velocity) > 1e-2 and np.linalg.norm(slip) < 1e-6


# ---------------------------------------------------------------------------------- the box
def corner_scene(scene: mbi.Scene) -> mbi.Scene:
    """The same scene with the box's eight corners as frame contacts (plain points on a plane)."""
    law = scene.contacts[0].law
    corners = tuple(mbi.SceneContact(f"corner{k}", law, friction=scene.contacts[0].friction) for k in range(8))
    return mbi.Scene(scene.mechanism, scene.q0, scene.v0, corners, duration=0.3, simultaneous="newton")


def test_tumbling_box_first_impacts_equal_those_of_its_corner_points():
    """Coal's box against the half-space and eight frame points on a plane: the same impacts."""
    scene = mbi.load_scene("box_tumbling")
    tr = run("box_tumbling")
    ref = mbi.simulate(corner_scene(scene))
    mine, theirs = impacts(tr)[:4], impacts(ref)[:4]
    assert len(theirs) == 4
    np.testing.assert_allclose([e.t for e in mine], [e.t for e in theirs], rtol=1e-9)
    np.testing.assert_allclose([e.un_plus for e in mine], [e.un_plus for e in theirs], rtol=1e-7)
    for e in mine:
        assert e.points == 1  # corners


def test_tumbling_box_strikes_corners_and_edges_and_settles_on_a_face():
    tr = run("box_tumbling")
    assert tr.status == "completed" and tr.min_gap >= -tr.tolerance
    energy_never_grows(tr, tol=1.0 * 9.81 * 1e-3**2)  # m g h²: an edge striking inside a contact step
    points = {e.points for e in impacts(tr)}
    assert {1, 2} <= points  # corners, and an edge landing flat (two witness points at once)
    for e in impacts(tr):
        if e.rule.startswith("NewtonLaw"):
            assert e.kappa == pytest.approx(0.3, abs=1e-9)
    q = tr.q[-1]
    R = pin.Quaternion(q[3:7]).matrix()
    assert abs(R[2, 2]) == pytest.approx(1.0, abs=1e-6) and q[2] == pytest.approx(0.05, abs=1e-6)  # flat, on a face
    assert np.abs(tr.v[-1]).max() < 1e-6
    mech = mbi.load_scene("box_tumbling").mechanism
    # on its four corners, within the scene's patch tolerance of each other
    assert len(mbi.contact_points(mech, q, [mbi.HalfSpace()], margin=1e-5, patch_tolerance=1e-5)) == 4


def test_box_dropped_flat_is_the_frame_corner_scene():
    ref_scene = mbi.load_scene("box_landing")
    law = ref_scene.contacts[0].law
    scene = mbi.Scene(ref_scene.mechanism, ref_scene.q0, ref_scene.v0,
                      (mbi.SceneCollision("box_0", law, obstacle=mbi.HalfSpace(), friction=0.5),),
                      duration=1.5, simultaneous="newton")
    tr, ref = mbi.simulate(scene), mbi.simulate(ref_scene)
    assert tr.status == "completed"
    mine = impacts(tr)
    assert all(e.points == 4 for e in mine)  # the whole face at once
    first_by_time = sorted({e.t for e in impacts(ref)})
    np.testing.assert_allclose([e.t for e in mine], first_by_time[:len(mine)], rtol=1e-9)
    np.testing.assert_allclose(tr.q[-1], ref.q[-1], atol=1e-9)


# ---------------------------------------------------------------------------------- Solo12
def test_solo12_lands_on_its_feet_only_and_stands():
    tr = run("solo12_geometry_landing")
    scene = mbi.load_scene("solo12_geometry_landing")
    assert tr.status == "completed" and tr.min_gap >= -tr.tolerance
    assert len(scene.contacts) == 17  # "all": every collision object against the ground
    labels = [c.label for c in scene.contacts]
    touched = {labels[e.contact].split(" |")[0] for e in tr.events}
    assert touched == {"FL_FOOT_0", "FR_FOOT_0", "HL_FOOT_0", "HR_FOOT_0"}
    first = impacts(tr)[:4]
    assert len({e.t for e in first}) == 1 and all(e.group == 4 for e in first)  # the four feet together
    feet = [i for i, lab in enumerate(labels) if "FOOT" in lab]
    assert all(tr.active[-1, i] for i in feet)
    legs = [i for i, lab in enumerate(labels) if "LOWER_LEG" in lab]
    assert tr.gaps[:, legs].min() > 5e-3
    assert 0.2 < tr.q[-1, 2] < 0.26 and np.abs(tr.v[-1]).max() < 1e-3


# ---------------------------------------------------------------------------------- UR5
def test_ur5_forearm_strikes_the_top_of_the_box_and_rests_on_it():
    tr = run("ur5_forearm_box")
    scene = mbi.load_scene("ur5_forearm_box")
    assert tr.status == "completed" and tr.min_gap >= -tr.tolerance
    energy_never_grows(tr)
    hits = impacts(tr)
    forearm = [i for i, c in enumerate(scene.contacts) if c.label == "forearm_link_0 | box"]
    assert {e.contact for e in tr.events} == set(forearm)
    first = hits[0]
    assert first.point[2] == pytest.approx(0.27, abs=1e-9) and 0.5 - 1e-9 <= first.point[0] <= 0.6 + 1e-9  # the top face
    for e in hits:
        # Newton's law: one point rebounds at e; several (the newton rule) leave at least at e each
        if e.rule.startswith("NewtonLaw"):
            assert e.kappa == pytest.approx(0.5, abs=1e-9)
        else:
            assert e.points > 1 and e.kappa >= 0.5 - 1e-9
    assert tr.resting[forearm[0]]


# ---------------------------------------------------------------------------------- self-collision
def test_links_striking_each_other_keep_the_angular_momentum_about_the_pivot():
    """No gravity: the only external impulse acts at the fixed shoulder, so an impact between the two
    links (an internal impulse, equal and opposite on both) keeps the angular momentum about it; with
    e = 1 it keeps the kinetic energy too, and the relative normal velocity reverses."""
    mech = mbi.Mechanism.from_model("double_pendulum")
    cm = mech.collision_model()
    cm.add("peg", "link1", mbi.Sphere(0.05, position=(0.25, 0.0, -0.6)))
    cm.add("rod2", "link2", mbi.Capsule(0.02, 0.8, position=(0.0, 0.0, -0.5)))
    scene = mbi.Scene(mech, [0.0, 1.5], [0.0, 3.0], (mbi.SceneCollision("rod2", mbi.NewtonLaw(1.0), other="peg"),),
                      gravity=False, duration=2.0)
    tr = mbi.simulate(scene)
    assert tr.status == "completed" and tr.min_gap >= -tr.tolerance
    (hit,) = impacts(tr)
    assert hit.un_plus == pytest.approx(-hit.un_minus, rel=1e-12)
    k = tr.before(hit.t)
    L = [angular_momentum_about(mech.model, q, v, np.zeros(3))[1] for q, v in zip(tr.q[k:k + 2], tr.v[k:k + 2])]
    assert L[1] == pytest.approx(L[0], rel=1e-12)
    assert tr.energy[k + 1] == pytest.approx(tr.energy[k], rel=1e-12)
    assert np.ptp(tr.energy) < 1e-8 * tr.energy[0]


# ---------------------------------------------------------------------------------- declared effects
def test_frame_contact_scenes_never_load_collision_geometry():
    tr = mbi.simulate(mbi.load_scene("ball_drop"))
    assert "collision_queries" not in tr.work
    tr = run("sphere_spin_rough_plane")
    assert tr.work["collision_queries"] > 0

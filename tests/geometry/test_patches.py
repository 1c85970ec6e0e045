"""Several witness points: every corner of a flat face, both ends of an edge, one point for a corner."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from mbimpact import geometry as G

from tests.geometry.helpers import model, two_balls

HALF_BOX = np.array([0.1, 0.1, 0.05])  # models/box.urdf
CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * HALF_BOX


def box_q(R: np.ndarray, lowest: float, xy=(0.0, 0.0)) -> np.ndarray:
    """The floating box with attitude R, its lowest corner at height ``lowest``."""
    q = model("box").neutral()
    q[:2] = xy
    q[2] = lowest - (CORNERS @ R.T)[:, 2].min()
    q[3:7] = pin.Quaternion(R).coeffs()
    return q


def sort_rows(a: np.ndarray) -> np.ndarray:
    return a[np.lexsort(a.T[::-1])]


@pytest.mark.parametrize("height", [0.0, 5e-4, -5e-4])
def test_flat_box_gives_its_four_corners(height):
    mech = model("box")
    q = box_q(np.eye(3), height, xy=(0.3, -0.2))
    pts = G.contact_points(mech, q, [G.HalfSpace()], margin=1e-3)
    assert len(pts) == 4
    expected = np.array([[0.3 + sx * 0.1, -0.2 + sy * 0.1, height] for sx in (-1, 1) for sy in (-1, 1)])
    np.testing.assert_allclose(sort_rows(np.array([p.point for p in pts])), sort_rows(expected), atol=1e-9)
    for p in pts:
        assert p.distance == pytest.approx(height, abs=1e-9)
        np.testing.assert_allclose(p.normal, [0, 0, 1], atol=1e-12)
        np.testing.assert_allclose(p.jacobian, mech.point_jacobian(q, "box", p.point - q[:3]), atol=1e-9)
        np.testing.assert_allclose(p.gradient, p.jacobian[2], atol=1e-12)


def test_box_on_an_edge_gives_both_ends():
    mech = model("box")
    R = pin.utils.rotate("x", 0.6)
    q = box_q(R, 1e-4)
    pts = G.contact_points(mech, q, [G.HalfSpace()], margin=1e-3)
    assert len(pts) == 2
    world = q[:3] + CORNERS @ R.T
    low = world[np.argsort(world[:, 2])[:2]]  # the two corners of the lowest edge
    np.testing.assert_allclose(sort_rows(np.array([p.point for p in pts])), sort_rows(low), atol=1e-9)
    assert all(p.distance == pytest.approx(1e-4, abs=1e-9) for p in pts)


def test_box_on_a_corner_gives_one_point_the_nearest():
    mech = model("box")
    R = pin.utils.rotate("x", 0.5) @ pin.utils.rotate("y", 0.4)
    q = box_q(R, -2e-4)
    pts = G.contact_points(mech, q, [G.HalfSpace()], margin=1e-3)
    (g,) = G.gaps(mech, q, [G.HalfSpace()])
    assert len(pts) == 1
    np.testing.assert_allclose(pts[0].point, g.point, atol=1e-9)
    assert pts[0].distance == pytest.approx(g.distance, abs=1e-12)


def test_margin_decides_which_pairs_are_in_contact():
    mech = model("box")
    q = box_q(np.eye(3), 2e-3)
    assert G.contact_points(mech, q, [G.HalfSpace()], margin=1e-3) == []
    assert len(G.contact_points(mech, q, [G.HalfSpace()], margin=5e-3)) == 4
    assert G.contact_points(mech, q, [G.HalfSpace()], margin=1e-3) == []  # the margin is reset


def test_tilted_slope_and_a_box_obstacle():
    """A box resting flat on a slope gets 4 points with the slope's normal; on a box obstacle too."""
    mech = model("box")
    R = pin.utils.rotate("y", 0.3)
    slope = G.HalfSpace(R[:, 2], 0.0)
    q = mech.neutral()
    q[:3] = 0.05 * R[:, 2] + 1e-4 * R[:, 2]
    q[3:7] = pin.Quaternion(R).coeffs()
    pts = G.contact_points(mech, q, [slope])
    assert len(pts) == 4
    for p in pts:
        np.testing.assert_allclose(p.normal, R[:, 2], atol=1e-9)
        assert p.distance == pytest.approx(1e-4, abs=1e-9)
    table = G.Box((1.0, 1.0, 0.2), position=(0, 0, -0.1))
    q = box_q(np.eye(3), 0.0)
    assert len(G.contact_points(mech, q, [table])) == 4


def test_sphere_and_self_collision_patches():
    sphere = model("sphere")
    q = sphere.neutral()
    q[2] = 0.05
    (p,) = G.contact_points(sphere, q, [G.HalfSpace()])
    np.testing.assert_allclose(p.point, [0, 0, 0], atol=1e-12)
    balls = two_balls(0.1, 0.2)
    qb = balls.neutral()
    qb[7:10] = [0.3, 0.0, 0.0]  # touching
    (c,) = G.contact_points(balls, qb, self_pairs=[("ball_a", "ball_b")])
    np.testing.assert_allclose(c.normal, [-1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(c.point, [0.1, 0, 0], atol=1e-9)


def test_solo12_feet_on_the_ground():
    mech = model("solo12")
    gm = G.GapModel(mech, [G.HalfSpace()], bodies=["FL_FOOT_0", "FR_FOOT_0", "HL_FOOT_0", "HR_FOOT_0"])
    q = mech.neutral()
    q[2] = 0.5
    q[2] -= gm.distances(q).min() + 1e-4
    pts = gm.contact_points(q, 1e-3)
    assert {p.body for p in pts} == {"FL_FOOT_0", "FR_FOOT_0", "HL_FOOT_0", "HR_FOOT_0"}
    for p in pts:
        assert p.distance == pytest.approx(-1e-4, abs=1e-9)
        assert p.point[2] == pytest.approx(-1e-4, abs=1e-9)

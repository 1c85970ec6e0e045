"""Obstacles and attachable shapes: coal conventions, validation, immutability."""

from __future__ import annotations

import dataclasses
import math

import coal
import numpy as np
import pinocchio as pin
import pytest

import mbimpact as mbi
from mbimpact import geometry as G
from mbimpact.mechanism.robots import robots_dir

FOOT = robots_dir() / "solo_description/meshes/stl/with_foot/solo_foot.stl"


def test_halfspace_is_the_solid_below_its_plane():
    h = G.HalfSpace(normal=(0, 0, 2.0), offset=0.5)
    np.testing.assert_array_equal(h.normal, [0, 0, 1])
    g = h.geometry()
    assert isinstance(g, coal.Halfspace) and g.d == 0.5
    assert not h.bounded and h.label == "halfspace"


def test_primitive_conventions():
    box = G.Box(size=(0.4, 0.3, 0.2), position=(1, 2, 3), rotation=pin.utils.rotate("z", 0.3))
    np.testing.assert_allclose(box.geometry().halfSide, [0.2, 0.15, 0.1])
    np.testing.assert_allclose(box.placement().translation, [1, 2, 3])
    cap = G.Capsule(radius=0.05, length=0.2)
    assert cap.geometry().halfLength == pytest.approx(0.1)
    assert G.Sphere(0.1).geometry().radius == 0.1
    assert G.Cylinder(0.1, 0.3).geometry().halfLength == pytest.approx(0.15)


def test_mesh_is_a_true_convex_hull():
    """buildConvexHull (qhull), not buildConvexRepresentation, which keeps a non-convex soup."""
    base = robots_dir() / "solo_description/meshes/stl/solo12/solo_12_base.stl"
    m = G.Mesh(base)
    assert isinstance(m.geometry(), coal.ConvexBase)
    raw = coal.MeshLoader().load(str(base), np.ones(3))
    assert m.geometry().num_points < raw.num_vertices
    zmin = raw.vertices()[:, 2].min()
    res = coal.DistanceResult()
    d = coal.distance(m.geometry(), coal.Transform3s(np.eye(3), np.array([0, 0, 0.3])),
                      coal.Halfspace(np.array([0, 0, 1.0]), 0.0), coal.Transform3s(), coal.DistanceRequest(), res)
    assert d == pytest.approx(0.3 + zmin, abs=1e-9)


def test_mesh_scale_and_triangles():
    m = G.Mesh(FOOT, scale=2.0, convex=False)
    assert isinstance(m.geometry(), coal.BVHModelBase)
    np.testing.assert_array_equal(m.scale, [2, 2, 2])


def test_shapes_are_immutable():
    s = G.Sphere(0.1, position=(1, 2, 3))
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.radius = 2.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        s.position[0] = 5.0
    b = G.Box((1, 1, 1))
    with pytest.raises(ValueError):
        b.size[0] = 5.0


@pytest.mark.parametrize(
    "make, error, match",
    [
        (lambda: G.Sphere(0.0), mbi.ParameterError, "radius"),
        (lambda: G.Sphere(-1.0), mbi.ParameterError, "radius"),
        (lambda: G.Sphere(math.nan), mbi.NonFiniteError, "radius"),
        (lambda: G.Sphere(0.1, position=(0, 0)), mbi.ShapeError, "position"),
        (lambda: G.Sphere(0.1, position=(0, math.nan, 0)), mbi.NonFiniteError, "position"),
        (lambda: G.Box((1, 0, 1)), mbi.ParameterError, "positive full side"),
        (lambda: G.Box((1, 1)), mbi.ShapeError, "size"),
        (lambda: G.Box((1, 1, 1), rotation=2 * np.eye(3)), mbi.ShapeError, "rotation matrix"),
        (lambda: G.Box((1, 1, 1), rotation=np.diag([1.0, 1.0, -1.0])), mbi.ShapeError, "det"),
        (lambda: G.Capsule(0.1, -0.2), mbi.ParameterError, "length"),
        (lambda: G.Cylinder(0.1, 0.0), mbi.ParameterError, "length"),
        (lambda: G.HalfSpace((0, 0, 0)), mbi.ShapeError, "zero vector"),
        (lambda: G.HalfSpace((0, 0, 1), math.inf), mbi.NonFiniteError, "offset"),
        (lambda: G.HalfSpace((0, 0, 1), name=""), mbi.ParameterError, "name"),
        (lambda: G.Mesh("/nonexistent/foot.stl"), G.GeometryError, "not found"),
        (lambda: G.Mesh(FOOT, scale=(1, 1)), mbi.ParameterError, "scale"),
        (lambda: G.Mesh(FOOT, scale=-1.0), mbi.ParameterError, "scale"),
    ],
)
def test_bad_shapes_are_named_errors(make, error, match):
    with pytest.raises(error, match=match):
        make()
    assert issubclass(error, mbi.ImpactError)

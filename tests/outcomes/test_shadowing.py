"""Shadowed relief: the facets met are those a straight approach reaches first, found here by casting rays."""

from __future__ import annotations

import numpy as np
import pytest

import mbimpact as mbi


def lit_by_rays(heights: np.ndarray, dx: float, u: np.ndarray, points: int = 400) -> np.ndarray:
    """Part of each segment of a (non-periodic) profile that rays arriving along u reach first: a point
    is lit when the ray back from it, upstream, stays above the profile (brute force on a fine grid)."""
    x_nodes = dx * np.arange(heights.size)
    fine_x = np.linspace(0.0, x_nodes[-1], 20_001)
    fine_h = np.interp(fine_x, x_nodes, heights)
    lit = np.zeros(heights.size - 1)
    for k in range(heights.size - 1):
        xs = x_nodes[k] + dx * (np.arange(points) + 0.5) / points
        ys = np.interp(xs, x_nodes, heights)
        seen = 0
        for x, y in zip(xs, ys):
            # the ray upstream: (x, y) − t u, t > 0; its height over the profile at the same abscissa
            t = (x - fine_x) / u[0]
            ahead = t > 1e-9
            seen += bool(np.all(y - t[ahead] * u[1] >= fine_h[ahead] - 1e-12))
        lit[k] = seen / points
    return lit


def test_shadowed_profile_probabilities_are_those_of_ray_casting():
    heights = np.array([0.0, 0.3, 1.2, 0.2, 0.5, 0.1, 0.9, 1.0, 0.0, 0.4])
    dx, e = 0.5, 0.8
    v = np.array([1.0, -0.35])  # grazing, along +x: the valleys behind the peaks are hidden
    law = mbi.RoughLaw(mbi.Profile(heights, dx, shadowing=True), e)
    out = law.outcomes(np.eye(2), np.eye(2), v, [0.0, 1.0])
    plain = mbi.RoughLaw(mbi.Profile(heights, dx), e).outcomes(np.eye(2), np.eye(2), v, [0.0, 1.0])
    # the weight of a segment: its true length, lit part, flux −mᵀu (2.7); normals (−h', 1)/sec
    slope = np.diff(heights) / dx
    sec = np.hypot(1.0, slope)
    normals = np.column_stack([-slope / sec, 1.0 / sec])
    flux = np.maximum(-(normals @ v), 0.0) * dx * sec * lit_by_rays(heights, dx, v)
    facing = flux > 1e-3 * flux.max()
    assert len(out.probabilities) < len(plain.probabilities)  # shadowing removes facets
    np.testing.assert_allclose(out.normals, normals[facing], atol=1e-14)
    np.testing.assert_allclose(out.probabilities, flux[facing] / flux.sum(), atol=5e-3)
    # and the outcomes average to the shadowed law, not to the plain one
    scale = np.abs(out.results.P).max()
    np.testing.assert_allclose(out.probabilities @ out.results.P, out.mean.P, atol=1e-12 * scale)
    np.testing.assert_allclose(out.mean.P, law.apply(np.eye(2), np.eye(2), v, [0.0, 1.0]).P, rtol=1e-13)
    assert np.abs(out.mean.P - plain.mean.P).max() > 1e-3


def test_shadowed_height_map_meets_fewer_triangles_and_averages_to_the_law():
    rng = np.random.default_rng(4)
    z = rng.normal(size=(5, 5)) * 0.15
    v = np.array([1.0, 0.3, -0.4])
    plain = mbi.RoughLaw(mbi.HeightMap(z, 0.1, 0.1), 0.5)
    shadowed = mbi.RoughLaw(mbi.HeightMap(z, 0.1, 0.1, shadowing=True), 0.5)
    a = plain.outcomes(np.eye(3), np.eye(3), v, [0.0, 0.0, 1.0])
    b = shadowed.outcomes(np.eye(3), np.eye(3), v, [0.0, 0.0, 1.0])
    assert len(b.probabilities) < len(a.probabilities)
    assert {tuple(m) for m in b.normals} <= {tuple(m) for m in a.normals}
    for out in (a, b):
        assert out.probabilities.sum() == pytest.approx(1.0, abs=1e-14)
        np.testing.assert_allclose(out.probabilities @ out.results.P, out.mean.P,
                                   atol=1e-12 * np.abs(out.results.P).max())
    # without shadowing the probability of a triangle is its true area times its flux
    m = plain.roughness.normals
    flux = plain.roughness.areas * np.maximum(-(m @ v), 0.0)
    np.testing.assert_allclose(a.probabilities, flux[flux > 0] / flux.sum(), rtol=1e-12)

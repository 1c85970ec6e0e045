"""Measured microrelief: a height profile (planar) or height map (spatial).

Each segment (triangle) of the sampled relief is a facet, weighted by its true
length (area). With ``shadowing=True`` a facet only counts for the part of it that
a straight approach along the velocity reaches first: parts hidden behind higher
relief get nothing, which is why friction falls at grazing incidence on smooth
profiles (the dashed curve of the paper's Fig. 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..common.validation import as_array, as_scalar
from ..errors import RoughnessError
from .base import Roughness

__all__ = ["Profile", "HeightMap", "SIZE_RANGE"]

# Elements per work array of the exact height-map shadowing (intervals × crossings²).
_CHUNK = 1 << 21


#: Magnitudes of sample spacings (from SIZE_RANGE[0] to SIZE_RANGE[1]) and heights (up to SIZE_RANGE[1]),
#: in any unit: slopes, true lengths and areas of the relief stay far inside the float range.
SIZE_RANGE = (1e-100, 1e100)


def _spacing(name: str, x: float) -> float:
    """A sample spacing within :data:`SIZE_RANGE`."""
    val = as_scalar(name, x, 0.0, math.inf)
    if not SIZE_RANGE[0] <= val <= SIZE_RANGE[1]:
        raise RoughnessError(f"{name} must be in [{SIZE_RANGE[0]:g}, {SIZE_RANGE[1]:g}] (any unit, the same as "
                             f"the heights'), got {val:g}")
    return val


def _heights(name: str, x: object, ndim: int) -> NDArray[np.float64]:
    """Finite heights of magnitude up to ``SIZE_RANGE[1]``."""
    h = as_array(name, x, ndim)  # type: ignore[arg-type]
    if h.size and float(np.abs(h).max()) > SIZE_RANGE[1]:
        raise RoughnessError(f"{name} must lie within ±{SIZE_RANGE[1]:g} (any unit, the same as the spacing's), "
                             f"got {float(np.abs(h).max()):g}")
    return h


def _flag(name: str, x: object) -> bool:
    """A True/False setting."""
    if not isinstance(x, (bool, np.bool_)):
        raise RoughnessError(f"{name} must be True or False, got {x!r}")
    return bool(x)


@dataclass(frozen=True, eq=False)
class Profile(Roughness):
    """A planar microrelief sampled at equal spacing.

    Parameters
    ----------
    heights : array_like, shape (K + 1,)
        Heights above the base line at x = 0, dx, ..., K dx (any unit, same as dx).
    dx : float
        Sample spacing, in [1e-100, 1e100] (:data:`SIZE_RANGE`; heights within ±1e100).
    shadowing : bool
        Weight each segment by its part that a straight approach along the
        velocity reaches first (exact for the piecewise-linear profile).
    periodic : bool
        The profile repeats with period K dx (a segment may then be shadowed by
        the end of the previous period).
    """

    heights: NDArray[np.float64]
    dx: float
    shadowing: bool = False
    periodic: bool = False
    normals: NDArray[np.float64] = field(init=False, repr=False)
    lengths: NDArray[np.float64] = field(init=False, repr=False)
    dim = 2

    def __post_init__(self) -> None:
        h = _heights("heights", self.heights, 1)
        if h.size < 2:
            raise RoughnessError(f"a profile needs at least 2 heights, got {h.size}")
        dx = _spacing("dx", self.dx)
        object.__setattr__(self, "shadowing", _flag("shadowing", self.shadowing))
        object.__setattr__(self, "periodic", _flag("periodic", self.periodic))
        slope = np.diff(h) / dx  # |slope| ≤ 2e200: its hypot with 1 is finite
        sec = np.hypot(1.0, slope)
        normals = np.column_stack([-slope / sec, 1.0 / sec])
        for a in (h, normals, sec):
            a.flags.writeable = False
        object.__setattr__(self, "heights", h)
        object.__setattr__(self, "dx", dx)
        object.__setattr__(self, "normals", normals)
        object.__setattr__(self, "lengths", dx * sec)

    def __repr__(self) -> str:
        return f"Profile({self.heights.size} heights, dx={self.dx:g}, shadowing={self.shadowing})"

    def lit_fraction(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        """Part of each segment reached first by an approach along ``u`` (d = 2), shape (K,).

        With rays moving towards +x (mirror otherwise), a point x is hit first iff
        g(x) = |u_t| h(x) + |u_n| x is not below the running maximum of g
        upstream, so the lit set follows from a prefix maximum.
        """
        h = self.heights
        if u[0] == 0.0:
            return np.ones(h.size - 1)
        forward = u[0] > 0.0
        hh = h if forward else h[::-1]
        # g scaled by |u_t| > 0 (the running maximum does not care): no division by u_t
        ut, un = abs(u[0]), abs(u[1])
        g = ut * hh + un * self.dx * np.arange(h.size)
        start = -np.inf
        if self.periodic:
            start = float(g.max()) - un * self.dx * (h.size - 1)  # previous period's relief
        prefix = np.maximum.accumulate(np.concatenate([[start], g[:-1]]))[1:]  # max of g up to each left end
        g0, g1 = g[:-1], g[1:]
        rising = g1 > g0
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.where(rising, (g1 - np.maximum(prefix, g0)) / (g1 - g0), 0.0)
        frac = np.clip(frac, 0.0, 1.0)
        return frac if forward else frac[::-1]

    def rule_batch(self, U: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if not self.shadowing:
            return self.normals, self.lengths / self.lengths.sum()
        w = np.stack([self.lit_fraction(u) * self.lengths for u in U])
        return self.normals, w / self.lengths.sum()

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        if self.shadowing:
            raise RoughnessError("Monte Carlo sampling of a shadowed profile is not supported; use the quadrature")
        return self.normals[rng.choice(len(self.lengths), size=count, p=self.lengths / self.lengths.sum())]


@dataclass(frozen=True, eq=False)
class HeightMap(Roughness):
    """A spatial microrelief sampled on a regular grid, split into triangles.

    Parameters
    ----------
    z : array_like, shape (nx, ny)
        Heights at x = i dx, y = j dy.
    dx, dy : float
        Grid spacings, in [1e-100, 1e100] (:data:`SIZE_RANGE`; heights within ±1e100).
    shadowing : bool
        Weight each triangle by the part of it hit first by an approach along
        the velocity (exact to rounding, :meth:`lit_fraction`; about 0.2 s per
        velocity for a 32 × 32 map and 1 s for 64 × 64, growing like N^2.6).
    """

    z: NDArray[np.float64]
    dx: float
    dy: float
    shadowing: bool = False
    normals: NDArray[np.float64] = field(init=False, repr=False)
    areas: NDArray[np.float64] = field(init=False, repr=False)
    dim = 3

    def __post_init__(self) -> None:
        z = _heights("z", self.z, 2)
        if z.shape[0] < 2 or z.shape[1] < 2:
            raise RoughnessError(f"a height map needs at least 2×2 samples, got {z.shape}")
        dx, dy = _spacing("dx", self.dx), _spacing("dy", self.dy)
        object.__setattr__(self, "shadowing", _flag("shadowing", self.shadowing))
        # two triangles per cell: (00, 10, 11) and (00, 11, 01); their slopes are exact
        sx1 = (z[1:, :-1] - z[:-1, :-1]) / dx
        sy1 = (z[1:, 1:] - z[1:, :-1]) / dy
        sx2 = (z[1:, 1:] - z[:-1, 1:]) / dx
        sy2 = (z[:-1, 1:] - z[:-1, :-1]) / dy
        sx = np.concatenate([sx1.ravel(), sx2.ravel()])
        sy = np.concatenate([sy1.ravel(), sy2.ravel()])
        sec = np.hypot(1.0, np.hypot(sx, sy))  # slopes up to 2e200: no overflow
        normals = np.column_stack([-sx / sec, -sy / sec, 1.0 / sec])
        areas = 0.5 * dx * dy * sec
        for a in (z, normals, areas):
            a.flags.writeable = False
        object.__setattr__(self, "z", z)
        object.__setattr__(self, "dx", dx)
        object.__setattr__(self, "dy", dy)
        object.__setattr__(self, "normals", normals)
        object.__setattr__(self, "areas", areas)

    def __repr__(self) -> str:
        return f"HeightMap({self.z.shape[0]}×{self.z.shape[1]}, dx={self.dx:g}, dy={self.dy:g}, shadowing={self.shadowing})"

    def _cell(self, x: NDArray[np.float64], y: NDArray[np.float64]
              ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """Grid cell (i, j) of (x, y), clipped to the map, and the position (a, b) in it."""
        nx, ny = self.z.shape
        fx = np.clip(x / self.dx, 0.0, nx - 1 - 1e-12)
        fy = np.clip(y / self.dy, 0.0, ny - 1 - 1e-12)
        i, j = np.floor(fx).astype(np.int64), np.floor(fy).astype(np.int64)
        return i, j, fx - i, fy - j

    def height(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Height of the triangulated surface at (x, y), clipped to the map."""
        i, j, a, b = self._cell(x, y)
        z = self.z
        lower = a >= b  # triangle (00, 10, 11)
        z00, z10, z11, z01 = z[i, j], z[i + 1, j], z[i + 1, j + 1], z[i, j + 1]
        return np.where(lower, z00 + a * (z10 - z00) + b * (z11 - z10), z00 + b * (z01 - z00) + a * (z11 - z01))

    def lit_fraction(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        """Part of each triangle reached first by an approach along ``u`` (d = 3), shape (T,).

        Along a vertical plane parallel to the horizontal part of ``u`` the map is a
        piecewise-linear profile on which visibility is exact (:class:`Profile`'s
        running maximum of g = h + (|u_n| / |u_t|) t). Between the offsets s of two
        grid vertices the plane crosses the same edges in the same order, so the
        value g_k(s) at every crossing is linear in s, and the lit length of every
        triangle is linear in s except where two of these lines meet (the shadow
        changes its casting peak or reaches a segment's end). Splitting at all such
        meeting points leaves pieces on which the midpoint rule is exact: the lit
        areas are exact to rounding.
        """
        ut = float(np.hypot(u[0], u[1]))
        T = len(self.areas)
        if ut == 0.0:
            return np.ones(T)
        d = np.array([u[0], u[1]]) / ut  # rays travel downstream along d
        e = np.array([-d[1], d[0]])  # offset of the plane
        c = abs(float(u[2])) / ut
        nx, ny = self.z.shape
        gx, gy = np.meshgrid(np.arange(nx) * self.dx, np.arange(ny) * self.dy, indexing="ij")
        proj = np.unique(gx.ravel() * e[0] + gy.ravel() * e[1])
        proj = proj[np.concatenate([[True], np.diff(proj) > 1e-12 * (proj[-1] - proj[0])])]
        lit = np.zeros(T)
        width = 2 * nx + 2 * ny  # crossings per plane, at most
        chunk = max(1, _CHUNK // (width * width))
        for start in range(0, proj.size - 1, chunk):
            stop = min(start + chunk, proj.size - 1)
            lo, hi = proj[start:stop], proj[start + 1 : stop + 1]
            # g_k(s) on each interval from two planes inside it (same crossings, same order)
            sa, sb = lo + 0.25 * (hi - lo), lo + 0.75 * (hi - lo)
            _, ga, _ = self._profiles(sa, d, e, c)
            _, gb, _ = self._profiles(sb, d, e, c)
            with np.errstate(invalid="ignore", divide="ignore"):  # padding: −inf − (−inf)
                slope = (gb - ga) / (sb - sa)[:, None]
                s_meet = sa[:, None, None] - (ga[:, :, None] - ga[:, None, :]) / (slope[:, :, None] - slope[:, None, :])
            inside = np.isfinite(s_meet) & (s_meet > lo[:, None, None]) & (s_meet < hi[:, None, None])
            piece = np.concatenate([np.arange(lo.size), np.arange(lo.size), np.nonzero(inside)[0]])
            cut = np.concatenate([lo, hi, s_meet[inside]])
            order = np.lexsort((cut, piece))
            piece, cut = piece[order], cut[order]
            same = piece[1:] == piece[:-1]
            a, b = cut[:-1][same], cut[1:][same]
            keep = b - a > 0.0
            a, b = a[keep], b[keep]
            for s0 in range(0, a.size, chunk * width):
                aa, bb = a[s0 : s0 + chunk * width], b[s0 : s0 + chunk * width]
                tri, length = self.lit_lengths(0.5 * (aa + bb), d, e, c)
                ok = tri >= 0
                lit += np.bincount(tri[ok], weights=((bb - aa)[:, None] * length)[ok], minlength=T)
        return np.clip(lit / (0.5 * self.dx * self.dy), 0.0, 1.0)

    def _profiles(
        self, S: NDArray[np.float64], d: NDArray[np.float64], e: NDArray[np.float64], c: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
        """Sorted crossings t of the planes at offsets S with the grid lines and diagonals, and
        g = h + c t there, shape (len(S), C); missing crossings have t = +inf, g = −inf."""
        nx, ny = self.z.shape
        X, Y = (nx - 1) * self.dx, (ny - 1) * self.dy
        ox, oy = S * e[0], S * e[1]  # the plane passes through (ox, oy) at t = 0
        cuts = []
        if abs(d[0]) > 1e-15:
            cuts.append((np.arange(nx)[None, :] * self.dx - ox[:, None]) / d[0])
        if abs(d[1]) > 1e-15:
            cuts.append((np.arange(ny)[None, :] * self.dy - oy[:, None]) / d[1])
        den = d[0] / self.dx - d[1] / self.dy
        if abs(den) > 1e-15:  # diagonals x/dx − y/dy = k of the triangulation
            k = np.arange(-(ny - 1), nx)[None, :]
            cuts.append((k - (ox / self.dx - oy / self.dy)[:, None]) / den)
        t = np.concatenate(cuts, axis=1)
        px, py = ox[:, None] + t * d[0], oy[:, None] + t * d[1]
        eps = 1e-12 * (X + Y)
        inside = (px >= -eps) & (px <= X + eps) & (py >= -eps) & (py <= Y + eps)
        t = np.sort(np.where(inside, t, np.inf), axis=1)
        valid = np.isfinite(t)
        tf = np.where(valid, t, 0.0)
        h = self.height(ox[:, None] + tf * d[0], oy[:, None] + tf * d[1])
        return t, np.where(valid, h + c * tf, -np.inf), valid

    def lit_lengths(
        self, S: NDArray[np.float64], d: NDArray[np.float64], e: NDArray[np.float64], c: float
    ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Triangle index and lit horizontal length of every segment of the vertical planes at
        offsets S, shape (len(S), C − 1); padding segments have triangle −1.

        The building block of :meth:`lit_fraction`, exposed for verification: the planes are
        parallel to the horizontal direction ``d`` of the approach, offset along ``e`` (⊥ d), and
        ``c`` = |u_n| / |u_t|.
        """
        nx, ny = self.z.shape
        t, g, valid = self._profiles(S, d, e, c)
        tf = np.where(valid, t, 0.0)
        run = np.maximum.accumulate(g, axis=1)  # a point is lit iff g ≥ max of g upstream
        t0, t1, g0, g1, P = tf[:, :-1], tf[:, 1:], g[:, :-1], g[:, 1:], run[:, :-1]
        seg = valid[:, 1:] & (t1 - t0 > 1e-12 * ((nx - 1) * self.dx + (ny - 1) * self.dy))
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.where(seg & (g1 > g0), np.clip((g1 - P) / (g1 - g0), 0.0, 1.0), 0.0)
        length = np.where(seg, frac * (t1 - t0), 0.0)
        # the triangle of each segment, from its midpoint
        ox, oy = S * e[0], S * e[1]
        i, j, a, b = self._cell(ox[:, None] + 0.5 * (t0 + t1) * d[0], oy[:, None] + 0.5 * (t0 + t1) * d[1])
        tri = i * (ny - 1) + j + (b > a) * (nx - 1) * (ny - 1)  # triangle (00, 11, 01) above the diagonal
        return np.where(seg, tri, -1), length

    def rule_batch(self, U: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        total = self.areas.sum()
        if not self.shadowing:
            return self.normals, self.areas / total
        return self.normals, np.stack([self.lit_fraction(u) * self.areas for u in U]) / total

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        if self.shadowing:
            raise RoughnessError("Monte Carlo sampling of a shadowed height map is not supported; use the quadrature")
        return self.normals[rng.choice(len(self.areas), size=count, p=self.areas / self.areas.sum())]



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

from ._validate import as_array, as_scalar
from .errors import RoughnessError
from .roughness import Roughness

__all__ = ["Profile", "HeightMap"]


def _spacing(name: str, x: float) -> float:
    val = as_scalar(name, x, 0.0, math.inf)
    if not val > 0:
        raise RoughnessError(f"{name} must be > 0, got {val}")
    return val


@dataclass(frozen=True, eq=False)
class Profile(Roughness):
    """A planar microrelief sampled at equal spacing.

    Parameters
    ----------
    heights : array_like, shape (K + 1,)
        Heights above the base line at x = 0, dx, ..., K dx (any unit, same as dx).
    dx : float
        Sample spacing, > 0.
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
    dim = 2  # type: ignore[assignment]

    def __post_init__(self) -> None:
        h = as_array("heights", self.heights, 1)
        if h.size < 2:
            raise RoughnessError(f"a profile needs at least 2 heights, got {h.size}")
        dx = _spacing("dx", self.dx)
        slope = np.diff(h) / dx
        sec = np.sqrt(1.0 + slope * slope)
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
        Grid spacings, > 0.
    shadowing : bool
        Weight each triangle by the part of it hit first by an approach along
        the velocity, estimated on ``shadow_samples``² points per triangle by
        marching upstream over the map (resolution-limited, unlike
        :class:`Profile`'s exact rule).
    shadow_samples : int
        Sub-triangle subdivision level for the shadowing estimate.
    """

    z: NDArray[np.float64]
    dx: float
    dy: float
    shadowing: bool = False
    shadow_samples: int = 3
    normals: NDArray[np.float64] = field(init=False, repr=False)
    areas: NDArray[np.float64] = field(init=False, repr=False)
    dim = 3  # type: ignore[assignment]

    def __post_init__(self) -> None:
        z = as_array("z", self.z, 2)
        if z.shape[0] < 2 or z.shape[1] < 2:
            raise RoughnessError(f"a height map needs at least 2×2 samples, got {z.shape}")
        dx, dy = _spacing("dx", self.dx), _spacing("dy", self.dy)
        # two triangles per cell: (00, 10, 11) and (00, 11, 01); their slopes are exact
        sx1 = (z[1:, :-1] - z[:-1, :-1]) / dx
        sy1 = (z[1:, 1:] - z[1:, :-1]) / dy
        sx2 = (z[1:, 1:] - z[:-1, 1:]) / dx
        sy2 = (z[:-1, 1:] - z[:-1, :-1]) / dy
        sx = np.concatenate([sx1.ravel(), sx2.ravel()])
        sy = np.concatenate([sy1.ravel(), sy2.ravel()])
        sec = np.sqrt(1.0 + sx * sx + sy * sy)
        normals = np.column_stack([-sx / sec, -sy / sec, 1.0 / sec])
        areas = 0.5 * dx * dy * sec
        for a in (z, normals, areas):
            a.flags.writeable = False
        object.__setattr__(self, "z", z)
        object.__setattr__(self, "dx", dx)
        object.__setattr__(self, "dy", dy)
        object.__setattr__(self, "normals", normals)
        object.__setattr__(self, "areas", areas)
        if int(self.shadow_samples) < 1:
            raise RoughnessError(f"shadow_samples must be ≥ 1, got {self.shadow_samples}")

    def __repr__(self) -> str:
        return f"HeightMap({self.z.shape[0]}×{self.z.shape[1]}, dx={self.dx:g}, dy={self.dy:g}, shadowing={self.shadowing})"

    def height(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Height of the triangulated surface at (x, y), clipped to the map."""
        nx, ny = self.z.shape
        fx = np.clip(x / self.dx, 0.0, nx - 1 - 1e-12)
        fy = np.clip(y / self.dy, 0.0, ny - 1 - 1e-12)
        i, j = np.floor(fx).astype(int), np.floor(fy).astype(int)
        a, b = fx - i, fy - j
        z = self.z
        lower = a >= b  # triangle (00, 10, 11)
        z00, z10, z11, z01 = z[i, j], z[i + 1, j], z[i + 1, j + 1], z[i, j + 1]
        return np.where(lower, z00 + a * (z10 - z00) + b * (z11 - z10), z00 + b * (z01 - z00) + a * (z11 - z01))

    def _sample_points(self) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """Centroids of the k² sub-triangles of every triangle: x, y (T, k²)."""
        k = int(self.shadow_samples)
        bary = []
        for r in range(k):
            for s in range(k - r):
                bary.append(((r + 1 / 3) / k, (s + 1 / 3) / k))
                if r + s < k - 1:
                    bary.append(((r + 2 / 3) / k, (s + 2 / 3) / k))
        bary_arr = np.array(bary)  # (k², 2): coordinates along the two edges from the right-angle-free corner
        nx, ny = self.z.shape
        I, Jg = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
        x0, y0 = (I * self.dx).ravel(), (Jg * self.dy).ravel()
        # triangle 1: 00 + p (10 - 00) + q (11 - 10); triangle 2: 00 + p (01 - 00) + q (11 - 01)
        p, q = bary_arr[:, 0][None, :], bary_arr[:, 1][None, :]
        x1, y1 = x0[:, None] + (p * self.dx), y0[:, None] + (q * self.dy)
        x2, y2 = x0[:, None] + (q * self.dx), y0[:, None] + (p * self.dy)
        return np.concatenate([x1, x2]), np.concatenate([y1, y2]), bary_arr.shape[0]

    def lit_fraction(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        """Estimated part of each triangle hit first by an approach along ``u``, shape (T,)."""
        ut = float(np.hypot(u[0], u[1]))
        if ut == 0.0:
            return np.ones(len(self.areas))
        x, y, _ = self._sample_points()
        h0 = self.height(x, y)
        dirx, diry = -u[0] / ut, -u[1] / ut  # upstream, horizontally
        c = abs(u[2]) / ut  # the ray rises by c per unit of horizontal distance upstream
        step = 0.5 * min(self.dx, self.dy)
        nx, ny = self.z.shape
        reach = math.hypot((nx - 1) * self.dx, (ny - 1) * self.dy)
        zmax = float(self.z.max())
        lit = np.ones(x.shape, dtype=bool)
        for k in range(1, int(reach / step) + 2):
            lam = k * step
            px, py = x + lam * dirx, y + lam * diry
            inside = (px >= 0) & (px <= (nx - 1) * self.dx) & (py >= 0) & (py <= (ny - 1) * self.dy)
            active = lit & inside & (h0 + c * lam < zmax)
            if not active.any():
                break
            lit[active] = self.height(px[active], py[active]) <= h0[active] + c * lam
        return lit.mean(axis=1)

    def rule_batch(self, U: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        total = self.areas.sum()
        if not self.shadowing:
            return self.normals, self.areas / total
        return self.normals, np.stack([self.lit_fraction(u) * self.areas for u in U]) / total

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        if self.shadowing:
            raise RoughnessError("Monte Carlo sampling of a shadowed height map is not supported; use the quadrature")
        return self.normals[rng.choice(len(self.areas), size=count, p=self.areas / self.areas.sum())]



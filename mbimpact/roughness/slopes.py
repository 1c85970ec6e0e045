"""Continuous isotropic roughness: a density of facet tilts, azimuth uniform (§3, (2.9)).

A facet tilted by α from n⁰ has normal m = (sin α · l, cos α) with l a unit tangent
direction, uniform (spatial) or ± with probability ½ each (planar). The measure is
given by a density of α over the facets' *true* area (:mod:`mbimpact.theory`, §3).

Averaging is a product rule: Gauss–Legendre in α, split where the cone of tilt α
begins to be cut by G* (α* = atan(|u_n| / |u_t|)), times the exact facing arc of
:func:`mbimpact.quadrature.rules.azimuth_rule` in azimuth. Both parts converge
geometrically for smooth densities. For a nearly singular W both are graded
towards the peaks of 1/mᵀWm (:meth:`IsotropicSlopes.graded_rule`).
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import incidence_split
from ..common.validation import as_scalar
from ..errors import AccuracyWarning, ParameterError, RoughnessError, warn
from ..quadrature.graded import graded_azimuth_rule, graded_tilt_rule, peak_tilts, peak_width_bound, ring_minima_many
from ..quadrature.rules import azimuth_rule, gauss_legendre, tilt_segments
from .base import Roughness, Rule

__all__ = ["IsotropicSlopes", "GaussianSlopes", "GaussianTiltDensity"]

# Points of the tabulated tilt CDF used to draw Monte Carlo samples.
_CDF_POINTS = 4097


@dataclass(frozen=True, eq=False)
class IsotropicSlopes(Roughness):
    """Isotropic roughness with any density of the facet tilt α.

    Parameters
    ----------
    pdf : callable
        Density of the tilt, ``pdf(alpha: ndarray) -> ndarray`` (non-negative,
        vectorised), over the facets' true area; it is normalised numerically.
    dim : {3, 2}
        Spatial (azimuth uniform) or planar (the two sides ± equally likely: a
        symmetric slope density).
    support : (float, float)
        Interval of tilts carrying the density, within [0, π/2).
    """

    pdf: Callable[[NDArray[np.float64]], NDArray[np.float64]]
    dim: int = 3  # type: ignore[misc]
    support: tuple[float, float] = (0.0, math.pi / 2 * (1 - 1e-9))
    mass: float = field(init=False, repr=False)
    exact: ClassVar[bool] = False
    initial_nodes: ClassVar[int] = 8
    node_limit: ClassVar[int] = 256  # product rule: 2 n² facets per velocity
    methods: ClassVar[tuple[str, ...]] = ("tilt-table", "graded", "fixed", "adaptive", "monte-carlo")
    graded_rows: ClassVar[int | None] = 4  # ~10⁸ bytes a row at 128 nodes a piece

    def __post_init__(self) -> None:
        dim = self.dim
        if isinstance(dim, (bool, np.bool_)) or not isinstance(dim, (int, np.integer)) or dim not in (2, 3):
            raise RoughnessError(f"dim must be 2 (planar) or 3 (spatial), got {self.dim!r}")
        object.__setattr__(self, "dim", int(self.dim))
        if not callable(self.pdf):
            raise RoughnessError(f"pdf must be a callable density of the tilt, got {type(self.pdf).__name__}")
        if not isinstance(self.support, (tuple, list)) or len(self.support) != 2:
            raise RoughnessError(f"support must be an interval (lo, hi) of tilts within [0, π/2), "
                                 f"got {self.support!r}")
        lo = as_scalar("support[0]", self.support[0], 0.0, math.pi / 2, hi_open=True)
        hi = as_scalar("support[1]", self.support[1], 0.0, math.pi / 2, hi_open=True)
        if not lo < hi:
            raise RoughnessError(f"support must be an interval lo < hi within [0, π/2), got {self.support}")
        object.__setattr__(self, "support", (lo, hi))
        grid = np.linspace(lo, hi, 257)
        raw = np.asarray(self.pdf(grid))
        if raw.dtype.kind not in "biuf":
            raise RoughnessError(f"pdf must return real numbers, got an array of dtype {raw.dtype}")
        vals = raw.astype(float)
        if vals.shape != grid.shape or not np.all(np.isfinite(vals)):
            raise RoughnessError("pdf must return finite values of the same shape as its argument")
        if np.any(vals < 0):
            raise RoughnessError(f"pdf must be non-negative; pdf({grid[np.argmin(vals)]:.4g}) = {vals.min():.4g}")
        mass = self._integral(lambda a: np.ones_like(a), 1e-13)
        if not mass > 0:
            raise RoughnessError("pdf integrates to zero over its support")
        object.__setattr__(self, "mass", mass)

    def _integral(self, f: Callable[[NDArray[np.float64]], NDArray[np.float64]], rtol: float) -> float:
        """∫ f(α) pdf(α) dα over the support (unnormalised), to relative accuracy ``rtol``."""
        from scipy import integrate  # deferred: scipy.integrate costs 0.1 s to import

        lo, hi = self.support
        # full_output: quad reports a failure to converge in its return value instead of warning
        # (scipy's IntegrationWarning is outside mbimpact's tree): it is re-issued as ours
        out = integrate.quad(lambda a: float(f(np.array([a]))[0] * self.pdf(np.array([a]))[0]), lo, hi,
                             limit=200, epsabs=0, epsrel=rtol, full_output=1)
        value, abserr = float(out[0]), float(out[1])
        if len(out) > 3:
            warn(AccuracyWarning, f"the tilt density's integral over its support {self.support} did not converge "
                 f"to rtol={rtol:g} (estimated error {abserr:.3g} of {value:.6g}): the pdf may be singular or "
                 f"discontinuous inside the support; scipy says: {str(out[3]).splitlines()[0]}")
        return value

    def density(self, alpha: NDArray[np.float64]) -> NDArray[np.float64]:
        """The normalised tilt density p(α) (∫ p dα = 1 over the support)."""
        return np.asarray(self.pdf(alpha), dtype=float) / self.mass

    def rule_batch(self, U: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        lo, hi = self.support
        split = incidence_split(U)  # α*: tilts above it are partly hidden
        if self.dim == 3:
            tilt, dtilt = tilt_segments(lo, hi, split, nodes)
            return azimuth_rule(tilt, self.density(tilt) * dtilt, U, nodes)
        # planar: the side facing away from the motion is always met; the other side up to α*
        x, w = gauss_legendre(nodes)
        B = U.shape[0]
        a_all = lo + (hi - lo) * (x + 1) / 2
        w_all = (hi - lo) / 2 * w * self.density(a_all) / 2
        top = np.clip(split, lo, hi)[:, None]
        a_cut = lo + (top - lo) * (x + 1) / 2
        w_cut = (top - lo) / 2 * w * self.density(a_cut) / 2
        side = np.where(U[:, 0] >= 0, 1.0, -1.0)[:, None]  # sign of u_t: tilting "with" the motion
        tilt = np.concatenate([np.broadcast_to(a_all, (B, nodes)), a_cut], axis=1)
        sgn = np.concatenate([np.broadcast_to(-side, (B, nodes)), np.broadcast_to(side, (B, nodes))], axis=1)
        weights = np.concatenate([np.broadcast_to(w_all, (B, nodes)), w_cut], axis=1)
        normals = np.stack([sgn * np.sin(tilt), np.cos(tilt)], axis=-1)
        return normals, weights

    def rule_size(self, nodes: int, graded: bool = False) -> int:
        """Plain rules: 2 n tilts × n azimuths (spatial), 2 sides × n tilts (planar). Graded ones: tilts
        in up to 10 half-pieces (α* and three peak tilts cut the support) × azimuths in up to 6 (two
        minima cut each ring), or 2 sides × 6 half-pieces of tilt (planar)."""
        if self.dim == 3:
            return (60 if graded else 2) * nodes * nodes
        return (12 if graded else 2) * nodes

    def graded_rule(self, W: NDArray[np.float64], peaked: float) -> Rule | None:
        if self.dim == 2:
            return functools.partial(self._graded_planar, W) if _planar_peak(W)[2] < peaked else None
        # the closed-form bound first: it rules out most W (a foot on the ground) for a few µs
        if peak_width_bound(W) >= peaked:
            return None
        if not np.isfinite(peak_tilts(W, np.array([[0.0, 0.0, -1.0]]), peaked)[1][0, :2]).any():
            return None
        return functools.partial(self._graded_spatial, W, peaked)

    def _graded_spatial(self, W: NDArray[np.float64], peaked: float, U: NDArray[np.float64], nodes: int
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Tilt × azimuth rule graded in both: tilts towards :func:`~mbimpact.quadrature.graded.peak_tilts`,
        each ring's azimuths towards its own minima of mᵀWm."""
        lo, hi = self.support
        split = incidence_split(U)
        tilt, dtilt = graded_tilt_rule(lo, hi, split, peak_tilts(W, U, peaked), nodes)
        # pieces of zero length (hints outside the support, minima off the facing arc) carry
        # no weight in any row of the block: leave their nodes out
        used = (dtilt > 0.0).any(axis=0)
        tilt, dtilt = tilt[:, used], dtilt[:, used]
        normals, w_az = graded_azimuth_rule(tilt, ring_minima_many(tilt, W), U, nodes)
        B, L = tilt.shape
        weights = (w_az.reshape(B, L, -1) * (self.density(tilt) * dtilt)[..., None]).reshape(B, -1)
        used = (weights > 0.0).any(axis=0)
        return normals[:, used], weights[:, used]

    def _graded_planar(self, W: NDArray[np.float64], U: NDArray[np.float64], nodes: int
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The planar rule of :meth:`rule_batch` with both sides graded towards the tilt where
        m ∥ w₁ (the least eigenvector of W) and its mirror image −α₁ on the other side."""
        lo, hi = self.support
        alpha1, sigma1, eps1 = _planar_peak(W)
        B = U.shape[0]
        side = np.where(U[:, 0] >= 0, 1.0, -1.0)  # sign of u_t: tilting "with" the motion
        top = np.clip(incidence_split(U), lo, hi)  # α*: that side is met below it
        parts = []
        for sgn, upper in ((-side, np.full(B, hi)), (side, top)):
            peak = (np.where(sgn == sigma1, alpha1, -alpha1)[:, None], np.full((B, 1), eps1))
            tilt, dtilt = graded_tilt_rule(lo, upper, upper, peak, nodes)
            parts.append((np.repeat(sgn[:, None], tilt.shape[1], axis=1), tilt, dtilt * self.density(tilt) / 2))
        sgn, tilt, weights = (np.concatenate(x, axis=1) for x in zip(*parts))
        return np.stack([sgn * np.sin(tilt), np.cos(tilt)], axis=-1), weights

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        lo, hi = self.support
        grid = np.linspace(lo, hi, _CDF_POINTS)
        from scipy import integrate

        cdf = integrate.cumulative_trapezoid(self.density(grid), grid, initial=0.0)
        alpha = np.interp(rng.uniform(0.0, cdf[-1], count), cdf, grid)
        if self.dim == 2:
            side = rng.choice([-1.0, 1.0], count)
            return np.column_stack([side * np.sin(alpha), np.cos(alpha)])
        phi = rng.uniform(0.0, 2 * math.pi, count)
        s = np.sin(alpha)
        return np.column_stack([s * np.cos(phi), s * np.sin(phi), np.cos(alpha)])

    def moment(self, f: Callable[[NDArray[np.float64]], NDArray[np.float64]]) -> float:
        """E[f(α)] over the facet measure, e.g. ``moment(np.cos)`` for (4.2)."""
        return self._integral(f, 1e-12) / self.mass


def _planar_peak(W: NDArray[np.float64]) -> tuple[float, float, float]:
    """Where 1/mᵀWm peaks on the planar facets m = (σ sin α, cos α): the tilt α₁ and side σ₁
    of the least eigenvector w₁ of the 2 × 2 W, and the width sqrt(λ₁ / λ₂)."""
    lam, vec = np.linalg.eigh(W)
    w1 = vec[:, 0] if vec[1, 0] >= 0 else -vec[:, 0]
    width = math.sqrt(max(float(lam[0]), 0.0) / max(float(lam[1]), 1e-300))
    return math.atan2(abs(float(w1[0])), float(w1[1])), (1.0 if w1[0] >= 0 else -1.0), width


@dataclass(frozen=True)
class GaussianTiltDensity:
    """Tilt density of a Gaussian slope field, per true area, up to a constant (a picklable callable).

    Slopes s = tan α are normal with RMS σ per component over the base plane; a
    facet of base area dA has true area dA / cos α, so the density of α is that of
    the slopes times sec α times ds/dα = sec²α. The slope density is written in x = s/σ
    (x e^{−x²/2} spatial, e^{−x²/2} planar), so that its values stay of order one for any σ.
    """

    sigma: float
    dim: int

    def __call__(self, alpha: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.in_slope(np.tan(alpha)) / np.cos(alpha) ** 3

    def in_slope(self, s: NDArray[np.float64]) -> NDArray[np.float64]:
        """The slope density at slopes ``s`` = tan α (its integral over s gives the facets' base area)."""
        x = np.asarray(s, dtype=float) / self.sigma
        radial = x if self.dim == 3 else 1.0  # Rayleigh |s| in 2-D slope space, half-normal in 1-D
        with np.errstate(under="ignore"):  # far tails: exp(−x) below the smallest float is 0
            return radial * np.exp(-0.5 * x * x)


class GaussianSlopes(IsotropicSlopes):
    """Random surface whose slopes are normal with RMS ``sigma`` per component.

    Parameters
    ----------
    sigma : float
        RMS slope per base-plane component, > 0.
    dim : {3, 2}
        Spatial (slope vector (∂h/∂x, ∂h/∂y)) or planar (∂h/∂x).
    """

    sigma: float

    #: Smallest RMS slope: tilts below it are below every float's resolution of a facet normal.
    min_sigma: ClassVar[float] = 1e-300
    methods: ClassVar[tuple[str, ...]] = ("tilt-table", "laplace", *IsotropicSlopes.methods[1:])

    def __init__(self, sigma: float, dim: int = 3) -> None:
        sigma = as_scalar("sigma", sigma, 0.0, math.inf)
        if not sigma >= self.min_sigma:
            raise ParameterError(f"sigma must be ≥ {self.min_sigma:g} (use Smooth() for a flat surface), "
                                 f"got {sigma:g}")
        object.__setattr__(self, "sigma", sigma)
        top = math.atan(11.0 * sigma)  # density below exp(-60) beyond: negligible at rtol 1e-12
        super().__init__(GaussianTiltDensity(sigma, dim), dim, (0.0, min(top, math.pi / 2 * (1 - 1e-9))))

    def _integral(self, f: Callable[[NDArray[np.float64]], NDArray[np.float64]], rtol: float) -> float:
        """∫ f(α) pdf(α) dα in the slope s = tan α ∈ [0, T], scaled to [0, 1]: pdf dα = g(s) √(1 + s²) ds
        is smooth there for every σ, where in α it piles up against π/2 for a large σ."""
        from scipy import integrate

        density = self.pdf
        assert isinstance(density, GaussianTiltDensity)
        top = math.tan(self.support[1])

        def integrand(x: float) -> float:
            s = np.array([top * x])
            return float(f(np.arctan(s))[0] * density.in_slope(s)[0] * np.hypot(1.0, s[0]))

        with warnings.catch_warnings():
            # for σ ≫ 1 the facets crowd against π/2, where f(α) (cos α, ...) is known only to a relative
            # ~ε / cos α: quad then stops at that rounding noise (~1e-8) instead of rtol, and says so
            warnings.simplefilter("ignore", integrate.IntegrationWarning)
            return top * float(integrate.quad(integrand, 0.0, 1.0, limit=200, epsabs=0, epsrel=rtol)[0])

    def __repr__(self) -> str:
        return f"GaussianSlopes(sigma={self.sigma:g}, dim={self.dim})"

"""A spatial isotropic roughness with one tilt: a cone of facets."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..quadrature.graded import graded_azimuth_rule, ring_minima, ring_width_bound
from ..quadrature.rules import azimuth_rule
from .base import Roughness, Rule, check_tilt

__all__ = ["Cone"]


@dataclass(frozen=True)
class Cone(Roughness):
    """Spatial isotropic roughness with a single tilt: facets at angle α from n⁰.

    The facet normal is m = (sin α cos φ, sin α sin φ, cos α) with the azimuth φ
    uniform on [0, 2π). When the whole cone faces the velocity
    (|u_t| tan α < |u_n|) the rule is the periodic trapezoid rule, which
    converges geometrically; otherwise the facing arc
    cos(φ - ψ) < cot α |u_n| / |u_t| is found in closed form and integrated by
    Gauss–Legendre on that arc, so convergence stays geometric in the truncated
    regime too (:func:`mbimpact.quadrature.rules.azimuth_rule`).

    Parameters
    ----------
    alpha : float
        Tilt of the facets, 0 ≤ α < π/2.
    """

    alpha: float
    dim: ClassVar[int | None] = 3
    exact: ClassVar[bool] = False
    initial_nodes: ClassVar[int] = 32  # 32 and 64 nodes agree to ~1e-15 for ordinary W: one pass
    methods: ClassVar[tuple[str, ...]] = ("ring", "poles", "graded", "fixed", "adaptive", "monte-carlo")

    def __post_init__(self) -> None:
        object.__setattr__(self, "alpha", check_tilt("alpha", self.alpha))

    def rule_batch(self, U: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if self.alpha == 0.0:
            return np.array([[0.0, 0.0, 1.0]]), np.ones(1)
        B = U.shape[0]
        return azimuth_rule(np.full((B, 1), self.alpha), np.ones((B, 1)), U, nodes)

    def graded_rule(self, W: NDArray[np.float64], peaked: float) -> Rule | None:
        if self.alpha == 0.0 or ring_width_bound(self.alpha, W) >= peaked:
            return None
        minima = ring_minima(self.alpha, W)
        # ε ≲ 1e-7 means q_min / q_max ≲ 1e-14: facets the mechanism cannot push (skipped as
        # degenerate), around which the flux weight is not integrable; grading cannot help
        if not minima[1].size or not 1e-7 < minima[1].min() < peaked:
            return None
        return functools.partial(graded_azimuth_rule, self.alpha, minima)

    def rule_size(self, nodes: int, graded: bool = False) -> int:
        # the graded ring is cut at its (at most two) minima of q, every piece halved: 6 pieces
        return 6 * nodes if graded else nodes

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        phi = rng.uniform(0.0, 2.0 * math.pi, count)
        s, c = math.sin(self.alpha), math.cos(self.alpha)
        return np.column_stack([s * np.cos(phi), s * np.sin(phi), np.full(count, c)])

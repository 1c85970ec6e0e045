"""Finite roughness measures: a few facets, the same for every velocity (exact averages)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..errors import ParameterError
from .base import FiniteRoughness, check_normals, check_tilt, check_weights

__all__ = ["Smooth", "Sawtooth", "Facets"]


@dataclass(frozen=True)
class Smooth(FiniteRoughness):
    """No microrelief, g ≡ 0: every facet is the base surface (property 5°)."""

    methods: ClassVar[tuple[str, ...]] = ("exact",)

    def facets(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        raise AssertionError("Smooth has no fixed dimension; use rule_batch")  # pragma: no cover

    def rule_batch(self, U: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        normal = np.zeros((1, U.shape[1]))
        normal[0, -1] = 1.0
        return normal, np.ones(1)

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        raise ParameterError("Smooth has a single facet; Monte Carlo sampling is pointless, use the quadrature")


@dataclass(frozen=True)
class Sawtooth(FiniteRoughness):
    """Planar sawtooth of the paper's example (2.11)–(2.13).

    Facet normals (∓sin α, cos α) with probability ½ each.

    Parameters
    ----------
    alpha : float
        Slope angle of the teeth, 0 ≤ α < π/2.
    """

    alpha: float
    dim: ClassVar[int | None] = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "alpha", check_tilt("alpha", self.alpha))

    def facets(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        s, c = math.sin(self.alpha), math.cos(self.alpha)
        return np.array([[-s, c], [s, c]]), np.array([0.5, 0.5])


@dataclass(frozen=True, eq=False)
class Facets(FiniteRoughness):
    """Any finite measure: facet normals with weights, planar or spatial.

    Parameters
    ----------
    normals : array_like, shape (K, d)
        Unit facet normals in the local frame (last component along n⁰, > 0:
        a facet tilts by less than π/2), d = 2 or 3.
    weights : array_like, shape (K,), optional
        Non-negative, not all zero; normalised to sum 1. Uniform by default.
    """

    normals: NDArray[np.float64]
    weights: NDArray[np.float64] | None = field(default=None)

    def __post_init__(self) -> None:
        m = check_normals("normals", self.normals).copy()
        if self.weights is None:
            w = np.full(m.shape[0], 1.0 / m.shape[0])
        else:
            w = check_weights("weights", self.weights, m.shape[0])
        m.flags.writeable = False
        w.flags.writeable = False
        object.__setattr__(self, "normals", m)
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "dim", m.shape[1])

    def __repr__(self) -> str:
        return f"Facets({self.normals.shape[0]} facets, d={self.normals.shape[1]})"

    def facets(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        assert self.weights is not None
        return self.normals, self.weights

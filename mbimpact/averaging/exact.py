"""Finite facet sets: (2.8) summed exactly, and the Monte Carlo baseline."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..results.impact import ContactImpulses
from .base import Averaging
from .integrand import (AveragingSpec, check_facing, facet_impulses, facet_terms, general_facets, in_blocks,
                        rule_average)

__all__ = ["Exact", "MonteCarlo"]


class Exact(Averaging):
    """The finite sum over the facets of a finite measure (error 0): Smooth, Sawtooth,
    Facets, and measured relief (Profile, HeightMap, with exact shadowing)."""

    name: ClassVar[str] = "exact"
    #: Averages any facet law (:mod:`mbimpact.facets`), not only Newton's.
    any_facet: ClassVar[bool] = True

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        def block(rows: NDArray[np.float64]) -> ContactImpulses:
            (P,), (facets,) = rule_average(spec, W, rows, (1,))
            return ContactImpulses(P, np.zeros(len(rows)), facets, self.name)

        return in_blocks(block, U)


class MonteCarlo(Averaging):
    """(2.8) as a ratio of sample means over ``samples`` facets drawn from P with ``seed``
    (the naive baseline); the error estimate is the delta-method standard error."""

    name: ClassVar[str] = "monte-carlo"
    any_facet: ClassVar[bool] = True

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        return False  # never chosen by "auto": it is the baseline the others are measured against

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        m = spec.roughness.sample(np.random.default_rng(spec.seed), spec.samples)
        return in_blocks(lambda rows: self._sampled(spec, m, W, rows), U)

    def _sampled(self, spec: AveragingSpec, m: NDArray[np.float64], W: NDArray[np.float64], U: NDArray[np.float64]
                 ) -> ContactImpulses:
        w, c = facet_terms(spec, m, np.ones(len(m)), W, U)
        total = w.sum(axis=1)
        check_facing(spec, total, U)
        if general_facets(spec):
            a = w[:, :, None] * facet_impulses(spec, m, W, U, w)  # (B, N, d)
        else:
            a = (1.0 + spec.e) * (w * c)[:, :, None] * m[None, :, :]
        P = a.sum(axis=1) / total[:, None]
        resid = a - P[:, None, :] * w[:, :, None]
        n = spec.samples
        se = np.sqrt((resid**2).sum(axis=(1, 2)) / (n - 1) / n) / (total / n)
        return ContactImpulses(P, se / np.linalg.norm(P, axis=1), n, self.name)

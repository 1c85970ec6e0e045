"""One velocity on a :class:`~mbimpact.Cone`: the first pass of the adaptive rule of (2.8) in one compiled call.

A single impact on a cone is what simulations call in their inner loop, and in numpy its cost
is the number of array operations, not the number of nodes. The first pass of the adaptive
rule — n and 2n azimuth nodes, exactly those of :func:`mbimpact.quadrature.rules.azimuth_rule`
(the periodic trapezoid rule on the full ring, Gauss–Legendre on the facing arc), their impulses
P = (1+e) N / D and the relative difference of the two — is therefore one call of a numba kernel
(:func:`mbimpact.averaging.cone_kernels.cone_pair`) on floats. Its result is the one of the
adaptive rule's first pass up to rounding. The kernel is compiled (or loaded from numba's
on-disk cache) on first use (:data:`KERNELS`; :func:`mbimpact.compile_kernels` does it ahead of time).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.compiled import KernelModule
from ..common.geometry import DEGENERATE
from ..results.impact import ContactImpulses
from .base import Averaging
from .kernels import AveragingSpec

__all__ = ["ConePair", "KERNELS"]

#: The compiled kernel of :class:`ConePair` (:mod:`mbimpact.averaging.cone_kernels`), loaded on first use.
KERNELS = KernelModule("mbimpact.averaging.cone_kernels")


class ConePair(Averaging):
    """One velocity on a :class:`~mbimpact.Cone`: the first pass of the adaptive rule (n and 2n
    nodes) in one compiled call (:func:`mbimpact.averaging.cone_kernels.cone_pair`). Declines when
    that pass is not conclusive (or meets a degenerate facet): the adaptive rule then goes on.
    Chosen by ``"auto"`` for single velocities without a fixed node count."""

    name: ClassVar[str] = "cone-pair"

    def supports(self, spec: AveragingSpec) -> bool:
        return super().supports(spec) and getattr(spec.roughness, "alpha", 0.0) > 0.0

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        return spec.nodes is None and len(U) == 1

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        n = spec.roughness.initial_nodes
        if 2 * n > spec.max_nodes or len(U) != 1:
            return None
        kernels = KERNELS.get()
        P, err = np.empty((1, 3)), np.empty(1)  # written by the kernel (cheaper than arrays it returns)
        status = kernels.cone_pair(spec.roughness.alpha, W, U, kernels.rule_table(n),  # type: ignore[attr-defined]
                                   spec.flux == "configuration", spec.e, spec.rtol, DEGENERATE, P, err)
        if status != kernels.SETTLED:
            return None
        return ContactImpulses(P, err, 2 * n, self.name)

    def reason(self, spec: AveragingSpec) -> str:
        return "the two-level pass is not conclusive here (or there are several velocities); use 'adaptive'"

"""One velocity on a :class:`~mbimpact.Cone`: every level of the adaptive rule of (2.8) in one compiled call.

:class:`~mbimpact.averaging.ConePair` settles most single impacts on a cone with the adaptive
rule's first pass (n and 2n azimuth nodes). Where W is strongly anisotropic — a foot of a legged
robot on the ground, an arm near a singular posture — the kernels of (2.8) peak on the ring and
the rule needs more levels (128 nodes and more); in numpy each level costs its array operations.
:class:`ConePass` runs all of them in one call of
:func:`mbimpact.averaging.cone_kernels.cone_pass`: the same nodes, error estimate and stopping
rule as :func:`mbimpact.averaging.refinement.refine`, so its result is the adaptive rule's up to
rounding. It declines where it cannot reach rtol itself (rounding or ``max_nodes`` stops it short):
``"adaptive"`` then runs and says so. Its level sums are compensated, so that on an
ill-conditioned W it may settle, to rounding, where the adaptive rule's pairwise sums stall and
warn (and then a level earlier or later than it).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import DEGENERATE
from ..results.impact import ContactImpulses
from .base import Averaging
from .cone_pair import KERNELS
from .kernels import AveragingSpec
from .refinement import level_plan

__all__ = ["ConePass"]


class ConePass(Averaging):
    """One velocity on a :class:`~mbimpact.Cone`: the adaptive rule (n, 2n, 4n, … azimuth nodes
    until two levels agree to rtol) in one compiled call
    (:func:`mbimpact.averaging.cone_kernels.cone_pass`). Declines where it stops short of rtol
    (rounding, ``max_nodes``), or on a node where the mechanism cannot push the facet. Chosen by ``"auto"`` for
    single velocities without a fixed node count, after ``"cone-pair"``."""

    name: ClassVar[str] = "cone-pass"

    def supports(self, spec: AveragingSpec) -> bool:
        return super().supports(spec) and getattr(spec.roughness, "alpha", 0.0) > 0.0

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        return spec.nodes is None and len(U) == 1

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        n, levels = level_plan(spec)  # the levels refine() may reach: n, 2n, … ≤ max_nodes
        if levels < 2 or len(U) != 1:
            return None
        kernels = KERNELS.get()
        P, err = np.empty((1, 3)), np.empty(1)  # written by the kernel (cheaper than arrays it returns)
        status, nodes = kernels.cone_pass(spec.roughness.alpha, W, U,  # type: ignore[attr-defined]
                                          kernels.rule_table(n, levels), levels, spec.flux == "configuration",
                                          spec.e, spec.rtol, DEGENERATE, P, err)
        if status != kernels.SETTLED:
            return None
        return ContactImpulses(P, err, nodes, self.name)

    def reason(self, spec: AveragingSpec) -> str:
        return ("the compiled rule stops short of rtol here (rounding, max_nodes or a facet the mechanism cannot "
                "push), or there are several velocities; use 'adaptive'")

"""One velocity on a :class:`~mbimpact.Cone` with a nearly singular W: the graded rule of (2.8) in one compiled call.

Near a singular posture (an arm stretched out) the Delassus matrix W is nearly singular, the
kernels of (2.8) with the flux weights of (2.7) peak on the ring of facets with widths ε ≪ 1, and
``"auto"`` grades the rule towards the peaks (:class:`~mbimpact.averaging.Graded`): a few levels of
tens of nodes a piece, but in numpy ~0.5 ms a single impact, most of it array operations and the
search for the minima of q = mᵀWm. :class:`GradedPass` runs all of it in one call of
:func:`mbimpact.averaging.graded_kernels.graded_pass`: the same minima, pieces, nodes, error estimate
and stopping rule, so its result is :class:`~mbimpact.averaging.Graded`'s up to rounding, at the same
node count, and its error estimate holds, as that method's does, the rounding of q at the minima and
that of P where W nearly annihilates it (:func:`~mbimpact.averaging.graded_kernels.minima_sensitivity`,
:func:`~mbimpact.averaging.refinement.rounding_floor`), which successive levels do not see. It declines
where that method would decline, where it cannot reach rtol itself (rounding or ``max_nodes`` stops it
short), and on a node where the mechanism cannot push the facet:
``"graded"`` then runs. Its level sums are compensated, so that where two levels differ by rounding
(cond W ~ 1e7) it may settle where the numpy rule stalls and warns, or the other way round.
The kernels are compiled (or loaded from numba's on-disk cache) on first use (:data:`KERNELS`;
:func:`mbimpact.compile_kernels` does it ahead of time).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.compiled import KernelModule
from ..common.geometry import DEGENERATE
from ..metric.delassus import eigen_ratio, spread_bound
from ..results.impact import ContactImpulses
from .base import Averaging
from .kernels import AveragingSpec
from .refinement import Graded, level_plan

__all__ = ["GradedPass", "KERNELS"]

#: The compiled kernels of :class:`GradedPass` (:mod:`mbimpact.averaging.graded_kernels`), loaded on first use.
KERNELS = KernelModule("mbimpact.averaging.graded_kernels")


class GradedPass(Averaging):
    """One velocity on a :class:`~mbimpact.Cone`: the graded rule for a nearly singular W (n, 2n, 4n, …
    nodes a piece until two levels agree to rtol) in one compiled call
    (:func:`mbimpact.averaging.graded_kernels.graded_pass`). Declines where ``"graded"`` would
    decline, where it stops short of rtol, or on a node where the mechanism cannot push the facet.
    Chosen by ``"auto"`` where ``"graded"`` would be, for single velocities without a fixed node
    count."""

    name: ClassVar[str] = "graded-pass"
    shares_screen_with: ClassVar[str | None] = "graded"

    def supports(self, spec: AveragingSpec) -> bool:
        return super().supports(spec) and getattr(spec.roughness, "alpha", 0.0) > 0.0

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        """:meth:`Graded.worthwhile` for one velocity without a fixed node count: its closed-form
        screens of W (:func:`~mbimpact.averaging.refinement.peaked_rule`), then the ring's peak test
        of :meth:`mbimpact.Cone.graded_rule` compiled (numpy's search for the minima of q costs
        ~50 µs, more than the whole compiled rule)."""
        if spec.nodes is not None or len(U) != 1 or W.shape != (3, 3):
            return False
        peaked = Graded.peaked
        # peaked_rule's screens: λ_min / λ_max ≥ 4 det W / tr(W)³, then the closed-form eigenvalues
        if spread_bound(W) > peaked**2 or eigen_ratio(W) > 4 * peaked**2:
            return False
        return bool(KERNELS.get().ring_peaks(spec.roughness.alpha, W, peaked) > 0)  # type: ignore[attr-defined]

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        if spec.nodes is not None or len(U) != 1 or W.shape != (3, 3):
            return None
        n, levels = level_plan(spec)  # the levels refine() may reach: n, 2n, … ≤ max_nodes
        if levels < 2:  # max_nodes = 1: refine() computes the pair (1, 2) anyway, and warns
            return None
        kernels = KERNELS.get()
        P, err = np.empty((1, 3)), np.empty(1)  # written by the kernel (cheaper than arrays it returns)
        status, nodes = kernels.graded_pass(spec.roughness.alpha, W, U,  # type: ignore[attr-defined]
                                            kernels.rule_table(n, levels), levels, Graded.peaked,
                                            spec.flux == "configuration", spec.e, spec.rtol, DEGENERATE, P, err)
        if status != kernels.SETTLED:
            return None
        return ContactImpulses(P, err, nodes, self.name)

    def reason(self, spec: AveragingSpec) -> str:
        return ("the compiled graded rule does not apply here (no narrow peak of the kernels on this W, several "
                "velocities or a fixed node count) or stops short of rtol (rounding, max_nodes or a facet the "
                "mechanism cannot push); use 'graded'")

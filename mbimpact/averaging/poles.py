"""The pole rule: one velocity on a :class:`~mbimpact.Cone` with a nearly singular W, the peaks of (2.8)'s
kernels taken out as poles and integrated in closed form, in one compiled call.

With the physical flux the kernels of (2.8) on a ring of facets are rational in z = e^{iφ}; a nearly
singular W puts a pair of their poles (a, 1/ā) within ε ≪ 1 of the unit circle at each minimum of
q = mᵀWm, where the kernels peak. :class:`Poles` subtracts 2 Re[r / (e^{iφ} − a)], which carries both
poles with their residues, integrates it in closed form over the facing arc and the smooth rest with the
cone's plain rule (:func:`mbimpact.averaging.compiled.poles.poles`): 16 and 32 nodes where the graded
rule (:class:`~mbimpact.averaging.Graded`) needs 6 × (32 + 64) graded ones. Its error estimate and
stopping rule are the adaptive rule's. The rounding of f near a peak is amplified by ~1/(n ε) in the
plain rule (a node there weighs 2π/n, against ~ε/n in the graded rule), so the estimate rises as the peak
narrows: at cond W ~ 1e7 (the UR5 stretched out) it settles at a few 1e-13. Its error estimate also holds
what level differences do not see (:mod:`mbimpact.averaging.compiled.poles`): the rounding of q at the peaks
(where it exceeds rtol, the rule declines and the graded rule runs), and that of P itself where W nearly
annihilates it (:func:`mbimpact.averaging.refinement.rounding_floor`; no rule does better, so the estimate
just says so). The configuration flux (branch points, not poles) is left to the graded rule.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import DEGENERATE
from ..results.impact import ContactImpulses
from .base import SKIP, Averaging
from .compiled import CONE, POLES
from .compiled.codes import POLES_STEP, SETTLED
from .integrand import AveragingSpec
from .refinement import Graded, peaked_ring

__all__ = ["Poles", "FIRST_NODES", "MOST_NODES", "pole_plan"]

#: Nodes of the first level: without its peaks the rest is smooth, and 16 and 32 nodes settle the UR5
#: stretched out (the graded rule needs 6 × (32 + 64)).
FIRST_NODES = 16

#: Nodes of the last level the pass computes: where a peak is too narrow for the plain rule to settle by
#: then, the graded rule takes over.
MOST_NODES = 128


def pole_plan(spec: AveragingSpec) -> tuple[int, int]:
    """The levels of :class:`Poles`: n, 2n, … nodes from :data:`FIRST_NODES`, within ``max_nodes`` and
    :data:`MOST_NODES` (n halved when the first pair would pass them).

    Returns
    -------
    (n, L) : (int, int)
        The first level's node count and the number of levels (≥ 2 unless max_nodes = 1).
    """
    top = min(int(spec.max_nodes), MOST_NODES)
    nodes = FIRST_NODES if 2 * FIRST_NODES <= top else max(1, top // 2)
    levels = 1
    while nodes << levels <= top:
        levels += 1
    return nodes, levels


class Poles(Averaging):
    """One velocity on a :class:`~mbimpact.Cone` with a nearly singular W and the physical flux: the poles
    of the kernels near the ring subtracted and integrated in closed form, the rest by the cone's rule (16,
    32, … 128 nodes until two levels agree to rtol: :func:`pole_plan`), in one compiled call
    (:func:`mbimpact.averaging.compiled.poles.poles`). Chosen by ``"auto"`` where the kernels peak (as for
    :class:`~mbimpact.averaging.Graded`), before the graded rule; declines where it stops short of rtol,
    where a zero of q is not found, on a facet the mechanism cannot push, and for several velocities or a
    fixed node count. The configuration flux (branch points, not poles) is not supported."""

    name: ClassVar[str] = "poles"

    def supports(self, spec: AveragingSpec) -> bool:
        return super().supports(spec) and getattr(spec.roughness, "alpha", 0.0) > 0.0

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        """The physical flux, one velocity without a fixed node count, and kernels that peak on the ring
        (:func:`~mbimpact.averaging.refinement.peaked_ring`, as for the graded rule)."""
        return spec.flux == "physical" and spec.nodes is None and len(U) == 1 and peaked_ring(spec, W, Graded.peaked)

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        if spec.nodes is not None or len(U) != 1 or W.shape != (3, 3) or spec.flux != "physical":
            return None
        n, levels = pole_plan(spec)
        if levels < 2:
            return None
        kernels = POLES.get()
        P, err = np.empty((1, 3)), np.empty(1)  # written by the kernel
        table = CONE.get().rule_table(n, levels)
        status, nodes = kernels.poles(spec.roughness.alpha, W, U, table, levels,  # type: ignore[attr-defined]
                                      Graded.peaked, spec.e, spec.rtol, DEGENERATE, P, err)
        if status != SETTLED:
            return None
        return ContactImpulses(P, err, nodes, self.name)

    def reason(self, spec: AveragingSpec) -> str:
        return ("the pole rule takes one velocity on a cone with the physical flux (the configuration flux has "
                "branch points) whose kernels have a narrow peak on this W, without a fixed node count; or the peak "
                "is too narrow for the plain rule to reach rtol, a zero of q was not found, or a facet on the ring "
                "cannot be pushed; use 'graded'")

    def cone_step(self, spec: AveragingSpec) -> int | None:
        return POLES_STEP if spec.flux == "physical" else SKIP

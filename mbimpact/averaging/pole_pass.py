"""One velocity on a :class:`~mbimpact.Cone` with a nearly singular W: the peaks of (2.8)'s kernels taken
out as poles and integrated in closed form, in one compiled call.

With the physical flux the kernels of (2.8) on a ring of facets are rational in z = e^{iφ}; a nearly
singular W puts a pair of their poles (a, 1/ā) within ε ≪ 1 of the unit circle at each minimum of
q = mᵀWm, where the kernels peak. :class:`PolePass` subtracts 2 Re[r / (e^{iφ} − a)], which carries both
poles with their residues, integrates it in closed form over the facing arc and the smooth rest with the
cone's plain rule (:func:`mbimpact.averaging.pole_kernels.pole_pass`): 16 and 32 nodes where the graded
rule (:class:`~mbimpact.averaging.GradedPass`) needs 6 × (32 + 64) graded ones. Its error estimate and
stopping rule are the adaptive rule's. The rounding of f near a peak is amplified by ~1/(n ε) in the
plain rule (a node there weighs 2π/n, against ~ε/n in the graded rule), so the estimate rises as the peak
narrows: at cond W ~ 1e7 (the UR5 stretched out) it settles at a few 1e-13. Its error estimate also holds
what level differences do not see (:mod:`mbimpact.averaging.pole_kernels`): the rounding of q at the peaks
(where it exceeds rtol, the pass declines and the graded rule runs), and that of P itself where W nearly
annihilates it (:func:`mbimpact.averaging.refinement.rounding_floor`; no rule does better, so the estimate
just says so). The configuration flux (branch points, not poles) is left to the graded rule.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.compiled import KernelModule
from ..common.geometry import DEGENERATE
from ..results.impact import ContactImpulses
from .base import Averaging
from .cone_pair import KERNELS as CONE_KERNELS
from .graded_pass import GradedPass
from .kernels import AveragingSpec
from .refinement import Graded

__all__ = ["PolePass", "KERNELS", "FIRST_NODES", "MOST_NODES", "pole_plan"]

#: The compiled kernels of :class:`PolePass` (:mod:`mbimpact.averaging.pole_kernels`), loaded on first use.
KERNELS = KernelModule("mbimpact.averaging.pole_kernels")

#: Nodes of the first level: without its peaks the rest is smooth, and 16 and 32 nodes settle the UR5
#: stretched out (the graded rule needs 6 × (32 + 64)).
FIRST_NODES = 16

#: Nodes of the last level the pass computes: where a peak is too narrow for the plain rule to settle by
#: then, the graded rule takes over.
MOST_NODES = 128


def pole_plan(spec: AveragingSpec) -> tuple[int, int]:
    """The levels of :class:`PolePass`: n, 2n, … nodes from :data:`FIRST_NODES`, within ``max_nodes`` and
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


class PolePass(Averaging):
    """One velocity on a :class:`~mbimpact.Cone` with a nearly singular W and the physical flux: the poles
    of the kernels near the ring subtracted and integrated in closed form, the rest by the cone's rule (16,
    32, … 128 nodes until two levels agree to rtol: :func:`pole_plan`), in one compiled call
    (:func:`mbimpact.averaging.pole_kernels.pole_pass`). Chosen by ``"auto"`` where
    :class:`~mbimpact.averaging.GradedPass` would be, before it; declines where it stops short of rtol,
    where a zero of q is not found, on a facet the mechanism cannot push, for the configuration flux,
    several velocities or a fixed node count."""

    name: ClassVar[str] = "pole-pass"
    shares_screen_with: ClassVar[str | None] = "graded"

    def supports(self, spec: AveragingSpec) -> bool:
        return super().supports(spec) and getattr(spec.roughness, "alpha", 0.0) > 0.0

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        """With the physical flux, :meth:`GradedPass.worthwhile`: the kernels peak on the ring (one velocity, no
        fixed node count)."""
        return spec.flux == "physical" and GradedPass().worthwhile(spec, W, U)

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        if spec.nodes is not None or len(U) != 1 or W.shape != (3, 3) or spec.flux != "physical":
            return None
        n, levels = pole_plan(spec)
        if levels < 2:
            return None
        kernels = KERNELS.get()
        P, err = np.empty((1, 3)), np.empty(1)  # written by the kernel
        table = CONE_KERNELS.get().rule_table(n, levels)
        status, nodes = kernels.pole_pass(spec.roughness.alpha, W, U, table, levels,  # type: ignore[attr-defined]
                                          Graded.peaked, spec.e, spec.rtol, DEGENERATE, P, err)
        if status != kernels.SETTLED:
            return None
        return ContactImpulses(P, err, nodes, self.name)

    def reason(self, spec: AveragingSpec) -> str:
        return ("the poles of the kernels are taken out for one velocity on a cone with the physical flux (the "
                "configuration flux has branch points) and a narrow peak on this W, without a fixed node count; or "
                "the peak is too narrow for the plain rule to reach rtol, or a facet on the ring cannot be pushed; "
                "use 'graded-pass' or 'graded'")


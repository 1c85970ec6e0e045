"""One velocity on an :class:`~mbimpact.IsotropicSlopes` measure with a nearly singular W: the graded rule
of (2.8) in one compiled call.

Near a singular posture (the UR5 stretched out) the Delassus matrix W is nearly singular, the kernels
of (2.8) with the flux weights of (2.7) peak with widths ε ≪ 1, and ``"auto"`` grades the product rule
of a tilt density towards the peaks (:class:`~mbimpact.averaging.Graded` with
:meth:`mbimpact.IsotropicSlopes.graded_rule`): tilts towards
:func:`~mbimpact.quadrature.graded.peak_tilts`, each ring's azimuths towards its own minima of
q = mᵀWm. In numpy a single impact costs tens of milliseconds, arrays of 10⁵–10⁶ facets a level.
:class:`GradedSlopePass` computes the graded tilt nodes of the levels with the numpy rule's own
functions (a few small arrays) and the measure's density on all of them in one call, then runs the
rings' minima, the azimuth pieces and nodes, the sums, the error estimate and the stopping rule of
every level in one call of :func:`mbimpact.averaging.graded_slope_kernels.graded_slope_pass`. Its
result is :class:`~mbimpact.averaging.Graded`'s up to rounding, at the same node count (its level sums
are compensated, so that where two levels differ by rounding it may settle one level apart). It
declines where Graded would decline, where it stops short of rtol (``max_nodes``, rounding), on a
facet the mechanism cannot push, and on no facing facet: ``"graded"`` then runs.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.compiled import KernelModule, kernel_array
from ..common.geometry import DEGENERATE, incidence_split
from ..quadrature.graded import peak_tilts
from ..results.impact import ContactImpulses
from ..roughness.slopes import IsotropicSlopes
from .base import Averaging
from .kernels import AveragingSpec, general_facets
from .refinement import Graded, level_plan

__all__ = ["GradedSlopePass", "KERNELS", "FIRST_LEVELS"]

#: The compiled kernels of :class:`GradedSlopePass` (:mod:`mbimpact.averaging.graded_slope_kernels`), on first use.
KERNELS = KernelModule("mbimpact.averaging.graded_slope_kernels")

#: Levels whose tilt nodes the first call gets (n … 8n: 8 … 64 nodes a piece); a velocity that needs more
#: is run again with the tilts of every level up to ``max_nodes``.
FIRST_LEVELS = 4


def _tilts(rough: IsotropicSlopes, U: NDArray[np.float64], peaks: tuple[NDArray[np.float64], NDArray[np.float64]],
           table: NDArray[np.float64], n: int, count: int
           ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]] | None:
    """The graded tilt nodes of ``count`` levels (n, 2n, … nodes a piece) as
    :meth:`IsotropicSlopes._graded_spatial` forms them (those of positive dα;
    :func:`mbimpact.averaging.graded_slope_kernels.tilt_nodes`), their weights p(α) dα (the measure's
    density in one call), and where each level starts; None for a density of another shape.

    Returns
    -------
    tilt, pd : ndarray, shape (L,)
    start : ndarray of int, shape (count + 1,)
    """
    lo, hi = rough.support
    size = 10 * n * ((1 << count) - 1)  # graded_tilt_rule's 2h + 4 = 10 half-pieces a level
    tilt, dtilt, start = np.empty(size), np.empty(size), np.empty(count + 1, dtype=np.int64)
    at, et = (np.ascontiguousarray(p[0], dtype=np.float64) for p in peaks)
    total = KERNELS.get().tilt_nodes(float(lo), float(hi), float(incidence_split(U)[0]), at, et, table, n, count,
                                     tilt, dtilt, start)
    tilt = tilt[:total]
    density = np.asarray(rough.density(tilt), dtype=np.float64)
    if density.shape != tilt.shape:
        return None
    return tilt, kernel_array(density * dtilt[:total]), start


class GradedSlopePass(Averaging):
    """One velocity on a spatial :class:`~mbimpact.IsotropicSlopes` measure (such as
    :class:`~mbimpact.GaussianSlopes`) with a nearly singular W: the graded rule (n, 2n, 4n, … nodes a
    piece until two levels agree to rtol), every level in one compiled call
    (:func:`mbimpact.averaging.graded_slope_kernels.graded_slope_pass`). Declines where ``"graded"``
    would decline, where it stops short of rtol, on a facet the mechanism cannot push or with no facing
    facet. Chosen by ``"auto"`` where ``"graded"`` would be, for single velocities without a fixed node count."""

    name: ClassVar[str] = "graded-slope-pass"
    shares_screen_with: ClassVar[str | None] = "graded"

    def supports(self, spec: AveragingSpec) -> bool:
        rough = spec.roughness
        return (super().supports(spec) and isinstance(rough, IsotropicSlopes) and rough.dim == 3
                and not general_facets(spec))

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        """:meth:`Graded.worthwhile` (its closed-form screens of W, then the measure's peak test), for one
        velocity without a fixed node count."""
        if spec.nodes is not None or len(U) != 1 or W.shape != (3, 3):
            return False
        return Graded().worthwhile(spec, W, U)

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        rough = spec.roughness
        if (spec.nodes is not None or len(U) != 1 or W.shape != (3, 3) or U.shape[1] != 3
                or not isinstance(rough, IsotropicSlopes) or rough.dim != 3 or general_facets(spec)):
            return None
        peaks = peak_tilts(W, U, Graded.peaked)
        # IsotropicSlopes.graded_rule's test (its first two columns do not depend on U): Graded declines
        if not np.isfinite(peaks[1][0, :2]).any():
            return None
        n, levels = level_plan(spec)  # the levels refine() may reach: n, 2n, … ≤ max_nodes
        if levels < 2:  # max_nodes = 1: refine() computes the pair (1, 2) anyway, and warns
            return None
        kernels = KERNELS.get()
        W, U = kernel_array(W), kernel_array(U)
        table = kernels.rule_table(n, levels)
        P, err = np.empty((1, 3)), np.empty(1)  # written by the kernel
        count = min(levels, FIRST_LEVELS)
        while True:
            tilts = _tilts(rough, U, peaks, table, n, count)
            if tilts is None:
                return None
            tilt, pd, start = tilts
            status, nodes = kernels.graded_slope_pass(W, U, tilt, pd, start, table, n, levels,
                                                      spec.flux == "configuration", spec.e, spec.rtol, DEGENERATE,
                                                      P, err)
            if status != kernels.NEED_TABLE or count == levels:
                break
            count = levels  # every level max_nodes allows, from the start (the first levels cost little)
        if status != kernels.SETTLED:
            return None
        return ContactImpulses(P, err, nodes, self.name)

    def reason(self, spec: AveragingSpec) -> str:
        return ("the compiled graded rule of a tilt density does not apply here (no narrow peak of the kernels on "
                "this W, a planar measure, several velocities or a fixed node count) or stops short of rtol "
                "(rounding, max_nodes, a facet the mechanism cannot push); use 'graded'")

"""One velocity on an isotropic tilt density: the adaptive rule of (2.8) in one compiled call.

A single impact on :class:`~mbimpact.GaussianSlopes` (or another :class:`~mbimpact.IsotropicSlopes`)
is what simulations call in their inner loop. The adaptive rule
(:class:`~mbimpact.averaging.refinement.Adaptive`) doubles the nodes of the measure's product
rule — Gauss–Legendre tilts split at α* (:func:`mbimpact.quadrature.rules.tilt_segments`) times
the exact facing arc of each ring (:func:`mbimpact.quadrature.rules.azimuth_rule`) — from 8 to
typically 64 nodes a piece, ~10⁴ facets in all, and in numpy its cost is that of the array
operations of every level (~1.5 ms), not of the arithmetic. :class:`SlopePass` runs the same
refinement — the same nodes, level after level, the same error estimate (the relative change of
W P between the last two levels, :func:`mbimpact.averaging.kernels.relative_change`), the same
stopping rule (``rtol`` or the rounding floor 100 ε √K) — as one call of a numba kernel
(:func:`mbimpact.averaging.slope_pass_kernels.slope_pass`), in tens of microseconds. Its result
is the adaptive rule's up to rounding.

The Gaussian slope density is evaluated in closed form inside the kernel; any other tilt density
(a Python callable) is evaluated once per call at the tilt nodes of the levels the kernel may
need. Where the adaptive rule would warn (``max_nodes`` reached, rounding amplified by an
ill-conditioned W) or raise (no facing facet), the method declines and ``"auto"`` hands the
velocity to ``adaptive``, which then does exactly that.

The kernels are compiled (or loaded from numba's on-disk cache) on first use:
:data:`KERNELS`, and :func:`mbimpact.compile_kernels` does it ahead of time with every other kernel of
the package.
"""

from __future__ import annotations

import functools
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.compiled import KernelModule, kernel_array
from ..common.geometry import DEGENERATE
from ..results.impact import ContactImpulses
from ..roughness.slopes import GaussianTiltDensity, IsotropicSlopes
from .base import Averaging
from .kernels import AveragingSpec, general_facets

__all__ = ["SlopePass", "KERNELS", "FIRST_LEVELS"]

#: Levels of the first call (n0 … 8 n0: the 8 … 64 nodes a piece of a typical single impact);
#: a velocity that needs more gets the table of every level up to ``max_nodes`` and goes on.
FIRST_LEVELS = 4

#: The compiled kernels of :class:`SlopePass` (:mod:`mbimpact.averaging.slope_pass_kernels`), loaded on first use.
KERNELS = KernelModule("mbimpact.averaging.slope_pass_kernels")


@functools.lru_cache(maxsize=32)
def _table(n0: int, count: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The nodes of ``count`` levels from n0 nodes a piece
    (:func:`mbimpact.averaging.slope_pass_kernels.level_table`; read-only, shared), and the density
    argument of a closed-form density (zeros of the size of a tabulated one: read, not used)."""
    table = KERNELS.get().level_table(n0, count)
    return table, np.zeros(2 * table.shape[1])


#: What every call on one spec passes to the kernel: d, n0, the levels the adaptive rule may reach
#: and those of a first call, lo, hi, the kind of density, σ, whether it is the spatial slope density,
#: the density's mass, e, whether the flux is "configuration", rtol, max_nodes.
_Setup = tuple[int, int, int, int, float, float, int, float, bool, float, float, bool, float, int]


@functools.lru_cache(maxsize=64)
def _setup(spec: AveragingSpec) -> _Setup | None:
    """The kernel's arguments that depend on the spec alone (a spec is compared by identity, and
    immutable), or None for a measure or facet law it cannot average."""
    rough = spec.roughness
    if not isinstance(rough, IsotropicSlopes) or general_facets(spec):  # Newton facets only
        return None
    kernels = KERNELS.get()
    max_nodes = int(spec.max_nodes)
    n0 = int(rough.initial_nodes)
    if 2 * n0 > max_nodes:  # the first pair stays within max_nodes (as the adaptive rule's)
        n0 = max(1, max_nodes // 2)
    levels = 2  # n0 2ᵏ ≤ max_nodes, and always the first pair
    while n0 << levels <= max_nodes:
        levels += 1
    pdf = rough.pdf
    lo, hi = rough.support
    # the Gaussian slope density in closed form inside the kernel (not a subclass: it may differ)
    if isinstance(pdf, GaussianTiltDensity) and type(pdf) is GaussianTiltDensity:
        kind, sigma, radial = kernels.GAUSSIAN, float(pdf.sigma), pdf.dim == 3
    else:
        kind, sigma, radial = kernels.TABULATED, 1.0, False
    return (int(rough.dim), n0, levels, min(levels, FIRST_LEVELS), float(lo), float(hi), kind, sigma, radial,
            float(rough.mass), float(spec.e), spec.flux == "configuration", float(spec.rtol), max_nodes)


class SlopePass(Averaging):
    """One velocity on an :class:`~mbimpact.IsotropicSlopes` measure (:class:`~mbimpact.GaussianSlopes`
    and any other tilt density, spatial or planar): the adaptive rule, every level in one compiled
    call (:func:`mbimpact.averaging.slope_pass_kernels.slope_pass`). Declines where the adaptive
    rule would warn or raise (``max_nodes`` reached, rounding amplified by an ill-conditioned W, no
    facing facet), or for several velocities: the adaptive rule then goes on. Chosen by ``"auto"``
    for single velocities without a fixed node count, after ``graded``."""

    name: ClassVar[str] = "slope-pass"

    def supports(self, spec: AveragingSpec) -> bool:
        return super().supports(spec) and isinstance(spec.roughness, IsotropicSlopes)

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        return spec.nodes is None and len(U) == 1

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        setup = _setup(spec)
        if setup is None or len(U) != 1 or U.shape[1] != setup[0]:
            return None
        kernels = KERNELS.get()
        d, n0, levels, count, lo, hi, kind, sigma, radial, mass, e, configuration, rtol, max_nodes = setup
        U, W = kernel_array(U), kernel_array(W)
        P, state, start = np.empty((1, d)), np.empty(2), -1  # state: the last level compared, its error
        while True:
            table, density = _table(n0, count)
            if kind == kernels.TABULATED:  # the callable at every tilt node of the table's levels, in one call
                rough = spec.roughness
                assert isinstance(rough, IsotropicSlopes)  # as _setup found it
                density = kernel_array(np.asarray(rough.density(kernels.tilt_nodes(U, lo, hi, table, n0)), dtype=np.float64))
                if density.shape != (2 * table.shape[1],):
                    return None
            status = kernels.slope_pass(U, W, table, n0, density, kind, lo, hi, sigma, radial, mass, e,
                                        configuration, rtol, max_nodes, DEGENERATE, P, state, start)
            if status != kernels.NEED_TABLE or count == levels:
                break
            count, start = levels, int(state[0])  # every level up to max_nodes; on from where it stopped
        if status != kernels.DONE:
            return None
        return ContactImpulses(P, state[1:], n0 << int(state[0]), self.name)

    def reason(self, spec: AveragingSpec) -> str:
        return ("the compiled pass stops where the adaptive rule would warn or raise (max_nodes reached, rounding "
                "amplified by an ill-conditioned W, no facing facet), or there are several velocities; use 'adaptive'")

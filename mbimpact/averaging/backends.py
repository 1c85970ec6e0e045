"""The compiled backends of the adaptive and graded rules for one velocity.

A single impact is what simulations call in their inner loop, and in numpy its cost is the number of
array operations of every level, not the arithmetic: ~0.5 ms for a cone's graded rule, ~1.5 ms for a
tilt density's product rule, tens of ms for its graded rule. For one velocity with Newton facets and no
fixed node count, :class:`~mbimpact.averaging.Adaptive` and :class:`~mbimpact.averaging.Graded`
therefore run their levels in one compiled call (:mod:`mbimpact.averaging.compiled`): the same nodes,
error estimate and stopping rule, so that the result is the numpy rule's to rounding (the compiled
level sums are compensated, so that where two levels differ by rounding they may settle one level
apart). Each function here returns the status of :mod:`~mbimpact.averaging.compiled.codes` and, where
SETTLED, the impulses; on any other status the rule decides (it declines, or runs its numpy form,
which treats the case and warns where it must).
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from ..common.compiled import kernel_array
from ..common.geometry import DEGENERATE, incidence_split
from ..quadrature.graded import peak_tilts
from ..results.impact import ContactImpulses
from ..roughness.cone import Cone
from ..roughness.slopes import GaussianTiltDensity, IsotropicSlopes
from .compiled import CONE, GRADED_CONE, GRADED_SLOPES, SLOPES
from .compiled.codes import NEED_TABLE, NOT_PEAKED, SETTLED
from .integrand import AveragingSpec, general_facets

__all__ = ["level_plan", "one_velocity", "adaptive", "graded", "FIRST_LEVELS", "NO_BACKEND", "Outcome"]

#: Levels whose nodes a first call of a tilt density's backends gets (n … 8n: the 8 … 64 nodes a piece of a
#: typical single impact); a velocity that needs more is run again with every level up to ``max_nodes``.
FIRST_LEVELS = 4

#: The status of a case no compiled backend takes (a measure, shape or level count it does not treat): the
#: rule runs its numpy form.
NO_BACKEND = -1

#: What a backend returns: its status, and the impulses where it is SETTLED.
Outcome = tuple[int, ContactImpulses | None]

_NONE: Outcome = (NO_BACKEND, None)


def level_plan(spec: AveragingSpec) -> tuple[int, int]:
    """The levels :func:`mbimpact.averaging.refinement.refine` may run for ``spec``: n, 2n, …, 2^(L−1) n
    nodes a piece, every one within ``max_nodes`` (n is halved when the first pair would pass it).

    Returns
    -------
    (n, L) : (int, int)
        The first level's node count and the number of levels (≥ 2 unless max_nodes = 1).
    """
    nodes = spec.roughness.initial_nodes
    if 2 * nodes > spec.max_nodes:  # the first pair must stay within max_nodes
        nodes = max(1, spec.max_nodes // 2)
    levels = 1
    while nodes << levels <= spec.max_nodes:
        levels += 1
    return nodes, levels


def one_velocity(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
    """Whether a compiled backend may take this case: one spatial or planar velocity, Newton facets, no
    fixed node count."""
    return len(U) == 1 and spec.nodes is None and not general_facets(spec) and W.shape[0] == U.shape[1]


# ---------------------------------------------------------------------- the adaptive rule
def adaptive(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> Outcome:
    """The adaptive rule for one velocity on a :class:`~mbimpact.Cone` or an
    :class:`~mbimpact.IsotropicSlopes` measure, compiled (``one_velocity`` holds)."""
    rough = spec.roughness
    if isinstance(rough, Cone) and rough.alpha > 0.0 and W.shape == (3, 3):
        return _cone_adaptive(spec, W, U)
    if isinstance(rough, IsotropicSlopes):
        return _slopes_adaptive(spec, W, U)
    return _NONE


def _cone_adaptive(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> Outcome:
    n, levels = level_plan(spec)
    if levels < 2:  # max_nodes = 1: refine() computes the pair (1, 2) anyway, and warns
        return _NONE
    kernels = CONE.get()
    P, err = np.empty((1, 3)), np.empty(1)  # written by the kernel (cheaper than arrays it returns)
    status, nodes = kernels.cone_adaptive(spec.roughness.alpha, W, U, kernels.rule_table(n, levels), levels,  # type: ignore[attr-defined]
                                          spec.flux == "configuration", spec.e, spec.rtol, DEGENERATE, P, err)
    return status, (ContactImpulses(P, err, nodes, "adaptive[compiled]") if status == SETTLED else None)


@functools.lru_cache(maxsize=32)
def _slope_table(n0: int, count: int) -> NDArray[np.float64]:
    """The nodes of ``count`` levels from n0 nodes a piece (read-only, shared)."""
    table: NDArray[np.float64] = SLOPES.get().level_table(n0, count)
    return table


#: What every call on one spec passes to the slopes kernel: d, n0, the levels the adaptive rule may reach
#: and those of a first call, lo, hi, the kind of density, σ, whether it is the spatial slope density,
#: the density's mass, e, whether the flux is "configuration", rtol, max_nodes.
_Setup = tuple[int, int, int, int, float, float, int, float, bool, float, float, bool, float, int]


@functools.lru_cache(maxsize=64)
def _slope_setup(spec: AveragingSpec) -> _Setup:
    """The slopes kernel's arguments that depend on the spec alone (a spec is compared by identity, and
    immutable)."""
    rough = spec.roughness
    assert isinstance(rough, IsotropicSlopes)
    kernels = SLOPES.get()
    n0, levels = level_plan(spec)
    levels = max(levels, 2)  # the first pair always (as refine computes it)
    pdf = rough.pdf
    lo, hi = rough.support
    # the Gaussian slope density in closed form inside the kernel (not a subclass: it may differ)
    if type(pdf) is GaussianTiltDensity:
        kind, sigma, radial = kernels.GAUSSIAN, float(pdf.sigma), pdf.dim == 3
    else:
        kind, sigma, radial = kernels.TABULATED, 1.0, False
    return (int(rough.dim), n0, levels, min(levels, FIRST_LEVELS), float(lo), float(hi), kind, sigma, radial,
            float(rough.mass), float(spec.e), spec.flux == "configuration", float(spec.rtol), int(spec.max_nodes))


def _slopes_adaptive(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> Outcome:
    rough = spec.roughness
    assert isinstance(rough, IsotropicSlopes)
    d, n0, levels, count, lo, hi, kind, sigma, radial, mass, e, configuration, rtol, max_nodes = _slope_setup(spec)
    if U.shape[1] != d:
        return _NONE
    kernels = SLOPES.get()
    U, W = kernel_array(U), kernel_array(W)
    P, state, start = np.empty((1, d)), np.empty(2), -1  # state: the last level compared, its error
    while True:
        table = _slope_table(n0, count)
        if kind == kernels.TABULATED:  # the callable at every tilt node of the table's levels, in one call
            tilts = kernels.tilt_nodes(U, lo, hi, table, n0)
            density = kernel_array(np.asarray(rough.density(tilts), dtype=np.float64))
            if density.shape != (2 * table.shape[1],):
                return _NONE
        else:  # read, not used
            density = np.zeros(2 * table.shape[1])
        status = kernels.slope_adaptive(U, W, table, n0, density, kind, lo, hi, sigma, radial, mass, e,
                                        configuration, rtol, max_nodes, DEGENERATE, P, state, start)
        if status != NEED_TABLE or count == levels:
            break
        count, start = levels, int(state[0])  # every level up to max_nodes; on from where it stopped
    if status != SETTLED:
        return status, None
    return status, ContactImpulses(P, state[1:], n0 << int(state[0]), "adaptive[compiled]")


# ---------------------------------------------------------------------- the graded rule
def graded(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64], peaked: float) -> Outcome:
    """The graded rule for one spatial velocity on a :class:`~mbimpact.Cone` or a spatial
    :class:`~mbimpact.IsotropicSlopes` measure, compiled (``one_velocity`` holds); NOT_PEAKED where
    the kernels have no peak narrower than ``peaked`` (the rule declines), :data:`NO_BACKEND` for
    another measure or a planar contact."""
    rough = spec.roughness
    if W.shape != (3, 3):
        return _NONE
    if isinstance(rough, Cone) and rough.alpha > 0.0:
        return _cone_graded(spec, W, U, peaked)
    if isinstance(rough, IsotropicSlopes) and rough.dim == 3:
        return _slopes_graded(spec, W, U, peaked)
    return _NONE


def _cone_graded(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64], peaked: float) -> Outcome:
    n, levels = level_plan(spec)
    if levels < 2:  # max_nodes = 1: refine() computes the pair (1, 2) anyway, and warns
        return _NONE
    kernels = GRADED_CONE.get()
    P, err = np.empty((1, 3)), np.empty(1)  # written by the kernel
    status, nodes = kernels.graded_cone(spec.roughness.alpha, W, U, kernels.rule_table(n, levels), levels,  # type: ignore[attr-defined]
                                        peaked, spec.flux == "configuration", spec.e, spec.rtol, DEGENERATE, P, err)
    return status, (ContactImpulses(P, err, nodes, "graded[compiled]") if status == SETTLED else None)


def _tilts(rough: IsotropicSlopes, U: NDArray[np.float64], peaks: tuple[NDArray[np.float64], NDArray[np.float64]],
           table: NDArray[np.float64], n: int, count: int
           ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]] | None:
    """The graded tilt nodes of ``count`` levels (n, 2n, … nodes a piece) as the measure's graded rule
    forms them (those of positive dα; :func:`mbimpact.averaging.compiled.graded_slopes.tilt_nodes`), their
    weights p(α) dα (the measure's density in one call), and where each level starts; None for a
    density of another shape.

    Returns
    -------
    tilt, pd : ndarray, shape (L,)
    start : ndarray of int, shape (count + 1,)
    """
    lo, hi = rough.support
    size = 10 * n * ((1 << count) - 1)  # graded_tilt_rule's 2h + 4 = 10 half-pieces a level
    tilt, dtilt, start = np.empty(size), np.empty(size), np.empty(count + 1, dtype=np.int64)
    at, et = (np.ascontiguousarray(p[0], dtype=np.float64) for p in peaks)
    total = GRADED_SLOPES.get().tilt_nodes(float(lo), float(hi), float(incidence_split(U)[0]), at, et, table, n,
                                           count, tilt, dtilt, start)
    tilt = tilt[:total]
    density = np.asarray(rough.density(tilt), dtype=np.float64)
    if density.shape != tilt.shape:
        return None
    return tilt, kernel_array(density * dtilt[:total]), start


def _slopes_graded(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64], peaked: float) -> Outcome:
    rough = spec.roughness
    assert isinstance(rough, IsotropicSlopes)
    peaks = peak_tilts(W, U, peaked)
    # the measure's graded_rule test (its first two columns do not depend on U)
    if not np.isfinite(peaks[1][0, :2]).any():
        return NOT_PEAKED, None
    n, levels = level_plan(spec)
    if levels < 2:
        return _NONE
    kernels = GRADED_SLOPES.get()
    W, U = kernel_array(W), kernel_array(U)
    table = kernels.rule_table(n, levels)
    P, err = np.empty((1, 3)), np.empty(1)  # written by the kernel
    count = min(levels, FIRST_LEVELS)
    while True:
        tilts = _tilts(rough, U, peaks, table, n, count)
        if tilts is None:
            return _NONE
        tilt, pd, start = tilts
        status, nodes = kernels.graded_slopes(W, U, tilt, pd, start, table, n, levels, spec.flux == "configuration",
                                              spec.e, spec.rtol, DEGENERATE, P, err)
        if status != NEED_TABLE or count == levels:
            break
        count = levels  # every level max_nodes allows, from the start (the first levels cost little)
    return status, (ContactImpulses(P, err, nodes, "graded[compiled]") if status == SETTLED else None)

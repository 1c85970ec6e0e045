"""Quadrature rules refined to an accuracy: fixed, adaptive, and graded for a nearly singular W.

The measure's rule (:meth:`mbimpact.Roughness.rule_batch`) follows the facing set G*
exactly, so it converges geometrically in the node count in every regime. A
nearly singular Delassus matrix (an arm near a singular posture) makes the kernels
of (2.8) peak with width ε ≪ 1 where mᵀWm is smallest; the plain rule then needs
≫ 1/ε nodes, and the graded rule (:meth:`mbimpact.Roughness.graded_rule`, sinh maps
towards the peaks) restores geometric convergence.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import EPS
from ..errors import AccuracyWarning, warn
from ..metric.delassus import eigen_ratio, spread_bound
from ..quadrature.graded import minima_sensitivity, ring_minima
from ..results.impact import ContactImpulses
from ..roughness.base import Rule
from ..roughness.cone import Cone
from . import backends
from .base import SKIP, Averaging
from .compiled import GRADED_CONE
from .compiled.codes import ADAPTIVE_STEP, GRADED_STEP, PASSES_ON, SETTLED
from . import integrand
from .integrand import AveragingSpec, in_blocks, relative_change, rule_average

__all__ = ["Fixed", "Adaptive", "Graded", "peaked_rule", "refine", "rounding_floor"]


class Fixed(Averaging):
    """The measure's rule with ``nodes`` nodes; the error estimate compares with ``nodes // 2``.
    Chosen by ``"auto"`` when ``RoughLaw(nodes=...)`` is given."""

    name: ClassVar[str] = "fixed"
    any_facet: ClassVar[bool] = True

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        return spec.nodes is not None

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        return fixed(spec, W, U, None, self.name)

    def cone_step(self, spec: AveragingSpec) -> int | None:
        return SKIP if spec.nodes is None else None


class Adaptive(Averaging):
    """The measure's rule, node count doubled on the rows that have not converged to ``rtol``
    (or to the rounding floor 100 ε √K of a K-facet sum); an :class:`AccuracyWarning` says
    when ``max_nodes`` or rounding amplified by |W||P|/|WP| stopped it short.

    One velocity with Newton facets on a :class:`~mbimpact.Cone` or an
    :class:`~mbimpact.IsotropicSlopes` measure runs every level in one compiled call
    (:func:`mbimpact.averaging.backends.adaptive`, ``method == "adaptive[compiled]"``); what that does
    not settle (a facet the mechanism cannot push, rounding or ``max_nodes`` short of rtol) runs here."""

    name: ClassVar[str] = "adaptive"
    any_facet: ClassVar[bool] = True

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        return spec.nodes is None

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        if backends.one_velocity(spec, W, U):
            status, out = backends.adaptive(spec, W, U)
            if status == SETTLED and out is not None:
                return out
        return self.reference(spec, W, U)

    def reference(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        """The rule in numpy, for any rows and facet law: the reference its compiled backend agrees with."""
        return refine(spec, W, U, None, min(len(U), integrand.BLOCK_ROWS), self.name)

    def cone_step(self, spec: AveragingSpec) -> int | None:
        return ADAPTIVE_STEP


class Graded(Averaging):
    """The measure's rule graded towards the peaks of the kernels of (2.8), for a nearly
    singular W; fixed (``nodes`` per piece) or adaptive like the plain rule. On a
    :class:`~mbimpact.Cone`, the adaptive rule's error estimate also holds the rounding of
    q = mᵀWm at the ring's minima (:func:`~mbimpact.quadrature.graded.minima_sensitivity`) and
    that of P (:func:`rounding_floor`): successive levels agree while both are off by as much.

    One velocity with Newton facets on a :class:`~mbimpact.Cone` or a spatial
    :class:`~mbimpact.IsotropicSlopes` measure runs every level in one compiled call
    (:func:`mbimpact.averaging.backends.graded`, ``method == "graded[compiled]"``): the same minima,
    pieces, nodes, error estimate and stopping rule; what it does not settle runs here.

    Attributes
    ----------
    peaked : float
        ``"auto"`` grades when a peak is narrower than this (radians).
    """

    name: ClassVar[str] = "graded"
    any_facet: ClassVar[bool] = True
    peaked: ClassVar[float] = 0.15

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        if isinstance(spec.roughness, Cone) and backends.one_velocity(spec, W, U):
            return peaked_ring(spec, W, self.peaked)
        return peaked_rule(spec, W, self.peaked, screen=True) is not None

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        if backends.one_velocity(spec, W, U):
            status, out = backends.graded(spec, W, U, self.peaked)
            if status == SETTLED and out is not None:
                return out
            if status in PASSES_ON[GRADED_STEP]:  # no narrow peak: the rule declines
                return None
        return self.reference(spec, W, U)

    def reference(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        """The rule in numpy, for any rows and facet law (None where the measure has no graded rule for W):
        the reference its compiled backends agree with."""
        rule = peaked_rule(spec, W, self.peaked, screen=False)
        if rule is None:
            return None
        if spec.nodes is not None:
            return fixed(spec, W, U, rule, self.name)
        sensitivity = None
        rough = spec.roughness
        if isinstance(rough, Cone) and W.shape == (3, 3):  # the rounding of q at the ring's minima (its peaks)
            sensitivity = minima_sensitivity(rough.alpha, W, ring_minima(rough.alpha, W)[0],
                                             1.0 if spec.flux == "configuration" else 0.5)
        return refine(spec, W, U, rule, rough.graded_rows or min(len(U), integrand.BLOCK_ROWS), self.name,
                      sensitivity)

    def reason(self, spec: AveragingSpec) -> str:
        return f"{spec.roughness!r} has no graded rule for this W (its kernels have no narrow peak)"

    def cone_step(self, spec: AveragingSpec) -> int | None:
        return GRADED_STEP


def screened(W: NDArray[np.float64], peaked: float) -> bool:
    """Whether the closed-form screens of W leave a peak narrower than ``peaked`` possible: q_min ≥ λ_min
    and q'' ≤ 8 λ_max on a ring, so every peak width sqrt(2 q_min / q'') is ≥ sqrt(λ_min / 4 λ_max). They
    rule out only what the measures' own peak tests rule out."""
    if W.shape == (2, 2):  # det / tr² ≤ λ₁ / λ₂, the square of the width of the peak
        return spread_bound(W) <= peaked**2
    # λ_min / λ_max ≥ 4 det W / tr(W)³ (the other two eigenvalues multiply to at most (tr W / 2)²):
    # the cheaper bound rules out most W before the closed-form eigenvalues are needed
    return W.shape == (3, 3) and spread_bound(W) <= peaked**2 and eigen_ratio(W) <= 4 * peaked**2


def peaked_ring(spec: AveragingSpec, W: NDArray[np.float64], peaked: float) -> bool:
    """Whether the kernels of a cone peak on its ring narrower than ``peaked`` (:meth:`mbimpact.Cone.graded_rule`'s
    test, compiled: numpy's search for the minima of q costs more than the whole compiled rule), after the
    closed-form screens (:func:`screened`)."""
    if W.shape != (3, 3) or not screened(W, peaked):
        return False
    return bool(GRADED_CONE.get().ring_peaks(spec.roughness.alpha, W, peaked) > 0)  # type: ignore[attr-defined]


def peaked_rule(spec: AveragingSpec, W: NDArray[np.float64], peaked: float, screen: bool) -> Rule | None:
    """The measure's graded rule for W, or None; with ``screen``, a W that :func:`screened` rules out
    gets None without the measure's test."""
    if screen and not screened(W, peaked):
        return None
    return spec.roughness.graded_rule(W, peaked)


def fixed(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64], rule: Rule | None, method: str
          ) -> ContactImpulses:
    """``spec.nodes`` nodes (the estimate compares with half as many)."""
    nodes = spec.nodes
    assert nodes is not None

    def block(rows: NDArray[np.float64]) -> ContactImpulses:
        (P, coarse), _ = rule_average(spec, W, rows, (nodes, max(1, nodes // 2)), rule)
        return ContactImpulses(P, relative_change(P, coarse, W), nodes, method)

    return in_blocks(block, U)


def refine(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64], rule: Rule | None, rows: int,
           method: str, sensitivity: float | None = None) -> ContactImpulses:
    """Adaptive refinement, ``rows`` rows at a time; one :class:`AccuracyWarning` if rounding
    or ``max_nodes`` stopped some row short of ``rtol``.

    With a ``sensitivity`` (the graded rule of a ring: :func:`~mbimpact.quadrature.graded.minima_sensitivity`),
    the error estimates also hold what successive levels cannot see: that bound and each row's
    :func:`rounding_floor`. No level reduces them; where they exceed rtol the estimate says so, as it
    says where two levels agree to the rounding floor 100 ε √K above rtol (neither warns).
    """
    P, err = np.empty_like(U), np.empty(len(U))
    nodes, limited, capped = 0, False, False
    for start in range(0, len(U), rows):
        block = slice(start, start + rows)
        P[block], err[block], nodes_b, limited_b, capped_b = _refine_block(spec, W, U[block], rule)
        nodes, limited, capped = max(nodes, nodes_b), limited or limited_b, capped or capped_b
    if capped:
        warn(AccuracyWarning, f"{spec!r}: quadrature reached {nodes} nodes with estimated relative error "
                              f"{err.max():.3g} > rtol={spec.rtol:g}")
    elif limited:
        warn(AccuracyWarning, f"{spec!r}: converged to rounding at relative error {err.max():.3g} > rtol={spec.rtol:g}; "
                              "W nearly annihilates the impulse (an ill-conditioned contact), so rtol is out of reach")
    if sensitivity is not None:
        err = np.maximum(err, np.maximum(rounding_floor(P, W), sensitivity))
    return ContactImpulses(P, err, nodes, method)


def rounding_floor(P: NDArray[np.float64], W: NDArray[np.float64]) -> NDArray[np.float64]:
    """ε tr(W) |P| / |W P| for each row of P (B, d): the relative error by W P (the measure of every
    error estimate here) that P's own rounding, ε |P|, can make where W nearly annihilates P. No rule
    computed in float64 certifies less."""
    WP = P @ W
    with np.errstate(divide="ignore", invalid="ignore"):
        floor = EPS * float(np.trace(W)) * np.sqrt(np.einsum("bd,bd->b", P, P) / np.einsum("bd,bd->b", WP, WP))
    return np.where(np.isnan(floor), np.inf, floor)


def _refine_block(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64], rule: Rule | None
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], int, bool, bool]:
    """:func:`refine` on one block of rows: impulses, error estimates, final node count, and
    whether rounding (``limited``) or ``max_nodes`` (``capped``) ended the refinement."""
    nodes = backends.level_plan(spec)[0]
    (P, fine), (_, facets) = rule_average(spec, W, U, (nodes, 2 * nodes), rule)
    err = np.full(len(U), np.inf)
    todo = np.arange(len(U))
    first, limited = True, False
    scale_W = float(np.trace(W))  # ≥ |W|₂ for W ⪰ 0
    while True:
        nodes *= 2
        if not first:
            (fine,), (facets,) = rule_average(spec, W, U[todo], (nodes,), rule)
        first = False
        previous = err[todo]
        err[todo] = relative_change(fine, P[todo], W)
        P[todo] = fine
        # two results that differ only by rounding (≈ ε √K for K facets) have converged;
        # so have results that stopped improving at that level amplified by |W| |P| / |W P|
        # (W nearly annihilates P: an ill-conditioned contact)
        floor = 100 * EPS * np.sqrt(facets)
        unconverged = err[todo] > max(spec.rtol, floor)
        if not unconverged.any():
            todo = todo[:0]
        else:
            amplification = scale_W * np.sqrt(np.einsum("bd,bd->b", fine, fine) / np.einsum("bd,bd->b", fine @ W, fine @ W))
            stalled = unconverged & (err[todo] <= floor * amplification) & (err[todo] > 0.1 * previous)
            limited = limited or bool(stalled.any())
            todo = todo[unconverged & ~stalled]
        if todo.size == 0:
            return P, err, nodes, limited, False
        if nodes * 2 > spec.max_nodes:
            return P, err, nodes, limited, True

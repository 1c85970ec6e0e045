"""The integrand of (2.8), written once: facet weights (2.7), Newton facet impulses, their quotient.

With a facet normal m, its share p of the measure, a unit contact velocity u and the
Delassus matrix W (local frame), a facet of G* = {mᵀu < 0} weighs

    w = p (−mᵀu)            flux = "physical": the rate at which the contact point sweeps it,
    w = p (−mᵀu) / √(mᵀWm)   flux = "configuration": the A-metric flux (N_m, v) of (2.7),

and its Newton impact has the contact impulse −(1+e) (mᵀu / mᵀWm) m, so that

    P = (1+e) N / D,   N = Σ w (−mᵀu / mᵀWm) m,   D = Σ w.

Written with the kernel powers (γ, δ) = (1, 0) (physical) or (3/2, 1/2)
(configuration): N = Σ p (mᵀu)² m / (mᵀWm)^γ and D = Σ p (−mᵀu) / (mᵀWm)^δ — the
form the closed-form averages (ring expansion, tilt tables) integrate.

Other facet laws (:mod:`mbimpact.facets`: Coulomb, compliant, Hunt–Crossley facets) keep
the weights and replace the Newton impulse by the facet law's own, P_i = facet.impulse(m_i, W, u):

    P = Σ w P_i / Σ w                                    (:func:`facet_impulses`),

which only the quadrature methods (exact, fixed, adaptive, graded, monte-carlo) evaluate.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import DEGENERATE
from ..errors import NoFacingFacetError, ParameterError
from ..results.impact import ContactImpulses

if TYPE_CHECKING:
    from ..facets.base import FacetLaw
    from ..roughness.base import Roughness, Rule

__all__ = ["BLOCK_ROWS", "in_blocks", "Flux", "FLUXES", "check_flux", "kernel_powers", "AveragingSpec", "facet_terms", "facet_impulses",
           "general_facets", "rule_average", "relative_change", "quotient", "check_facing"]

#: Rows a rule works on at a time where it keeps work arrays of (rows × nodes) (exact sums, quadratures,
#: tables): they stay in cache, and a batch of any size in bounded memory.
BLOCK_ROWS = 2048


def in_blocks(average: Callable[[NDArray[np.float64]], ContactImpulses], U: NDArray[np.float64]
              ) -> ContactImpulses:
    """``average(U)`` on blocks of :data:`BLOCK_ROWS` rows at a time, the results joined (the node count
    the largest, the methods joined by "+")."""
    rows = BLOCK_ROWS
    if len(U) <= rows:
        return average(U)
    P, error, nodes, methods = np.empty_like(U), np.empty(len(U)), 0, []
    for start in range(0, len(U), rows):
        block = slice(start, start + rows)
        out = average(U[block])
        P[block], error[block], nodes = out.P, out.error, max(nodes, out.nodes)
        if out.method not in methods:
            methods.append(out.method)
    return ContactImpulses(P, error, nodes, "+".join(sorted(methods)))


#: The weight of a facet in (2.7) (:class:`mbimpact.RoughLaw`).
Flux = Literal["physical", "configuration"]
FLUXES: tuple[Flux, ...] = ("physical", "configuration")


def check_flux(flux: object) -> Flux:
    """``flux`` if it names a facet weight, else a :class:`ParameterError` saying what is valid."""
    # a str first: ``in`` compares with ==, which on an array is elementwise (an ambiguous truth value)
    if not isinstance(flux, str) or flux not in FLUXES:
        raise ParameterError(
            f"flux must be 'physical' (the contact point's sweep rate, default) or 'configuration' "
            f"(the A-metric flux, for a measure on configuration-space area), got {flux!r}"
        )
    return flux


def kernel_powers(flux: Flux) -> tuple[float, float]:
    """(γ, δ): N = Σ p (mᵀu)² m / (mᵀWm)^γ, D = Σ p (−mᵀu) / (mᵀWm)^δ."""
    return (1.0, 0.0) if flux == "physical" else (1.5, 0.5)


@dataclass(frozen=True, eq=False)
class AveragingSpec:
    """What an averaging method needs: the measure, the integrand and the accuracy asked for.

    Attributes
    ----------
    roughness : Roughness
        The facet measure.
    e : float
        Facet restitution (of Newton facets; the normal restitution of another facet law).
    flux : {"physical", "configuration"}
        The facet weight of (2.7).
    rtol : float
        Relative accuracy of refinable rules.
    nodes : int or None
        A fixed node count (per piece of a rule), or None for adaptive refinement.
    max_nodes : int
        Node count at which refinement stops.
    samples, seed : int
        Monte Carlo sample count and seed.
    facet : FacetLaw or None
        The facet law (:mod:`mbimpact.facets`); None, or a law with a ``newton_restitution``,
        means Newton facets with restitution ``e``, the integrand of the closed-form averages.
    """

    roughness: Roughness
    e: float
    flux: Flux
    rtol: float
    nodes: int | None
    max_nodes: int
    samples: int
    seed: int
    facet: FacetLaw | None = None

    def __repr__(self) -> str:
        if general_facets(self):
            return f"RoughLaw({self.roughness!r}, facet={self.facet!r})"
        return f"RoughLaw({self.roughness!r}, e={self.e:g})"


def general_facets(spec: AveragingSpec) -> bool:
    """Whether the spec's facet law is not Newton's, so that only the quadrature methods apply."""
    return spec.facet is not None and spec.facet.newton_restitution is None


def facet_impulses(spec: AveragingSpec, m: NDArray[np.float64], W: NDArray[np.float64], U: NDArray[np.float64],
                   w: NDArray[np.float64]) -> NDArray[np.float64]:
    """Impulses P_i (B, K, d) of the facet law on every facet with weight w > 0 (zero elsewhere).

    ``m`` is (K, d) or (B, K, d) as in :func:`facet_terms`, ``w`` (B, K) its weights; the facet law
    is called once on the facing (row, facet) pairs, :meth:`mbimpact.facets.FacetLaw.impulse`.
    """
    assert spec.facet is not None
    B, K = w.shape
    d = U.shape[1]
    out = np.zeros((B, K, d))
    rows, cols = np.nonzero(w > 0.0)
    if rows.size:
        normals = m[cols] if m.ndim == 2 else m[rows, cols]
        out[rows, cols] = spec.facet.impulse(normals, W, U[rows])
    return out


def facet_terms(spec: AveragingSpec, m: NDArray[np.float64], p: NDArray[np.float64], W: NDArray[np.float64],
                U: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Weights w (B, K) and impulse coefficients c = −mᵀu / mᵀWm (B, K) of facets m.

    ``m`` is (K, d), shared by every row, or (B, K, d); ``p`` broadcasts against (B, K).
    Facets outside G*, or that the mechanism cannot push (mᵀWm ≤ DEGENERATE tr W), get w = 0.
    """
    if m.ndim == 2:  # shared facets: mᵀWm once
        s = U @ m.T
        q = np.broadcast_to(np.einsum("kd,de,ke->k", m, W, m), s.shape)
    else:
        s = (m @ U[:, :, None])[..., 0]
        q = np.einsum("bkd,bkd->bk", m @ W, m)  # (m W)·m: much faster than a 3-operand einsum
    facing = (s < 0.0) & (q > DEGENERATE * np.trace(W)) & (p > 0.0)
    safe_q = np.where(facing, q, 1.0)
    flux = np.where(facing, -s / np.sqrt(safe_q) if spec.flux == "configuration" else -s, 0.0)
    return p * flux, np.where(facing, -s / safe_q, 0.0)


def rule_average(spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64], levels: tuple[int, ...],
                 rule: Rule | None = None) -> tuple[list[NDArray[np.float64]], list[int]]:
    """(2.8) by a quadrature rule at several node counts in one pass over their concatenated nodes
    (the per-call cost of a single impact is mostly the number of array operations).

    Returns the contact impulses (B, d) per level, local frame, and the facet count of each level.
    ``rule(U, nodes)`` defaults to the measure's own :meth:`~mbimpact.Roughness.rule_batch`.
    """
    rule = rule or spec.roughness.rule_batch
    rules = [rule(U, n) for n in levels]
    sizes = [p.shape[-1] for _, p in rules]
    if len(rules) == 1:
        m, p = rules[0]
    elif all(m.ndim == 2 for m, _ in rules):
        m, p = np.concatenate([r[0] for r in rules]), np.concatenate([r[1] for r in rules])
    else:
        B, d = U.shape
        m = np.concatenate([r[0] if r[0].ndim == 3 else np.broadcast_to(r[0], (B, k, d))
                            for r, k in zip(rules, sizes)], axis=1)
        p = np.concatenate([r[1] if r[1].ndim == 2 else np.broadcast_to(r[1], (B, k))
                            for r, k in zip(rules, sizes)], axis=1)
    w, c = facet_terms(spec, m, p, W, U)
    if general_facets(spec):
        wP = w[:, :, None] * facet_impulses(spec, m, W, U, w)
        out, start = [], 0
        for k in sizes:
            part = slice(start, start + k)
            start += k
            total = w[:, part].sum(axis=1)
            check_facing(spec, total, U)
            # sum along a contiguous last axis (pairwise rounding, as for Newton facets below)
            out.append(np.ascontiguousarray(np.moveaxis(wP[:, part], 1, 2)).sum(axis=2) / total[:, None])
        return out, sizes
    wc = w * c
    out = []
    start = 0
    for k in sizes:
        part = slice(start, start + k)
        start += k
        total = w[:, part].sum(axis=1)
        check_facing(spec, total, U)
        if m.ndim == 2:
            num = wc[:, part] @ m[part]
        else:
            # a product rule sums up to ~10⁶ facets a row: reduce along a contiguous last axis,
            # which numpy sums pairwise (rounding ~ε log K, not ~ε K, then amplified by |W||P|/|WP|)
            num = np.multiply(wc[:, None, part], np.moveaxis(m[:, part], 2, 1), order="C").sum(axis=2)
        out.append((1.0 + spec.e) * num / total[:, None])
    return out, sizes


def relative_change(fine: NDArray[np.float64], coarse: NDArray[np.float64], W: NDArray[np.float64]) -> NDArray[np.float64]:
    """Row-wise relative difference of two impulse estimates, measured by the contact-velocity
    change Δu = W P they produce: with a rank-deficient J, P is only defined up to the null
    space of Jᵀ (= that of W), while Δu is always well defined."""
    diff, ref = (fine - coarse) @ W, fine @ W
    return np.sqrt(np.einsum("bd,bd->b", diff, diff) / np.einsum("bd,bd->b", ref, ref))


def quotient(spec: AveragingSpec, N: NDArray[np.float64], D: NDArray[np.float64], U: NDArray[np.float64]
             ) -> NDArray[np.float64]:
    """P = (1+e) N / D from the two integrals, N (B, d) and D (B,), of a closed-form average."""
    check_facing(spec, D, U)
    return (1.0 + spec.e) * N / D[:, None]


def check_facing(spec: AveragingSpec, total: NDArray[np.float64], U: NDArray[np.float64]) -> None:
    """A :class:`NoFacingFacetError` for the first row whose G* is empty (total weight 0)."""
    empty = np.flatnonzero(~(total > 0.0))
    if empty.size:
        raise NoFacingFacetError(
            f"no facet of {spec.roughness!r} faces the contact velocity {U[empty[0]].tolist()} "
            "(local frame, unit): the set G* of (2.7) is empty"
        )

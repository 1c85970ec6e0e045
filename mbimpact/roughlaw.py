"""Ivanov's rough-surface law (2.8): the flux-weighted average of facet impacts."""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ._validate import as_scalar
from .cone_pair import cone_pair
from .errors import NoFacingFacetError, ParameterError, RoughnessError
from .laws import (
    _DEGENERATE,
    ImpactLaw,
    _relative_change,
    _restitution,
    warn_accuracy,
)
from .metric import eigen_ratio, spread_bound
from .result import SEPARATION_RTOL
from .ring import ring_expansion
from .roughness import Cone, Roughness, Rule
from .slopes import IsotropicSlopes
from .tilt_table import tilt_table

__all__ = ["RoughLaw"]

# From this many rows on, a Cone is averaged by its ring expansion at fixed W
# (mbimpact.ring): a one-off FFT, then O(degree) work per truncated row.
_RING_ROWS = 32
# From this many rows on, a spatial isotropic tilt density is averaged by its table in the
# incidence at fixed W (mbimpact.tilt_table): 0.1–3 s to build, then µs per row.
_TABLE_ROWS = 1024
_EPS = float(np.finfo(float).eps)
# Rows per adaptive pass of a graded tilt × azimuth rule (memory: ~10⁸ bytes per row at 128 nodes).
_GRADED_SLOPE_ROWS = 4
# A Cone's rule is graded towards the peaks of 1/mᵀWm when they are narrower than this (radians).
_PEAKED = 0.15
# repeat=True: at most this many applications of (2.8); a direction that comes back to within
# this (1 − cos) after one or two impacts, with a shrinking speed, has settled: the contact stops.
_MAX_REPEATS = 2000
_SETTLED = 1e-12
_SEPARATION = SEPARATION_RTOL


class RoughLaw(ImpactLaw):
    """Ivanov's constructive impact on a rough surface, (2.8).

    The velocity jump is the flux-weighted average of the Newton impacts on the
    facets that face the velocity,

        Δv = −(1+e) ∫_{G*} (N, v₋)² N dP / ∫_{G*} (N, v₋) dP,

    computed in contact space as P = −(1+e) Σ wᵢ (mᵢᵀu / mᵢᵀWmᵢ) mᵢ with
    wᵢ ∝ pᵢ · flux(mᵢ) on G* = {mᵢᵀu < 0}.

    Parameters
    ----------
    roughness : Roughness
        Facet-normal measure (:class:`Smooth`, :class:`Sawtooth`, :class:`Cone`,
        :class:`Facets`, :class:`GaussianSlopes`, :class:`Profile`, ...).
    e : float, optional
        Facet restitution in [0, 1].
    k : float, optional
        Kelvin–Voigt damping ratio in [0, 1] instead of ``e``; exactly one.
    flux : {"physical", "configuration"}
        Weight of a facet in (2.7). ``"physical"`` (default): pᵢ (−mᵢᵀu), the rate
        at which the contact point, moving along u = J v, sweeps facet i of a
        physical surface whose measure P is a share of true physical area — what
        (2.7) becomes when P is moved into configuration space, where a physical
        facet's A-metric area is its physical area times √(mᵀWm).
        ``"configuration"``: pᵢ (−(N_i, v)) = pᵢ (−mᵢᵀu)/√(mᵢᵀWmᵢ), the paper's
        (2.7) read literally, valid only when the roughness measure is defined on
        configuration-space area (e.g. J = I). The two coincide when W ∝ I (a
        point mass).
    method : {"quadrature", "mc"}
        "quadrature" (default) uses the measure's rule with G* handled exactly;
        "mc" averages over ``samples`` facets drawn from P with ``seed`` (the naive
        baseline), and reports its standard error as ``error_estimate``.
    rtol : float
        Relative accuracy of the adaptive quadrature for measures that are not
        finite; node counts are doubled until two successive results agree to
        ``rtol`` (or to the rounding floor 100 ε √K of a K-facet sum, if larger).
        When W nearly annihilates the impulse (|W| |P| ≫ |W P|, an ill-conditioned
        contact) the results stop improving above rtol; refinement then stops and
        an :class:`AccuracyWarning` reports the error reached.
    nodes : int, optional
        Fixed node count instead of adaptive refinement (the error estimate then
        compares with ``nodes // 2``); per piece of the graded rule (Notes).
    max_nodes : int, optional
        Node count at which refinement stops (an :class:`AccuracyWarning` is
        issued if ``rtol`` was not reached); default: the measure's ``node_limit``.
    samples, seed : int
        Monte Carlo sample count and seed (``method="mc"``).
    repeat : bool
        The model assumes one micro-impact per facet. When the averaged outcome
        still approaches the surface (κ < 0: steep facets at normal incidence, or
        an oblique impact on an anisotropic W), further micro-impacts follow. With
        ``repeat=True`` the law is applied again to the new contact velocity, with
        the same W, until the contact separates; once the velocity's direction has
        settled (a fixed direction or a two-cycle between the walls of a valley, along
        which the velocity shrinks geometrically), the limit is the impulse that stops
        the contact point, P = −W⁺ u₋. Default False: one application, and a
        :class:`NoSeparationWarning` when the contact still approaches.

    Notes
    -----
    For a nearly singular W (an arm near a singular posture) the kernels of (2.8)
    peak sharply where mᵀWm is smallest. The adaptive rule is then graded towards
    the peaks by sinh maps (:meth:`Roughness.graded_rule`): for a :class:`Cone`
    in azimuth (:func:`mbimpact.graded.graded_azimuth_rule`), converging with
    tens of nodes where a uniform rule needs 10⁵; for :class:`IsotropicSlopes` and
    :class:`GaussianSlopes` in tilt too (:func:`mbimpact.graded.graded_tilt_rule`
    towards :func:`mbimpact.graded.peak_tilts`), where the plain product rule
    is off by O(1). Such calls cost 10–150 ms per velocity (spatial).

    A single velocity on a :class:`Cone` (W not nearly singular) takes the first
    pass of the adaptive rule, 32 and 64 nodes, through :mod:`mbimpact.cone_pair`:
    the same nodes in a handful of array operations; the general route takes
    over if that pass does not settle it.

    Batches of at least 32 velocities on a :class:`Cone` (adaptive quadrature,
    ``nodes=None``) use the cone's ring expansion at the fixed W
    (:mod:`mbimpact.ring`): the two integrals of (2.8) become closed-form
    functions of the arc end points, exact to rounding, and ``nodes`` on the
    result then reports the number of Fourier terms. Kernels too peaked for a
    series of degree ≤ 1024 (nearly singular W) fall back on the quadrature.
    Batches of at least 1024 velocities on a spatial :class:`IsotropicSlopes` or
    :class:`GaussianSlopes` use a table of (2.8)
    in the incidence angle at the fixed W (:mod:`mbimpact.tilt_table`, built once
    in 0.1–3 s, then microseconds per velocity) instead of the tilt × azimuth
    product rule.
    """

    def __init__(
        self,
        roughness: Roughness,
        e: float | None = None,
        *,
        k: float | None = None,
        flux: Literal["physical", "configuration"] = "physical",
        method: Literal["quadrature", "mc"] = "quadrature",
        rtol: float = 1e-12,
        nodes: int | None = None,
        max_nodes: int | None = None,
        samples: int = 10_000,
        seed: int = 0,
        repeat: bool = False,
    ) -> None:
        if not isinstance(roughness, Roughness):
            raise RoughnessError(
                "roughness must be a Roughness measure (Smooth, Sawtooth, Cone, Facets, ...), "
                f"got {type(roughness).__name__}"
            )
        if flux not in ("physical", "configuration"):
            raise ParameterError(
                f"flux must be 'physical' (the contact point's sweep rate, default) or 'configuration' "
                f"(the A-metric flux, for a measure on configuration-space area), got {flux!r}"
            )
        if method not in ("quadrature", "mc"):
            raise ParameterError(f"method must be 'quadrature' or 'mc', got {method!r}")
        self.roughness = roughness
        self.e = _restitution(e, k)
        self.flux = flux
        self.method = method
        self.rtol = as_scalar("rtol", rtol, 0.0, 1.0)
        if nodes is not None and int(nodes) < 1:
            raise ParameterError(f"nodes must be ≥ 1, got {nodes}")
        self.nodes = None if nodes is None else int(nodes)
        max_nodes = roughness.node_limit if max_nodes is None else max_nodes
        if int(max_nodes) < max(1, roughness.initial_nodes):
            raise ParameterError(f"max_nodes must be ≥ {roughness.initial_nodes}, got {max_nodes}")
        self.max_nodes = int(max_nodes)
        if int(samples) < 2:
            raise ParameterError(f"samples must be ≥ 2, got {samples}")
        self.samples = int(samples)
        self.seed = int(seed)
        if not isinstance(repeat, bool):
            raise ParameterError(f"repeat must be True or False, got {repeat!r}")
        self.repeat = repeat
        if method == "mc":
            roughness.sample(np.random.default_rng(0), 2)  # fail now if it cannot be sampled

    def __repr__(self) -> str:
        extra = "" if self.flux == "physical" else f", flux={self.flux!r}"
        if self.method == "mc":
            extra += f", method='mc', samples={self.samples}"
        elif self.nodes is not None:
            extra += f", nodes={self.nodes}"
        if self.repeat:
            extra += ", repeat=True"
        return f"RoughLaw({self.roughness!r}, e={self.e:g}{extra})"

    @property
    def dim(self) -> int | None:
        return self.roughness.dim

    def _terms(
        self, m: NDArray[np.float64], p: NDArray[np.float64], W: NDArray[np.float64], U: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Per-facet weights w (B, K), impulse coefficients c (B, K) and normals m.

        (2.8) is then P = (1+e) Σ w c m / Σ w; facets outside G* get w = 0.
        """
        if m.ndim == 2:  # shared facets: mᵀWm once
            s = U @ m.T
            q = np.broadcast_to(np.einsum("kd,de,ke->k", m, W, m), s.shape)
        else:
            s = (m @ U[:, :, None])[..., 0]
            q = np.einsum("bkd,bkd->bk", m @ W, m)  # (m W)·m: much faster than a 3-operand einsum
        facing = (s < 0.0) & (q > _DEGENERATE * np.trace(W)) & (p > 0.0)
        safe_q = np.where(facing, q, 1.0)
        flux = np.where(facing, -s / np.sqrt(safe_q) if self.flux == "configuration" else -s, 0.0)
        return p * flux, np.where(facing, -s / safe_q, 0.0), m

    def _average(self, W: NDArray[np.float64], U: NDArray[np.float64], nodes: int, rule: Rule | None = None
                 ) -> tuple[NDArray[np.float64], int]:
        """(2.8) with the rule of ``nodes`` nodes: contact impulses (B, d), local frame, and the facet count."""
        (P,), (facets,) = self._average_levels(W, U, (nodes,), rule)
        return P, facets

    def _average_levels(
        self, W: NDArray[np.float64], U: NDArray[np.float64], levels: tuple[int, ...], rule: Rule | None = None
    ) -> tuple[list[NDArray[np.float64]], list[int]]:
        """:meth:`_average` for several node counts in one pass over their concatenated nodes
        (the per-call cost of a single impact is mostly the number of array operations).
        ``rule(U, nodes)`` defaults to the measure's own rule."""
        rule = rule or self.roughness.rule_batch
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
        w, c, m = self._terms(m, p, W, U)
        wc = w * c
        out = []
        start = 0
        for k in sizes:
            part = slice(start, start + k)
            start += k
            total = w[:, part].sum(axis=1)
            self._check_facing(total, U)
            if m.ndim == 2:
                num = wc[:, part] @ m[part]
            else:
                # a product rule sums up to ~10⁶ facets a row: reduce along a contiguous last axis,
                # which numpy sums pairwise (rounding ~ε log K, not ~ε K, then amplified by |W||P|/|WP|)
                num = np.multiply(wc[:, None, part], np.moveaxis(m[:, part], 2, 1), order="C").sum(axis=2)
            out.append((1.0 + self.e) * num / total[:, None])
        return out, sizes

    def _quotient(self, N: NDArray[np.float64], D: NDArray[np.float64], U: NDArray[np.float64], err: float,
                  nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """(2.8) as (1+e) N / D from closed-form integrals N (B, 3), D (B,) of a ring or a table."""
        self._check_facing(D, U)
        return (1.0 + self.e) * N / D[:, None], np.full(len(U), err), nodes

    def _check_facing(self, total: NDArray[np.float64], U: NDArray[np.float64]) -> None:
        empty = np.flatnonzero(~(total > 0.0))
        if empty.size:
            raise NoFacingFacetError(
                f"no facet of {self.roughness!r} faces the contact velocity {U[empty[0]].tolist()} "
                "(local frame, unit): the set G* of (2.7) is empty"
            )

    def _monte_carlo(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(2.8) as a ratio of sample means, with the delta-method standard error."""
        m = self.roughness.sample(np.random.default_rng(self.seed), self.samples)
        w, c, _ = self._terms(m, np.ones(len(m)), W, U)
        total = w.sum(axis=1)
        self._check_facing(total, U)
        a = (1.0 + self.e) * (w * c)[:, :, None] * m[None, :, :]  # (B, N, d)
        P = a.sum(axis=1) / total[:, None]
        resid = a - P[:, None, :] * w[:, :, None]
        n = self.samples
        se = np.sqrt((resid**2).sum(axis=(1, 2)) / (n - 1) / n) / (total / n)
        return P, se / np.linalg.norm(P, axis=1)

    def contact_impulses(
        self, W: NDArray[np.float64], U: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        P, err, nodes = self._once(W, U)
        if not self.repeat:
            return P, err, nodes
        return self._repeated(W, U, P, err, nodes)

    def _repeated(self, W: NDArray[np.float64], U: NDArray[np.float64], P: NDArray[np.float64],
                  err: NDArray[np.float64], nodes: int) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """Apply (2.8) again to the rows whose contact still approaches, until it separates.

        (2.8) is positively homogeneous of degree 1, so the micro-impacts either throw the
        contact off after finitely many of them, or their directions settle into a fixed
        direction or a two-cycle (bouncing between the walls of a valley) along which
        u_{k+p} = ρ u_k with ρ < 1: the velocities then shrink geometrically to u = 0, and
        the limit of the impulses is the one that stops the contact point, P = −W⁺ u₋."""
        total, err = P.copy(), err.copy()
        B, d = U.shape
        u = U + P @ W  # W is symmetric
        dirs = np.full((2, B, d), np.nan)  # the last two directions of each row, oldest first
        speeds = np.ones((2, B))
        todo = np.flatnonzero(u[:, -1] < -_SEPARATION)  # U is unit
        for _ in range(_MAX_REPEATS):
            if not todo.size:
                return total, err, nodes
            speed = np.linalg.norm(u[todo], axis=1)
            direction = u[todo] / speed[:, None]
            stuck = np.zeros(len(todo), dtype=bool)
            for period in (1, 2):
                rho = speed / speeds[2 - period, todo]
                stuck |= (np.einsum("bd,bd->b", direction, dirs[2 - period, todo]) > 1.0 - _SETTLED) & (rho < 1.0)
            if stuck.any():
                rows = todo[stuck]
                total[rows] = -np.linalg.lstsq(W, U[rows].T, rcond=1e-12)[0].T  # u₋ + W P = 0
                u[rows] = 0.0
                todo = todo[~stuck]
                speed, direction = speed[~stuck], direction[~stuck]
                if not todo.size:
                    return total, err, nodes
            Pk, err_k, nodes_k = self._once(W, direction)
            Pk *= speed[:, None]
            nodes = max(nodes, nodes_k)
            err[todo] = np.maximum(err[todo], err_k)
            total[todo] += Pk
            u[todo] += Pk @ W
            dirs[0, todo], dirs[1, todo] = dirs[1, todo], direction
            speeds[0, todo], speeds[1, todo] = speeds[1, todo], speed
            todo = todo[u[todo, -1] < -_SEPARATION]
        if todo.size:
            warn_accuracy(f"{self!r}: the contact still approaches after {_MAX_REPEATS} repeated impacts "
                          f"(n0·u = {u[todo[0], -1]:.3g} for a unit approach)")
        return total, err, nodes

    def _once(
        self, W: NDArray[np.float64], U: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """One application of (2.8) to unit local-frame velocities U (B, d)."""
        if self.method == "mc":
            P, err = self._monte_carlo(W, U)
            return P, err, self.samples
        rough = self.roughness
        if rough.exact:
            P, facets = self._average(W, U, 1)
            return P, np.zeros(len(U)), facets
        if self.nodes is None and len(U) >= _RING_ROWS and isinstance(rough, Cone) and rough.alpha > 0.0:
            ring = ring_expansion(rough.alpha, W, self.flux == "configuration")
            if ring is not None:
                # truncation plus the rounding of a sum of `degree` terms
                bound = (ring.tail + _EPS) * ring.degree
                return self._quotient(*ring.integrals(U), U, bound, 2 * ring.degree + 1)
        if self.nodes is None and isinstance(rough, IsotropicSlopes) and rough.dim == 3:
            table = tilt_table(rough, W, self.flux == "configuration", build=len(U) >= _TABLE_ROWS)
            if table is not None:
                bound = table.tail + _EPS * table.terms
                return self._quotient(*table.integrals(U), U, bound, 2 * table.degree + 1)
        rule = self._graded_rule(W)
        if rule is None and self.nodes is None and len(U) == 1 and isinstance(rough, Cone) and rough.alpha > 0.0:
            single = self._cone_single(W, U[0])
            if single is not None:
                return single
        if self.nodes is not None:
            (P, coarse), _ = self._average_levels(W, U, (self.nodes, max(1, self.nodes // 2)), rule)
            return P, _relative_change(P, coarse, W), self.nodes
        return self._adaptive(W, U, rule)

    def _cone_single(self, W: NDArray[np.float64], u: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], int] | None:
        """One velocity on a :class:`Cone`: the first pass of :meth:`_refine` (n and 2n nodes)
        in a few array operations (:func:`mbimpact.cone_pair.cone_pair`). None when that pass
        is not conclusive (or meets a degenerate facet, or no facet): the general route then."""
        n = self.roughness.initial_nodes
        if 2 * n > self.max_nodes:
            return None
        pair = cone_pair(self.roughness.alpha, W, u, n, self.flux == "configuration", _DEGENERATE)  # type: ignore[attr-defined]
        if pair is None or not pair[1].min() > 0.0:
            return None
        P = (1.0 + self.e) * pair[0] / pair[1][:, None]
        (c0, c1, c2), (f0, f1, f2) = (P @ W).tolist()
        err = math.sqrt(((f0 - c0) ** 2 + (f1 - c1) ** 2 + (f2 - c2) ** 2) / (f0 * f0 + f1 * f1 + f2 * f2))
        if not err <= max(self.rtol, 100 * _EPS * math.sqrt(2 * n)):  # the floor of _refine
            return None
        return P[1:], np.array([err]), 2 * n

    def _graded_rule(self, W: NDArray[np.float64]) -> Rule | None:
        """For a nearly singular W: the measure's rule graded towards the peaks of the
        kernels (:meth:`Roughness.graded_rule`), else None."""
        # q_min ≥ λ_min and q'' ≤ 8 λ_max on a ring, so every peak width ε = sqrt(2 q_min / q'')
        # is ≥ sqrt(λ_min / 4 λ_max): a cheap closed-form check rules out ordinary W
        if W.shape == (2, 2):  # det / tr² ≤ λ₁ / λ₂, the square of the width of the peak
            if spread_bound(W) > _PEAKED**2:
                return None
        elif W.shape != (3, 3) or eigen_ratio(W) > 4 * _PEAKED**2:
            return None
        return self.roughness.graded_rule(W, _PEAKED)

    def _adaptive(self, W: NDArray[np.float64], U: NDArray[np.float64], rule: Rule | None = None
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """Double the node count on the rows that have not converged to ``rtol``; warn once
        if rounding or ``max_nodes`` stopped some row short of it."""
        # a graded tilt × azimuth rule puts ~60 n² facets on a row (10⁶ at n = 128): a few rows at a time
        rows = _GRADED_SLOPE_ROWS if rule is not None and isinstance(self.roughness, IsotropicSlopes) else len(U)
        P, err = np.empty_like(U), np.empty(len(U))
        nodes, limited, capped = 0, False, False
        for start in range(0, len(U), rows):
            block = slice(start, start + rows)
            P[block], err[block], nodes_b, limited_b, capped_b = self._refine(W, U[block], rule)
            nodes, limited, capped = max(nodes, nodes_b), limited or limited_b, capped or capped_b
        if capped:
            warn_accuracy(f"{self!r}: quadrature reached {nodes} nodes with estimated relative error "
                          f"{err.max():.3g} > rtol={self.rtol:g}")
        elif limited:
            warn_accuracy(f"{self!r}: converged to rounding at relative error {err.max():.3g} > rtol={self.rtol:g}; "
                          "W nearly annihilates the impulse (an ill-conditioned contact), so rtol is out of reach")
        return P, err, nodes

    def _refine(self, W: NDArray[np.float64], U: NDArray[np.float64], rule: Rule | None
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], int, bool, bool]:
        """:meth:`_adaptive` on one block of rows: impulses, error estimates, final node count,
        and whether rounding (``limited``) or ``max_nodes`` (``capped``) ended the refinement."""
        nodes = self.roughness.initial_nodes
        if 2 * nodes > self.max_nodes:  # the first pair must stay within max_nodes
            nodes = max(1, self.max_nodes // 2)
        (P, fine), (_, facets) = self._average_levels(W, U, (nodes, 2 * nodes), rule)
        err = np.full(len(U), np.inf)
        todo = np.arange(len(U))
        first, limited = True, False
        scale_W = float(np.trace(W))  # ≥ |W|₂ for W ⪰ 0
        while True:
            nodes *= 2
            if not first:
                fine, facets = self._average(W, U[todo], nodes, rule)
            first = False
            previous = err[todo]
            err[todo] = _relative_change(fine, P[todo], W)
            P[todo] = fine
            # two results that differ only by rounding (≈ ε √K for K facets) have converged;
            # so have results that stopped improving at that level amplified by |W| |P| / |W P|
            # (W nearly annihilates P: an ill-conditioned contact)
            floor = 100 * _EPS * np.sqrt(facets)
            unconverged = err[todo] > max(self.rtol, floor)
            if not unconverged.any():
                todo = todo[:0]
            else:
                amplification = scale_W * np.sqrt(np.einsum("bd,bd->b", fine, fine) / np.einsum("bd,bd->b", fine @ W, fine @ W))
                stalled = unconverged & (err[todo] <= floor * amplification) & (err[todo] > 0.1 * previous)
                limited = limited or bool(stalled.any())
                todo = todo[unconverged & ~stalled]
            if todo.size == 0:
                return P, err, nodes, limited, False
            if nodes * 2 > self.max_nodes:
                return P, err, nodes, limited, True

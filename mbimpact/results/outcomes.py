"""The outcome of a rough impact as a random variable: the facet met, with the flux weights of (2.7).

A motion meets one realisation of the microrelief, one facet i of those facing it
(G* = {mᵢᵀu < 0}), with probability

    πᵢ = pᵢ (−mᵢᵀu) / Σⱼ pⱼ (−mⱼᵀu)                      (physical flux, (2.7))
    πᵢ = pᵢ (−mᵢᵀu)/√(mᵢᵀWmᵢ) / Σⱼ (same)                 (configuration flux)

and its outcome is the facet law's impact on that facet (Newton's (2.6) by default). The
rough law (2.8) is the mean of this mixture. :class:`ImpactOutcomes` holds the mixture of
one impact: its mean, its support (the outcomes and their probabilities) and the
statistics of κ, μ, the contact point's tangential restitution and its rebound angle.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_count
from ..errors import ParameterError, ShapeError
from .impact import BatchResult, ImpactResult

__all__ = ["ImpactOutcomes", "OUTCOME_QUANTITIES", "outcome_values", "take_rows", "as_generator", "MAX_SAMPLE"]

#: The quantities of :meth:`ImpactOutcomes.std` and :meth:`ImpactOutcomes.quantile`, named as the columns of an
#: :class:`~mbimpact.ImpactTable` (:mod:`mbimpact.calibration.quantities`), read in contact space.
OUTCOME_QUANTITIES: tuple[str, ...] = ("kappa", "mu", "et_cp", "rebound_cp_deg")

#: Largest sample :meth:`ImpactOutcomes.sample` draws at once (a typo must not fill the memory).
MAX_SAMPLE = 10_000_000

# Tolerance on the probabilities' sum.
_SUM_TOL = 1e-9


def as_generator(seed: object) -> np.random.Generator:
    """A numpy Generator from ``seed``: an integer in [0, 2⁶³ − 1] or a Generator (used as it is).

    Raises
    ------
    ParameterError
        Anything else (a negative or fractional number, a string, None, a legacy ``RandomState``).
    """
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(as_count("seed", seed, 0, 2**63 - 1))


def take_rows(batch: BatchResult, rows: NDArray[np.intp]) -> BatchResult:
    """The rows ``rows`` of a batch at one configuration (shared ``A``, ``J``, ``n0``), as a new batch."""
    n0 = batch.n0 if batch.n0.ndim == 1 else batch.n0[rows]
    A = batch.A if batch.A.ndim == 2 else batch.A[rows]
    J = batch.J if batch.J.ndim == 2 else batch.J[rows]
    return BatchResult(
        V_minus=batch.V_minus[rows], V_plus=batch.V_plus[rows], dV=batch.dV[rows], P=batch.P[rows],
        U_minus=batch.U_minus[rows], U_plus=batch.U_plus[rows], n0=n0, A=A, J=J, law=batch.law,
        error_estimate=batch.error_estimate[rows], nodes=batch.nodes, method=batch.method,
    )


def outcome_values(batch: BatchResult, name: str) -> NDArray[np.float64]:
    """One of :data:`OUTCOME_QUANTITIES` for every row of a batch, shape (B,).

    ``"kappa"``
        Newton's restitution −(n⁰·u₊)/(n⁰·u₋), (1.2).
    ``"mu"``
        The impulse ratio |P_t| / P_n read in contact space, (3.1).
    ``"et_cp"``
        The contact point's tangential restitution (u_t⁺ · u_t⁻) / |u_t⁻|²: the tangential velocity
        after the impact along the incoming one, over the incoming one (< 0: reversed). NaN at normal
        incidence (u_t⁻ = 0).
    ``"rebound_cp_deg"``
        The contact point's rebound angle from the normal, atan2(|u_t⁺|, n⁰·u₊) in degrees, negative
        where the tangential velocity is reversed (u_t⁺ · u_t⁻ < 0); at normal incidence its magnitude.

    Raises
    ------
    ParameterError
        An unknown name.
    """
    if name == "kappa":
        return np.asarray(batch.kappa, dtype=float)
    if name == "mu":
        return np.asarray(batch.mu, dtype=float)
    if name not in OUTCOME_QUANTITIES:
        raise ParameterError(f"unknown outcome quantity {name!r}; valid: {', '.join(map(repr, OUTCOME_QUANTITIES))}")
    n0 = np.broadcast_to(batch.n0, batch.U_minus.shape)
    un_minus = np.einsum("bd,bd->b", n0, batch.U_minus)
    un_plus = np.einsum("bd,bd->b", n0, batch.U_plus)
    ut_minus = batch.U_minus - un_minus[:, None] * n0
    ut_plus = batch.U_plus - un_plus[:, None] * n0
    along = np.einsum("bd,bd->b", ut_plus, ut_minus)
    if name == "et_cp":
        incoming = np.einsum("bd,bd->b", ut_minus, ut_minus)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(incoming > 0.0, along / np.where(incoming > 0.0, incoming, 1.0), np.nan)
    angle = np.degrees(np.arctan2(np.linalg.norm(ut_plus, axis=1), un_plus))
    return np.where(along < 0.0, -angle, angle)


def _frozen(a: NDArray[np.float64]) -> NDArray[np.float64]:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class ImpactOutcomes:
    """The outcomes of one rough impact over the microrelief, (2.6)–(2.8), and their statistics.

    Made by :meth:`mbimpact.RoughLaw.outcomes` (arrays) and :func:`mbimpact.impact_outcomes` (a mechanism).

    Attributes
    ----------
    mean : ImpactResult
        The law's result, (2.8): ``law.apply`` (or :func:`mbimpact.impact`) itself, computed by the law's
        averaging method to its accuracy (the support of a finite measure is exact whatever the method).
    weights : ndarray, shape (K,)
        Probabilities of the rows of ``support``, summing to 1.
    support : BatchResult
        K single-facet impacts at the configuration of ``mean``. For a finite measure, the facets
        that face the motion, in the measure's order, with their flux weights (2.7) as ``weights``
        (shadowing included, as in the law): the exact distribution. For a continuous measure, the
        nodes of the measure's quadrature rule on G* weighted by the flux: a discretisation of the
        distribution, on which the statistics below are computed.
    normals : ndarray, shape (K, d)
        The facet normal of each row of ``support``, world-aligned contact coordinates.
    exact : bool
        Whether the measure is finite (``support`` is then the distribution itself).
    sampler : callable, optional
        ``sampler(n, rng) -> BatchResult``: n outcomes drawn from a continuous measure (rejection
        from the measure's own sampler, :meth:`mbimpact.Roughness.sample`); unused when ``exact``.

    Raises
    ------
    ShapeError
        Weights, support and normals that do not match, or weights that are negative or do not sum to 1.
    """

    mean: ImpactResult
    weights: NDArray[np.float64]
    support: BatchResult
    normals: NDArray[np.float64]
    exact: bool
    sampler: Callable[[int, np.random.Generator], BatchResult] | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.mean, ImpactResult) or not isinstance(self.support, BatchResult):
            raise ShapeError("ImpactOutcomes needs an ImpactResult as mean and a BatchResult as support")
        w = _frozen(self.weights)
        K = len(self.support)
        if w.shape != (K,) or K == 0:
            raise ShapeError(f"weights must have shape (K,) = ({K},), one per row of the support; got {w.shape}")
        if not (np.all(np.isfinite(w)) and np.all(w >= 0.0) and abs(float(w.sum()) - 1.0) <= _SUM_TOL):
            raise ShapeError("weights must be non-negative and sum to 1")
        m = _frozen(self.normals)
        if m.shape != (K, self.mean.P.shape[0]):
            raise ShapeError(f"normals must have shape ({K}, {self.mean.P.shape[0]}); got {m.shape}")
        if not self.exact and self.sampler is None:
            raise ShapeError("the outcomes of a continuous measure need a sampler")
        for name in ("V_minus", "V_plus", "dV", "P", "U_minus", "U_plus", "n0", "error_estimate"):
            getattr(self.support, name).setflags(write=False)  # the outcomes are values, as a result's are
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "normals", m)
        object.__setattr__(self, "exact", bool(self.exact))

    def __repr__(self) -> str:
        kind = "finite" if self.exact else "continuous"
        return (f"ImpactOutcomes({self.mean.law!r}, {kind}, {len(self.support)} "
                f"{'facets' if self.exact else 'nodes'}, kappa={self.mean.kappa:.6g}, mu={self.mean.mu:.6g})")

    @property
    def probabilities(self) -> NDArray[np.float64] | None:
        """Probabilities (K,) of the facets facing the motion, (2.7), summing to 1 (finite measures;
        None for continuous ones, whose outcomes have no finite support)."""
        return self.weights if self.exact else None

    @property
    def results(self) -> BatchResult | None:
        """The K single-facet impacts in the order of :attr:`probabilities` (finite measures; None for
        continuous ones: :meth:`sample` draws their outcomes)."""
        return self.support if self.exact else None

    def sample(self, n: int, seed: int | np.random.Generator = 0) -> BatchResult:
        """n single-facet outcomes drawn with the flux weights of (2.7).

        Finite measures: rows of :attr:`results` drawn with :attr:`probabilities` (exact). Continuous
        measures: facet normals drawn from the measure (:meth:`mbimpact.Roughness.sample`: inversion of
        the tilt's distribution, uniform azimuth) and accepted with probability proportional to their
        flux, restricted to G* (rejection), each followed by its facet impact.

        Parameters
        ----------
        n : int
            Sample size, 1 … :data:`MAX_SAMPLE`.
        seed : int or numpy.random.Generator
            An integer in [0, 2⁶³ − 1] (the same seed gives the same sample) or a Generator.

        Returns
        -------
        BatchResult
            n rows at the configuration of :attr:`mean`.

        Raises
        ------
        ParameterError
            n < 1 or too large, or a bad seed.
        """
        count = as_count("n", n, 1, MAX_SAMPLE)
        rng = as_generator(seed)
        if self.exact:
            return take_rows(self.support, rng.choice(len(self.weights), size=count, p=self.weights))
        assert self.sampler is not None
        return self.sampler(count, rng)

    def _centred(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        w = self.weights
        mean = w @ x
        d = x - mean
        return (d * w[:, None]).T @ d

    @property
    def covariance(self) -> NDArray[np.float64]:
        """Covariance of v₊ over the outcomes, shape (n, n): Σ πᵢ (v₊ᵢ − v̄₊)(v₊ᵢ − v̄₊)ᵀ over
        :attr:`support` (exact for finite measures; on the quadrature nodes for continuous ones)."""
        return self._centred(self.support.V_plus)

    @property
    def impulse_covariance(self) -> NDArray[np.float64]:
        """Covariance of the contact impulse P over the outcomes, shape (d, d) (as :attr:`covariance`)."""
        return self._centred(self.support.P)

    def values(self, name: str) -> NDArray[np.float64]:
        """The quantity ``name`` (:data:`OUTCOME_QUANTITIES`) of every row of :attr:`support`, shape (K,)."""
        return outcome_values(self.support, name)

    def std(self, name: str) -> float:
        """Standard deviation of ``name`` over the outcomes (:func:`outcome_values` defines the names:
        ``"kappa"``, ``"mu"``, ``"et_cp"``, ``"rebound_cp_deg"``); NaN where the quantity is undefined
        (``"et_cp"`` at normal incidence).

        Raises
        ------
        ParameterError
            An unknown name.
        """
        x = self.values(name)
        w = self.weights
        mean = float(w @ x)
        return math.sqrt(max(float(w @ (x - mean) ** 2), 0.0)) if math.isfinite(mean) else math.nan

    def quantile(self, name: str, p: ArrayLike) -> Any:
        """Quantiles of ``name`` over the outcomes: the smallest value x with P(X ≤ x) ≥ p.

        Exact for finite measures (the distribution is discrete); for continuous ones, on the quadrature
        nodes of :attr:`support` (accurate to about the largest node weight in probability).

        Parameters
        ----------
        name : str
            One of :data:`OUTCOME_QUANTITIES`.
        p : float or array_like
            Probabilities in [0, 1].

        Returns
        -------
        float or ndarray
            Of the shape of ``p``; NaN where the quantity is undefined.

        Raises
        ------
        ParameterError
            An unknown name, or p outside [0, 1] or not finite.
        """
        try:
            probs = np.asarray(p, dtype=float)
        except (TypeError, ValueError):
            raise ParameterError(f"p must be a probability or an array of them, got {p!r}") from None
        if not (np.all(np.isfinite(probs)) and np.all((probs >= 0.0) & (probs <= 1.0))):
            raise ParameterError(f"p must lie in [0, 1], got {p!r}")
        x = self.values(name)
        if np.isnan(x).any():
            out = np.full(probs.shape, np.nan)
        else:
            order = np.argsort(x, kind="stable")
            cdf = np.cumsum(self.weights[order])
            cdf /= cdf[-1]
            index = np.minimum(np.searchsorted(cdf, probs * (1.0 - 1e-12), side="left"), len(x) - 1)
            out = x[order][index]
        return float(out) if out.ndim == 0 else out

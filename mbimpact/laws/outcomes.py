"""The outcomes of a rough impact over the microrelief, (2.6)–(2.7): which facet is met, and what it does.

(2.8) is the mean of a random outcome: a motion meets one facet i of those facing it,
G* = {mᵢᵀu < 0}, with the probability of (2.7),

    πᵢ = wᵢ / Σⱼ wⱼ,   wᵢ = pᵢ (−mᵢᵀu)  (physical flux)   or   pᵢ (−mᵢᵀu)/√(mᵢᵀWmᵢ)  (configuration flux),

and the outcome is the facet law's impact on that facet, Pᵢ = facet.impulse(mᵢ, W, u)
(Newton's: −(1+e)(mᵢᵀu / mᵢᵀWmᵢ) mᵢ, (2.6)), Δvᵢ = A⁻¹JᵀPᵢ by (1.1). The weights are the
law's own (:func:`mbimpact.averaging.integrand.facet_terms`, shadowing included through the
measure's rule) and the facet impulses the facet law's own, in the law's local frame (unit
contact velocity, W of unit trace; physical speeds for a speed-dependent facet law); the
impulses are taken back to the world frame by the law pipeline itself
(:meth:`mbimpact.ImpactLaw.impulses`), so that Σ πᵢ Pᵢ is the law's P to rounding.

Continuous measures have no finite support: their statistics (covariances, standard deviations,
quantiles) are computed on the nodes of the measure's own quadrature rule on G* with the flux
weights, at the largest node count up to 1024 a piece that puts at most :data:`STATISTICS_FACETS`
facets on the velocity (a cone: 1024 nodes; spatial slopes: 2 × 64² nodes). Their samples are
drawn by rejection: normals from the measure (:meth:`mbimpact.Roughness.sample`: a cone's azimuth
uniform; the tilt of isotropic slopes by inverting its distribution function, tabulated at 4097
tilts), accepted with probability w / w_max, where w_max bounds the flux: |u| for the physical
flux, min(|u| / √max(λ_min, floor), √(uᵀW⁻¹u)) for the configuration flux (the facets with
mᵀWm below the degenerate floor get no weight, as in the law).
"""

from __future__ import annotations

import functools
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..averaging.integrand import check_facing, facet_terms
from ..common.basis import local_basis
from ..common.geometry import DEGENERATE
from ..common.validation import as_array
from ..errors import ParameterError, ShapeError
from ..facets.base import FacetLaw, method_label
from ..metric.delassus import ContactMetric
from ..results.impact import BatchResult, ContactImpulses, ImpactResult
from ..results.outcomes import ImpactOutcomes
from .base import ImpactLaw, WrappedLaw
from .rough import RoughLaw

__all__ = ["rough_outcomes", "rough_outcomes_batch", "outcomes_at_metric", "facet_outcomes", "STATISTICS_FACETS",
           "MAX_PROPOSALS"]

#: Most quadrature nodes on which the statistics of a continuous measure are computed.
STATISTICS_FACETS = 20_000

#: Rejection sampling gives up after this many proposals per accepted facet (an acceptance rate that low
#: means a nearly singular W with the configuration flux).
MAX_PROPOSALS = 10_000


class _LocalFrame(WrappedLaw):
    """Runs the law pipeline's checks and scalings and keeps what the law's core would see:
    the local W of unit trace and the unit local contact velocities."""

    def __init__(self, law: ImpactLaw) -> None:
        super().__init__(law)
        self.W: NDArray[np.float64] | None = None
        self.U: NDArray[np.float64] | None = None

    def contact_impulses(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        self.W, self.U = W.copy(), U.copy()
        return ContactImpulses(np.zeros_like(U), np.zeros(len(U)), 1, "outcomes")


class _Replay(WrappedLaw):
    """Gives back given local impulses, one per row, for the pipeline to take to the world frame."""

    def __init__(self, law: ImpactLaw, P: NDArray[np.float64]) -> None:
        super().__init__(law)
        self.P = P

    def contact_impulses(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        return ContactImpulses(self.P, np.zeros(len(self.P)), 1, "outcomes")


def _speed(u: NDArray[np.float64]) -> float:
    """|u| as the pipeline computes it (scaled by the largest entry first: no under- or overflow)."""
    big = float(np.abs(u).max())
    return big * float(np.linalg.norm(u / big))


def facet_outcomes(facet: FacetLaw, normals: NDArray[np.float64], W: NDArray[np.float64], u: NDArray[np.float64],
                   speed: float) -> NDArray[np.float64]:
    """Local contact impulses (K, d) of the facet law on facets ``normals`` (K, d) for the unit local
    velocity ``u`` (d,) at the local W, as the rough law computes them: at the physical velocity
    ``u · speed`` for a speed-dependent facet law, divided by ``speed`` (the impulses of unit velocities)."""
    rows = np.ascontiguousarray(np.broadcast_to(u, normals.shape))
    if facet.homogeneous:
        return facet.impulse(normals, W, rows)
    return facet.impulse(normals, W, rows * speed) / speed


def _world_batch(law: RoughLaw, metric: ContactMetric, v: NDArray[np.float64], u: NDArray[np.float64],
                 R: NDArray[np.float64], P_local: NDArray[np.float64]) -> BatchResult:
    """The single-facet impacts of local impulses ``P_local`` (K, d) at one velocity, through the
    pipeline's own scalings and frame (:meth:`ImpactLaw.impulses`), as a batch."""
    K = len(P_local)
    U = np.repeat(u[None, :], K, axis=0)
    P = _Replay(law, P_local).impulses(metric, U, R).P
    V = np.repeat(v[None, :], K, axis=0)
    dV = P @ metric.AinvJt.T
    return BatchResult(
        V_minus=V, V_plus=V + dV, dV=dV, P=P, U_minus=U, U_plus=U + P @ metric.W, n0=R[:, -1].copy(), A=metric.A,
        J=metric.J, law=law, error_estimate=np.zeros(K), nodes=1, method=method_label("facet", law.facet),
    )


def _statistics_nodes(law: RoughLaw) -> int:
    """The largest power of two up to 1024 whose rule puts at most :data:`STATISTICS_FACETS` facets on a velocity."""
    nodes = 1024
    while nodes > 1 and law.roughness.rule_size(nodes) > STATISTICS_FACETS:
        nodes //= 2
    return nodes


def _flux_bound(law: RoughLaw, W: NDArray[np.float64], u: NDArray[np.float64]) -> float:
    """An upper bound of the flux weight of a unit facet normal (see the module docstring)."""
    if law.flux == "physical":
        return float(np.linalg.norm(u)) * (1.0 + 1e-12)
    lam, vec = np.linalg.eigh(W)
    floor = DEGENERATE * float(np.trace(W))  # facets with mᵀWm below it get no weight (facet_terms)
    bound = float(np.linalg.norm(u)) / np.sqrt(max(float(lam[0]), floor))  # mᵀWm ≥ max(λ_min, floor)
    if lam[0] > 0.0:  # Cauchy–Schwarz: (mᵀu)² ≤ (mᵀWm)(uᵀW⁻¹u)
        bound = min(bound, float(np.sqrt(np.sum((vec.T @ u) ** 2 / lam))))
    return bound * (1.0 + 1e-12)


def _sample(law: RoughLaw, metric: ContactMetric, v: NDArray[np.float64], u: NDArray[np.float64],
            R: NDArray[np.float64], W: NDArray[np.float64], u_local: NDArray[np.float64], speed: float,
            n: int, rng: np.random.Generator) -> BatchResult:
    """n outcomes of a continuous measure, by rejection (see the module docstring)."""
    spec, rough = law.spec, law.roughness
    bound = _flux_bound(law, W, u_local)
    chosen: list[NDArray[np.float64]] = []
    accepted = proposed = 0
    batch = max(1024, int(1.25 * n))
    while accepted < n:
        m = rough.sample(rng, batch)
        w, _ = facet_terms(spec, m, np.ones(len(m)), W, u_local[None, :])
        keep = m[rng.uniform(0.0, bound, len(m)) < w[0]]
        chosen.append(keep)
        accepted += len(keep)
        proposed += batch
        if accepted < n and proposed > MAX_PROPOSALS * n:
            raise ParameterError(f"{law!r}: rejection sampling accepted {accepted} of {proposed} facets; the flux "
                                 "weights are too peaked to sample (a nearly singular W with the configuration flux)")
        rate = max(accepted / proposed, 1e-4)
        batch = int(min(1 << 22, max(1024, 1.25 * (n - accepted) / rate)))
    normals = np.concatenate(chosen)[:n]
    return _world_batch(law, metric, v, u, R, facet_outcomes(law.facet, normals, W, u_local, speed))


def outcomes_at_metric(law: RoughLaw, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64],
                       mean: ImpactResult) -> ImpactOutcomes:
    """The :class:`~mbimpact.results.outcomes.ImpactOutcomes` of one impact at a validated metric.

    Parameters
    ----------
    law : RoughLaw
        Without ``repeat`` (the outcomes are those of one micro-impact, the model's).
    metric : ContactMetric
    v : ndarray, shape (n,)
        Pre-impact velocity.
    R : ndarray, shape (d, d)
        Local frame, last column n⁰.
    mean : ImpactResult
        The law's result for this impact (``law.apply_metric(metric, v, R)``, or :func:`mbimpact.impact`).

    Raises
    ------
    ParameterError
        ``law`` is not a :class:`~mbimpact.RoughLaw`, or repeats micro-impacts.
    NoImpactError, NoFacingFacetError, RoughnessError
        As the law raises them.
    """
    if not isinstance(law, RoughLaw):
        raise ParameterError(f"outcomes are those of a rough law (RoughLaw), got {type(law).__name__}")
    if law.repeat:
        raise ParameterError(f"{law!r}: the outcomes are those of one micro-impact on one facet; with repeat=True the "
                             "law's mean is not their mean (use law.replace(repeat=False))")
    u = metric.J @ v
    frame = _LocalFrame(law)
    frame.impulses(metric, u[None, :], R)  # the law's checks: approach, reach of n⁰, dimension
    assert frame.W is not None and frame.U is not None
    W, u_local, speed = frame.W, frame.U[0], _speed(u)
    rough = law.roughness
    m, p = rough.rule_batch(frame.U, 1 if rough.exact else _statistics_nodes(law))
    m = m if m.ndim == 2 else m[0]
    p = np.broadcast_to(p if p.ndim == 1 else p[0], (len(m),))
    w, _ = facet_terms(law.spec, m, p, W, frame.U)
    check_facing(law.spec, w.sum(axis=1), frame.U)
    facing = np.flatnonzero(w[0] > 0.0)
    normals = m[facing]
    weights = w[0, facing] / w[0, facing].sum()
    support = _world_batch(law, metric, v, u, R, facet_outcomes(law.facet, normals, W, u_local, speed))
    sampler = None if rough.exact else functools.partial(_sample, law, metric, v, u, R, W, u_local, speed)
    return ImpactOutcomes(mean=mean, weights=weights, support=support, normals=normals @ R.T, exact=rough.exact,
                          sampler=sampler)


def rough_outcomes(law: RoughLaw, A: ArrayLike, J: ArrayLike, v: ArrayLike, frame: ArrayLike) -> ImpactOutcomes:
    """:meth:`mbimpact.RoughLaw.outcomes`: the outcomes of ``law.apply(A, J, v, frame)`` over the microrelief."""
    metric = ContactMetric.from_arrays(A, J)
    vv = as_array("v", v, 1, (metric.n,))
    R = local_basis(frame, metric.d)
    return outcomes_at_metric(law, metric, vv, R, law.apply_metric(metric, vv, R))


def rough_outcomes_batch(law: RoughLaw, A: ArrayLike, J: ArrayLike, V: ArrayLike, frame: ArrayLike
                         ) -> tuple[ImpactOutcomes, ...]:
    """:meth:`mbimpact.RoughLaw.outcomes_batch`: the outcomes of every row of ``V`` (B, n) at one configuration."""
    metric = ContactMetric.from_arrays(A, J)
    rows = as_array("V", V, 2, (None, metric.n))
    if not len(rows):
        raise ShapeError("V must have at least one row (one velocity per impact)")
    R = local_basis(frame, metric.d)
    return tuple(outcomes_at_metric(law, metric, v, R, law.apply_metric(metric, v, R)) for v in rows)

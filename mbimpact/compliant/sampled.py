"""Microrelief sampling: facets drawn from a roughness measure, each impact resolved in time."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..averaging.integrand import check_flux
from ..common.geometry import scaled_norm
from ..common.validation import as_count
from ..mechanism.contact import PointContact
from ..errors import NoFacingFacetError, ParameterError, RoughnessError
from ..mechanism.mechanism import Mechanism
from .resolve import check_mechanism, resolve
from ..roughness.base import Roughness

__all__ = ["RoughResolved", "resolve_rough"]

#: Facets drawn at most: each is an impact resolved in time (~10 ms), so 10⁵ already take minutes.
MAX_SAMPLES = 100_000


@dataclass(frozen=True, eq=False)
class RoughResolved:
    """Flux-weighted average of resolved facet impacts, with a confidence interval.

    Attributes
    ----------
    v_plus : ndarray, shape (nv,)
        Estimated post-impact velocity.
    ci95 : ndarray, shape (nv,)
        Half-width of the 95 % confidence interval of ``v_plus`` (delta method).
    samples : int
        Facets drawn (including those that do not face the velocity, weight 0).
    """

    v_minus: NDArray[np.float64]
    v_plus: NDArray[np.float64]
    ci95: NDArray[np.float64]
    samples: int

    @property
    def dv(self) -> NDArray[np.float64]:
        return self.v_plus - self.v_minus


def resolve_rough(
    mech: Mechanism,
    q: ArrayLike,
    v: ArrayLike,
    contact: PointContact,
    roughness: Roughness,
    *,
    samples: int = 200,
    seed: int = 0,
    flux: Literal["physical", "configuration"] = "physical",
    **kwargs: object,
) -> RoughResolved:
    """Draw facets from ``roughness``, resolve each impact in time, average with (2.7).

    Facets are drawn from P; each facing facet's resolved velocity jump is
    weighted by the contact point's sweep rate −mᵀu (``"physical"``) or its A-metric flux
    −(N, v₋) (``"configuration"``), as in
    (2.8). Keyword arguments go to :func:`resolve` (M, k or e, dynamics, ...).

    Raises
    ------
    ParameterError
        ``mech`` not a :class:`Mechanism`, ``contact`` not a :class:`PointContact`, ``samples``
        outside [2, :data:`MAX_SAMPLES`], a negative ``seed`` or an unknown ``flux``.
    RoughnessError
        ``roughness`` is not a spatial roughness measure.
    """
    check_mechanism(mech)
    if not isinstance(contact, PointContact):
        raise ParameterError(f"contact must be an mbimpact.PointContact, got {type(contact).__name__}")
    if not isinstance(roughness, Roughness):
        raise RoughnessError(f"roughness must be a Roughness measure (Cone, GaussianSlopes, ...), "
                             f"got {type(roughness).__name__}")
    if roughness.dim != 3:
        raise RoughnessError(f"resolve_rough needs a spatial roughness measure, got {roughness!r}")
    samples = as_count("samples", samples, 2, MAX_SAMPLES)
    seed = as_count("seed", seed, 0, 2**63 - 1)
    if not isinstance(flux, str):
        raise ParameterError(f"flux must be 'physical' or 'configuration', got {flux!r}")
    flux = check_flux(flux)
    q0, v0 = mech.check_state(q, v)
    m_local = roughness.sample(np.random.default_rng(seed), samples)
    R = contact.basis()
    J = mech.point_jacobian(q0, contact.frame, contact.point)
    A = mech.mass_matrix(q0)
    W = J @ np.linalg.solve(A, J.T)
    u = J @ v0
    weights, jumps = [], []
    for m in m_local:
        mw = R @ m
        s = float(mw @ u)
        if s >= 0:
            weights.append(0.0)
            jumps.append(np.zeros(mech.nv))
            continue
        res = resolve(mech, q0, v0, contact, m, **kwargs)  # type: ignore[arg-type]
        weights.append(-s / math.sqrt(float(mw @ W @ mw)) if flux == "configuration" else -s)
        jumps.append(res.dv)
    w = np.array(weights)
    if not w.sum() > 0:
        raise NoFacingFacetError(f"none of the {samples} facets drawn faces the velocity")
    X = np.array(jumps)
    mean = (w @ X) / w.sum()
    n = len(w)
    resid = w[:, None] * (X - mean)
    se = scaled_norm(resid, axis=0) / math.sqrt((n - 1) * n) / (w.sum() / n)  # no overflow of the squares
    return RoughResolved(v0.copy(), v0 + mean, 1.96 * se, n)

"""Impact laws: Newton's frictionless law (1.2) and the rough-surface average (2.8).

Every law shares one pipeline (THEORY §5):

1. metric — factorise A once, W = J A⁻¹ Jᵀ, u = J v (:mod:`mbimpact.metric`);
2. law — a contact impulse P from (W, u) in the local frame of the base surface;
3. result — Δv = A⁻¹ Jᵀ P and I = Jᵀ P, Lagrange's equations (1.1).

Only step 2 differs between laws.
"""

from __future__ import annotations

import warnings
from abc import ABC, abstractmethod
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._validate import as_array, as_scalar
from .errors import NoFacingFacetError, NoImpactError, ParameterError, RoughnessError
from .metric import ContactMetric, local_basis
from .restitution import e_from_k
from .result import ImpactResult
from .roughness import Roughness, Smooth

__all__ = ["ImpactLaw", "NewtonLaw", "RoughLaw", "AccuracyWarning"]

# A facet (or base normal) with mᵀWm below this fraction of trace(W) cannot be
# moved along by the mechanism (Jᵀm ≈ 0): it carries no flux and is skipped.
_DEGENERATE = 1e-14


class AccuracyWarning(RuntimeWarning):
    """The averaging quadrature stopped before reaching the requested ``rtol``."""


def _restitution(e: float | None, k: float | None) -> float:
    """The facet restitution e from exactly one of e or the damping ratio k."""
    if (e is None) == (k is None):
        raise ParameterError("give exactly one of e (restitution) or k (Kelvin–Voigt damping ratio)")
    if e is not None:
        return as_scalar("e", e, 0.0, 1.0)
    return e_from_k(k)  # type: ignore[arg-type]


class ImpactLaw(ABC):
    """Base class: the pipeline metric → contact impulse → result.

    Subclasses implement :meth:`contact_impulse` in the local frame of the base
    surface (last axis along n⁰).
    """

    e: float

    #: Contact-space dimension the law requires (None: 2 or 3).
    @property
    def dim(self) -> int | None:
        return None

    @abstractmethod
    def contact_impulse(
        self, W: NDArray[np.float64], u: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], float, int]:
        """Contact impulse in the local frame.

        Parameters
        ----------
        W : ndarray, shape (d, d)
            Delassus matrix in the local frame, Rᵀ W R.
        u : ndarray, shape (d,)
            Pre-impact contact velocity in the local frame, ``u[-1] < 0``.

        Returns
        -------
        P : ndarray, shape (d,)
            Contact impulse in the local frame.
        error_estimate : float
            Relative error estimate of ``P`` (0 when exact).
        nodes : int
            Facet nodes used.
        """

    def apply(self, A: ArrayLike, J: ArrayLike, v: ArrayLike, frame: ArrayLike) -> ImpactResult:
        """Post-impact state for mass matrix ``A``, contact Jacobian ``J``, velocity ``v``.

        Parameters
        ----------
        A : array_like, shape (n, n)
            Symmetric positive definite mass matrix A(q).
        J : array_like, shape (d, n)
            World-aligned translational contact Jacobian, d = 2 or 3.
        v : array_like, shape (n,)
            Pre-impact generalised velocity.
        frame : array_like, shape (d,) or (d, d)
            Base normal n⁰, or a rotation whose last column is n⁰.

        Returns
        -------
        ImpactResult

        Raises
        ------
        ShapeError, NonFiniteError, NotPositiveDefiniteError
            Invalid arrays.
        NoImpactError
            The contact point does not approach the base surface.
        NoFacingFacetError
            No facet faces the velocity (G* of (2.7) is empty).
        """
        metric = ContactMetric.from_arrays(A, J)
        v = as_array("v", v, 1, (metric.n,))
        return self.apply_metric(metric, v, local_basis(frame, metric.d))

    def apply_metric(
        self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]
    ) -> ImpactResult:
        """:meth:`apply` on an already validated metric and contact basis ``R`` (d, d)."""
        d = metric.d
        if self.dim is not None and self.dim != d:
            raise RoughnessError(
                f"{self!r} needs a {self.dim}-D contact space but J has {d} rows"
            )
        n0 = R[:, -1]
        u = metric.J @ v
        un = float(n0 @ u)
        w_nn = float(n0 @ metric.W @ n0)
        scale = float(np.trace(metric.W))
        if not un < 0.0:
            raise NoImpactError(
                f"the contact point does not approach the surface: n0·(J v) = {un:.6g} must be < 0"
            )
        if w_nn <= _DEGENERATE * scale:
            raise NoImpactError(
                "the mechanism cannot move the contact point along n0 (n0ᵀ W n0 ≈ 0); no impact can occur"
            )
        # Every law is positively homogeneous of degree 1 in u (1°): work with the
        # unit direction so that velocity scales far from 1 neither under- nor overflow.
        speed = float(np.linalg.norm(u))
        P_local, err, nodes = self.contact_impulse(R.T @ metric.W @ R, R.T @ u / speed)
        P = R @ P_local * speed
        dv = metric.AinvJt @ P
        return ImpactResult(
            v_minus=v.copy(),
            v_plus=v + dv,
            dv=dv,
            P=P,
            u_minus=u,
            u_plus=u + metric.W @ P,
            n0=n0.copy(),
            A=metric.A,
            J=metric.J,
            law=repr(self),
            error_estimate=err,
            nodes=nodes,
        )


class NewtonLaw(ImpactLaw):
    """Frictionless Newton impact (1.2): Δv = −(1+e)(N, v₋) N / |N|².

    Equal to ``pin.impulseDynamics(model, data, q, v, n0ᵀJ[None, :], e, 0.0)``.

    Parameters
    ----------
    e : float, optional
        Restitution in [0, 1].
    k : float, optional
        Kelvin–Voigt damping ratio in [0, 1] instead of ``e`` (e = e_from_k(k)).
    """

    def __init__(self, e: float | None = None, *, k: float | None = None) -> None:
        self.e = _restitution(e, k)

    def __repr__(self) -> str:
        return f"NewtonLaw(e={self.e:g})"

    def contact_impulse(
        self, W: NDArray[np.float64], u: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], float, int]:
        P = np.zeros_like(u)
        P[-1] = -(1.0 + self.e) * u[-1] / W[-1, -1]
        return P, 0.0, 1


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
        :class:`Facets`, ...).
    e : float, optional
        Facet restitution in [0, 1].
    k : float, optional
        Kelvin–Voigt damping ratio in [0, 1] instead of ``e``; exactly one.
    flux : {"metric", "contact"}
        Weight of a facet: the paper's A-metric flux (N_m, v) = mᵀu / sqrt(mᵀWm)
        ("metric", default) or the projected-area flux mᵀu of the contact point
        ("contact", THEORY §5). They agree when W ∝ I (a point mass).
    rtol : float
        Relative accuracy of the averaging quadrature for measures that are not
        finite (:class:`Cone`); node counts are doubled until two successive
        results agree to ``rtol``.
    max_nodes : int
        Node count at which refinement stops (an :class:`AccuracyWarning` is
        issued if ``rtol`` was not reached).
    """

    def __init__(
        self,
        roughness: Roughness,
        e: float | None = None,
        *,
        k: float | None = None,
        flux: Literal["metric", "contact"] = "metric",
        rtol: float = 1e-12,
        max_nodes: int = 1 << 14,
    ) -> None:
        if not isinstance(roughness, Roughness):
            raise RoughnessError(
                f"roughness must be a Roughness measure (Smooth, Sawtooth, Cone, Facets), got {type(roughness).__name__}"
            )
        if flux not in ("metric", "contact"):
            raise ParameterError(f"flux must be 'metric' or 'contact', got {flux!r}")
        self.roughness = roughness
        self.e = _restitution(e, k)
        self.flux = flux
        self.rtol = as_scalar("rtol", rtol, 0.0, 1.0)
        if int(max_nodes) < max(1, roughness.initial_nodes):
            raise ParameterError(f"max_nodes must be ≥ {roughness.initial_nodes}, got {max_nodes}")
        self.max_nodes = int(max_nodes)

    def __repr__(self) -> str:
        extra = "" if self.flux == "metric" else f", flux={self.flux!r}"
        return f"RoughLaw({self.roughness!r}, e={self.e:g}{extra})"

    @property
    def dim(self) -> int | None:
        return self.roughness.dim

    def _average(self, W: NDArray[np.float64], u: NDArray[np.float64], nodes: int) -> NDArray[np.float64]:
        """(2.8) with the rule of ``nodes`` nodes: the contact impulse, local frame."""
        m, p = self.roughness.rule(u, nodes)
        s = m @ u  # mᵀu: flux of the contact point through each facet
        q = np.einsum("kd,de,ke->k", m, W, m)  # mᵀWm = |A⁻¹Jᵀm|² in the A-metric
        facing = (s < 0.0) & (q > _DEGENERATE * np.trace(W)) & (p > 0.0)
        if not np.any(facing):
            raise NoFacingFacetError(
                f"no facet of {self.roughness!r} faces the contact velocity {u.tolist()} "
                "(local frame): the set G* of (2.7) is empty"
            )
        m, p, s, q = m[facing], p[facing], s[facing], q[facing]
        flux = -s / np.sqrt(q) if self.flux == "metric" else -s
        w = p * flux
        return (1.0 + self.e) * ((w * (-s / q)) @ m) / w.sum()

    def contact_impulse(
        self, W: NDArray[np.float64], u: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], float, int]:
        nodes = self.roughness.initial_nodes
        P = self._average(W, u, nodes)
        if self.roughness.exact:
            return P, 0.0, nodes
        while True:
            nodes *= 2
            P_fine = self._average(W, u, nodes)
            err = float(np.linalg.norm(P_fine - P) / np.linalg.norm(P_fine))
            P = P_fine
            if err <= self.rtol:
                return P, err, nodes
            if nodes * 2 > self.max_nodes:
                warnings.warn(
                    f"{self!r}: quadrature reached {nodes} nodes with estimated relative error "
                    f"{err:.3g} > rtol={self.rtol:g}",
                    AccuracyWarning,
                    stacklevel=4,
                )
                return P, err, nodes


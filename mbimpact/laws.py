"""Impact laws: Newton's frictionless law (1.2) and the rough-surface average (2.8).

Every law shares one pipeline (THEORY §5):

1. metric — factorise A once, W = J A⁻¹ Jᵀ, u = J v (:mod:`mbimpact.metric`);
2. law — a contact impulse P from (W, u) in the local frame of the base surface;
3. result — Δv = A⁻¹ Jᵀ P and I = Jᵀ P, Lagrange's equations (1.1).

Only step 2 differs between laws, and it is written once for a batch of
velocities (rows); a single impact is a batch of one.
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
from .result import BatchResult, ImpactResult
from .roughness import Roughness

__all__ = ["ImpactLaw", "NewtonLaw", "RoughLaw", "AccuracyWarning"]

# A facet (or base normal) with mᵀWm below this fraction of trace(W) cannot be
# moved along by the mechanism (Jᵀm ≈ 0): it carries no flux and is skipped.
_DEGENERATE = 1e-14
# Rows per block in batch evaluation: keeps (rows × nodes × d) work arrays in cache.
_BLOCK = 2048


class AccuracyWarning(RuntimeWarning):
    """The averaging quadrature stopped before reaching the requested ``rtol``."""


def _restitution(e: float | None, k: float | None) -> float:
    """The facet restitution e from exactly one of e or the damping ratio k."""
    if (e is None) == (k is None):
        raise ParameterError("give exactly one of e (restitution) or k (Kelvin–Voigt damping ratio)")
    if e is not None:
        return as_scalar("e", e, 0.0, 1.0)
    return e_from_k(k)  # type: ignore[arg-type]


def _relative_change(fine: NDArray[np.float64], coarse: NDArray[np.float64], W: NDArray[np.float64]) -> NDArray[np.float64]:
    """Relative difference of two impulse estimates, measured by the contact-velocity
    change Δu = W P they produce: with a rank-deficient J, P is only defined up to
    the null space of Jᵀ (= that of W), while Δu is always well defined."""
    return np.linalg.norm((fine - coarse) @ W, axis=1) / np.linalg.norm(fine @ W, axis=1)


def _range_projector(W: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """Orthogonal projector onto range(W), or None when W has full rank."""
    d = W.shape[0]
    tr = float(np.trace(W))
    if np.linalg.det(W) > 1e-12 * tr**d:  # λ_min / λ_max ≥ det / tr^d: clearly full rank
        return None
    lam, vec = np.linalg.eigh(W)
    keep = lam > 1e-12 * lam[-1]
    if keep.all():
        return None
    return vec[:, keep] @ vec[:, keep].T


class ImpactLaw(ABC):
    """Base class: the pipeline metric → contact impulse → result.

    Subclasses implement :meth:`contact_impulses` in the local frame of the base
    surface (last axis along n⁰) for unit contact velocities.
    """

    e: float

    @property
    def dim(self) -> int | None:
        """Contact-space dimension the law requires (None: 2 or 3)."""
        return None

    @abstractmethod
    def contact_impulses(
        self, W: NDArray[np.float64], U: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """Contact impulses for a batch of unit contact velocities, local frame.

        Parameters
        ----------
        W : ndarray, shape (d, d)
            Delassus matrix in the local frame, Rᵀ W R.
        U : ndarray, shape (B, d)
            Unit pre-impact contact velocities, ``U[:, -1] < 0``.

        Returns
        -------
        P : ndarray, shape (B, d)
            Contact impulses in the local frame.
        error_estimate : ndarray, shape (B,)
            Relative error estimates of ``P`` (0 when exact).
        nodes : int
            Facet nodes (or samples) used in the final evaluation.
        """

    # ------------------------------------------------------------------ single
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
        P, u, err, nodes = self._impulses(metric, v[None, :], R)
        dv = metric.AinvJt @ P[0]
        return ImpactResult(
            v_minus=v.copy(),
            v_plus=v + dv,
            dv=dv,
            P=P[0],
            u_minus=u[0],
            u_plus=u[0] + metric.W @ P[0],
            n0=R[:, -1].copy(),
            A=metric.A,
            J=metric.J,
            law=self,
            error_estimate=float(err[0]),
            nodes=nodes,
        )

    # ------------------------------------------------------------------ batch
    def apply_batch(self, A: ArrayLike, J: ArrayLike, V: ArrayLike, frame: ArrayLike) -> BatchResult:
        """:meth:`apply` for many velocities at one configuration, vectorised.

        Parameters
        ----------
        A : array_like, shape (n, n)
        J : array_like, shape (d, n)
        V : array_like, shape (B, n)
            Pre-impact velocities, one per row; every row must approach the surface.
        frame : array_like, shape (d,) or (d, d)

        Returns
        -------
        BatchResult
        """
        metric = ContactMetric.from_arrays(A, J)
        V = as_array("V", V, 2, (None, metric.n))
        R = local_basis(frame, metric.d)
        P, U, err, nodes = self._impulses(metric, V, R)
        dV = P @ metric.AinvJt.T
        return BatchResult(
            V_minus=V.copy(), V_plus=V + dV, dV=dV, P=P, U_minus=U, U_plus=U + P @ metric.W,
            n0=R[:, -1].copy(), A=metric.A, J=metric.J, law=self, error_estimate=err, nodes=nodes,
        )

    def _impulses(
        self, metric: ContactMetric, V: NDArray[np.float64], R: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], int]:
        """World-frame impulses P (B, d), contact velocities U (B, d), errors (B,), nodes."""
        U = V @ metric.J.T
        P, err, nodes = self.impulses_for(metric, U, R)
        return P, U, err, nodes

    def impulses_for(
        self, metric: ContactMetric, U: NDArray[np.float64], R: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """Contact impulses P (B, d), world frame, for given contact velocities U (B, d).

        ``U`` is the velocity of the contact point relative to the surface; it
        differs from J v when the surface moves (a vibrating table).
        """
        d = metric.d
        if self.dim is not None and self.dim != d:
            raise RoughnessError(f"{self!r} needs a {self.dim}-D contact space but J has {d} rows")
        n0 = R[:, -1]
        un = U @ n0
        bad = np.flatnonzero(~(un < 0.0))
        if bad.size:
            where = "" if len(un) == 1 else f" (rows {bad[:5].tolist()}{'...' if bad.size > 5 else ''})"
            raise NoImpactError(
                f"the contact point does not approach the surface{where}: "
                f"n0·(J v) = {un[bad[0]]:.6g} must be < 0"
            )
        if float(n0 @ metric.W @ n0) <= _DEGENERATE * float(np.trace(metric.W)):
            raise NoImpactError(
                "the mechanism cannot move the contact point along n0 (n0ᵀ W n0 ≈ 0); no impact can occur"
            )
        # Every law is positively homogeneous of degree 1 in u (1°): work with unit
        # directions so that velocity scales far from 1 neither under- nor overflow.
        speed = np.linalg.norm(U, axis=1)
        W_local = R.T @ metric.W @ R
        U_local = (U @ R) / speed[:, None]
        P = np.empty_like(U)
        err = np.empty(len(U))
        nodes = 0
        for start in range(0, len(U), _BLOCK):
            block = slice(start, start + _BLOCK)
            P[block], err[block], nodes_b = self.contact_impulses(W_local, U_local[block])
            nodes = max(nodes, nodes_b)
        P = P @ R.T
        proj = _range_projector(metric.W)
        if proj is not None:
            # rank-deficient J: report the minimum-norm impulse, the only one that
            # does not depend on how the quadrature split the part in null(Jᵀ)
            P = P @ proj
        return P * speed[:, None], err, nodes


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

    def contact_impulses(
        self, W: NDArray[np.float64], U: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        P = np.zeros_like(U)
        P[:, -1] = -(1.0 + self.e) * U[:, -1] / W[-1, -1]
        return P, np.zeros(len(U)), 1


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
    flux : {"metric", "contact"}
        Weight of a facet: the paper's A-metric flux (N_m, v) = mᵀu / sqrt(mᵀWm)
        ("metric", default) or the projected-area flux mᵀu of the contact point
        ("contact", THEORY §5). They agree when W ∝ I (a point mass).
    method : {"quadrature", "mc"}
        "quadrature" (default) uses the measure's rule with G* handled exactly;
        "mc" averages over ``samples`` facets drawn from P with ``seed`` (the naive
        baseline), and reports its standard error as ``error_estimate``.
    rtol : float
        Relative accuracy of the adaptive quadrature for measures that are not
        finite; node counts are doubled until two successive results agree to
        ``rtol``.
    nodes : int, optional
        Fixed node count instead of adaptive refinement (the error estimate then
        compares with ``nodes // 2``).
    max_nodes : int, optional
        Node count at which refinement stops (an :class:`AccuracyWarning` is
        issued if ``rtol`` was not reached); default: the measure's ``node_limit``.
    samples, seed : int
        Monte Carlo sample count and seed (``method="mc"``).
    """

    def __init__(
        self,
        roughness: Roughness,
        e: float | None = None,
        *,
        k: float | None = None,
        flux: Literal["metric", "contact"] = "metric",
        method: Literal["quadrature", "mc"] = "quadrature",
        rtol: float = 1e-12,
        nodes: int | None = None,
        max_nodes: int | None = None,
        samples: int = 10_000,
        seed: int = 0,
    ) -> None:
        if not isinstance(roughness, Roughness):
            raise RoughnessError(
                "roughness must be a Roughness measure (Smooth, Sawtooth, Cone, Facets, ...), "
                f"got {type(roughness).__name__}"
            )
        if flux not in ("metric", "contact"):
            raise ParameterError(f"flux must be 'metric' or 'contact', got {flux!r}")
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
        if method == "mc":
            roughness.sample(np.random.default_rng(0), 2)  # fail now if it cannot be sampled

    def __repr__(self) -> str:
        extra = "" if self.flux == "metric" else f", flux={self.flux!r}"
        if self.method == "mc":
            extra += f", method='mc', samples={self.samples}"
        elif self.nodes is not None:
            extra += f", nodes={self.nodes}"
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
        flux = np.where(facing, -s / np.sqrt(safe_q) if self.flux == "metric" else -s, 0.0)
        return p * flux, np.where(facing, -s / safe_q, 0.0), m

    def _average(self, W: NDArray[np.float64], U: NDArray[np.float64], nodes: int) -> NDArray[np.float64]:
        """(2.8) with the rule of ``nodes`` nodes: contact impulses (B, d), local frame."""
        m, p = self.roughness.rule_batch(U, nodes)
        w, c, m = self._terms(m, p, W, U)
        total = w.sum(axis=1)
        self._check_facing(total, U)
        wc = w * c
        num = wc @ m if m.ndim == 2 else np.einsum("bk,bkd->bd", wc, m)
        return (1.0 + self.e) * num / total[:, None]

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
        if self.method == "mc":
            P, err = self._monte_carlo(W, U)
            return P, err, self.samples
        rough = self.roughness
        if rough.exact:
            return self._average(W, U, 1), np.zeros(len(U)), len(rough.rule_batch(U[:1], 1)[1].ravel())
        if self.nodes is not None:
            P = self._average(W, U, self.nodes)
            coarse = self._average(W, U, max(1, self.nodes // 2))
            return P, _relative_change(P, coarse, W), self.nodes
        return self._adaptive(W, U)

    def _adaptive(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """Double the node count on the rows that have not converged to ``rtol``."""
        nodes = self.roughness.initial_nodes
        P = self._average(W, U, nodes)
        err = np.full(len(U), np.inf)
        todo = np.arange(len(U))
        while True:
            nodes *= 2
            fine = self._average(W, U[todo], nodes)
            err[todo] = _relative_change(fine, P[todo], W)
            P[todo] = fine
            todo = todo[err[todo] > self.rtol]
            if todo.size == 0:
                return P, err, nodes
            if nodes * 2 > self.max_nodes:
                warnings.warn(
                    f"{self!r}: quadrature reached {nodes} nodes with estimated relative error "
                    f"{err.max():.3g} > rtol={self.rtol:g}",
                    AccuracyWarning,
                    stacklevel=5,
                )
                return P, err, nodes

"""Impacts in a scene: one contact by its law, several at once by a declared rule.

A single contact that strikes is resolved by its own law (:class:`mbimpact.RoughLaw` with
``repeat=True``, so that an averaged outcome that still approaches is followed by its
further micro-impacts). Contacts already in persistent contact take part as plastic
unilateral contacts with Coulomb friction: if the impact pushes them into their surface,
a plastic frictional impulse follows (Pinocchio's ADMM on their cones), and the two
alternate until nothing approaches.

Contacts that strike together, or several points of one contact (a face landing flat),
have no unique outcome; the scene declares the rule:

``"newton"``
    Newton's law at all of them at once: the normal impulses λᵢ ≥ 0 with
    uᵢ⁺ = uᵢ⁻ + (W λ)ᵢ ≥ −eᵢ uᵢ⁻ and λᵢ (uᵢ⁺ + eᵢ uᵢ⁻) = 0 (a linear complementarity
    problem, solved on the cones with μ = 0), persistent contacts plastic and frictional.
``"rough"``
    The rough law at several contacts: every contact meets one facet of its own
    measure, independently; a realisation (m₁, …, m_c) weighs ∏ pᵢ(mᵢ) (−mᵢᵀuᵢ) (the
    physical flux (2.7) of each, the probability that the contact points meet those
    facets together), and its outcome is Newton's multi-contact law on the facets. The
    average over ``samples`` realisations drawn from the measures (seeded), with its
    standard error. For one contact this is the rough law (2.8) itself (by Monte Carlo).
``"compliant"``
    The Kelvin–Voigt contacts (2.3) integrated in time with their stiffnesses
    (:func:`mbimpact.resolve` with A and J frozen): the outcome depends on the ratio of
    the stiffnesses, which the scene declares. Fixed surfaces only.
``"sequential"``
    Each contact's own law, one contact at a time (the most approaching first), until
    none approaches.
``"auto"``
    ``"sequential"`` if a striking contact has a Coulomb law or a rough law with other than
    Newton facets, else ``"rough"`` if one has a rough law, else ``"newton"``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import SceneError
from ..laws.base import ImpactLaw
from ..laws.coulomb import CoulombLaw
from ..laws.rough import RoughLaw
from ..common.basis import local_basis
from ..metric.delassus import ContactMetric
from .cones import ConeSolver
from .state import ContactState

__all__ = ["Impulses", "ImpactSolver", "choose_rule"]


@dataclass
class Impulses:
    """World impulses (3,) at the points that took part, by :attr:`ContactState.key`, and the
    velocity jump (nv,)."""

    dv: NDArray[np.float64]
    P: dict[tuple[int, int], NDArray[np.float64]]
    rule: str
    error: float = 0.0


def choose_rule(rule: str, laws: list[ImpactLaw]) -> str:
    """The rule for a group of striking contacts (resolving ``"auto"``)."""
    if rule != "auto":
        return rule
    if any(isinstance(law, CoulombLaw) or (isinstance(law, RoughLaw) and law.facet.newton_restitution is None)
           for law in laws):
        return "sequential"  # the facet realisations of the rough rule are Newton impacts
    if any(isinstance(law, RoughLaw) for law in laws):
        return "rough"
    return "newton"


class ImpactSolver:
    """Impacts at a state: the mass-matrix solver, the laws, and the frictional cone solver.

    Parameters
    ----------
    laws : list of ImpactLaw
        Each contact's law (rough laws with ``repeat=True``).
    frictions : list of float
        Each contact's persistent-contact μ.
    solve : callable
        b ↦ A⁻¹ b at the current configuration.
    A : ndarray, shape (nv, nv)
    rng : numpy Generator
        For the facet realisations of the "rough" rule.
    cones : ConeSolver
    """

    def __init__(self, laws: list[ImpactLaw], frictions: list[float], A: NDArray[np.float64], solve: Any,
                 rng: np.random.Generator, cones: ConeSolver, samples: int) -> None:
        self.laws, self.frictions, self.A, self.solve_A = laws, frictions, A, solve
        self.rng, self.cones, self.samples = rng, cones, samples

    # ------------------------------------------------------------------ one contact, its law
    def single(self, s: ContactState, dim: int | None) -> Impulses:
        """The contact's own law, on its velocity relative to the surface."""
        law = self.laws[s.index]
        if dim == 2:  # a planar roughness acts in the plane of t₁ and n
            B = s.frame[:, [0, 2]].T
            metric = ContactMetric(self.A, B @ s.J, self.solve_A)
            P = B.T @ law.impulses(metric, (B @ s.u)[None, :], np.eye(2)).P[0]
        else:
            metric = ContactMetric(self.A, s.J, self.solve_A)
            P = law.impulses(metric, s.u[None, :], s.frame).P[0]
        return Impulses(self.solve_A(s.J.T @ P), {s.key: P}, repr(law))

    # ------------------------------------------------------------------ cones
    def cone_impulses(self, rows: list[tuple[tuple[int, int], NDArray[np.float64], NDArray[np.float64],
                                               NDArray[np.float64], float, float]]
                      ) -> tuple[NDArray[np.float64], dict[tuple[int, int], NDArray[np.float64]]]:
        """Impulses on Coulomb cones: rows of (key, frame R (3, 3), J (3, nv), relative u (3,), μ, e).

        The normal free velocity is shifted by (1 + e) u_n (Newton's restitution); e = 0 is plastic.
        """
        Jc = np.vstack([R.T @ J for _, R, J, _, _, _ in rows])
        AinvJt = self.solve_A(Jc.T)
        G = Jc @ AinvJt
        G = 0.5 * (G + G.T)
        g = np.concatenate([R.T @ u for _, R, _, u, _, _ in rows])
        g[2::3] *= 1.0 + np.array([e for *_, e in rows])
        lam = self.cones.solve(G, g, tuple(mu for *_, mu, _ in rows))
        P = {key: R @ lam[3 * k: 3 * k + 3] for k, (key, R, *_rest) in enumerate(rows)}
        return AinvJt @ lam, P

    def plastic(self, active: list[ContactState]) -> Impulses:
        """A plastic frictional impulse at persistent contacts pushed into their surfaces."""
        dv, P = self.cone_impulses([(s.key, s.frame, s.J, s.u, self.frictions[s.index], 0.0) for s in active])
        return Impulses(dv, P, "plastic frictional contact")

    # ------------------------------------------------------------------ several contacts
    def newton(self, struck: list[ContactState], active: list[ContactState],
               normals: list[NDArray[np.float64]] | None = None) -> Impulses:
        """Newton's law at the struck points at once (frictionless, along ``normals`` if given: facets,
        one per struck point), persistent points plastic and frictional."""
        rows = []
        for k, s in enumerate(struck):
            n = s.normal if normals is None else normals[k]
            R = s.frame if normals is None else local_basis(n, 3)
            rows.append((s.key, R, s.J, s.u, 0.0, float(self.laws[s.index].e)))
        rows += [(s.key, s.frame, s.J, s.u, self.frictions[s.index], 0.0) for s in active]
        dv, P = self.cone_impulses(rows)
        return Impulses(dv, P, "newton")

    def rough(self, struck: list[ContactState], active: list[ContactState]) -> Impulses:
        """The average of Newton's multi-contact law over independent facet realisations, weighted by
        the product of the physical fluxes (2.7)."""
        facets = []
        for s in struck:
            law = self.laws[s.index]
            if isinstance(law, RoughLaw):
                if law.facet.newton_restitution is None:
                    raise SceneError(f"the 'rough' rule for contacts striking together realises Newton facets; contact "
                                     f"{s.index} has {law.facet!r} facets: use simultaneous = 'sequential'")
                if law.roughness.dim == 2:
                    raise SceneError("the 'rough' rule for contacts striking together needs spatial (3-D) roughness; "
                                     f"contact {s.index} has {law.roughness!r}")
                try:
                    m = law.roughness.sample(self.rng, self.samples)
                except Exception as exc:  # a measure that cannot be sampled (shadowed relief)
                    raise SceneError(f"the 'rough' rule needs measures that can be sampled: {exc}") from exc
                facets.append(m @ s.frame.T)  # world normals
            else:
                facets.append(np.tile(s.normal, (self.samples, 1)))
        jumps, weights, impulses = [], [], []
        for k in range(self.samples):
            normals = [m[k] for m in facets]
            w = 1.0
            for s, n in zip(struck, normals):
                w *= max(0.0, -float(n @ s.u))
            if w <= 0.0:
                continue
            out = self.newton(struck, active, normals)
            jumps.append(out.dv)
            weights.append(w)
            impulses.append(out.P)
        if not weights:
            raise SceneError(f"no facet realisation of contacts {[s.index for s in struck]} faces their velocities")
        W = np.array(weights)
        X = np.array(jumps)
        total_w = float(W.sum())
        mean = (W @ X) / total_w
        n = len(W)
        resid = W[:, None] * (X - mean)
        se = np.sqrt((resid**2).sum(axis=0) / max(n - 1, 1) / n) / (total_w / n)
        err = float(np.sqrt(se @ self.A @ se / max(float(mean @ self.A @ mean), 1e-300)))
        P = {i: sum(w * imp[i] for w, imp in zip(W, impulses)) / total_w for i in impulses[0]}
        return Impulses(mean, P, f"rough ({n} facet realisations)", err)

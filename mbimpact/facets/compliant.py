r"""The compliant facet: (2.3) carried to the tangential direction, resolved in time.

The constructive model gets Newton's facet law from a force that is a function of the
deformation, integrated through the impact (2.3)–(2.5). Here the same is done in both
directions, in contact space with W fixed (2.4), in the facet frame (last axis along
the facet normal m):

* normal: Kelvin–Voigt, F_n = −(K_n δ_n + C_n δ̇_n) with K_n = M² / W_nn and
  C_n = 2kM / W_nn, so that alone it gives f̈ = −(M² f + 2kM ḟ) and the restitution e
  of (2.5) (k = :func:`mbimpact.k_from_e`);
* tangential: a linear spring F_t = −K_t ξ of stiffness K_t = κ_t K_n (κ_t the
  ``stiffness_ratio``; Mindlin's value for a sphere is 2(1−ν)/(2−ν) ≈ 0.8), whose
  elongation ξ follows the contact point's tangential motion, ξ̇ = u_t, while it sticks;
* Coulomb slip: |F_t| ≤ μ max(F_n, 0). When the spring force reaches the bound the
  contact slips and the spring is held on it (Cundall–Strack); when u_t turns back the
  spring unloads elastically. Stick, slip, reversal and re-stick all follow.

The contact point moves by u̇ = W F; the impact ends when the normal deformation
returns to zero, like (2.5) (the Kelvin–Voigt force is tensile just before, as in the
paper's facet; friction then vanishes). The impulse is P = ∫ F dt.

Scale invariance
----------------
In the dimensionless time τ = M t, with y = M δ and z = M ξ (velocity units) and
G = F / M, the equations read

    u' = W G,   y_n' = u_n,   z' = u_t (stick),   G_n = −(y_n + 2k u_n)/W_nn,
    G_t = −κ_t z / W_nn  with  |G_t| ≤ μ max(G_n, 0),   P = ∫ G dτ,

free of M: the impulse does not depend on the stiffness (only on e, μ, κ_t and W),
exactly as (2.5). It is also homogeneous of degree 1 in u.

Integrator
----------
Classical Runge–Kutta (RK4) with fixed steps in τ: ``resolution`` steps per period
2π/ω_max of the fastest sticking mode (ω_max² the largest eigenvalue of K^{1/2} W K^{1/2},
K = diag(κ_t, …, κ_t, 1)/W_nn), with the spring returned to the friction bound after
every step (return mapping), the end of the impact located by cubic Hermite
interpolation of y_n, and the last piece of the impact taken again as one step to that
end. Within one regime — sticking, slipping, or the tensile end of the Kelvin–Voigt
force where friction vanishes — the force is smooth and the steps are fourth order
(planar slip included: the force is then μ G_n along a fixed direction). A step whose
stages straddle a change of regime (a kink of the force; a steep one as μ grows) is
split where the regime changes, located by :data:`LOCATE` halvings. The return mapping
decides the end of a slip at the end of a step, a second-order error, and in a spatial
contact it turns the spring at first order, so spatial slipping steps are taken in
:data:`SUBSTEPS` substeps. Measured against 30× finer solutions (random W, μ = 0.3,
κ_t = 0.8, e = 0.6), the relative error at the default 48 steps a period is ≤ 5e-5
(median 5e-8) on planar facets and ≤ 3e-4 (median 8e-6) on spatial ones, and it falls
at second and first order; the tests check the convergence. The averaged law's default
``rtol`` is 1e-4 (planar) and 1e-3 (spatial).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.validation import as_count, as_scalar
from ..errors import IntegrationError
from .restitution import k_from_e
from .base import FacetLaw

__all__ = ["CompliantFacet", "compliant_impulses", "CompliantHistory"]


@dataclass(frozen=True)
class CompliantFacet(FacetLaw):
    """Each facet impact resolved in time: Kelvin–Voigt normal force, tangential spring, Coulomb slip.

    Parameters
    ----------
    e : float
        Normal restitution in [0, 1) of the Kelvin–Voigt force (2.5) (e = 0: critical damping
        is excluded; use e ≥ 1e-6).
    mu : float
        Coulomb friction coefficient, ≥ 0. μ = 0 gives Newton's facet (the tangential spring
        carries no force).
    stiffness_ratio : float
        κ_t = K_t / K_n > 0, tangential over normal contact stiffness.
    resolution : int
        RK4 steps per period of the fastest sticking mode (≥ 8).
    """

    e: float
    mu: float
    stiffness_ratio: float
    resolution: int = 48
    name: ClassVar[str] = "compliant"
    default_rtol: ClassVar[float] = 1e-4

    def __post_init__(self) -> None:
        object.__setattr__(self, "e", as_scalar("e", self.e, 1e-6, 1.0))
        object.__setattr__(self, "mu", as_scalar("mu", self.mu, 0.0, math.inf))
        object.__setattr__(self, "stiffness_ratio",
                           as_scalar("stiffness_ratio", self.stiffness_ratio, 0.0, 1e6, lo_open=True))
        object.__setattr__(self, "resolution", as_count("resolution", self.resolution, 8, 100_000))

    def __repr__(self) -> str:
        return f"CompliantFacet(e={self.e:g}, mu={self.mu:g}, stiffness_ratio={self.stiffness_ratio:g})"

    def quadrature_rtol(self, d: int | None) -> float:
        """1e-4 on planar facets, 1e-3 on spatial ones (the integrator's accuracy, module notes)."""
        return 1e-4 if d == 2 else 1e-3

    @property
    def k(self) -> float:
        """The Kelvin–Voigt damping ratio of e, (2.5)."""
        return k_from_e(self.e)

    def facet_impulse(self, W: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        return compliant_impulses(W, u, self.k, self.mu, self.stiffness_ratio, self.resolution)

    def history(self, W: NDArray[np.float64], u: NDArray[np.float64], M: float = 1.0) -> CompliantHistory:
        """One facet impact in physical time: forces, velocities and spring over the contact.

        Parameters
        ----------
        W : ndarray, shape (d, d)
            Facet-frame Delassus matrix.
        u : ndarray, shape (d,)
            Facet-frame contact velocity, u[-1] < 0.
        M : float
            Stiffness parameter of (2.3) (1/s); times scale as 1/M, forces as M.
        """
        M = as_scalar("M", M, 0.0, math.inf, lo_open=True)
        rec: list[NDArray[np.float64]] = []
        P = compliant_impulses(W[None], u[None], self.k, self.mu, self.stiffness_ratio, self.resolution, rec)
        tau, state = np.array([r[0] for r in rec]), np.array([r[1:] for r in rec])
        d = len(u)
        return CompliantHistory(t=tau / M, u=state[:, :d], force=M * state[:, d:2 * d],
                                spring=state[:, 2 * d:3 * d - 1] / M, P=P[0])


@dataclass(frozen=True, eq=False)
class CompliantHistory:
    """A resolved facet impact (facet frame, physical units), :meth:`CompliantFacet.history`.

    Attributes
    ----------
    t : ndarray, shape (S,)
        Times of the steps (s).
    u : ndarray, shape (S, d)
        Contact velocity.
    force : ndarray, shape (S, d)
        Contact force (tangential within the friction bound).
    spring : ndarray, shape (S, d − 1)
        Tangential spring elongation ξ.
    P : ndarray, shape (d,)
        Impulse of the whole impact.
    """

    t: NDArray[np.float64]
    u: NDArray[np.float64]
    force: NDArray[np.float64]
    spring: NDArray[np.float64]
    P: NDArray[np.float64]


def _fastest_mode(W: NDArray[np.float64], kappa: float) -> NDArray[np.float64]:
    """ω_max (N,): √ of the largest eigenvalue of K^{1/2} W K^{1/2}, K = diag(κ_t, …, 1)/W_nn."""
    d = W.shape[1]
    s = np.full(d, math.sqrt(kappa))
    s[-1] = 1.0
    S = W * (s[:, None] * s[None, :]) / W[:, -1, -1][:, None, None]
    return np.sqrt(np.linalg.eigvalsh(S)[:, -1])


class _Facets:
    """The constants of N facet impacts (dimensionless, see the module notes) — W's blocks, 2k, μ
    and the tangential stiffness κ_t / W_nn — the right-hand side and one step.

    The spring force is cut to the friction bound μ max(G_n, 0) where it exceeds it (the contact
    slips), and after every step the spring itself is returned to the bound (return mapping:
    its direction is that of the elastic trial). A step whose stages are not all in one regime
    (sticking, slipping, no normal compression) straddles a kink of the force: it is split
    where the regime changes. A slipping step of a spatial contact, where the return mapping
    turns the spring at first order, is taken in :data:`SUBSTEPS` substeps."""

    def __init__(self, W: NDArray[np.float64], k: float, mu: float, kappa: float) -> None:
        self.A, self.b, self.c = W[:, :-1, :-1], W[:, :-1, -1], W[:, -1, -1]
        self.two_k, self.mu = 2.0 * k, mu
        self.kt = kappa / self.c

    def take(self, keep: NDArray[np.bool_] | NDArray[np.intp]) -> _Facets:
        out = object.__new__(_Facets)
        out.A, out.b, out.c, out.kt = self.A[keep], self.b[keep], self.c[keep], self.kt[keep]
        out.two_k, out.mu = self.two_k, self.mu
        return out

    def forces(self, un: NDArray[np.float64], yn: NDArray[np.float64], z: NDArray[np.float64]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int8]]:
        """G_t (N, d−1), G_n (N,) and the regime: 0 sticking, 1 slipping (the spring on or beyond
        the bound), 2 no friction (G_n ≤ 0, the Kelvin–Voigt force's tensile end)."""
        gn = -(yn + self.two_k * un) / self.c
        if self.mu == 0.0:
            return np.zeros_like(z), gn, np.full(len(gn), 2, dtype=np.int8)
        gt = -self.kt[:, None] * z
        bound = self.mu * np.maximum(gn, 0.0)
        size = np.sqrt(np.einsum("ni,ni->n", gt, gt))
        regime = np.where(gn > 0.0, (size >= (1.0 - 1e-9) * bound).astype(np.int8), np.int8(2))
        over = size > bound
        if over.any():
            gt = np.where(over[:, None], gt * (bound / np.where(over, size, 1.0))[:, None], gt)
        return gt, gn, regime

    def project(self, un: NDArray[np.float64], yn: NDArray[np.float64], z: NDArray[np.float64]) -> NDArray[np.float64]:
        """The spring returned to the friction bound |κ_t z / W_nn| ≤ μ max(G_n, 0)."""
        if self.mu == 0.0:
            return np.zeros_like(z)
        gn = -(yn + self.two_k * un) / self.c
        bound = self.mu * np.maximum(gn, 0.0) / self.kt
        size = np.sqrt(np.einsum("ni,ni->n", z, z))
        over = size > bound
        if not over.any():
            return z
        return np.where(over[:, None], z * (bound / np.where(over, size, 1.0))[:, None], z)

    def rates(self, ut: NDArray[np.float64], un: NDArray[np.float64], yn: NDArray[np.float64],
              z: NDArray[np.float64]) -> tuple[tuple[NDArray[np.float64], ...], NDArray[np.int8]]:
        """(u_t', u_n', y_n', z', P_t', P_n') and the regime (:meth:`forces`)."""
        gt, gn, regime = self.forces(un, yn, z)
        if self.A.shape[1] == 1:  # planar: scalars, no einsum
            dut = self.A[:, 0, 0, None] * gt + self.b * gn[:, None]
            dun = self.b[:, 0] * gt[:, 0] + self.c * gn
        else:
            dut = np.einsum("nij,nj->ni", self.A, gt) + self.b * gn[:, None]
            dun = np.einsum("ni,ni->n", self.b, gt) + self.c * gn
        return (dut, dun, un, ut, gt, gn), regime

    def step(self, state: tuple[NDArray[np.float64], ...], h: NDArray[np.float64]
             ) -> tuple[tuple[NDArray[np.float64], ...], NDArray[np.bool_], NDArray[np.bool_]]:
        """One RK4 step of (u_t, u_n, y_n, z, P_t, P_n) and the return mapping; also whether the
        stages (and the end) are not all in one regime, and whether a spatial contact slips."""
        hh = h[:, None]

        def shifted(ks: tuple[NDArray[np.float64], ...], f: float) -> tuple[NDArray[np.float64], ...]:
            return tuple(x + (f * hh if x.ndim == 2 else f * h) * dx for x, dx in zip(state[:4], ks[:4]))

        k1, o1 = self.rates(*state[:4])
        k2, o2 = self.rates(*shifted(k1, 0.5))
        k3, o3 = self.rates(*shifted(k2, 0.5))
        k4, o4 = self.rates(*shifted(k3, 1.0))
        new = []
        for i, x in enumerate(state):
            inc = (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]) / 6.0
            new.append(x + (hh if x.ndim == 2 else h) * inc)
        new[3] = self.project(new[1], new[2], new[3])
        none = np.zeros(len(h), dtype=bool)
        if self.mu == 0.0:
            return tuple(new), none, none
        _, _, o5 = self.forces(new[1], new[2], new[3])
        changed = (o1 != o2) | (o1 != o3) | (o1 != o4) | (o1 != o5)
        turning = ((o1 == 1) | (o5 == 1)) if self.A.shape[1] > 1 else none
        return tuple(new), changed, turning

    def settle(self, state: tuple[NDArray[np.float64], ...], h: NDArray[np.float64], depth: int = 4
               ) -> tuple[NDArray[np.float64], ...]:
        """Advance by h (N,). A step across a change of regime is split where the regime changes
        (located by bisection on the step's length, :data:`LOCATE` halvings) and the rest advanced
        again (up to ``depth`` changes in one step); a slipping step of a spatial contact is taken in
        :data:`SUBSTEPS` substeps."""
        new, changed, turning = self.step(state, h)
        if depth > 0 and changed.any():
            i = np.flatnonzero(changed)
            sub, part, H = self.take(i), tuple(x[i] for x in state), h[i]
            lo, hi = np.zeros(len(i)), np.ones(len(i))
            for _ in range(LOCATE):  # the longest fraction of the step that stays in one regime
                mid = 0.5 * (lo + hi)
                _, mixed, _t = sub.step(part, mid * H)
                lo, hi = np.where(mixed, lo, mid), np.where(mixed, mid, hi)
            part = sub.settle(part, lo * H, 0)
            part = sub.settle(part, (hi - lo) * H, 0)  # across the change: a sliver of the step
            part = sub.settle(part, (1.0 - hi) * H, depth - 1)
            new = tuple(_put(a, i, b) for a, b in zip(new, part))
            turning = turning & ~changed
        if turning.any():
            i = np.flatnonzero(turning)
            sub, part = self.take(i), tuple(x[i] for x in state)
            for _ in range(SUBSTEPS):
                part = sub.step(part, h[i] / SUBSTEPS)[0]
            new = tuple(_put(a, i, b) for a, b in zip(new, part))
        return new


def compliant_impulses(W: NDArray[np.float64], u: NDArray[np.float64], k: float, mu: float, kappa: float,
                       resolution: int, record: list[NDArray[np.float64]] | None = None) -> NDArray[np.float64]:
    """Impulses of compliant facet impacts, in dimensionless time (see the module notes).

    Parameters
    ----------
    W : ndarray, shape (N, d, d)
        Facet-frame Delassus matrices.
    u : ndarray, shape (N, d)
        Facet-frame contact velocities, u[:, -1] < 0.
    k, mu, kappa : float
        Damping ratio, friction coefficient, stiffness ratio κ_t.
    resolution : int
        RK4 steps per period of the fastest sticking mode (see :meth:`_Facets.settle` for the
        steps across a change of regime and the slipping steps of spatial contacts).
    record : list, optional
        For one impact (N = 1): filled with rows (τ, u, G, z) at every step.

    Returns
    -------
    ndarray, shape (N, d)
        P = ∫ G dτ.

    Raises
    ------
    IntegrationError
        An impact that has not ended after 200 periods of the fastest mode.
    """
    N, d = u.shape
    facets = _Facets(W, k, mu, kappa)
    h = 2.0 * math.pi / (resolution * _fastest_mode(W, kappa))
    out = np.empty((N, d))
    rows = np.arange(N)
    state: tuple[NDArray[np.float64], ...] = (u[:, :-1].copy(), u[:, -1].copy(), np.zeros(N), np.zeros((N, d - 1)),
                                              np.zeros((N, d - 1)), np.zeros(N))
    tau = 0.0
    limit = 200 * resolution
    for _ in range(limit):
        if record is not None:
            gt0, gn0, _s = facets.forces(state[1], state[2], state[3])
            record.append(np.concatenate([[tau], state[0][0], [state[1][0]], gt0[0], [gn0[0]], state[3][0]]))
            tau += float(h[0])
        new = facets.settle(state, h)
        yn0, yn1 = state[2], new[2]
        ended = yn1 >= 0.0  # the deformation is back to zero (after the first step it is < 0)
        if ended.any():
            e_ = ended
            # cubic Hermite on the step: θ with y_n(θ) = 0
            y0, y1, v0, v1, he = yn0[e_], yn1[e_], state[1][e_], new[1][e_], h[e_]
            theta = np.clip(y0 / np.where(y0 != y1, y0 - y1, 1.0), 0.0, 1.0)
            for _ in range(8):
                t2, t3 = theta * theta, theta**3
                H = (2 * t3 - 3 * t2 + 1) * y0 + (t3 - 2 * t2 + theta) * he * v0 + (-2 * t3 + 3 * t2) * y1 \
                    + (t3 - t2) * he * v1
                dH = (6 * t2 - 6 * theta) * y0 + (3 * t2 - 4 * theta + 1) * he * v0 + (-6 * t2 + 6 * theta) * y1 \
                    + (3 * t2 - 2 * theta) * he * v1
                theta = np.clip(theta - H / np.where(dH != 0, dH, 1.0), 0.0, 1.0)
            # the last piece, from the step's start to the end of the impact, taken again as one step
            # (the friction force may turn sharply at the very end: no interpolation across it)
            final = facets.take(e_).settle(tuple(x[e_] for x in state), theta * he)
            out[rows[e_], :-1] = final[4]
            out[rows[e_], -1] = final[5]
            keep = ~e_
            rows = rows[keep]
            if not rows.size:
                return out
            new = tuple(x[keep] for x in new)
            facets, h = facets.take(keep), h[keep]
        state = new
    raise IntegrationError(f"a compliant facet impact has not ended after {limit} steps "
                           f"({200} periods of its fastest mode); W or the parameters are degenerate")


#: Substeps of a slipping step of a spatial contact.
SUBSTEPS = 8
#: Halvings that locate a change of regime within a step.
LOCATE = 4


def _put(full: NDArray[np.float64], rows: NDArray[np.intp], part: NDArray[np.float64]) -> NDArray[np.float64]:
    """``full`` with ``rows`` replaced by ``part``."""
    out = full.copy()
    out[rows] = part
    return out

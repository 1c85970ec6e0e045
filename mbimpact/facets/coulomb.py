"""Coulomb's facet: each facet impact an axiomatic impact with Coulomb friction (Routh, Stronge).

On a facet, in its frame (last axis along the facet normal m), the contact velocity
is integrated in impulse space with the normal impulse p as the clock,

    u(P) = u₋ + W P,   dP_t = −μ ŝ dp while the contact slips (ŝ = u_t / |u_t|),

sticking when the slip stops if the ratio needed to keep u_t = 0, |W_tt⁻¹ W_tn|, is
within μ, otherwise slipping on the other way. The impact ends by the restitution
hypothesis (as :class:`mbimpact.CoulombLaw`): ``"energetic"`` (Stronge, default: the
normal work of restitution is −e² that of compression), ``"poisson"`` (p = (1+e) p_c)
or ``"newton"`` (u_n⁺ = −e u_n⁻).

Planar facets (d = 2) are solved in closed form: the slip keeps its sign until it
stops, so u(p) is piecewise linear with one break, and every end condition is a
linear or quadratic equation (:func:`planar_coulomb`). Spatial facets (d = 3) are
integrated by implicit steps in impulse space (:func:`spatial_coulomb`): each step
Δp takes the tangential impulse x with |x| ≤ μ Δp that opposes the slip at the step's
end — the minimiser of ½ xᵀW_tt x + bᵀx on that disc, a trust-region subproblem
solved by Newton's method on its secular equation — or, while the contact slips
through the whole step, at the step's midpoint (the same subproblem with W_tt/2).
Slip, stop, stick and reversal all come out of these steps; sticking is exact,
slipping second order in Δp, and a step in which the slip stops and reverses first
order. With the default 100 steps the relative error is ~1e-5 without reversal and
≲ 1e-3 with one (checked against :class:`mbimpact.CoulombLaw` and against the planar
closed form in the tests).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Literal

import numpy as np
from numpy.typing import NDArray

from ..common.validation import as_count, as_scalar
from ..errors import IntegrationError, ParameterError
from .base import FacetLaw

__all__ = ["CoulombFacet", "planar_coulomb", "spatial_coulomb", "RESTITUTIONS", "MAX_FACET_MU", "MIN_FACET_MU",
           "MAX_STEPS"]

Restitution = Literal["newton", "poisson", "energetic"]
RESTITUTIONS: tuple[Restitution, ...] = ("energetic", "poisson", "newton")

#: Friction coefficients of a facet: above 1e6 every facet that can stick sticks (friction is infinite
#: to rounding, and larger values overflow the impulse steps); below 1e-12 friction's impulse is far
#: below the quadrature's accuracy and μ acts as 0 (Newton's facet law).
MAX_FACET_MU = 1e6
MIN_FACET_MU = 1e-12

#: Impulse steps per unit of normal impulse: each facet takes up to 100 × steps of them (10⁴ steps
#: already resolve the friction impulse to 1e-5).
MAX_STEPS = 10_000


@dataclass(frozen=True)
class CoulombFacet(FacetLaw):
    """Coulomb's impact on each facet, in the facet's frame with W fixed.

    Parameters
    ----------
    e : float
        Restitution in [0, 1], meaning set by ``restitution``.
    mu : float
        Coulomb friction coefficient of the facet, in [0, 1e6] (:data:`MAX_FACET_MU`). With μ = 0
        the facet impact is Newton's (:class:`NewtonFacet`) for every hypothesis; μ below 1e-12
        (:data:`MIN_FACET_MU`) acts as 0.
    restitution : {"energetic", "poisson", "newton"}
        End-of-impact hypothesis (see :class:`mbimpact.CoulombLaw`).
    steps : int
        Spatial facets only: impulse steps per unit of the frictionless normal impulse
        −u_n / W_nn (:func:`spatial_coulomb`), 4 … 10⁴ (:data:`MAX_STEPS`).
    """

    e: float
    mu: float
    restitution: Restitution = "energetic"
    steps: int = 100
    name: ClassVar[str] = "coulomb"

    def __post_init__(self) -> None:
        object.__setattr__(self, "e", as_scalar("e", self.e, 0.0, 1.0))
        mu = as_scalar("mu", self.mu, 0.0, MAX_FACET_MU)
        object.__setattr__(self, "mu", 0.0 if mu < MIN_FACET_MU else mu)
        if not isinstance(self.restitution, str) or self.restitution not in RESTITUTIONS:
            raise ParameterError(f"restitution must be one of {', '.join(RESTITUTIONS)}; got {self.restitution!r}")
        object.__setattr__(self, "steps", as_count("steps", self.steps, 4, MAX_STEPS))

    def __repr__(self) -> str:
        extra = "" if self.restitution == "energetic" else f", restitution={self.restitution!r}"
        return f"CoulombFacet(e={self.e:g}, mu={self.mu:g}{extra})"

    def quadrature_rtol(self, d: int | None) -> float:
        """1e-4 on planar facets: the impulse is exact, but it has kinks in the facet's tilt where the
        contact starts to stick, so quadratures converge algebraically (~n⁻²); 0.1/steps (≥ 1e-4) on
        spatial ones (see :func:`spatial_coulomb`)."""
        return 1e-4 if d == 2 else max(1e-4, 0.1 / self.steps)

    def facet_impulse(self, W: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        if u.shape[1] == 2:
            return planar_coulomb(W, u, self.mu, self.e, self.restitution)
        return spatial_coulomb(W, u, self.mu, self.e, self.restitution, self.steps)


def planar_coulomb(W: NDArray[np.float64], u: NDArray[np.float64], mu: float, e: float,
                   restitution: Restitution = "energetic") -> NDArray[np.float64]:
    """Coulomb impacts in closed form on planar facets.

    Parameters
    ----------
    W : ndarray, shape (N, 2, 2)
        Facet-frame Delassus matrices [[a, b], [b, c]] (a = W_tt, b = W_tn, c = W_nn).
    u : ndarray, shape (N, 2)
        Facet-frame contact velocities (u_t, u_n), u_n < 0.
    mu, e : float
    restitution : {"energetic", "poisson", "newton"}

    Returns
    -------
    ndarray, shape (N, 2)
        (P_t, p) at the end of the impact.

    Notes
    -----
    Slip of sign s = sgn u_t: dP_t/dp = −μs, du/dp = (b − μsa, c − μsb) =: (g₁, h₁); it stops at
    p₁ = −u_t / g₁ if s g₁ < 0. Then it sticks (dP_t/dp = −b/a, du_n/dp = c − b²/a) if |b| ≤ μa,
    else slips the way of b (dP_t/dp = −μ sgn b, du_n/dp = c − μ|b|). Both later rates h₂ are
    > 0 for W ≻ 0, and h₁ ≤ 0 only if the slip stops, so u_n(p) crosses 0 once.
    """
    a, b, c = W[:, 0, 0], W[:, 0, 1], W[:, 1, 1]
    ut, un = u[:, 0], u[:, 1]
    scale = a + c
    a = np.maximum(a, 1e-15 * scale)  # a facet the mechanism cannot move tangentially
    s = np.sign(ut)
    g1, h1, r1 = b - mu * s * a, c - mu * s * b, -mu * s
    stops = s * g1 < 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        p1 = np.where(s == 0.0, 0.0, np.where(stops, -ut / np.where(stops, g1, 1.0), np.inf))
    stick = np.abs(b) <= mu * a
    s2 = np.sign(b)
    r2 = np.where(stick, -b / a, -mu * s2)
    h2 = np.maximum(np.where(stick, c - b * b / a, c - mu * s2 * b), 1e-15 * scale)
    finite = np.isfinite(p1)
    p1f = np.where(finite, p1, 0.0)
    v1 = un + h1 * p1f  # u_n at the break (meaningful where finite)
    w1 = un * p1f + 0.5 * h1 * p1f * p1f  # ∫₀^p₁ u_n dp

    def reach(v0: NDArray[np.float64], h: NDArray[np.float64], target: NDArray[np.float64]) -> NDArray[np.float64]:
        """q ≥ 0 with v0 q + h q²/2 = target on a piece where u_n increases through it (stable roots)."""
        disc = np.sqrt(np.maximum(v0 * v0 + 2.0 * h * target, 0.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            big = np.where(v0 > 0.0, 2.0 * target / (v0 + disc), (disc - v0) / h)
        return np.where(target <= 0.0, np.where(v0 >= 0.0, 0.0, big), big)

    # compression ends where u_n = 0
    with np.errstate(divide="ignore", invalid="ignore"):
        on1 = (h1 > 0.0) & (-un <= h1 * p1)
        pc = np.where(on1, -un / np.where(h1 > 0.0, h1, 1.0), p1f - v1 / h2)
    if restitution == "poisson":
        pf = (1.0 + e) * pc
    elif restitution == "newton":
        vf = -e * un
        with np.errstate(divide="ignore", invalid="ignore"):
            first = on1 & (vf <= un + h1 * p1)
            pf = np.where(first, (vf - un) / np.where(h1 > 0.0, h1, 1.0), p1f + (vf - v1) / h2)
    else:
        # the work ∫ u_n dp: W_c at p_c, then the end where it has risen by −e² W_c
        wc = np.where(on1, -0.5 * un * un / np.where(h1 > 0.0, h1, 1.0),
                      w1 + reach_neg(v1, h2))
        target = (1.0 - e * e) * wc  # ∫₀^p_f u_n dp
        q1 = reach(un, np.where(h1 > 0.0, h1, 1.0), target)  # root on the first piece
        first = on1 & (q1 <= p1)
        pf = np.where(first, q1, p1f + reach(v1, h2, target - w1))
    Pt = r1 * np.minimum(pf, p1) + r2 * np.maximum(pf - p1f, 0.0) * finite
    return np.column_stack([Pt, pf])


def reach_neg(v0: NDArray[np.float64], h: NDArray[np.float64]) -> NDArray[np.float64]:
    """∫ u_n dp from a point where u_n = v0 ≤ 0 to where u_n = 0, at slope h > 0: −v0²/(2h)."""
    return -0.5 * np.minimum(v0, 0.0) ** 2 / h


def spatial_coulomb(W: NDArray[np.float64], u: NDArray[np.float64], mu: float, e: float,
                    restitution: Restitution = "energetic", steps: int = 100, second_order: bool = True
                    ) -> NDArray[np.float64]:
    """Coulomb impacts on spatial facets by implicit steps in impulse space.

    Parameters
    ----------
    W : ndarray, shape (N, 3, 3)
        Facet-frame Delassus matrices.
    u : ndarray, shape (N, 3)
        Facet-frame contact velocities, u[:, 2] < 0.
    mu, e : float
    restitution : {"energetic", "poisson", "newton"}
    steps : int
        Steps per frictionless normal impulse −u_n / W_nn.
    second_order : bool
        Midpoint steps while slipping (default); False: implicit Euler throughout (first order).

    Returns
    -------
    ndarray, shape (N, 3)
        The impulses at the end of the impacts.

    Raises
    ------
    IntegrationError
        An impact still going after 100 × ``steps`` steps (a nearly singular W).
    """
    N = len(u)
    Wtt, Wtn, Wnn = W[:, :2, :2], W[:, :2, 2], W[:, 2, 2]
    lam, Q = np.linalg.eigh(Wtt)
    lam = np.maximum(lam, 1e-15 * (lam[:, 1:] + Wnn[:, None]))
    un0 = u[:, 2].copy()
    dp = -un0 / Wnn / steps
    ut, un = u[:, :2].copy(), u[:, 2].copy()
    Pt, pn = np.zeros((N, 2)), np.zeros(N)
    work = np.zeros(N)  # ∫ u_n dp: of compression, then (restarted at 0) of restitution
    wc = np.full(N, np.nan)  # the work of compression, once it has ended
    pc = np.full(N, np.nan)
    out = np.empty((N, 3))
    rows = np.arange(N)
    # a contact that sticks with |W_tt⁻¹ W_tn| ≤ μ sticks to the end: finished in closed form
    g_stick = -np.linalg.solve(Wtt, Wtn[:, :, None])[:, :, 0]
    can_stick = np.sqrt(np.einsum("ni,ni->n", g_stick, g_stick)) <= mu * (1 + 1e-12)
    schur = np.maximum(Wnn + np.einsum("ni,ni->n", Wtn, g_stick), 1e-15 * (Wnn + lam[:, 1]))
    for _ in range(100 * steps):
        if not rows.size:
            return out
        h = dp[rows]
        b = ut + Wtn[rows] * h[:, None]
        lam_r, Q_r = lam[rows], Q[rows]
        x, stuck = _disc_minimiser(lam_r, Q_r, b, mu * h)
        if second_order and not stuck.all():
            # slipping through the step: friction opposes the slip at the step's midpoint
            # (the same subproblem with W_tt/2 and b = u_t + W_tn h/2); kept unless it would stop there
            slip = ~stuck
            xm, mid_stop = _disc_minimiser(0.5 * lam_r[slip], Q_r[slip], ut[slip] + 0.5 * (b[slip] - ut[slip]),
                                           mu * h[slip])
            good = np.flatnonzero(slip)[~mid_stop]
            x[good] = xm[~mid_stop]
        ut_new = b + np.einsum("nij,nj->ni", Wtt[rows], x)
        un_new = un + np.einsum("ni,ni->n", Wtn[rows], x) + Wnn[rows] * h
        step_work = 0.5 * (un + un_new) * h
        # compression ends within this step: split it at u_n = 0
        ending = np.isnan(pc[rows]) & (un_new >= 0.0)
        theta_c = np.where(ending, -un / np.where(ending, un_new - un, 1.0), 0.0)
        part = theta_c * h * (un + 0.5 * theta_c * (un_new - un))  # work up to u_n = 0
        pc[rows] = np.where(ending, pn + theta_c * h, pc[rows])
        wc[rows] = np.where(ending, work + part, wc[rows])
        w_start = np.where(ending, 0.0, work)  # restitution work at the step's start (or at u_n = 0)
        w_end = np.where(ending, step_work - part, work + step_work)
        done_c = ~np.isnan(pc[rows])
        if restitution == "energetic":
            target = -e * e * wc[rows]
            fin = done_c & (w_end >= target)
            with np.errstate(divide="ignore", invalid="ignore"):
                frac = np.where(ending, theta_c + (1 - theta_c) * (target - w_start) / (w_end - w_start),
                                (target - w_start) / (w_end - w_start))
        elif restitution == "poisson":
            target = (1.0 + e) * pc[rows]
            fin = done_c & (pn + h >= target)
            frac = (target - pn) / h
        else:
            target = -e * un0[rows]
            fin = done_c & (un_new >= target)
            with np.errstate(divide="ignore", invalid="ignore"):
                frac = (target - un) / (un_new - un)
        frac = np.clip(np.nan_to_num(frac, nan=1.0), 0.0, 1.0)
        if fin.any():
            f = frac[fin]
            out[rows[fin], :2] = Pt[fin] + f[:, None] * x[fin]
            out[rows[fin], 2] = pn[fin] + f * h[fin]
        work_new = np.where(done_c, w_end, work + step_work)
        settled = ~fin & stuck & can_stick[rows]
        if settled.any():
            i = rows[settled]
            out[i] = _stick_to_the_end(Pt[settled] + x[settled], pn[settled] + h[settled], un_new[settled],
                                       work_new[settled], done_c[settled], pc[i], wc[i], g_stick[i], schur[i],
                                       un0[i], e, restitution)
        keep = ~fin & ~settled
        rows = rows[keep]
        ut, un, Pt = ut_new[keep], un_new[keep], (Pt + x)[keep]
        pn = (pn + h)[keep]
        work = work_new[keep]
    raise IntegrationError(f"a Coulomb facet impact still goes on after {100 * steps} impulse steps "
                           f"(normal impulse {pn[0]:.3g} for u_n = {un0[rows[0]]:.3g}): W is nearly singular")


def _stick_to_the_end(Pt: NDArray[np.float64], pn: NDArray[np.float64], un: NDArray[np.float64],
                      work: NDArray[np.float64], compressed: NDArray[np.bool_], pc: NDArray[np.float64],
                      wc: NDArray[np.float64], g: NDArray[np.float64], h: NDArray[np.float64],
                      un0: NDArray[np.float64], e: float, restitution: Restitution) -> NDArray[np.float64]:
    """The rest of impacts that stick from impulse ``pn`` on: dP_t/dp = g, du_n/dp = h > 0 (the Schur
    complement), so u_n is linear and its work quadratic. ``work`` is that of compression, or of
    restitution once ``compressed`` (then ``pc``, ``wc`` hold the end of compression)."""
    start = np.where(compressed, pn, pn - un / h)  # where restitution (u_n ≥ 0) begins
    pc = np.where(compressed, pc, start)
    wc = np.where(compressed, wc, work - 0.5 * un * un / h)
    v0 = np.where(compressed, un, 0.0)  # u_n at ``start``
    w0 = np.where(compressed, work, 0.0)  # restitution work at ``start``
    if restitution == "poisson":
        pf = (1.0 + e) * pc
    elif restitution == "newton":
        pf = start + np.maximum(-e * un0 - v0, 0.0) / h
    else:
        rest = np.maximum(-e * e * wc - w0, 0.0)
        pf = start + 2.0 * rest / (v0 + np.sqrt(v0 * v0 + 2.0 * h * rest) + 1e-300)
    pf = np.maximum(pf, pn)
    return np.column_stack([Pt + g * (pf - pn)[:, None], pf])


def _disc_minimiser(lam: NDArray[np.float64], Q: NDArray[np.float64], b: NDArray[np.float64],
                    r: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """argmin ½ xᵀ(Q Λ Qᵀ)x + bᵀx over |x| ≤ r, per row (lam (N, 2), Q (N, 2, 2), b (N, 2), r (N,)).

    Interior: x = −W_tt⁻¹ b (the contact sticks). Otherwise x = −(W_tt + νI)⁻¹ b with |x| = r,
    ν > 0 from Newton's method on 1/|x(ν)| = 1/r, which is monotone from ν = 0 (Moré–Sorensen).
    The post-step slip W_tt x + b = −ν x then opposes x: Coulomb's law at the step's end.
    """
    beta = np.einsum("nji,nj->ni", Q, b)  # Qᵀ b
    x0 = -beta / lam
    inside = np.einsum("ni,ni->n", x0, x0) <= r * r
    if inside.all():
        return np.einsum("nij,nj->ni", Q, x0), inside
    out = np.empty_like(x0)
    out[inside] = x0[inside]
    edge = ~inside
    be, la, re = beta[edge], lam[edge], r[edge]
    nu = np.zeros(len(be))
    for _ in range(60):
        denom = la + nu[:, None]
        xs = be / denom
        norm = np.sqrt(np.einsum("ni,ni->n", xs, xs))
        dphi = np.einsum("ni,ni->n", xs * xs, 1.0 / denom) / norm**3
        phi = 1.0 / norm - 1.0 / np.where(re > 0, re, 1.0)
        step = -phi / dphi
        nu = np.maximum(nu + step, 0.0)
        if np.all(np.abs(step) <= 1e-14 * (nu + la[:, 1])):
            break
    xe = -be / (la + nu[:, None])
    xe[re <= 0.0] = 0.0
    out[edge] = xe
    return np.einsum("nij,nj->ni", Q, out), inside

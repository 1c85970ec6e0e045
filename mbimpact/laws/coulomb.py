"""The axiomatic impact with Coulomb friction (Routh, Bolotov, Keller; Stronge).

The contact velocity is integrated in impulse space, u(P) = u₋ + W P, with the
normal impulse p_n as the clock. While the contact slips the friction impulse
opposes the current slip, dP_t = −μ û_t dp_n, so the slip direction can curve
(anisotropic W), stop, stick or reverse. When the slip stops the contact sticks
if the impulse ratio needed to keep u_t = 0, |W_tt⁻¹ W_tn|, is within μ;
otherwise it slips on along the direction that is invariant under the flow.
The impact ends by one of three restitution hypotheses:

* ``"newton"`` — kinematic: n·u₊ = −e n·u₋ (may create energy with slip reversal);
* ``"poisson"`` — kinetic: p_n = (1 + e) p_c, p_c the normal impulse at maximum compression;
* ``"energetic"`` — Stronge: the normal work in restitution is −e² times that of compression.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..common.validation import as_scalar
from ..errors import ParameterError
from ..results.impact import ContactImpulses
from .base import ImpactLaw
from .restitution import restitution_from

__all__ = ["CoulombLaw"]

_RESTITUTION = ("newton", "poisson", "energetic")


class CoulombLaw(ImpactLaw):
    """Impact with Coulomb friction throughout, in generalised coordinates.

    Works for any mechanism through the Delassus matrix W = J A⁻¹ Jᵀ, planar
    (d = 2) and spatial (d = 3); returns the same :class:`ImpactResult`.

    Parameters
    ----------
    e : float, optional
        Coefficient of restitution in [0, 1] (meaning set by ``restitution``).
    mu : float
        Coulomb friction coefficient, ≥ 0.
    restitution : {"newton", "poisson", "energetic"}
        End-of-impact hypothesis; "energetic" (Stronge) never creates energy.
    k : float, optional
        Kelvin–Voigt damping ratio instead of ``e``.
    rtol : float
        Relative tolerance of the impulse-space integration.
    """

    def __init__(
        self,
        e: float | None = None,
        mu: float = 0.0,
        restitution: Literal["newton", "poisson", "energetic"] = "energetic",
        *,
        k: float | None = None,
        rtol: float = 1e-10,
    ) -> None:
        self.e = restitution_from(e, k)
        self.mu = as_scalar("mu", mu, 0.0, math.inf)
        if restitution not in _RESTITUTION:
            raise ParameterError(f"restitution must be one of {', '.join(_RESTITUTION)}; got {restitution!r}")
        self.restitution = restitution
        self.rtol = as_scalar("rtol", rtol, 1e-14, 1e-2)

    def __repr__(self) -> str:
        return f"CoulombLaw(e={self.e:g}, mu={self.mu:g}, restitution={self.restitution!r})"

    def contact_impulses(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        P = np.stack([self._one(W, u) for u in U])
        return ContactImpulses(P, np.full(len(U), self.rtol), 1, "impulse-space")

    # ------------------------------------------------------------------ one impact
    def _stick_ratio(self, W: NDArray[np.float64]) -> NDArray[np.float64]:
        """dP_t / dp_n that keeps u_t = 0: −W_tt⁻¹ W_tn (minimum norm if W_tt is singular)."""
        return np.asarray(-np.linalg.lstsq(W[:-1, :-1], W[:-1, -1], rcond=1e-12)[0], dtype=float)

    def _invariant_slip(self, W: NDArray[np.float64]) -> NDArray[np.float64]:
        """Unit slip direction s kept by the flow from u_t = 0: W_tn − μ W_tt s ∥ +s."""
        Wtt, Wtn = W[:-1, :-1], W[:-1, -1]
        if len(Wtn) == 1:
            return np.array([math.copysign(1.0, Wtn[0])])

        def rate(theta: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
            s = np.array([math.cos(theta), math.sin(theta)])
            return Wtn - self.mu * Wtt @ s, s

        from scipy.optimize import brentq  # deferred: scipy.optimize costs 0.1 s to import

        def cross(theta: float) -> float:
            r, s = rate(theta)
            return float(r[0] * s[1] - r[1] * s[0])

        grid = np.linspace(0.0, 2 * math.pi, 721)
        vals = [cross(t) for t in grid]
        best = None
        for a, b, fa, fb in zip(grid, grid[1:], vals, vals[1:]):
            if fa == 0.0 or fa * fb < 0:
                theta = a if fa == 0.0 else brentq(cross, a, b, xtol=1e-14)
                r, s = rate(theta)
                growth = float(r @ s)
                if growth > 0 and (best is None or growth > best[0]):
                    best = (growth, s)
        if best is None:  # cannot happen when sticking is impossible; fall back to W_tn's direction
            return Wtn / np.linalg.norm(Wtn)
        return best[1]

    def _one(self, W: NDArray[np.float64], u0: NDArray[np.float64]) -> NDArray[np.float64]:
        """Integrate one impact from unit contact velocity u0 (local frame)."""
        from scipy.integrate import solve_ivp  # deferred: scipy.integrate costs 0.1 s to import

        d = len(u0)
        mu, e = self.mu, self.e
        un0 = float(u0[-1])
        scale = float(np.trace(W))
        atol = self.rtol * 1e-3 / scale
        tiny = 1e-9 * float(np.linalg.norm(u0))  # slip speed regarded as zero
        # a 3-D slip is stopped well above what the integrator resolves (≈ rtol): closer to
        # u_t = 0 it chatters in ever smaller steps without crossing the threshold
        stop_3d = max(tiny, 1e3 * self.rtol * float(np.linalg.norm(u0)))

        # state y = (P_t (d-1), work_n): the work of compression, then (restarted) of restitution; clock p_n
        def velocity(pn: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
            P = np.append(y[: d - 1], pn)
            return u0 + W @ P

        stick_rate = self._stick_ratio(W) if mu > 0 else np.zeros(d - 1)
        can_stick = mu > 0 and float(np.linalg.norm(stick_rate)) <= mu * (1 + 1e-12)
        pn, y = 0.0, np.zeros(d)  # P_t and work_n = ∫ u_n dp_n
        mode = "slip"
        ut = u0[:-1]
        if float(np.linalg.norm(ut)) <= tiny and mu > 0:
            mode = "stick" if can_stick else "reslip"
        direction = self._invariant_slip(W) if mode == "reslip" else np.zeros(d - 1)
        p_c: float | None = None  # normal impulse at maximum compression
        work_c: float | None = None
        # the normal impulse over which compression must end: u_n grows at rate W_nn while
        # slipping, but only at the Schur complement W_nn − W_ntW_tt⁻¹W_tn while sticking,
        # which a nearly singular W makes far smaller
        schur = float(W[-1, -1] + W[-1, :-1] @ stick_rate) if can_stick else float(W[-1, -1])
        horizon = 1e3 * abs(un0) * (1.0 / max(W[-1, -1], 1e-300) + 1.0 / max(schur, 1e-12 * scale) + 1.0 / scale)

        slip_sign = np.sign(u0[:-1])
        for _ in range(6):  # slip → stop → stick / reverse: a few phases at most
            def rhs(pn: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
                u = velocity(pn, y)
                if mu == 0.0:
                    dpt = np.zeros(d - 1)
                elif mode == "stick":
                    dpt = stick_rate
                elif mode == "reslip":
                    dpt = -mu * direction
                elif d == 2:
                    # planar slip keeps its sign until it stops: a constant (smooth) right-hand
                    # side lets the integrator step across u_t = 0 and the event find it
                    dpt = -mu * slip_sign
                else:
                    ut = u[:-1]
                    dpt = -mu * ut / max(float(np.linalg.norm(ut)), 1e-300)
                return np.append(dpt, u[-1])

            def compression_end(pn: float, y: NDArray[np.float64]) -> float:
                return float(velocity(pn, y)[-1])

            compression_end.terminal = True  # type: ignore[attr-defined]
            compression_end.direction = 1.0  # type: ignore[attr-defined]

            def finished(pn: float, y: NDArray[np.float64]) -> float:
                if p_c is None or work_c is None:  # both are set together, at maximum compression
                    return -1.0
                if self.restitution == "newton":
                    return float(velocity(pn, y)[-1]) + e * un0
                if self.restitution == "poisson":
                    return pn - (1.0 + e) * p_c
                return y[-1] + e * e * work_c  # energetic: W_r = −e² W_c (y[-1] = W_r after compression)

            finished.terminal = True  # type: ignore[attr-defined]
            finished.direction = 1.0  # type: ignore[attr-defined]

            def stops(pn: float, y: NDArray[np.float64]) -> float:
                if mode != "slip" or mu == 0.0:
                    return 1.0
                ut = velocity(pn, y)[:-1]
                if d == 2:
                    return float(ut[0]) * math.copysign(1.0, float(u0[0]) if u0[0] != 0 else 1.0)
                return float(np.linalg.norm(ut)) - stop_3d

            stops.terminal = True  # type: ignore[attr-defined]
            stops.direction = -1.0  # type: ignore[attr-defined]

            if mode == "slip" and mu > 0 and float(np.linalg.norm(velocity(pn, y)[:-1])) <= tiny:
                mode = "stick" if can_stick else "reslip"  # the slip stopped with the last phase
                direction = self._invariant_slip(W) if mode == "reslip" else np.zeros(d - 1)
            if p_c is None and float(velocity(pn, y)[-1]) >= 0.0:  # compression ended with the last phase
                p_c, work_c, y = pn, float(y[-1]), np.append(y[:-1], 0.0)
            if p_c is not None and (e == 0.0 or finished(pn, y) >= 0.0):
                return np.append(y[: d - 1], pn)
            events = [finished, stops] + ([compression_end] if p_c is None else [])
            # after compression the work restarts from 0; its tolerance stays that of the work
            # done so far (rtol |W_c|), as when it was accumulated on top of W_c
            tol = atol if work_c is None else np.append(np.full(d - 1, atol), max(atol, self.rtol * abs(work_c)))
            sol = solve_ivp(rhs, (pn, pn + horizon), y, method="DOP853", events=events,
                            rtol=self.rtol, atol=tol, dense_output=False)
            pn, y = float(sol.t[-1]), sol.y[:, -1]
            hit = [i for i, ev in enumerate(sol.t_events) if len(ev)]
            if sol.status != 1 or not hit:
                raise RuntimeError(f"Coulomb impact integration did not terminate: {sol.message}")
            which = events[min(hit, key=lambda i: sol.t_events[i][0])]  # the earliest event
            if which is finished:
                return np.append(y[: d - 1], pn)
            if which is compression_end:
                # the work restarts from 0: W_r = −e² W_c is then located to the precision of W_r
                # itself, not of W_c (u_n⁺ would otherwise carry an error of order sqrt(ε |W_c|))
                p_c, work_c, y = pn, float(y[-1]), np.append(y[:-1], 0.0)
                continue
            # slip stopped
            mode = "stick" if can_stick else "reslip"
            if mode == "reslip":
                direction = self._invariant_slip(W)
            elif d > 2:
                # the residual slip (≤ stop_3d) is what an exact stop would have removed: remove it
                # with the small tangential impulse −W_tt⁻¹ u_t, then stick
                ut_left = velocity(pn, y)[:-1]
                y = np.append(y[: d - 1] - np.linalg.lstsq(W[:-1, :-1], ut_left, rcond=1e-12)[0], y[-1])
        raise RuntimeError("Coulomb impact: too many phase changes")  # pragma: no cover

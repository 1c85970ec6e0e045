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

How it is computed
------------------
Write W = [[W_tt, b], [bᵀ, c]] (tangential block, coupling, normal entry). While the
tangential impulse grows at a constant rate g per unit of p_n, dP_t = g dp_n, the
contact velocity is linear in p_n, u(p_n + s) = u + s W [g; 1], and the normal work
∫u_n dp_n is quadratic: every event — the slip stops, compression ends, restitution
ends — is the root of a linear or quadratic equation. The rate is constant

* without friction (g = 0) and while sticking (g = −W_tt⁺ b);
* while the contact slips along a direction s that the flow keeps,
  b − μ W_tt s = λ s: always in the plane (d = 2), after a stop when sticking is
  impossible (λ > 0, the one root of a secular equation), and in space once the slip
  has settled on such a direction.

So planar impacts are closed forms (slip → stop → stick or reverse), and so are
spatial ones without friction, from normal incidence, along an invariant direction,
or when the slip surely stops during compression (the decay of u_tᵀ W_tt⁻¹ u_t
bounds the stop; what follows — Newton's or Poisson's end, or e = 0 — then does not
depend on how it stopped). Only a 3-D slip that still turns is integrated, and only
its one ODE, du_t/dp_n = b − μ W_tt û_t: the normal velocity follows from P, and the
normal work from the energy identity w = ΔT(P) + D with the friction dissipation
D = ∫μ|u_t| dp_n the integrated quantity, so that Stronge's end never creates energy
whatever the integration error. The integrator is Dormand–Prince 8(5,3) in floats
(the tableau unrolled); its steps never straddle u_t = 0, and each event is located
exactly (Newton on the step length, each iterate a full step from the last accepted
point). The turning slip hands over to a closed form as soon as the angle δ to the
stable invariant direction it approaches makes the rest a straight line within the
tolerance (δ (|u_t| + μ Δp) ≤ rtol), or once |u_t| is down to what the state resolves.

A residual slip left at a stop is removed by the tangential impulse −W_tt⁺ u_t, which
only dissipates (½ u_tᵀ W_tt⁺ u_t). A phase whose impulse lies in null(Jᵀ),
W [g; 1] = 0, jams the contact: Newton's and Stronge's targets are then out of reach
and the impact ends there. Everything works on unit contact velocities and on
W / tr W (the law is homogeneous: of degree 1 in u, of degree −1 in W), so no scale
between ~1e-300 and ~1e300 under- or overflows; a failure to integrate is an
:class:`~mbimpact.IntegrationError` saying where.
"""

from __future__ import annotations

import math
from operator import mul
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import DEGENERATE
from ..common.validation import as_scalar, check_in_range, quiet_overflow
from ..errors import IntegrationError, NoSeparationWarning, ParameterError, warn
from ..metric.delassus import ContactMetric
from ..results.impact import ContactImpulses, ImpactResult
from ..results.quantities import SEPARATION_RTOL
from .base import ImpactLaw
from .restitution import restitution_from

__all__ = ["CoulombLaw"]

_RESTITUTION = ("newton", "poisson", "energetic")

# Eigenvalues of W_tt / tr W below this count as zero (a rank-deficient tangential block).
_CUT = 1e-12
# A constant phase whose velocity rate |W [g; 1]| is below this (relative to (1 + |g|)², W / tr W
# and unit velocities) cannot change the contact velocity: more impulse is lost in null(Jᵀ).
_JAM = 64 * 2.220446049250313e-16
# Normal velocity (unit scale) regarded as zero when compression ends in such a phase.
_UN_ZERO = 1e-12
# A 3-D slip below this fraction of the tolerance has stopped (its remaining impulse is below it).
_STOP = 1e-2
_MAX_PHASES = 64
_MAX_STEPS = 100_000

# modes of the tangential motion
_FREE, _STICK, _RESLIP, _SLIP = 0, 1, 2, 3


# Friction coefficients beyond it are sticks within 1e-6 (a slip stops within a normal impulse
# 1/(μ α_min) of the impact's), and their slip stages fall below what the phases resolve.
_MU_MAX = 1e6


class CoulombLaw(ImpactLaw):
    """Impact with Coulomb friction throughout, in generalised coordinates.

    Works for any mechanism through the Delassus matrix W = J A⁻¹ Jᵀ, planar
    (d = 2) and spatial (d = 3); returns the same :class:`ImpactResult`.

    Parameters
    ----------
    e : float, optional
        Coefficient of restitution in [0, 1] (meaning set by ``restitution``).
    mu : float
        Coulomb friction coefficient in [0, 1e6] (beyond, friction is a stick to within 1e-6
        and the slip stops too early in the impact to be resolved).
    restitution : {"newton", "poisson", "energetic"}
        End-of-impact hypothesis; "energetic" (Stronge) never creates energy.
    k : float, optional
        Kelvin–Voigt damping ratio instead of ``e``.
    rtol : float
        Relative tolerance of the impulse-space integration, in [1e-14, 1e-2]; it only
        matters while a 3-D slip turns (every other phase is a closed form).

    Notes
    -----
    When the contact jams — the impulse that keeps it sticking lies in the null space
    of Jᵀ, so the contact velocity can no longer change — Newton's and Stronge's
    restitution cannot be reached; the impact then ends where the contact velocity
    stopped changing (plastically, n·u₊ = 0). Poisson's ends at p_n = (1 + e) p_c as
    always, the extra impulse doing nothing.

    Kinetic energy never grows for ``"poisson"`` and ``"energetic"`` beyond rounding:
    the energy change ΔT = Pᵀ(u₋ + u₊)/2 of the computed impulse errs by about
    ε cond(W) |P| (|u₋| + |u₊|), the error of solving W_tt g = −b and of u₊ = u₋ + W P
    (the tests allow 64 times that).

    ``result.nodes`` is the number of integration steps (1 when every phase was a closed
    form) and ``result.error_estimate`` is ``rtol`` when a turning slip was integrated,
    0 otherwise.
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
        self.mu = as_scalar("mu", mu, 0.0, _MU_MAX)
        if not isinstance(restitution, str) or restitution not in _RESTITUTION:
            raise ParameterError(f"restitution must be one of {', '.join(_RESTITUTION)}; got {restitution!r}")
        self.restitution = restitution
        self.rtol = as_scalar("rtol", rtol, 1e-14, 1e-2)

    def __repr__(self) -> str:
        return f"CoulombLaw(e={self.e:g}, mu={self.mu:g}, restitution={self.restitution!r})"

    # ------------------------------------------------------------------ core
    def contact_impulses(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        """Contact impulses for unit contact velocities, local frame.

        Parameters
        ----------
        W : ndarray, shape (d, d)
            Delassus matrix in the local frame (last axis along n⁰), d = 2 or 3.
        U : ndarray, shape (B, d)
            Unit pre-impact contact velocities, ``U[:, -1] < 0``.

        Returns
        -------
        ContactImpulses
            P (B, d); ``error`` is ``rtol`` for rows whose slip turned (integrated) and
            0 for closed forms; ``nodes`` the most integration steps a row took (1 when
            every row was a closed form); method ``"impulse-space"``.

        Raises
        ------
        IntegrationError
            The integration of a turning slip gave up (the message says where).
        """
        setup = _Setup(np.asarray(W, dtype=float), self.mu)
        rows = np.asarray(U, dtype=float).tolist()
        P = np.empty((len(rows), setup.d))
        err = np.zeros(len(rows))
        nodes = 1
        for i, u in enumerate(rows):
            Pi, steps = _Impact(self, setup, u).run()
            P[i] = Pi
            if steps:
                err[i] = self.rtol
                nodes = max(nodes, steps)
        P /= setup.tr  # the core works on W / tr W
        return ContactImpulses(P, err, nodes, "impulse-space")

    def apply_metric(self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]) -> ImpactResult:
        """:meth:`ImpactLaw.apply_metric` without the batch machinery: one impact in floats.

        The degenerate cases (no approach, n⁰ out of reach, rank-deficient J) take the
        general route, which names the error or reports the minimum-norm impulse.
        """
        J = metric.J
        with quiet_overflow():  # extreme magnitudes overflow silently here and are named below
            u = J @ v
        check_in_range("the contact velocity J v", u)
        n0 = R[:, -1]
        ul = (u @ R).tolist()  # local frame
        if not ul[-1] < 0.0:
            return super().apply_metric(metric, v, R)
        W = metric.W
        setup = _Setup(R.T @ W @ R, self.mu)
        # what ImpactLaw.impulses checks (n0ᵀWn0 > 0) and ContactMetric.range_projector tests
        # (spread_bound = det(W / tr W)), read off the setup instead of recomputed
        if not setup.c > DEGENERATE or not setup.det > 1e-12:
            return super().apply_metric(metric, v, R)
        big = max(abs(x) for x in ul)
        speed = big * math.sqrt(sum((x / big) ** 2 for x in ul))
        P_local, steps = _Impact(self, setup, [x / speed for x in ul]).run()
        with quiet_overflow():
            P = R @ np.array(P_local) * (speed / setup.tr)
            dv = metric.AinvJt @ P
            u_plus = u + W @ P
            v_plus = v + dv
        check_in_range("the impact's outcome (P, v₊ or u₊)", P, v_plus, u_plus)
        result = ImpactResult(
            v_minus=v.copy(), v_plus=v_plus, dv=dv, P=P, u_minus=u, u_plus=u_plus, n0=n0.copy(),
            A=metric.A, J=J, law=self, error_estimate=self.rtol if steps else 0.0, nodes=max(steps, 1),
            method="impulse-space",
        )
        if float(n0 @ u_plus) < -SEPARATION_RTOL * speed:  # as result.separates, without its arrays
            warn(NoSeparationWarning, f"{self!r}: the contact still approaches the surface after the impact "
                 f"(kappa = {result.kappa:.6g} < 0); further micro-impacts follow: use repeat=True to apply them")
        return result


# ---------------------------------------------------------------------- shared per W
class _Setup:
    """What every row at one Delassus matrix shares, for W / tr W, in floats.

    Attributes
    ----------
    d : int
        Contact-space dimension.
    tr : float
        tr W (the core works on W / tr W; impulses are divided by it at the end).
    W, A, Ainv : list of lists
        W / tr W, its tangential block W_tt and the pseudo-inverse W_tt⁺.
    b : list
        Coupling W_tn; c: the normal entry W_nn.
    alpha_min : float
        Smallest eigenvalue of W_tt (0 when cut).
    stick : list
        Sticking rate dP_t/dp_n = −W_tt⁺ b (keeps u_t = 0).
    can_stick : bool
        |stick| ≤ μ: a slip that stops sticks.
    reslip : list
        When it cannot stick: the unit slip direction s kept by the flow from u_t = 0,
        b − μ W_tt s = λ s with λ > 0 (unique: the only root of the secular equation
        to the right of −μ α_min); computed on first use.
    det : float
        det(W / tr W).
    """

    __slots__ = ("d", "tr", "W", "A", "Ainv", "b", "c", "mu", "alpha_min", "stick", "stick_norm",
                 "can_stick", "_reslip", "bnorm", "Anorm", "det")

    def __init__(self, W: NDArray[np.float64], mu: float) -> None:
        d = W.shape[0]
        tr = float(W[0, 0] + W[1, 1] + (W[2, 2] if d == 3 else 0.0))
        if not (tr > 0.0 and math.isfinite(tr)):
            raise IntegrationError(f"the Delassus matrix must have a positive finite trace, got {tr!r}")
        Wn = (W / tr).tolist()
        self.d, self.tr, self.W, self.mu = d, tr, Wn, mu
        self.c = Wn[-1][-1]
        b = [Wn[i][-1] for i in range(d - 1)]
        self.b = b
        self.A = A = [row[:-1] for row in Wn[:-1]]
        if d == 2:
            a = A[0][0]
            self.alpha_min = a if a > _CUT else 0.0
            self.Ainv = [[1.0 / a if a > _CUT else 0.0]]
            self.Anorm = abs(a)
        else:
            (a11, a12), (_, a22) = A
            m, half = 0.5 * (a11 + a22), 0.5 * (a11 - a22)
            hi = m + math.hypot(half, a12)
            det = a11 * a22 - a12 * a12
            lo = max(det / hi, 0.0) if hi > 0.0 else 0.0  # no cancellation in m − rad
            self.Anorm = hi
            if lo > _CUT:
                self.alpha_min = lo
                self.Ainv = [[a22 / det, -a12 / det], [-a12 / det, a11 / det]]
            else:  # rank ≤ 1: W_tt⁺ = q qᵀ / α along the one eigenvector left
                self.alpha_min = 0.0
                phi = 0.5 * math.atan2(2.0 * a12, a11 - a22)
                q1, q2 = math.cos(phi), math.sin(phi)
                inv = 1.0 / hi if hi > _CUT else 0.0
                self.Ainv = [[q1 * q1 * inv, q1 * q2 * inv], [q1 * q2 * inv, q2 * q2 * inv]]
        Ai = self.Ainv
        self.stick = g = [-sum(map(mul, row, b)) for row in Ai]
        self.stick_norm = math.sqrt(sum(x * x for x in g))
        self.bnorm = math.sqrt(sum(x * x for x in b))
        self.can_stick = mu > 0.0 and self.stick_norm <= mu * (1.0 + 1e-12)
        self._reslip: list[float] | None = None
        # det(W / tr W) (rotation-invariant): spread_bound's test of a rank-deficient W
        if d == 2:
            self.det = Wn[0][0] * Wn[1][1] - Wn[0][1] * Wn[1][0]
        else:
            (w11, w12, w13), (_, w22, w23), (_, _, w33) = Wn
            self.det = w11 * (w22 * w33 - w23 * w23) - w12 * (w12 * w33 - w23 * w13) + w13 * (w12 * w23 - w22 * w13)

    @property
    def reslip(self) -> list[float]:
        """Unit slip direction kept by the flow from u_t = 0 when the contact cannot stick."""
        if self._reslip is None:
            self._reslip = self._invariant_slip()[0]
        return self._reslip

    def rate(self, g: list[float]) -> list[float]:
        """W [g; 1]: d u / d p_n at tangential impulse rate g."""
        return [sum(map(mul, row[:-1], g)) + row[-1] for row in self.W]

    def _invariant_slip(self) -> tuple[list[float], float]:
        """The slip direction s leaving u_t = 0 when sticking is impossible, and its growth λ > 0.

        Solves (μ W_tt + λ) s = b, |s| = 1 for the root λ > 0 of the secular equation
        Σ b̃ᵢ² / (μ αᵢ + λ)² = 1 (eigenbasis of W_tt), which decreases for λ > −μ α_min:
        exactly one root, positive because |W_tt⁺ b| > μ.
        """
        b, mu = self.b, self.mu
        if self.d == 2:
            return [math.copysign(1.0, b[0])], abs(b[0]) - mu * self.A[0][0]
        (a11, a12), (_, a22) = self.A
        phi = 0.5 * math.atan2(2.0 * a12, a11 - a22)
        q = [(math.cos(phi), math.sin(phi)), (-math.sin(phi), math.cos(phi))]  # eigenvectors of W_tt
        alphas = [q[i][0] * (a11 * q[i][0] + a12 * q[i][1]) + q[i][1] * (a12 * q[i][0] + a22 * q[i][1])
                  for i in range(2)]
        bt = [q[i][0] * b[0] + q[i][1] * b[1] for i in range(2)]
        terms = [(max(alphas[i], 0.0) * mu, bt[i]) for i in range(2) if bt[i] != 0.0]

        def secular(lam: float) -> tuple[float, float]:
            # φ(λ) = 1/|x(λ)| − 1, x = (μα + λ)⁻¹ b̃: concave and increasing, so Newton from the
            # left converges monotonically; computed on ratios, which neither under- nor overflow
            r = [bi / (ai + lam) if ai + lam > 0.0 else math.copysign(math.inf, bi) for ai, bi in terms]
            n = math.hypot(*r)
            if not math.isfinite(n):
                return -1.0, 0.0
            return 1.0 / n - 1.0, sum((ri / n) ** 2 / (ai + lam) for ri, (ai, _) in zip(r, terms)) / n

        lo, hi = 0.0, max(self.bnorm, 1e-300)
        lam = 0.0
        for _ in range(200):
            val, der = secular(lam)
            if val < 0.0:
                lo = lam
            else:
                hi = lam
            if abs(val) <= 1e-15:
                break
            step = lam - val / der if der > 0.0 else math.inf
            lam = step if lo < step < hi else 0.5 * (lo + hi)
            if hi - lo <= 1e-16 * hi:
                break
        st = [bt[i] / (max(alphas[i], 0.0) * mu + lam) for i in range(2)]
        x = q[0][0] * st[0] + q[1][0] * st[1]
        z = q[0][1] * st[0] + q[1][1] * st[1]
        norm = math.hypot(x, z)
        x, z = x / norm, z / norm
        return [x, z], x * (b[0] - mu * (a11 * x + a12 * z)) + z * (b[1] - mu * (a12 * x + a22 * z))


# ---------------------------------------------------------------------- one impact
_DOP_STEP: Any = None


def _dop853_step() -> Any:
    """One Dormand–Prince 8(5,3) step (Hairer's DOP853) for the state (P_t1, P_t2, D), built once.

    ``step(f, p, y0, y1, y2, k0, h)`` returns the new state and the pair of embedded error
    vectors (5th and 3rd order) of the three components. The tableau (50 non-zero a_ij) is
    unrolled into straight-line float arithmetic: a loop over stages costs CPython ~3× more.
    The third component (the dissipation D) does not feed back into f, so its stages are
    not formed.
    """
    global _DOP_STEP
    if _DOP_STEP is None:
        # deferred: scipy.integrate costs 0.1 s to import and only a turning 3-D slip needs it
        from scipy.integrate._ivp import dop853_coefficients as tab

        n = tab.N_STAGES

        def combo(weights: Any, comp: int) -> str:
            return " + ".join(f"{float(w)!r} * k{j}_{comp}" for j, w in enumerate(weights) if w != 0.0) or "0.0"

        lines = ["def step(f, p, y0, y1, y2, k0, h):", "    k0_0, k0_1, k0_2 = k0"]
        for i in range(1, n):
            a = tab.A[i, :i]
            lines.append(f"    k{i}_0, k{i}_1, k{i}_2 = f(p + {float(tab.C[i])!r} * h, "
                         f"y0 + h * ({combo(a, 0)}), y1 + h * ({combo(a, 1)}))")
        new = ", ".join(f"y{c} + h * ({combo(tab.B, c)})" for c in range(3))
        e5 = ", ".join(combo(tab.E5[:n], c) for c in range(3))
        e3 = ", ".join(combo(tab.E3[:n], c) for c in range(3))
        lines.append(f"    return ({new}), ({e5}), ({e3})")
        namespace: dict[str, Any] = {}
        exec("\n".join(lines), namespace)  # noqa: S102 — our own tableau, formatted above
        _DOP_STEP = namespace["step"]
    return _DOP_STEP


class _Impact:
    """One impact from a unit contact velocity u₋ (local frame, W / tr W).

    State: the normal impulse p (the clock), the tangential impulse P_t, the normal
    work ``w`` of the current stage (compression, then restitution from 0; NaN when a
    certified stop skipped a slip whose work is never read), the stage (with p_c and
    W_c once compression ended) and, in :meth:`run`, the tangential mode (free, stick,
    reslip, slip along a fixed or a turning direction). ``run`` returns the impulse
    P = (P_t, p) for W / tr W and the number of integration steps (0 for closed forms).
    """

    def __init__(self, law: CoulombLaw, setup: _Setup, u: list[float]) -> None:
        self.law, self.s, self.u0 = law, setup, u
        self.e, self.kind, self.mu = law.e, law.restitution, setup.mu
        self.un0 = u[-1]
        self.p, self.Pt, self.w = 0.0, [0.0] * (setup.d - 1), 0.0
        self.compressing = True
        self.pc, self.Wc = 0.0, 0.0
        self.steps = 0
        self.tol = 0.1 * law.rtol  # velocity tolerance of a phase hand-over (unit speed)
        self._slip_stopped = False  # set by _constant_phase

    # ---------------------------------------------------------------- helpers
    def velocity(self) -> list[float]:
        """u = u₋ + W P at the current state."""
        P = self.Pt + [self.p]
        return [ui + sum(map(mul, row, P)) for ui, row in zip(self.u0, self.s.W)]

    def _target_work(self) -> float:
        """Stronge: restitution ends when its work reaches −e² W_c."""
        return 0.0 if self.e == 0.0 else -self.e * self.e * self.Wc

    def _poisson_left(self, p: float) -> float:
        """Normal impulse from p to Poisson's end (1 + e) p_c, as e p_c + (p_c − p): exact for a tiny e."""
        return self.e * self.pc + (self.pc - p)

    def _stage_length(self, un: float, rho_n: float) -> float:
        """Normal impulse until compression or the impact ends in a phase of constant rate."""
        if self.compressing:
            if un >= 0.0:
                return 0.0
            return -un / rho_n if rho_n > 0.0 else math.inf
        kind = self.kind
        if kind == "poisson":
            return max(self._poisson_left(self.p), 0.0)
        if kind == "newton":
            gap = -self.e * self.un0 - un
            if gap <= 0.0:
                return 0.0
            return gap / rho_n if rho_n > 0.0 else math.inf
        rem = self._target_work() - self.w  # energetic: w + un s + rho_n s²/2 = target
        if rem <= 0.0:
            return 0.0
        disc = un * un + 2.0 * rho_n * rem
        if rho_n > 0.0 and un < 0.0:
            return (-un + math.sqrt(disc)) / rho_n
        if disc >= 0.0 and un + math.sqrt(disc) > 0.0:
            return 2.0 * rem / (un + math.sqrt(disc))  # the smaller root, without cancellation
        return math.inf

    def _end_stage(self) -> bool:
        """Compression ended (start restitution, return False) or the impact did (True)."""
        if self.compressing:
            self.compressing = False
            self.pc, self.Wc, self.w = self.p, self.w, 0.0
            return self.e == 0.0  # every hypothesis ends a plastic impact at maximum compression
        return True

    def _stopped_mode(self) -> int:
        """The mode after the slip stopped: stick (removing the residual slip) or slip on."""
        s = self.s
        if s.can_stick:
            # the residual slip (what an exact stop would have removed, ≤ the tolerance) goes with
            # the tangential impulse −W_tt⁺ u_t: it only dissipates, ½ u_tᵀ W_tt⁺ u_t
            vt = self.velocity()[:-1]
            self.Pt = [P - sum(map(mul, row, vt)) for P, row in zip(self.Pt, s.Ainv)]
            return _STICK
        return _RESLIP

    # ---------------------------------------------------------------- driver
    def run(self) -> tuple[list[float], int]:
        s = self.s
        vt = self.u0[:-1]
        r = math.sqrt(sum(x * x for x in vt))
        whole = self._whole_impact(vt, r)
        if whole is not None:
            return whole, 0
        direction: list[float] | None = None  # slip direction of a straight slip
        if self.mu == 0.0:
            mode = _FREE
        elif r == 0.0:
            mode = _STICK if s.can_stick else _RESLIP
        elif s.d == 2:
            mode, direction = _SLIP, [math.copysign(1.0, vt[0])]
        else:
            mode = _SLIP  # direction None: a 3-D slip that may turn
        for _ in range(_MAX_PHASES):
            if mode == _SLIP and direction is None:
                done, mode, direction = self._turning_slip()
                if done:
                    break
                continue
            if self._constant_phase(mode, direction):
                break
            if mode == _SLIP and self._slip_stopped:
                mode, direction = self._stopped_mode(), None
        else:  # pragma: no cover - each phase either ends a stage or stops the slip
            raise IntegrationError(f"Coulomb impact: more than {_MAX_PHASES} phases at p_n = {self.p:.6g}")
        return self.Pt + [self.p], self.steps

    # ---------------------------------------------------------------- closed forms
    def _rate_of(self, mode: int, direction: list[float] | None) -> list[float]:
        s = self.s
        if mode == _FREE:
            return [0.0] * (s.d - 1)
        if mode == _STICK:
            return s.stick
        if mode == _RESLIP:
            return [-self.mu * x for x in s.reslip]
        assert direction is not None
        return [-self.mu * x for x in direction]

    def _constant_phase(self, mode: int, direction: list[float] | None) -> bool:
        """Advance through one phase of constant tangential rate to its first event.

        Returns True when the impact ended; sets ``_slip_stopped`` when the slip stopped.
        """
        s = self.s
        self._slip_stopped = False
        g = self._rate_of(mode, direction)
        rho = s.rate(g)
        u = self.velocity()
        un, rho_n = u[-1], rho[-1]
        gnorm = math.sqrt(sum(x * x for x in g))
        # W [g; 1] errs by ~ε (1 + |g|)² (g = −W_tt⁺ b itself carries ε |g| cond W_tt), and
        # u = u₋ + W P by ~ε (1 + |P|)
        noise = max(_UN_ZERO, _JAM * (1.0 + self.p + math.sqrt(sum(x * x for x in self.Pt))))
        if math.sqrt(sum(x * x for x in rho)) <= _JAM * (1.0 + gnorm) ** 2:
            # a jam: the impulse lies in null(Jᵀ), so u — and v₊, I = JᵀP — can no longer change;
            # any further impulse is invisible and the impact ends here, for every hypothesis
            if self.compressing and un < -noise:  # energy forbids it
                raise IntegrationError(
                    f"Coulomb impact: the contact jams while still approaching (n·u = {un:.3g} at p_n = "
                    f"{self.p:.6g}, mode {('free', 'stick', 'reslip', 'slip')[mode]}): W is too close to "
                    "singular for the contact to be stopped")
            if self.compressing:
                self._end_stage()
            return True
        length = self._stage_length(un, rho_n)
        stop = math.inf
        if mode == _SLIP:
            assert direction is not None
            along = sum(map(mul, u[:-1], direction))  # slip speed along the (invariant) direction
            lam = sum(map(mul, rho[:-1], direction))
            if along <= 0.0:
                stop = 0.0
            elif lam < 0.0:
                stop = along / -lam
        ds = min(length, stop)
        if ds == math.inf:
            # the velocity moves but never reaches the event (u_n falling, or Newton's target above
            # where it levels off): energy forbids it in compression; in restitution the target is
            # out of reach and the impact ends here
            if self.compressing:
                if un < -noise:
                    raise IntegrationError(
                        f"Coulomb impact: compression cannot end (n·u = {un:.3g} with rate {rho_n:.3g} at "
                        f"p_n = {self.p:.6g}, mode {('free', 'stick', 'reslip', 'slip')[mode]}); W is too close "
                        "to singular for the contact to be stopped")
                self._end_stage()  # the contact has stopped to rounding: a jam in all but name
            return True
        if not math.isfinite(ds * (1.0 + gnorm)):
            raise IntegrationError(f"Coulomb impact: a phase of infinite length at p_n = {self.p:.6g}")
        self.p += ds
        self.Pt = [P + gi * ds for P, gi in zip(self.Pt, g)]
        self.w += ds * (un + 0.5 * rho_n * ds)
        if length <= stop:
            return self._end_stage()
        self._slip_stopped = True
        return False

    # ---------------------------------------------------------------- the turning 3-D slip
    def _fixed_point(self, theta: float) -> tuple[float, float, float, float] | None:
        """The invariant slip direction nearest θ by Newton: (θ*, λ*, dh/dθ at θ*, h(θ)) or None.

        h(θ) = s⊥·(b − μ W_tt s) vanishes where the flow keeps the direction s(θ); the slip
        angle moves monotonically, with the sign of h, towards the next such direction.
        """
        s, mu = self.s, self.mu
        (a11, a12), (_, a22) = s.A
        b1, b2 = s.b
        t = theta
        h0 = math.nan
        negligible = 1e-15 * (s.bnorm + mu * s.Anorm)  # h ≡ 0 for W_tn = 0 and an isotropic W_tt
        for it in range(8):
            c, sn = math.cos(t), math.sin(t)
            F1, F2 = b1 - mu * (a11 * c + a12 * sn), b2 - mu * (a12 * c + a22 * sn)
            h = -sn * F1 + c * F2
            if it == 0:
                h0 = h
            f = c * F1 + sn * F2
            dh = -f - mu * (a11 * sn * sn - 2.0 * a12 * sn * c + a22 * c * c)
            if abs(h) <= negligible:
                break
            if dh == 0.0:
                return None
            step = h / dh
            t -= step
            if abs(step) <= 1e-15:
                break
        else:
            return None
        if abs(t - theta) > 0.5:
            return None
        c, sn = math.cos(t), math.sin(t)
        F1, F2 = b1 - mu * (a11 * c + a12 * sn), b2 - mu * (a12 * c + a22 * sn)
        f = c * F1 + sn * F2
        dh = -f - mu * (a11 * sn * sn - 2.0 * a12 * sn * c + a22 * c * c)
        return t, f, dh, h0

    def _snap(self, vt: list[float], r: float, force: bool = False) -> list[float] | None:
        """The invariant direction to continue straight along, if that is within the tolerance.

        Continuing along s* instead of the turning û_t changes the friction direction by the
        angle δ between them, which near a stable s* decays over a normal impulse of about
        r / |h'(θ*)|, and leaves the transverse slip r δ in place (removed at the stop):
        accepted when δ (r + μ min(Δp, 2 r / |h'|)) ≤ rtol, Δp the length of that straight
        phase. ``force``: the slip is down at the noise of the state, so δ means nothing;
        any stable direction close by is taken.
        """
        theta = math.atan2(vt[1], vt[0])
        if not force:
            # one Newton step first: far from any invariant direction, no need to find it
            s, mu = self.s, self.mu
            (a11, a12), (_, a22) = s.A
            c, sn = vt[0] / r, vt[1] / r
            F1, F2 = s.b[0] - mu * (a11 * c + a12 * sn), s.b[1] - mu * (a12 * c + a22 * sn)
            slope = -(c * F1 + sn * F2) - mu * (a11 * sn * sn - 2.0 * a12 * sn * c + a22 * c * c)
            h = abs(-sn * F1 + c * F2)
            if h * r > 10.0 * self.law.rtol * abs(slope) and h > 1e-15 * (s.bnorm + mu * s.Anorm):
                return None
        found = self._fixed_point(theta)
        if found is None:
            return None
        t, lam, dh, h0 = found
        delta = abs(t - theta)
        # on it to rounding (the flow keeps an exactly invariant slip), or approaching a stable one
        if (delta > 1e-14 or force) and not (dh < 0.0 and ((t - theta) * h0 > 0.0 or force)):
            return None
        direction = [math.cos(t), math.sin(t)]
        if force:
            return direction
        rtol = self.law.rtol
        if delta * r > rtol:
            return None
        # the length of the straight phase: to the stop, or to the next stage event
        rho = self.s.rate([-self.mu * direction[0], -self.mu * direction[1]])
        along = vt[0] * direction[0] + vt[1] * direction[1]
        ds = self._stage_length(self.velocity()[-1], rho[-1])
        if lam < 0.0:
            ds = min(ds, along / -lam)
        if delta > 1e-14:
            ds = min(ds, 2.0 * r / -dh)
        if delta * (r + self.mu * ds) > rtol:
            return None
        return direction

    def _whole_impact(self, vt: list[float], r: float) -> list[float] | None:
        """The impulse in one formula when the tangential rate never changes, or ends up not mattering.

        With a constant rate g the normal velocity is linear, u_n = u_n⁻ + k p (k = c + bᵀg), so
        all three hypotheses end at p = (1 + e) |u_n⁻| / k: without friction (g = 0), sticking
        from normal incidence (g = −W_tt⁺ b, k the Schur complement), slipping from normal
        incidence along the invariant direction (g = −μ s). A slip certain to stop during
        compression (:meth:`_certified_stick`) leaves the sticking state u_t = 0, P_t =
        −W_tt⁻¹(u_t⁻ + b p), at every later p; Newton's end (u_n = −e u_n⁻), Poisson's
        (p = (1 + e) p_c) and e = 0 follow from u_n = u_n⁻ − bᵀW_tt⁻¹u_t⁻ + S p.
        Returns None otherwise (or for a jam, k ≈ 0).
        """
        s, e, un0 = self.s, self.e, self.un0
        if self.mu == 0.0 or r == 0.0:
            g = [0.0] * (s.d - 1) if self.mu == 0.0 else s.stick if s.can_stick else [-self.mu * x for x in s.reslip]
            k = s.rate(g)[-1]
            if not k > _JAM * (1.0 + sum(x * x for x in g)):
                return None
            p = (1.0 + e) * -un0 / k
            return [x * p for x in g] + [p]
        if s.d != 3 or not self._stops_in_compression(vt):
            return None
        Ai, b = s.Ainv, s.b
        S = s.c + b[0] * s.stick[0] + b[1] * s.stick[1]
        if not S > _JAM * (1.0 + s.stick_norm) ** 2:
            return None
        beta = sum(b[i] * sum(map(mul, Ai[i], vt)) for i in range(2))  # bᵀ W_tt⁻¹ u_t⁻
        if self.kind == "newton":
            p = (-(1.0 + e) * un0 + beta) / S
        else:  # poisson, or e = 0
            p = (1.0 + e) * (-un0 + beta) / S
        return [-sum(Ai[i][j] * (vt[j] + b[j] * p) for j in range(2)) for i in range(2)] + [p]

    def _stops_in_compression(self, vt: list[float]) -> float | None:
        """A normal impulse by which the slip has surely stopped, before compression can end; or None.

        With V = u_tᵀ W_tt⁻¹ u_t, dV/dp ≤ −2 |u_t| (μ − |W_tt⁻¹ b|) ≤ −2 (μ − |g|) √(α_min V): the
        slip stops before Δp = √V₀ / ((μ − |g|) √α_min). Compression cannot end before
        −u_n / (c + μ |b|) (|du_n/dp| is at most that, slipping or sticking). Only when
        nothing after depends on how the slip stopped: Newton's and Poisson's restitution,
        and e = 0 (Stronge's would need the work of the slip).
        """
        s = self.s
        if not (self.compressing and s.can_stick and s.alpha_min > 0.0):
            return None
        if self.kind == "energetic" and self.e > 0.0:
            return None
        margin = self.mu - s.stick_norm
        if not margin > 1e-9 * self.mu:
            return None
        Ai = s.Ainv
        V = sum(vt[i] * sum(map(mul, Ai[i], vt)) for i in range(2))
        bound = 1.000001 * math.sqrt(max(V, 0.0)) / (margin * math.sqrt(s.alpha_min))
        un = self.velocity()[-1]
        earliest = -un / (s.c + self.mu * s.bnorm)
        return bound if bound < 0.5 * earliest else None

    def _certified_stick(self, vt: list[float]) -> bool:
        """Jump over a slip that surely stops during compression (:meth:`_stops_in_compression`)
        to the sticking state, when nothing after depends on how it stopped."""
        s = self.s
        bound = self._stops_in_compression(vt)
        if bound is None:
            return False
        Ai = s.Ainv
        # the sticking state at p + bound: u_t = 0, so P_t = P_t − W_tt⁻¹(u_t + b Δp)
        self.p += bound
        self.Pt = [P - sum(Ai[i][j] * (vt[j] + s.b[j] * bound) for j in range(2)) for i, P in enumerate(self.Pt)]
        self.w = math.nan  # not needed: no restitution hypothesis used here reads W_c
        return True

    def _turning_slip(self) -> tuple[bool, int, list[float] | None]:
        """A 3-D slip whose direction may turn: closed forms where possible, else integrate.

        Returns (impact ended, next mode, straight direction or None).
        """
        u = self.velocity()
        vt = u[:-1]
        r = math.hypot(vt[0], vt[1])
        if r <= _STOP * self.tol:
            return False, self._stopped_mode(), None
        if self._certified_stick(vt):
            return False, _STICK, None
        direction = self._snap(vt, r)
        if direction is not None:
            return False, _SLIP, direction
        return self._integrate()

    def _integrate(self) -> tuple[bool, int, list[float] | None]:
        """Integrate du_t/dp = b − μ W_tt û_t by DOP853 until the slip settles, stops or the impact ends.

        The integration runs on increments from a base point (the phase start, then the end
        of compression): the clock s = p − p_b and the state y = (ΔP_t1, ΔP_t2, D), D = ∫ μ |u_t| dp
        the friction dissipation since the base. The normal work is not integrated but read
        from the energy identity, w = w_b + ΔT + D with ΔT = ΔPᵀ u_b + ½ ΔPᵀ W ΔP exact for the
        increment ΔP: so Stronge's end, w = −e² W_c, leaves T₊ − T₋ = (1 − e²) W_c − D ≤ 0 up to
        rounding, whatever the integration error (which only moves the path). ΔT and D nearly
        cancel (w ≈ ½ (du_n/dp) s² near the end of compression while ΔT ≈ −D ≈ −μ |u_t| s), so
        they are formed from the increments themselves, which carry their own relative precision:
        from the absolute impulses (P − P_b, p − p_b) w would err by ~ε |u_t| |P|, and a small
        restitution target e² |W_c| would be located only to ~√ε in p_n.

        Steps never reach past where the slip, continued straight, would stop
        (r / |dr/dp|), and a step that turns u_t through 0 is refused, so no step straddles
        the discontinuity at u_t = 0. Near a stop the solution is self-similar (it scales
        with r = |u_t|), so step proposals shrink with r. Events (compression end, Newton's
        or Stronge's end) are located by :meth:`_locate`; a stage whose event function is
        already ≥ 0 at its base point (a restitution target within rounding of where
        compression ended, e.g. e² W_c or e u_n⁻ below the smallest float for a tiny e) ends
        there, since no crossing from below would ever be seen.
        """
        s, mu = self.s, self.mu
        dop = _dop853_step()
        (a11, a12), (_, a22) = s.A
        b1, b2 = s.b
        c = s.c
        un0 = self.un0
        rtol = self.law.rtol
        atol = 0.1 * rtol
        # the base point: p_b, P_t at it, the stage's work w_b there and the velocity u_b there
        pb, Pb1, Pb2, wb = self.p, self.Pt[0], self.Pt[1], self.w
        ub = self.velocity()

        def f(t: float, d1: float, d2: float) -> tuple[float, float, float]:
            v1 = ub[0] + a11 * d1 + a12 * d2 + b1 * t
            v2 = ub[1] + a12 * d1 + a22 * d2 + b2 * t
            k = -mu / math.hypot(v1, v2)
            return k * v1, k * v2, ub[2] + b1 * d1 + b2 * d2 + c * t  # dP_t/dp, u_n = dw/dp

        def step(t: float, y: list[float], k0: tuple[float, float, float], h: float) -> tuple[list[float], float]:
            """One DOP853 step: the new state and the error norm (≤ 1: accept), scaled on the impulses."""
            new, e5, e3 = dop(f, t, y[0], y[1], y[2], k0, h)
            n5 = n3 = 0.0
            for base, old, nw, x5, x3 in zip((Pb1, Pb2, 0.0), y, new, e5, e3):
                sc = atol + rtol * max(abs(base + old), abs(base + nw))
                n5 += (x5 / sc) ** 2
                n3 += (x3 / sc) ** 2
            if n5 == 0.0 and n3 == 0.0:
                return list(new), 0.0
            return list(new), abs(h) * n5 / math.sqrt((n5 + 0.01 * n3) * 3.0)

        def work(t: float, y: list[float]) -> float:
            return wb + y[2]

        def event(t: float, y: list[float], k: tuple[float, float, float]) -> tuple[float, float]:
            """The stage's event function g (crosses 0 upwards) and dg/dp."""
            un = ub[2] + b1 * y[0] + b2 * y[1] + c * t
            if self.compressing:
                return un, c + b1 * k[0] + b2 * k[1]
            if self.kind == "newton":
                return un + self.e * un0, c + b1 * k[0] + b2 * k[1]
            if self.kind == "poisson":
                return -1.0, 0.0  # its end is a value of p_n: the step is cut there
            return work(t, y) - self._target_work(), un

        def slip(t: float, y: list[float]) -> tuple[float, float, float]:
            v1 = ub[0] + a11 * y[0] + a12 * y[1] + b1 * t
            v2 = ub[1] + a12 * y[0] + a22 * y[1] + b2 * t
            return v1, v2, math.hypot(v1, v2)

        def settle(t: float, y: list[float]) -> None:
            self.p, self.Pt, self.w = pb + t, [Pb1 + y[0], Pb2 + y[1]], work(t, y)

        t, y = 0.0, [0.0, 0.0, 0.0]
        k = f(t, 0.0, 0.0)
        while event(t, y, k)[0] >= 0.0:  # the stage has ended at its base point
            if self._end_stage():
                return True, _SLIP, None
            wb = self.w  # 0: the work of restitution starts here
        v1, v2, r = slip(t, y)
        h = 0.1 * r / max(s.bnorm + mu * s.Anorm, 1e-300)  # |du_t/dp| ≤ |b| + μ |W_tt|
        for _ in range(_MAX_STEPS):
            # the slip continued straight would stop after r / |dr/dp|: step a fraction of that at most
            dr = (v1 * (b1 + a11 * k[0] + a12 * k[1]) + v2 * (b2 + a12 * k[0] + a22 * k[1])) / r
            if dr < 0.0:
                h = min(h, 0.8 * r / -dr)
            end = math.inf
            if not self.compressing and self.kind == "poisson":
                end = self._poisson_left(pb) - t
                if end <= 0.0:
                    return True, _SLIP, None
                h = min(h, end)
            new, err = step(t, y, k, h)
            self.steps += 1
            t_new = t + h
            w1, w2, r_new = slip(t_new, new)
            if not err <= 1.0 or w1 * v1 + w2 * v2 <= 0.0:  # refused (a turn through u_t = 0 too)
                h *= max(0.2, 0.9 * err ** -0.125) if 1.0 < err < math.inf else 0.2
                if h <= 1e-15 * max(pb + t, 1e-300):
                    raise IntegrationError(
                        f"Coulomb impact: the slip integration stalled at p_n = {pb + t:.6g} (|u_t| = {r:.3g}, "
                        f"{'compression' if self.compressing else 'restitution'})")
                continue
            k_new = f(t_new, new[0], new[1])
            g0, dg0 = event(t, y, k)
            g1, dg1 = event(t_new, new, k_new)
            ended = end == h
            if g1 >= 0.0 and g0 < 0.0:
                tau = self._locate(step, event, f, t, y, k, h, g0, dg0, g1, dg1, pb)
                if tau < h:
                    t_new = t + tau
                    new, _ = step(t, y, k, tau)
                    k_new = f(t_new, new[0], new[1])
                settle(t_new, new)
                if self._end_stage():
                    return True, _SLIP, None
                # the work restarts from 0 at the end of compression: a new base point
                pb, Pb1, Pb2, wb = self.p, self.Pt[0], self.Pt[1], self.w
                ub = self.velocity()
                t_new, new = 0.0, [0.0, 0.0, 0.0]
                k_new = f(0.0, 0.0, 0.0)
                w1, w2, r_new = slip(0.0, new)
                if event(0.0, new, k_new)[0] >= 0.0:  # restitution ends where it starts
                    self._end_stage()
                    return True, _SLIP, None
            elif ended:  # Poisson's end
                settle(t_new, new)
                return True, _SLIP, None
            grow = min(10.0, 0.9 * err ** -0.125) if err > 0.0 else 10.0
            h *= grow * min(1.0, r_new / r)
            t, y, k, v1, v2, r = t_new, new, k_new, w1, w2, r_new
            settle(t, y)
            # what u_t = u₋ + W_tt P_t + b p is worth: below that the slip has stopped for all we know
            floor = max(_STOP * self.tol, rtol * (s.Anorm * math.hypot(*self.Pt) + s.bnorm * self.p))
            if r <= floor:
                direction = self._snap([v1, v2], r, force=True)
                if direction is None:
                    return False, self._stopped_mode(), None
                return False, _SLIP, direction
            direction = self._snap([v1, v2], r)
            if direction is not None:
                return False, _SLIP, direction
        raise IntegrationError(
            f"Coulomb impact: the slip integration took more than {_MAX_STEPS} steps and reached p_n = "
            f"{pb + t:.6g} (|u_t| = {r:.3g})")

    def _locate(self, step: Any, event: Any, f: Any, p: float, y: list[float], k: tuple[float, float, float], h: float,
                g0: float, dg0: float, g1: float, dg1: float, origin: float = 0.0) -> float:
        """The step length τ ∈ (0, h] at which the event function crosses 0.

        A cubic Hermite guess from both ends (the dense output), then Newton on τ with
        each g(τ) from a full step of length τ, bracketed by bisection, down to the rounding
        of the normal impulse origin + p + τ (``p`` is counted from ``origin``).
        """
        # Hermite cubic on [0, 1] from both ends: the first guess
        m0, m1 = dg0 * h, dg1 * h
        t = g0 / (g0 - g1)
        for _ in range(30):
            t2, t3 = t * t, t * t * t
            val = (2 * t3 - 3 * t2 + 1) * g0 + (t3 - 2 * t2 + t) * m0 + (-2 * t3 + 3 * t2) * g1 + (t3 - t2) * m1
            der = (6 * t2 - 6 * t) * g0 + (3 * t2 - 4 * t + 1) * m0 + (-6 * t2 + 6 * t) * g1 + (3 * t2 - 2 * t) * m1
            nt = t - val / der if der > 0.0 else t
            if not 0.0 < nt < 1.0 or abs(nt - t) <= 1e-15:
                break
            t = nt
        lo, hi = 0.0, h  # g(lo) < 0 <= g(hi)
        tau = t * h
        for _ in range(60):
            if not lo < tau < hi:
                tau = 0.5 * (lo + hi)
            yt, _ = step(p, y, k, tau)
            self.steps += 1
            g, dg = event(p + tau, yt, f(p + tau, yt[0], yt[1]))
            if g >= 0.0:
                hi = tau
            else:
                lo = tau
            ulp = 4e-16 * (origin + p + hi)
            if hi - lo <= ulp:
                break
            nxt = tau - g / dg if dg > 0.0 else 0.5 * (lo + hi)
            if abs(nxt - tau) <= ulp:
                if g >= 0.0:
                    break  # converged from above: hi = tau
                nxt = tau + ulp  # converged just below the root: step past it
            tau = nxt
        return hi

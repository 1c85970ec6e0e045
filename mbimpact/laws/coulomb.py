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
depend on how it stopped). Only a 3-D slip that still turns is integrated: its ODE
du_t/dp_n = b − μ W_tt û_t on the tangential impulse, the normal velocity following from P,
and the normal work of the stage ∫u_n dp_n alongside, on increments from the stage's start.
The integrator is Dormand–Prince 8(5,3); its steps never straddle u_t = 0, and each event is
located exactly (Newton on the step length, each iterate a full step from the last accepted
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

Where it runs
-------------
The phases run in :mod:`mbimpact.laws.coulomb_kernels`, compiled by numba and imported on
first use (numba's import alone takes longer than ``import mbimpact`` may; see
:func:`compile_kernels` for that one-off cost). A single impact whose impulse is one formula
(frictionless, from normal incidence while sticking is possible, or a 3-D slip certain to stop
during compression) is computed here in floats and never needs them.
"""

from __future__ import annotations

import math
import time
from types import ModuleType
from typing import Literal

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

__all__ = ["CoulombLaw", "compile_kernels"]

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
# (these reach the compiled phases as values at every call, never as globals that numba would freeze
# into its on-disk cache)

# Friction coefficients beyond it are sticks within 1e-6 (a slip stops within a normal impulse
# 1/(μ α_min) of the impact's), and their slip stages fall below what the phases resolve.
_MU_MAX = 1e6

_EYE = {2: [[1.0, 0.0], [0.0, 1.0]], 3: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}  # R.tolist() of R = I


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

    The phases are compiled (numba) on first use: the first impact that needs them in a
    process pays numba's import and the loading of its cached machine code, or its compilation
    when that cache is missing (:func:`compile_kernels` does it and times it).
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
        setup = _Setup(np.asarray(W, dtype=float).tolist(), self.mu)
        U = np.ascontiguousarray(U, dtype=float)
        if len(U) == 1:  # one row: a closed form needs no compiled code
            u = U[0].tolist()
            whole = _closed_form(setup, u[0], u[1] if setup.d == 3 else 0.0, u[-1], self.e, self.restitution)
            if whole is not None:
                P = np.array([whole] if setup.d == 3 else [[whole[0], whole[2]]]) / setup.tr
                return ContactImpulses(P, np.zeros(1), 1, "impulse-space")
        kernels = _kernels()
        P = np.empty_like(U)
        steps = np.zeros(len(U), dtype=np.int64)
        info = np.zeros(5)
        bad = kernels.impact_rows(self._pack(setup, kernels), U, P, steps, info)
        if bad >= 0:
            raise self._failure(int(info[0]), info[1:].tolist(), kernels)
        P /= setup.tr  # the core works on W / tr W
        nodes = max(1, int(steps.max(initial=0)))
        return ContactImpulses(P, np.where(steps > 0, self.rtol, 0.0), nodes, "impulse-space")

    def apply_metric(self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]) -> ImpactResult:
        """:meth:`ImpactLaw.apply_metric` without the batch machinery: one impact in floats.

        The degenerate cases (no approach, n⁰ out of reach, rank-deficient J) take the
        general route, which names the error or reports the minimum-norm impulse.
        """
        # numpy's overflow warnings silenced once for the whole call: extreme magnitudes are named below
        with quiet_overflow():
            J, W = metric.J, metric.W
            u = J.dot(v)
            ul = u.tolist()
            if not math.isfinite(sum(ul)):
                check_in_range("the contact velocity J v", u)
            d = len(ul)
            rl = R.tolist()
            world = rl == _EYE[d]  # the rotations are exact no-ops: skipped
            if not world:
                ul = u.dot(R).tolist()  # local frame
            if not ul[-1] < 0.0:
                return super().apply_metric(metric, v, R)
            setup = _Setup(W.tolist() if world else R.T.dot(W).dot(R).tolist(), self.mu)
            # what ImpactLaw.impulses checks (n0ᵀWn0 > 0) and ContactMetric.range_projector tests
            # (spread_bound = det(W / tr W)), read off the setup instead of recomputed
            if not setup.w33 > DEGENERATE or not setup.det > 1e-12:
                return super().apply_metric(metric, v, R)
            # the unit velocity, scaled first (no over- or underflow); the squares by ** (libm's pow) as ever
            if d == 3:
                x1, x2, xn = ul
                big = max(abs(x1), abs(x2), abs(xn))
                speed = big * math.sqrt((x1 / big) ** 2 + (x2 / big) ** 2 + (xn / big) ** 2)
                u1, u2, un = x1 / speed, x2 / speed, xn / speed
            else:
                x1, xn = ul
                big = max(abs(x1), abs(xn))
                speed = big * math.sqrt((x1 / big) ** 2 + (xn / big) ** 2)
                u1, u2, un = x1 / speed, 0.0, xn / speed
            whole = _closed_form(setup, u1, u2, un, self.e, self.restitution)
            if whole is None:
                kernels = _kernels()
                status, p1, p2, pn, steps, *info = kernels.impact_one(self._pack(setup, kernels), u1, u2, un)
                if status:
                    raise self._failure(status, info, kernels)
                whole = [p1, p2, pn]
            else:
                steps = 0
            scale = speed / setup.tr
            if d == 2:
                del whole[1]
            if world:
                Pl = [x * scale for x in whole]
                P = np.array(Pl)
            else:
                P = R.dot(whole) * scale
                Pl = P.tolist()
            dv = metric.AinvJt.dot(P)
            u_plus = u + W.dot(P)
            v_plus = v + dv
        # check_in_range's test, in floats: a NaN, an inf or an overflowing sum
        up = u_plus.tolist()
        if not math.isfinite(sum(Pl) + sum(v_plus.tolist()) + sum(up)):
            check_in_range("the impact's outcome (P, v₊ or u₊)", P, v_plus, u_plus)
        result = ImpactResult(
            v_minus=v.copy(), v_plus=v_plus, dv=dv, P=P, u_minus=u, u_plus=u_plus, n0=R[:, -1].copy(), A=metric.A,
            J=J, law=self, error_estimate=self.rtol if steps else 0.0, nodes=max(steps, 1), method="impulse-space",
        )
        if sum([row[-1] * x for row, x in zip(rl, up)]) < -SEPARATION_RTOL * speed:  # result.separates, in floats
            warn(NoSeparationWarning, f"{self!r}: the contact still approaches the surface after the impact "
                 f"(kappa = {result.kappa:.6g} < 0); {self.separation_advice()}")
        return result

    # ------------------------------------------------------------------ the compiled phases
    def _pack(self, setup: _Setup, kernels: ModuleType) -> NDArray[np.float64]:
        """The kernels' setup array: W's setup, the law, and the tolerances (read now: tests lower them)."""
        return kernels.pack(setup, self.e, getattr(kernels, self.restitution.upper()), self.rtol, _JAM, _UN_ZERO,
                            _STOP, _MAX_PHASES, _MAX_STEPS)

    @staticmethod
    def _failure(status: int, info: list[float], kernels: ModuleType) -> IntegrationError:
        """The named error of a kernel's failure ``status`` with its numbers ``info``."""
        a, b, c, mode = info
        if status == kernels.JAMMED:
            return IntegrationError(
                f"Coulomb impact: the contact jams while still approaching (n·u = {a:.3g} at p_n = {b:.6g}, mode "
                f"{kernels.MODES[int(c)]}): W is too close to singular for the contact to be stopped")
        if status == kernels.NO_END:
            return IntegrationError(
                f"Coulomb impact: compression cannot end (n·u = {a:.3g} with rate {b:.3g} at p_n = {c:.6g}, mode "
                f"{kernels.MODES[int(mode)]}); W is too close to singular for the contact to be stopped")
        if status == kernels.INFINITE:
            return IntegrationError(f"Coulomb impact: a phase of infinite length at p_n = {a:.6g}")
        if status == kernels.STALLED:
            return IntegrationError(
                f"Coulomb impact: the slip integration stalled at p_n = {a:.6g} (|u_t| = {b:.3g}, "
                f"{'compression' if c else 'restitution'})")
        if status == kernels.TOO_MANY_STEPS:
            return IntegrationError(
                f"Coulomb impact: the slip integration took more than {_MAX_STEPS} steps and reached p_n = "
                f"{a:.6g} (|u_t| = {b:.3g})")
        return IntegrationError(f"Coulomb impact: more than {_MAX_PHASES} phases at p_n = {a:.6g}")


_KERNELS: ModuleType | None = None


def _kernels() -> ModuleType:
    """:mod:`mbimpact.laws.coulomb_kernels`, made ready on first use (:func:`compile_kernels`)."""
    if _KERNELS is None:
        compile_kernels()
    assert _KERNELS is not None
    return _KERNELS


def compile_kernels() -> tuple[float, float]:
    """Make the compiled phases of :class:`CoulombLaw` ready, and time it.

    The first impact that needs them does this once per process (both of the kernels' entry
    points at once, so that no later first call pays anything).

    Returns
    -------
    (import_seconds, jit_seconds) : tuple of float
        Wall times of importing :mod:`mbimpact.laws.coulomb_kernels` (numba, mostly) and of making
        its machine code callable: numba's start-up and the loading of the code from its on-disk
        cache, or its compilation when that cache is missing or stale. Their sum is what the first
        impact that needs the phases pays; both are ~0 once done in the process. For that first-call
        cost, call this in a fresh interpreter; for the cold compilation, with ``NUMBA_CACHE_DIR`` set
        to an empty directory.
    """
    global _KERNELS
    start = time.perf_counter()
    from . import coulomb_kernels

    imported = time.perf_counter() - start
    jitted = float(coulomb_kernels.jit_seconds())
    _KERNELS = coulomb_kernels
    return imported, jitted


# ---------------------------------------------------------------------- shared per W
class _Setup:
    """What every row at one Delassus matrix shares, for W / tr W, in floats.

    A planar W (d = 2) is stored as a spatial one without the second tangential axis (its
    entries 0), the layout of :func:`mbimpact.laws.coulomb_kernels.pack`.

    Attributes
    ----------
    d : int
        Contact-space dimension.
    tr : float
        tr W (the core works on W / tr W; impulses are divided by it at the end).
    w11 … w33 : float
        W / tr W in the local frame (t₁, t₂, n): W_tt, the coupling b = (w13, w23), c = w33.
    ai11, ai12, ai22 : float
        The pseudo-inverse W_tt⁺ (symmetric).
    alpha_min, anorm, bnorm : float
        Smallest eigenvalue of W_tt (0 when cut), largest, and |b|.
    g1, g2, stick_norm : float
        Sticking rate g = dP_t/dp_n = −W_tt⁺ b (keeps u_t = 0) and |g|.
    can_stick : bool
        |g| ≤ μ: a slip that stops sticks.
    mu, det : float
        The friction; det(W / tr W).
    """

    __slots__ = ("d", "tr", "w11", "w12", "w13", "w21", "w22", "w23", "w31", "w32", "w33", "ai11", "ai12", "ai22",
                 "alpha_min", "anorm", "bnorm", "g1", "g2", "stick_norm", "can_stick", "mu", "det")

    def __init__(self, W: list[list[float]], mu: float) -> None:
        d = len(W)
        if d == 3:
            (w11, w12, w13), (w21, w22, w23), (w31, w32, w33) = W
            tr = w11 + w22 + w33
        else:
            (w11, w13), (w31, w33) = W
            tr = w11 + w33 + 0.0
        if not (tr > 0.0 and math.isfinite(tr)):
            raise IntegrationError(f"the Delassus matrix must have a positive finite trace, got {tr!r}")
        w11, w13, w31, w33 = w11 / tr, w13 / tr, w31 / tr, w33 / tr
        if d == 3:
            w12, w21, w22, w23, w32 = w12 / tr, w21 / tr, w22 / tr, w23 / tr, w32 / tr
        else:
            w12 = w21 = w22 = w23 = w32 = 0.0
        self.d, self.tr, self.mu = d, tr, mu
        self.w11, self.w12, self.w13, self.w21, self.w22, self.w23 = w11, w12, w13, w21, w22, w23
        self.w31, self.w32, self.w33 = w31, w32, w33
        if d == 2:
            self.alpha_min = w11 if w11 > _CUT else 0.0
            ai11, ai12, ai22 = (1.0 / w11 if w11 > _CUT else 0.0), 0.0, 0.0
            self.anorm = abs(w11)
            self.det = w11 * w33 - w13 * w31
        else:
            a11, a12, a22 = w11, w12, w22
            m, half = 0.5 * (a11 + a22), 0.5 * (a11 - a22)
            hi = m + math.hypot(half, a12)
            det = a11 * a22 - a12 * a12
            lo = max(det / hi, 0.0) if hi > 0.0 else 0.0  # no cancellation in m − rad
            self.anorm = hi
            if lo > _CUT:
                self.alpha_min = lo
                ai11, ai12, ai22 = a22 / det, -a12 / det, a11 / det
            else:  # rank ≤ 1: W_tt⁺ = q qᵀ / α along the one eigenvector left
                self.alpha_min = 0.0
                phi = 0.5 * math.atan2(2.0 * a12, a11 - a22)
                q1, q2 = math.cos(phi), math.sin(phi)
                inv = 1.0 / hi if hi > _CUT else 0.0
                ai11, ai12, ai22 = q1 * q1 * inv, q1 * q2 * inv, q2 * q2 * inv
            # det(W / tr W) (rotation-invariant): spread_bound's test of a rank-deficient W
            self.det = w11 * (w22 * w33 - w23 * w23) - w12 * (w12 * w33 - w23 * w13) + w13 * (w12 * w23 - w22 * w13)
        self.ai11, self.ai12, self.ai22 = ai11, ai12, ai22
        self.g1, self.g2 = g1, g2 = -(ai11 * w13 + ai12 * w23), -(ai12 * w13 + ai22 * w23)
        self.stick_norm = math.sqrt(g1 * g1 + g2 * g2)
        self.bnorm = math.sqrt(w13 * w13 + w23 * w23)
        self.can_stick = mu > 0.0 and self.stick_norm <= mu * (1.0 + 1e-12)


# ---------------------------------------------------------------------- one formula
def _closed_form(s: _Setup, u1: float, u2: float, un: float, e: float, kind: str) -> list[float] | None:
    """The impulse (P_t1, P_t2, p_n) of a whole impact in one formula, or None (the compiled phases').

    With a constant tangential rate g the normal velocity is linear, u_n = u_n⁻ + k p (k = c + bᵀg),
    so all three hypotheses end at p = (1 + e) |u_n⁻| / k: without friction (g = 0), and sticking
    from normal incidence (g = −W_tt⁺ b, k the Schur complement). A 3-D slip certain to stop during
    compression leaves the sticking state u_t = 0, P_t = −W_tt⁻¹(u_t⁻ + b p), at every later p:
    with V = u_tᵀ W_tt⁻¹ u_t, dV/dp ≤ −2 (μ − |g|) √(α_min V), so the slip stops before
    Δp = √V₀ / ((μ − |g|) √α_min), and compression cannot end before −u_n / (c + μ |b|). Newton's end
    (u_n = −e u_n⁻), Poisson's (p = (1 + e) p_c) and e = 0 then follow from u_n = u_n⁻ − bᵀW_tt⁻¹u_t⁻ + S p
    (Stronge's would need the work of the slip). The same arithmetic as the kernels' ``_whole_impact``
    (u = (u1, u2, un) unit, local frame, W / tr W; u2 = 0 when d = 2); None for a jam (k ≈ 0) and for
    slipping from normal incidence, whose invariant direction the kernels find.
    """
    mu = s.mu
    r = math.sqrt(u1 * u1 + u2 * u2)
    if mu == 0.0 or r == 0.0:
        if mu == 0.0:
            g1 = g2 = 0.0
        elif s.can_stick:
            g1, g2 = s.g1, s.g2
        else:
            return None
        k = s.w31 * g1 + s.w32 * g2 + s.w33
        if not k > _JAM * (1.0 + (g1 * g1 + g2 * g2)):
            return None
        p = (1.0 + e) * -un / k
        return [g1 * p, g2 * p, p]
    if s.d != 3 or not (s.can_stick and s.alpha_min > 0.0) or (kind == "energetic" and e > 0.0):
        return None
    margin = mu - s.stick_norm
    if not margin > 1e-9 * mu:
        return None
    ai11, ai12, ai22, b1, b2 = s.ai11, s.ai12, s.ai22, s.w13, s.w23
    V = u1 * (ai11 * u1 + ai12 * u2) + u2 * (ai12 * u1 + ai22 * u2)
    bound = 1.000001 * math.sqrt(max(V, 0.0)) / (margin * math.sqrt(s.alpha_min))
    if not (bound < 0.5 * (-un / (s.w33 + mu * s.bnorm)) and bound > 0.0):
        return None
    schur = s.w33 + b1 * s.g1 + b2 * s.g2
    if not schur > _JAM * (1.0 + s.stick_norm) ** 2:
        return None
    beta = b1 * (ai11 * u1 + ai12 * u2) + b2 * (ai12 * u1 + ai22 * u2)  # bᵀ W_tt⁻¹ u_t⁻
    if kind == "newton":
        p = (-(1.0 + e) * un + beta) / schur
    else:  # poisson, or e = 0
        p = (1.0 + e) * (-un + beta) / schur
    return [-(ai11 * (u1 + b1 * p) + ai12 * (u2 + b2 * p)), -(ai12 * (u1 + b1 * p) + ai22 * (u2 + b2 * p)), p]

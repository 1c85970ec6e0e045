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
located exactly (Newton on the step length from a quintic Hermite guess, each iterate a full
step from the last accepted point). The turning slip hands over to a closed form as soon as
the angle δ to the stable invariant direction it approaches makes the rest a straight line
within the tolerance (δ (|u_t| + μ Δp) ≤ rtol), or once |u_t| is down to what the state resolves.

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
:func:`compile_kernels` for that one-off cost). Until then, a single impact whose impulse is one
formula (frictionless, from normal incidence while sticking is possible, or a 3-D slip certain to
stop during compression) is computed here in floats and never needs them. Once they are loaded,
every single impact is one compiled call — the setup of W, the unit velocity and the impulse
together — which costs less than those floats do in Python (the arithmetic is the same either way,
to the last bit). A mechanism's compiled route (:meth:`CoulombLaw.single_impulse`) has numba
imported already, and loads them at its first impact.
"""

from __future__ import annotations

import math
import sys
from types import ModuleType
from typing import Callable, Literal

import numpy as np
from numpy.typing import NDArray

from ..common.compiled import KernelModule
from ..common.geometry import DEGENERATE
from ..common.validation import as_scalar, check_in_range, quiet_overflow
from ..errors import IntegrationError, ParameterError
from ..metric.delassus import ContactMetric
from ..results.impact import BatchResult, ContactImpulses, ImpactResult
from ..results.quantities import SEPARATION_RTOL
from .base import ImpactLaw
from .restitution import restitution_from

__all__ = ["CoulombLaw", "KERNELS", "compile_kernels"]

_RESTITUTION = ("newton", "poisson", "energetic")
# the restitution codes of the kernels (their NEWTON, POISSON, ENERGETIC), as floats: the law tuple is all floats
_KIND = {name: float(code) for code, name in enumerate(_RESTITUTION)}

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
# (these, with _CUT and common.geometry's DEGENERATE, reach the compiled phases as values at every call
# (CoulombLaw._law), never as globals that numba would freeze into its on-disk cache)

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
        w = np.asarray(W, dtype=float).tolist()
        U = np.ascontiguousarray(U, dtype=float)
        if len(U) == 1 and not KERNELS.ready:  # one row before numba is loaded: a closed form needs none of it
            setup = _setup(w, self.mu)
            d, tr = setup[0], setup[1]
            u = U[0].tolist()
            whole = _closed_form(setup, self.mu, u[0], u[1] if d == 3 else 0.0, u[-1], self.e, self.restitution)
            if whole is not None:
                P = np.array([whole] if d == 3 else [[whole[0], whole[2]]]) / tr
                return ContactImpulses(P, np.zeros(1), 1, "impulse-space")
        kernels = KERNELS.get()
        P = np.empty_like(U)
        error = np.empty(len(U))
        row, status, steps, *info = kernels.impact_rows(_flat(w), self._law(), U, P, error)
        if row >= 0:
            raise self._failure(status, info, kernels)
        return ContactImpulses(P, error, max(1, steps), "impulse-space")

    def single_impulse(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        """:meth:`contact_impulses` for one unit velocity ``U`` (1, 3) at a unit-trace ``W`` (3, 3), local
        frame: one compiled call without the batch's arrays (:func:`~mbimpact.laws.coulomb_kernels.impact_local`,
        which reads W and U itself).

        The compiled route of a mechanism calls this with numba imported already (its own kernels need it):
        the first call then loads the phases from numba's cache (~0.06 s, once a process), and a closed form
        costs half as much as in floats. Without numba, a closed form is computed in floats (:meth:`_single`)
        and imports none of it.
        """
        kernels = KERNELS.module
        if kernels is None and "numba" in sys.modules:
            kernels = KERNELS.get()
        if kernels is not None:
            P = np.empty(U.shape)
            try:
                status, steps = kernels.impact_local(W, U, self._law(), P)
            except TypeError:  # not float64 arrays: the floats below take them
                status = -1
            if status == 0:
                return ContactImpulses(P, np.array([self.rtol if steps else 0.0]), max(steps, 1), "impulse-space")
            # n⁰ out of reach, W rank-deficient, a failure or other shapes: the floats below name or treat them
        single = self._single(W.tolist(), U[0].tolist())
        if single is None:  # n⁰ out of reach or W rank-deficient by _single's own rounding: the batch names it
            return self.contact_impulses(W, U)
        p1, p2, pn, steps, scale, _ = single
        return ContactImpulses(np.array([[p1 * scale, p2 * scale, pn * scale]]),
                               np.array([self.rtol if steps else 0.0]), max(steps, 1), "impulse-space")

    def _compiled_route(self) -> bool:
        # apply_metric below is ImpactLaw's pipeline in floats: a mechanism's spatial impact may take the
        # compiled route instead, unless a subclass overrides apply_metric
        return type(self).apply_metric is CoulombLaw.apply_metric and type(self).impulses is ImpactLaw.impulses

    def factored_stack(self) -> bool:
        """True where a mechanism's spatial impact takes the compiled route (:meth:`ImpactLaw.apply_mechanism`):
        :func:`mbimpact.impact_batch` then runs that route once for all rows (:meth:`apply_factored_stack`), unless
        a subclass changes the law that route runs (:meth:`single_impulse` or the kernels' law tuple)."""
        cls = type(self)
        return (self._compiled_route() and cls.single_impulse is CoulombLaw.single_impulse
                and cls._law is CoulombLaw._law)

    def apply_factored_stack(self, A: NDArray[np.float64], U: NDArray[np.float64], D: NDArray[np.float64],
                             J: NDArray[np.float64], V: NDArray[np.float64], R: NDArray[np.float64],
                             row: Callable[[int], ImpactResult],
                             fill: Callable[[int, int], None] | None = None) -> BatchResult:
        """:meth:`ImpactLaw.apply_factored_stack`: :func:`mbimpact.laws.coulomb_kernels.coulomb_batch`, the
        compiled single impact once for all rows; each row's result is that of :func:`mbimpact.impact` to
        the bit. The rows it leaves (what the metric does not prepare, n⁰ out of reach, an integration that
        gives up, an outcome beyond the float range) are ``row(i)``, which names or treats them
        (:meth:`ImpactLaw._factored_result`)."""
        if not self.factored_stack():
            raise ParameterError(f"{self!r}: a subclass that overrides apply_metric, impulses or single_impulse has no "
                                 "compiled route for batches across configurations; mbimpact.impact_batch applies it "
                                 "row by row")
        kernels = KERNELS.get()
        buffer, status, steps, stats = self._factored_run(kernels.coulomb_batch, (self._law(),), U, D, J, V, R, fill)
        settled = (status == 0) & (stats[:, 4] == 1.0)
        methods = {"impulse-space"} if settled.any() else set()
        return self._factored_result(A, J, buffer, settled, np.maximum(steps, 1), stats, methods, row)

    def apply_metric(self, metric: ContactMetric, v: NDArray[np.float64], R: NDArray[np.float64]) -> ImpactResult:
        """:meth:`ImpactLaw.apply_metric` without the batch machinery: one impact in floats, and at most
        one compiled call (:meth:`_single`); a closed form needs no compiled code at all. (A spatial
        impact of a mechanism takes :meth:`ImpactLaw.apply_mechanism`'s compiled route instead, whose
        law is :meth:`single_impulse`.)

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
            local = ul if world else u.dot(R).tolist()
            if not local[-1] < 0.0:
                return super().apply_metric(metric, v, R)
            single = self._single(W.tolist() if world else R.T.dot(W).dot(R).tolist(), local)
            if single is None:
                return super().apply_metric(metric, v, R)
            p1, p2, pn, steps, scale, speed = single
            if world:
                Pl = [p1 * scale, p2 * scale, pn * scale] if d == 3 else [p1 * scale, pn * scale]
                P = np.array(Pl)
            else:
                P = R.dot([p1, p2, pn] if d == 3 else [p1, pn]) * scale
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
        # result.separates, in floats: n⁰·u₊ (of the world frame, u₊'s last entry exactly)
        if world:
            un_plus = up[-1]
        elif d == 3:
            un_plus = rl[0][2] * up[0] + rl[1][2] * up[1] + rl[2][2] * up[2]
        else:
            un_plus = rl[0][1] * up[0] + rl[1][1] * up[1]
        if un_plus < -SEPARATION_RTOL * speed:
            self._warn_no_separation()
        return result

    # ------------------------------------------------------------------ one impact
    def _single(self, W: list[list[float]], u: list[float]) -> tuple[float, float, float, int, float, float] | None:
        """The impulse of one impact at the Delassus matrix ``W`` and contact velocity ``u``, local frame.

        Returns (P_t1, P_t2, p_n) for the unit velocity u / |u| at W / tr W (P_t2 = 0 when d = 2), the
        integration steps, |u| / tr W (what turns it into the impact's impulse) and |u|; or None for
        what the general route names or treats: n⁰ᵀWn⁰ ≈ 0 (:meth:`ImpactLaw.impulses`' test) and a
        rank-deficient W (det(W / tr W) ≤ 1e-12, :attr:`ContactMetric.range_projector`'s).

        Until numba is loaded a closed form is computed here in floats; once it is, every impact is
        one compiled call, cheaper than the floats (the same arithmetic, to the last bit).
        """
        kernels = KERNELS.module
        if kernels is None:
            setup = _setup(W, self.mu)
            if not setup[6] > DEGENERATE or not setup[16] > 1e-12:  # c = n⁰ᵀWn⁰ / tr W, det(W / tr W)
                return None
            speed, u1, u2, un = _unit(u)
            whole = _closed_form(setup, self.mu, u1, u2, un, self.e, self.restitution)
            if whole is not None:
                return whole[0], whole[1], whole[2], 0, speed / setup[1], speed
            kernels = KERNELS.get()
        x1, x2, xn = u if len(u) == 3 else (u[0], 0.0, u[1])
        status, p1, p2, pn, steps, scale, speed, *info = kernels.impact_one(_flat(W), self._law(), x1, x2, xn)
        if status:
            if status == kernels.OUT_OF_REACH:
                return None
            raise self._failure(status, info, kernels)
        return p1, p2, pn, steps, scale, speed

    def _law(self) -> tuple[float, ...]:
        """The kernels' law tuple: the law and the tolerances (read now: tests lower them), all floats
        (one compiled signature)."""
        return (self.mu, self.e, _KIND[self.restitution], self.rtol, _JAM, _UN_ZERO, _STOP, float(_MAX_PHASES),
                float(_MAX_STEPS), _CUT, DEGENERATE)

    @staticmethod
    def _failure(status: int, info: list[float], kernels: ModuleType) -> IntegrationError:
        """The named error of a kernel's failure ``status`` with its numbers ``info``."""
        a, b, c, mode = info
        if status == kernels.BAD_TRACE:
            return IntegrationError(f"the Delassus matrix must have a positive finite trace, got {a!r}")
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


#: The compiled phases of :class:`CoulombLaw` (:mod:`mbimpact.laws.coulomb_kernels`), loaded on first use.
KERNELS = KernelModule("mbimpact.laws.coulomb_kernels")


def compile_kernels() -> tuple[float, float]:
    """Make the compiled phases of :class:`CoulombLaw` ready, and time it: what the first impact that
    needs them pays once per process (both of the kernels' entry points at once, so that no later
    first call pays anything). ``(import_seconds, jit_seconds)``, see :meth:`KernelModule.compile`."""
    return KERNELS.compile()


# ---------------------------------------------------------------------- shared per W
# What a closed form needs of a Delassus matrix (:func:`_setup`): a plain tuple, unpacked at once where
# it is read (a closed form in floats then costs ~15 % less than through a slotted object's attributes)
_SetupTuple = tuple[int, float, float, float, float, float, float, float, float, float, float, float, float, float,
                    float, bool, float]


def _setup(W: list[list[float]], mu: float) -> _SetupTuple:
    """What every row at one Delassus matrix shares, for W / tr W, in floats.

    A planar W (d = 2) is the spatial one without the second tangential axis (its entries 0).
    The kernels' ``_setup`` computes the same, operation for operation (a single impact in
    floats here and one through the kernels agree to the last bit).

    Returns
    -------
    (d, tr, b1, b2, w31, w32, c, ai11, ai12, ai22, alpha_min, bnorm, g1, g2, stick_norm, can_stick, det)
        The contact-space dimension; tr W (the core works on W / tr W, its impulses divided by tr W
        at the end); of W / tr W in the local frame (t₁, t₂, n), the coupling b = (w13, w23), the
        normal row's (w31, w32) and c = w33; the pseudo-inverse W_tt⁺ (symmetric); the smallest
        eigenvalue of W_tt (0 when cut) and |b|; the sticking rate g = dP_t/dp_n = −W_tt⁺ b (keeps
        u_t = 0) and |g|; whether |g| ≤ μ (a slip that stops sticks); det(W / tr W).

    Raises
    ------
    IntegrationError
        tr W is not positive and finite.
    """
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
    if d == 2:
        w23 = w32 = 0.0
        alpha_min = w11 if w11 > _CUT else 0.0
        ai11, ai12, ai22 = (1.0 / w11 if w11 > _CUT else 0.0), 0.0, 0.0
        det = w11 * w33 - w13 * w31
    else:
        w12, w22, w23, w32 = w12 / tr, w22 / tr, w23 / tr, w32 / tr
        m, half = 0.5 * (w11 + w22), 0.5 * (w11 - w22)
        hi = m + math.hypot(half, w12)
        det = w11 * w22 - w12 * w12
        lo = max(det / hi, 0.0) if hi > 0.0 else 0.0  # no cancellation in m − rad
        if lo > _CUT:
            alpha_min = lo
            ai11, ai12, ai22 = w22 / det, -w12 / det, w11 / det
        else:  # rank ≤ 1: W_tt⁺ = q qᵀ / α along the one eigenvector left
            alpha_min = 0.0
            phi = 0.5 * math.atan2(2.0 * w12, w11 - w22)
            q1, q2 = math.cos(phi), math.sin(phi)
            inv = 1.0 / hi if hi > _CUT else 0.0
            ai11, ai12, ai22 = q1 * q1 * inv, q1 * q2 * inv, q2 * q2 * inv
        # det(W / tr W) (rotation-invariant): spread_bound's test of a rank-deficient W
        det = w11 * (w22 * w33 - w23 * w23) - w12 * (w12 * w33 - w23 * w13) + w13 * (w12 * w23 - w22 * w13)
    g1, g2 = -(ai11 * w13 + ai12 * w23), -(ai12 * w13 + ai22 * w23)
    stick_norm = math.sqrt(g1 * g1 + g2 * g2)
    return (d, tr, w13, w23, w31, w32, w33, ai11, ai12, ai22, alpha_min, math.sqrt(w13 * w13 + w23 * w23), g1, g2,
            stick_norm, mu > 0.0 and stick_norm <= mu * (1.0 + 1e-12), det)


def _flat(W: list[list[float]]) -> tuple[float, ...]:
    """``W`` as the kernels take it: (d, w11, w12, w13, w21, w22, w23, w31, w32, w33), a planar W in
    the corners (the second tangential axis 0)."""
    if len(W) == 3:
        (a, b, c), (d, e, f), (g, h, k) = W
        return 3.0, a, b, c, d, e, f, g, h, k
    (a, c), (g, k) = W
    return 2.0, a, 0.0, c, 0.0, 0.0, 0.0, g, 0.0, k


def _unit(u: list[float]) -> tuple[float, float, float, float]:
    """(|u|, u / |u|) of a contact velocity u (d = 2: its second tangential component 0), scaled
    first (no over- or underflow), the squares by ``**`` (libm's pow, as the kernels' ``_square``)."""
    if len(u) == 3:
        x1, x2, xn = u
        big = max(abs(x1), abs(x2), abs(xn))
        speed = big * math.sqrt((x1 / big) ** 2 + (x2 / big) ** 2 + (xn / big) ** 2)
        return speed, x1 / speed, x2 / speed, xn / speed
    x1, xn = u
    big = max(abs(x1), abs(xn))
    speed = big * math.sqrt((x1 / big) ** 2 + (xn / big) ** 2)
    return speed, x1 / speed, 0.0, xn / speed


# ---------------------------------------------------------------------- one formula
def _closed_form(s: _SetupTuple, mu: float, u1: float, u2: float, un: float, e: float, kind: str
                 ) -> list[float] | None:
    """The impulse (P_t1, P_t2, p_n) of a whole impact in one formula, or None (the compiled phases').

    With a constant tangential rate g the normal velocity is linear, u_n = u_n⁻ + k p (k = c + bᵀg),
    so all three hypotheses end at p = (1 + e) |u_n⁻| / k: without friction (g = 0), and sticking
    from normal incidence (g = −W_tt⁺ b, k the Schur complement). A 3-D slip certain to stop during
    compression leaves the sticking state u_t = 0, P_t = −W_tt⁻¹(u_t⁻ + b p), at every later p:
    with V = u_tᵀ W_tt⁻¹ u_t, dV/dp ≤ −2 (μ − |g|) √(α_min V), so the slip stops before
    Δp = √V₀ / ((μ − |g|) √α_min), and compression cannot end before −u_n / (c + μ |b|). Newton's end
    (u_n = −e u_n⁻), Poisson's (p = (1 + e) p_c) and e = 0 then follow from u_n = u_n⁻ − bᵀW_tt⁻¹u_t⁻ + S p
    (Stronge's would need the work of the slip). The same arithmetic as the kernels' ``_whole_impact``
    (``s`` the :func:`_setup` of W at friction μ, u = (u1, u2, un) unit, local frame, W / tr W; u2 = 0
    when d = 2); None for a jam (k ≈ 0) and for slipping from normal incidence, whose invariant
    direction the kernels find.
    """
    d, _, b1, b2, w31, w32, c, ai11, ai12, ai22, alpha_min, bnorm, g1, g2, stick_norm, can_stick, _ = s
    r = math.sqrt(u1 * u1 + u2 * u2)
    if mu == 0.0 or r == 0.0:
        if mu == 0.0:
            g1 = g2 = 0.0
        elif not can_stick:
            return None
        k = w31 * g1 + w32 * g2 + c
        if not k > _JAM * (1.0 + (g1 * g1 + g2 * g2)):
            return None
        p = (1.0 + e) * -un / k
        return [g1 * p, g2 * p, p]
    if d != 3 or not (can_stick and alpha_min > 0.0) or (kind == "energetic" and e > 0.0):
        return None
    margin = mu - stick_norm
    if not margin > 1e-9 * mu:
        return None
    V = u1 * (ai11 * u1 + ai12 * u2) + u2 * (ai12 * u1 + ai22 * u2)
    bound = 1.000001 * math.sqrt(max(V, 0.0)) / (margin * math.sqrt(alpha_min))
    if not (bound < 0.5 * (-un / (c + mu * bnorm)) and bound > 0.0):
        return None
    schur = c + b1 * g1 + b2 * g2
    if not schur > _JAM * (1.0 + stick_norm) ** 2:
        return None
    beta = b1 * (ai11 * u1 + ai12 * u2) + b2 * (ai12 * u1 + ai22 * u2)  # bᵀ W_tt⁻¹ u_t⁻
    if kind == "newton":
        p = (-(1.0 + e) * un + beta) / schur
    else:  # poisson, or e = 0
        p = (1.0 + e) * (-un + beta) / schur
    return [-(ai11 * (u1 + b1 * p) + ai12 * (u2 + b2 * p)), -(ai12 * (u1 + b1 * p) + ai22 * (u2 + b2 * p)), p]

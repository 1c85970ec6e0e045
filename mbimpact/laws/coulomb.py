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
The phases run in :mod:`mbimpact.laws.coulomb_kernels`, compiled by numba and loaded at the first
Coulomb impact (numba's import alone takes longer than ``import mbimpact`` may; see
:func:`compile_kernels` for that one-off cost). Every impact, single or batched, is then one compiled
call: the setup of W, the unit velocity and the impulse together.
"""

from __future__ import annotations

import functools
from types import ModuleType
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..common.compiled import KernelModule
from ..common.geometry import DEGENERATE
from ..common.validation import as_scalar
from ..errors import IntegrationError, ParameterError
from ..results.impact import ContactImpulses
from .base import ImpactLaw
from .compiled import CompiledImpact
from ..facets.restitution import restitution_from

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

    The phases are compiled (numba) on first use: the first impact in a process pays numba's
    import and the loading of its cached machine code, or its compilation when that cache is
    missing (:func:`compile_kernels` does it and times it).
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
        U = np.ascontiguousarray(U, dtype=float)
        kernels = KERNELS.get()
        P = np.empty_like(U)
        error = np.empty(len(U))
        row, status, steps, *info = kernels.impact_rows(W, self._law(), U, P, error)
        if row >= 0:
            raise self._failure(status, info, kernels)
        return ContactImpulses(P, error, max(1, steps), "impulse-space")

    def compiled_impact(self) -> CompiledImpact | None:
        """The whole spatial impact of a mechanism in one compiled call
        (:func:`mbimpact.laws.coulomb_kernels.coulomb_impact`); None for a subclass."""
        return _compiled(self._law()) if type(self) is CoulombLaw else None

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


@functools.lru_cache(maxsize=64)
def _compiled(law: tuple[float, ...]) -> CompiledImpact:
    return CompiledImpact(KERNELS, "coulomb_impact", "coulomb_batch", (law,), ("impulse-space",))


def compile_kernels() -> tuple[float, float]:
    """Make the compiled phases of :class:`CoulombLaw` ready, and time it: what the first impact that
    needs them pays once per process (both of the kernels' entry points at once, so that no later
    first call pays anything). ``(import_seconds, jit_seconds)``, see :meth:`KernelModule.compile`."""
    return KERNELS.compile()

"""The compiled core of :class:`~mbimpact.CoulombLaw`: one impact per row, phase by phase.

This is the algorithm the module docstring of :mod:`mbimpact.laws.coulomb` describes — closed
forms for the phases of constant tangential rate, a Dormand–Prince 8(5,3) integration of the
3-D slip that still turns, the hand-overs between them — compiled by numba (``njit``, cached on
disk). It is imported on first use only: numba costs ~0.3 s to import, more than ``import
mbimpact`` may take. :func:`jit_seconds` loads or compiles it and says how long that took.

Everything is in floats on two small arrays, for speed and so that the arithmetic is the same
operation for operation whatever runs it (CPython's ``math.hypot`` included, see
:func:`py_hypot`):

* the setup ``S`` (:data:`SETUP_SIZE` floats, what every row at one Delassus matrix shares, for
  W / tr W): the entries of W, W_tt⁺, the sticking rate, the friction, restitution and
  tolerances, filled by :func:`pack`; a planar contact (d = 2) is the spatial one with the second
  tangential axis absent (its entries 0, which adds exact zeros only);
* the row state ``X`` (:data:`ROW_SIZE` floats): the unit pre-impact velocity u₋ (local frame,
  W / tr W), the normal impulse p (the clock), the tangential impulse P_t, the normal work of the
  current stage, the stage and, for an error, what its message reports.

A failure is a status code (``JAMMED`` …), with the numbers its message reports; the caller
raises the named error. Divisions follow IEEE (numba's ``error_model="numpy"``): a division by
zero, which the interpreted law would have raised as a bare ZeroDivisionError, gives an inf or a NaN
that the caller's range checks name. Run with ``NUMBA_DISABLE_JIT=1``, the same source is the
interpreted law, to the last bit.
"""

from __future__ import annotations

import math
import time
from types import SimpleNamespace
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["pack", "impact_rows", "impact_one", "jit_seconds", "py_hypot", "NEWTON", "POISSON", "ENERGETIC", "MODES",
           "JAMMED", "NO_END", "INFINITE", "STALLED", "TOO_MANY_STEPS", "TOO_MANY_PHASES"]

# ---------------------------------------------------------------------- layouts
# the setup S: d, tr W, the rows of W / tr W (t₁, t₂, n), W_tt⁺ (symmetric), its norms, the sticking
# rate g = −W_tt⁺ b with |g| and whether |g| ≤ μ, the law, the tolerances, the slip direction kept
# by the flow from u_t = 0 when the contact cannot stick (and whether it has been computed), and 2.0
# (see :func:`_square`)
(D, TR, W11, W12, W13, W21, W22, W23, W31, W32, W33, AI11, AI12, AI22, ALPHA_MIN, ANORM, BNORM, G1, G2,
 STICK_NORM, CAN_STICK, MU, E, KIND, RTOL, JAM, UN_ZERO, STOP, MAX_PHASES, MAX_STEPS, RESLIP, RS1,
 RS2, TWO) = range(34)
SETUP_SIZE = 34
# the row state X: u₋, the state of the impact, the stage, integration steps, error report
(U1, U2, UN0, P, PT1, PT2, WK, COMP, PC, WC, STEPS, INFO) = range(12)
ROW_SIZE = INFO + 4

# restitution kinds (S[KIND]) and tangential modes
NEWTON, POISSON, ENERGETIC = 0, 1, 2
FREE, STICK, RESLIP_MODE, SLIP = 0, 1, 2, 3
MODES = ("free", "stick", "reslip", "slip")

# status codes: 0 done, or a failure with X[INFO:] = the numbers its message reports: jammed while
# approaching (n·u, p_n, mode); compression cannot end (n·u, its rate, p_n, mode); a phase of infinite
# length (p_n); the slip integration stalled (p_n, |u_t|, compressing); too many integration steps
# (p_n, |u_t|); too many phases (p_n)
JAMMED, NO_END, INFINITE, STALLED, TOO_MANY_STEPS, TOO_MANY_PHASES = 1, 2, 3, 4, 5, 6

# Dormand–Prince 8(5,3) (Hairer's DOP853, the floats of scipy.integrate's dop853_coefficients), frozen
# into the compiled code as constants: the nodes c, the stage weights a (row i: the stages j < i), the
# weights b of the 8th-order solution and those of the embedded error estimates (5th and 3rd order)
_NS = 12
_C = np.array([0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726,
              0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571, 1.0])
_A = np.zeros((_NS, _NS))
for _i, _row in enumerate((
        (0.05260015195876773,),
        (0.0197250569845379, 0.0591751709536137),
        (0.02958758547680685, 0.0, 0.08876275643042054),
        (0.2413651341592667, 0.0, -0.8845494793282861, 0.924834003261792),
        (0.037037037037037035, 0.0, 0.0, 0.17082860872947386, 0.12546768756682242),
        (0.037109375, 0.0, 0.0, 0.17025221101954405, 0.06021653898045596, -0.017578125),
        (0.03709200011850479, 0.0, 0.0, 0.17038392571223998, 0.10726203044637328, -0.015319437748624402,
         0.008273789163814023),
        (0.6241109587160757, 0.0, 0.0, -3.3608926294469414, -0.868219346841726, 27.59209969944671,
         20.154067550477894, -43.48988418106996),
        (0.47766253643826434, 0.0, 0.0, -2.4881146199716677, -0.590290826836843, 21.230051448181193,
         15.279233632882423, -33.28821096898486, -0.020331201708508627),
        (-0.9371424300859873, 0.0, 0.0, 5.186372428844064, 1.0914373489967295, -8.149787010746927,
         -18.52006565999696, 22.739487099350505, 2.4936055526796523, -3.0467644718982196),
        (2.273310147516538, 0.0, 0.0, -10.53449546673725, -2.0008720582248625, -17.9589318631188, 27.94888452941996,
         -2.8589982771350235, -8.87285693353063, 12.360567175794303, 0.6433927460157636),
), start=1):
    _A[_i, :_i] = _row
del _i, _row
_B = np.array([0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585,
              0.3111643669578199, -0.1521609496625161, 0.20136540080403034, 0.04471061572777259])
_E5 = np.array([0.01312004499419488, 0.0, 0.0, 0.0, 0.0, -1.2251564463762044, -0.4957589496572502,
               1.6643771824549864, -0.35032884874997366, 0.3341791187130175, 0.08192320648511571,
               -0.022355307863886294])
_E3 = np.array([-0.18980075407240762, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585,
               -0.4226823213237919, -0.1521609496625161, 0.20136540080403034, 0.02265179219836082])

_T27 = 134217729.0  # 2²⁷ + 1: Veltkamp's splitting constant


def pack(setup: Any, e: float, kind: int, rtol: float, jam: float, un_zero: float, stop: float, max_phases: int,
         max_steps: int) -> NDArray[np.float64]:
    """The setup array S from the law's per-W setup (attributes named as in
    :class:`mbimpact.laws.coulomb`'s ``_Setup``), its restitution and its tolerances.

    Returns
    -------
    ndarray, shape (SETUP_SIZE,)
    """
    s = setup
    return np.array([
        s.d, s.tr, s.w11, s.w12, s.w13, s.w21, s.w22, s.w23, s.w31, s.w32, s.w33, s.ai11, s.ai12, s.ai22,
        s.alpha_min, s.anorm, s.bnorm, s.g1, s.g2, s.stick_norm, 1.0 if s.can_stick else 0.0, s.mu, e, kind, rtol,
        jam, un_zero, stop, max_phases, max_steps, 0.0, 0.0, 0.0, 2.0])


# ---------------------------------------------------------------------- floats as CPython has them
@njit(cache=True, error_model="numpy")
def _add_square(x: float, csum: float, frac1: float, frac2: float, frac3: float
                ) -> tuple[float, float, float, float]:
    """csum + x², x = hi + lo split exactly (Dekker), its rounding errors kept in frac1 … frac3."""
    t = x * _T27
    hi = t - (t - x)
    lo = x - hi
    sq = hi * hi
    old = csum
    csum += sq
    frac1 += (old - csum) + sq
    sq = 2.0 * hi * lo
    old = csum
    csum += sq
    frac2 += (old - csum) + sq
    return csum, frac1, frac2, frac3 + lo * lo


@njit(cache=True, error_model="numpy")
def py_hypot(x: float, y: float) -> float:
    """``math.hypot(x, y)`` bit for bit as CPython 3.11 computes it (its ``vector_norm``: lossless
    scaling, Dekker's split squares, compensated sums, one correction of the square root), where
    libm's hypot differs in the last bit about once in 200: the compiled path then follows the
    same decisions (a step accepted, a direction snapped) as the interpreted one did."""
    a, b = abs(x), abs(y)
    if math.isinf(a) or math.isinf(b):
        return math.inf
    if math.isnan(a) or math.isnan(b):
        return math.nan
    big = b if b > a else a
    if big == 0.0:
        return big
    max_e = math.frexp(big)[1]
    if max_e < -1023:  # ldexp(1, −max_e) would overflow: CPython divides by the larger instead
        csum, frac = 1.0, 0.0
        for z in (a, b):
            z = z / big
            z = z * z
            old = csum
            csum += z
            frac += (old - csum) + z
        return big * math.sqrt(csum - 1.0 + frac)
    scale = math.ldexp(1.0, -max_e)
    csum, frac1, frac2, frac3 = _add_square(a * scale, 1.0, 0.0, 0.0, 0.0)
    csum, frac1, frac2, frac3 = _add_square(b * scale, csum, frac1, frac2, frac3)
    h = math.sqrt(csum - 1.0 + (frac1 + frac2 + frac3))
    t = h * _T27
    hi = t - (t - h)
    lo = h - hi
    sq = -hi * hi
    old = csum
    csum += sq
    frac1 += (old - csum) + sq
    sq = -2.0 * hi * lo
    old = csum
    csum += sq
    frac2 += (old - csum) + sq
    sq = -lo * lo
    old = csum
    csum += sq
    frac3 += (old - csum) + sq
    sq = csum - 1.0 + (frac1 + frac2 + frac3)
    return (h + sq / (2.0 * h)) / scale


@njit(cache=True, error_model="numpy")
def _max(a: float, b: float) -> float:
    """Python's max(a, b) (a unless b > a), NaN included."""
    return b if b > a else a


@njit(cache=True, error_model="numpy")
def _min(a: float, b: float) -> float:
    """Python's min(a, b) (a unless b < a)."""
    return b if b < a else a


@njit(cache=True, error_model="numpy")
def _square(x: float, S: NDArray[np.float64]) -> float:
    """Python's ``x ** 2``: libm's pow(x, 2.0), which differs from x * x in the last bit about once in
    1400. The exponent is read from S at run time: a constant 2.0 would be folded into x * x."""
    return math.pow(x, S[TWO])


# ---------------------------------------------------------------------- the setup's last part
@njit(cache=True, error_model="numpy")
def _invariant_slip(S: NDArray[np.float64]) -> None:
    """The slip direction s leaving u_t = 0 when sticking is impossible, into S[RS1], S[RS2].

    Solves (μ W_tt + λ) s = b, |s| = 1 for the root λ > 0 of the secular equation
    Σ b̃ᵢ² / (μ αᵢ + λ)² = 1 (eigenbasis of W_tt), which decreases for λ > −μ α_min: exactly
    one root, positive because |W_tt⁺ b| > μ. Newton from the left on φ(λ) = 1/|x(λ)| − 1,
    x = (μα + λ)⁻¹ b̃ (concave and increasing: monotone convergence), bracketed by bisection.
    """
    S[RESLIP] = 1.0
    b1, b2, mu = S[W13], S[W23], S[MU]
    if S[D] == 2.0:
        S[RS1], S[RS2] = math.copysign(1.0, b1), 0.0
        return
    a11, a12, a22 = S[W11], S[W12], S[W22]
    phi = 0.5 * math.atan2(2.0 * a12, a11 - a22)
    q00, q01 = math.cos(phi), math.sin(phi)  # eigenvectors of W_tt: (q00, q01), (q10, q11)
    q10, q11 = -math.sin(phi), math.cos(phi)
    al0 = q00 * (a11 * q00 + a12 * q01) + q01 * (a12 * q00 + a22 * q01)
    al1 = q10 * (a11 * q10 + a12 * q11) + q11 * (a12 * q10 + a22 * q11)
    bt0 = q00 * b1 + q01 * b2
    bt1 = q10 * b1 + q11 * b2
    # the terms with b̃ᵢ ≠ 0, in order
    n_terms = 0
    ta0 = tb0 = ta1 = tb1 = 0.0
    if bt0 != 0.0:
        ta0, tb0, n_terms = _max(al0, 0.0) * mu, bt0, 1
    if bt1 != 0.0:
        if n_terms == 0:
            ta0, tb0 = _max(al1, 0.0) * mu, bt1
        else:
            ta1, tb1 = _max(al1, 0.0) * mu, bt1
        n_terms += 1
    lo, hi = 0.0, _max(S[BNORM], 1e-300)
    lam = 0.0
    for _ in range(200):
        # φ and φ' on ratios, which neither under- nor overflow
        r0 = tb0 / (ta0 + lam) if ta0 + lam > 0.0 else math.copysign(math.inf, tb0)
        if n_terms == 2:
            r1 = tb1 / (ta1 + lam) if ta1 + lam > 0.0 else math.copysign(math.inf, tb1)
            n = py_hypot(r0, r1)
        else:
            r1 = 0.0
            n = abs(r0)
        if not math.isfinite(n):
            val, der = -1.0, 0.0
        else:
            val = 1.0 / n - 1.0
            der = _square(r0 / n, S) / (ta0 + lam)
            if n_terms == 2:
                der = der + _square(r1 / n, S) / (ta1 + lam)
            der = der / n
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
    st0 = bt0 / (_max(al0, 0.0) * mu + lam)
    st1 = bt1 / (_max(al1, 0.0) * mu + lam)
    x = q00 * st0 + q10 * st1
    z = q01 * st0 + q11 * st1
    norm = py_hypot(x, z)
    S[RS1], S[RS2] = x / norm, z / norm


# ---------------------------------------------------------------------- helpers of one impact
@njit(cache=True, error_model="numpy")
def _velocity(S: NDArray[np.float64], X: NDArray[np.float64]) -> tuple[float, float, float]:
    """u = u₋ + W P at the current state."""
    q1, q2, p = X[PT1], X[PT2], X[P]
    # summed from +0.0 as Python's sum() is: the sign of a zero slip component reaches atan2
    return (X[U1] + (0.0 + S[W11] * q1 + S[W12] * q2 + S[W13] * p),
            X[U2] + (0.0 + S[W21] * q1 + S[W22] * q2 + S[W23] * p),
            X[UN0] + (0.0 + S[W31] * q1 + S[W32] * q2 + S[W33] * p))


@njit(cache=True, error_model="numpy")
def _rate(S: NDArray[np.float64], g1: float, g2: float) -> tuple[float, float, float]:
    """W [g; 1]: du/dp_n at tangential impulse rate g."""
    return (S[W11] * g1 + S[W12] * g2 + S[W13], S[W21] * g1 + S[W22] * g2 + S[W23],
            S[W31] * g1 + S[W32] * g2 + S[W33])


@njit(cache=True, error_model="numpy")
def _target_work(S: NDArray[np.float64], X: NDArray[np.float64]) -> float:
    """Stronge: restitution ends when its work reaches −e² W_c."""
    e = S[E]
    return 0.0 if e == 0.0 else -e * e * X[WC]


@njit(cache=True, error_model="numpy")
def _poisson_left(S: NDArray[np.float64], X: NDArray[np.float64], p: float) -> float:
    """Normal impulse from p to Poisson's end (1 + e) p_c, as e p_c + (p_c − p): exact for a tiny e."""
    return S[E] * X[PC] + (X[PC] - p)


@njit(cache=True, error_model="numpy")
def _stage_length(S: NDArray[np.float64], X: NDArray[np.float64], un: float, rho_n: float) -> float:
    """Normal impulse until compression or the impact ends in a phase of constant rate."""
    if X[COMP] != 0.0:
        if un >= 0.0:
            return 0.0
        return -un / rho_n if rho_n > 0.0 else math.inf
    kind = S[KIND]
    if kind == POISSON:
        return _max(_poisson_left(S, X, X[P]), 0.0)
    if kind == NEWTON:
        gap = -S[E] * X[UN0] - un
        if gap <= 0.0:
            return 0.0
        return gap / rho_n if rho_n > 0.0 else math.inf
    rem = _target_work(S, X) - X[WK]  # energetic: w + un s + rho_n s²/2 = target
    if rem <= 0.0:
        return 0.0
    disc = un * un + 2.0 * rho_n * rem
    if rho_n > 0.0 and un < 0.0:
        return (-un + math.sqrt(disc)) / rho_n
    if disc >= 0.0 and un + math.sqrt(disc) > 0.0:
        return 2.0 * rem / (un + math.sqrt(disc))  # the smaller root, without cancellation
    return math.inf


@njit(cache=True, error_model="numpy")
def _end_stage(S: NDArray[np.float64], X: NDArray[np.float64]) -> bool:
    """Compression ended (start restitution, return False) or the impact did (True)."""
    if X[COMP] != 0.0:
        X[COMP] = 0.0
        X[PC], X[WC], X[WK] = X[P], X[WK], 0.0
        return S[E] == 0.0  # every hypothesis ends a plastic impact at maximum compression
    return True


@njit(cache=True, error_model="numpy")
def _stopped_mode(S: NDArray[np.float64], X: NDArray[np.float64]) -> int:
    """The mode after the slip stopped: stick (removing the residual slip) or slip on."""
    if S[CAN_STICK] != 0.0:
        # the residual slip (what an exact stop would have removed, ≤ the tolerance) goes with the
        # tangential impulse −W_tt⁺ u_t: it only dissipates, ½ u_tᵀ W_tt⁺ u_t
        v1, v2, _ = _velocity(S, X)
        X[PT1] = X[PT1] - (S[AI11] * v1 + S[AI12] * v2)
        X[PT2] = X[PT2] - (S[AI12] * v1 + S[AI22] * v2)
        return STICK
    return RESLIP_MODE


# ---------------------------------------------------------------------- closed forms
@njit(cache=True, error_model="numpy")
def _stops_in_compression(S: NDArray[np.float64], X: NDArray[np.float64], v1: float, v2: float
                          ) -> float:
    """A normal impulse by which the slip u_t = (v1, v2) has surely stopped, before compression can
    end; or −1.

    With V = u_tᵀ W_tt⁻¹ u_t, dV/dp ≤ −2 |u_t| (μ − |W_tt⁻¹ b|) ≤ −2 (μ − |g|) √(α_min V): the slip
    stops before Δp = √V₀ / ((μ − |g|) √α_min). Compression cannot end before −u_n / (c + μ |b|)
    (|du_n/dp| is at most that, slipping or sticking). Only when nothing after depends on how the
    slip stopped: Newton's and Poisson's restitution, and e = 0 (Stronge's needs the work of the slip).
    """
    mu = S[MU]
    if not (X[COMP] != 0.0 and S[CAN_STICK] != 0.0 and S[ALPHA_MIN] > 0.0):
        return -1.0
    if S[KIND] == ENERGETIC and S[E] > 0.0:
        return -1.0
    margin = mu - S[STICK_NORM]
    if not margin > 1e-9 * mu:
        return -1.0
    V = v1 * (S[AI11] * v1 + S[AI12] * v2) + v2 * (S[AI12] * v1 + S[AI22] * v2)
    bound = 1.000001 * math.sqrt(_max(V, 0.0)) / (margin * math.sqrt(S[ALPHA_MIN]))
    un = _velocity(S, X)[2]
    earliest = -un / (S[W33] + mu * S[BNORM])
    return bound if bound < 0.5 * earliest else -1.0


@njit(cache=True, error_model="numpy")
def _whole_impact(S: NDArray[np.float64], X: NDArray[np.float64], r: float) -> bool:
    """The impulse in one formula when the tangential rate never changes, or ends up not mattering
    (into X[P], X[PT1], X[PT2]); False otherwise (or for a jam, k ≈ 0).

    With a constant rate g the normal velocity is linear, u_n = u_n⁻ + k p (k = c + bᵀg), so all
    three hypotheses end at p = (1 + e) |u_n⁻| / k: without friction (g = 0), sticking from normal
    incidence (g = −W_tt⁺ b, k the Schur complement), slipping from normal incidence along the
    invariant direction (g = −μ s). A slip certain to stop during compression
    (:func:`_stops_in_compression`) leaves the sticking state u_t = 0, P_t = −W_tt⁻¹(u_t⁻ + b p), at
    every later p; Newton's end (u_n = −e u_n⁻), Poisson's (p = (1 + e) p_c) and e = 0 follow from
    u_n = u_n⁻ − bᵀW_tt⁻¹u_t⁻ + S p.
    """
    mu, e, un0 = S[MU], S[E], X[UN0]
    if mu == 0.0 or r == 0.0:
        if mu == 0.0:
            g1 = g2 = 0.0
        elif S[CAN_STICK] != 0.0:
            g1, g2 = S[G1], S[G2]
        else:
            if S[RESLIP] == 0.0:
                _invariant_slip(S)
            g1, g2 = -mu * S[RS1], -mu * S[RS2]
        k = _rate(S, g1, g2)[2]
        if not k > S[JAM] * (1.0 + (g1 * g1 + g2 * g2)):
            return False
        p = (1.0 + e) * -un0 / k
        X[PT1], X[PT2], X[P] = g1 * p, g2 * p, p
        return True
    if S[D] != 3.0:
        return False
    v1, v2 = X[U1], X[U2]
    bound = _stops_in_compression(S, X, v1, v2)
    if not bound > 0.0:
        return False
    b1, b2 = S[W13], S[W23]
    schur = S[W33] + b1 * S[G1] + b2 * S[G2]
    if not schur > S[JAM] * _square(1.0 + S[STICK_NORM], S):
        return False
    beta = b1 * (S[AI11] * v1 + S[AI12] * v2) + b2 * (S[AI12] * v1 + S[AI22] * v2)  # bᵀ W_tt⁻¹ u_t⁻
    if S[KIND] == NEWTON:
        p = (-(1.0 + e) * un0 + beta) / schur
    else:  # poisson, or e = 0
        p = (1.0 + e) * (-un0 + beta) / schur
    X[PT1] = -(S[AI11] * (v1 + b1 * p) + S[AI12] * (v2 + b2 * p))
    X[PT2] = -(S[AI12] * (v1 + b1 * p) + S[AI22] * (v2 + b2 * p))
    X[P] = p
    return True


@njit(cache=True, error_model="numpy")
def _constant_phase(S: NDArray[np.float64], X: NDArray[np.float64], mode: int, d1: float, d2: float
                    ) -> tuple[int, bool, bool]:
    """Advance through one phase of constant tangential rate to its first event.

    ``(d1, d2)`` is the slip direction of a straight slip (mode SLIP). Returns (status, ended,
    stopped): status 0, or a failure with X[INFO:] filled; ended when the impact ended; stopped
    when the phase ended because the slip stopped.
    """
    mu = S[MU]
    if mode == FREE:
        g1 = g2 = 0.0
    elif mode == STICK:
        g1, g2 = S[G1], S[G2]
    elif mode == RESLIP_MODE:
        if S[RESLIP] == 0.0:
            _invariant_slip(S)
        g1, g2 = -mu * S[RS1], -mu * S[RS2]
    else:
        g1, g2 = -mu * d1, -mu * d2
    rho1, rho2, rho_n = _rate(S, g1, g2)
    u1, u2, un = _velocity(S, X)
    gnorm = math.sqrt(g1 * g1 + g2 * g2)
    # W [g; 1] errs by ~ε (1 + |g|)² (g = −W_tt⁺ b itself carries ε |g| cond W_tt), and
    # u = u₋ + W P by ~ε (1 + |P|)
    noise = _max(S[UN_ZERO], S[JAM] * (1.0 + X[P] + math.sqrt(X[PT1] * X[PT1] + X[PT2] * X[PT2])))
    if math.sqrt(rho1 * rho1 + rho2 * rho2 + rho_n * rho_n) <= S[JAM] * _square(1.0 + gnorm, S):
        # a jam: the impulse lies in null(Jᵀ), so u — and v₊, I = JᵀP — can no longer change;
        # any further impulse is invisible and the impact ends here, for every hypothesis
        if X[COMP] != 0.0 and un < -noise:  # energy forbids it
            X[INFO], X[INFO + 1], X[INFO + 2] = un, X[P], mode
            return JAMMED, True, False
        if X[COMP] != 0.0:
            _end_stage(S, X)
        return 0, True, False
    length = _stage_length(S, X, un, rho_n)
    stop = math.inf
    if mode == SLIP:
        along = u1 * d1 + u2 * d2  # slip speed along the (invariant) direction
        lam = rho1 * d1 + rho2 * d2
        if along <= 0.0:
            stop = 0.0
        elif lam < 0.0:
            stop = along / -lam
    ds = _min(length, stop)
    if ds == math.inf:
        # the velocity moves but never reaches the event (u_n falling, or Newton's target above
        # where it levels off): energy forbids it in compression; in restitution the target is out
        # of reach and the impact ends here
        if X[COMP] != 0.0:
            if un < -noise:
                X[INFO], X[INFO + 1], X[INFO + 2], X[INFO + 3] = un, rho_n, X[P], mode
                return NO_END, True, False
            _end_stage(S, X)  # the contact has stopped to rounding: a jam in all but name
        return 0, True, False
    if not math.isfinite(ds * (1.0 + gnorm)):
        X[INFO] = X[P]
        return INFINITE, True, False
    X[P] += ds
    X[PT1] = X[PT1] + g1 * ds
    X[PT2] = X[PT2] + g2 * ds
    X[WK] += ds * (un + 0.5 * rho_n * ds)
    if length <= stop:
        return 0, _end_stage(S, X), False
    return 0, False, True


# ---------------------------------------------------------------------- the turning 3-D slip
@njit(cache=True, error_model="numpy")
def _fixed_point(S: NDArray[np.float64], theta: float) -> tuple[bool, float, float, float, float]:
    """The invariant slip direction nearest θ by Newton: (found, θ*, λ*, dh/dθ at θ*, h(θ)).

    h(θ) = s⊥·(b − μ W_tt s) vanishes where the flow keeps the direction s(θ); the slip angle
    moves monotonically, with the sign of h, towards the next such direction.
    """
    mu, a11, a12, a22, b1, b2 = S[MU], S[W11], S[W12], S[W22], S[W13], S[W23]
    t = theta
    h0 = math.nan
    negligible = 1e-15 * (S[BNORM] + mu * S[ANORM])  # h ≡ 0 for W_tn = 0 and an isotropic W_tt
    converged = False
    for it in range(8):
        c, sn = math.cos(t), math.sin(t)
        F1, F2 = b1 - mu * (a11 * c + a12 * sn), b2 - mu * (a12 * c + a22 * sn)
        h = -sn * F1 + c * F2
        if it == 0:
            h0 = h
        f = c * F1 + sn * F2
        dh = -f - mu * (a11 * sn * sn - 2.0 * a12 * sn * c + a22 * c * c)
        if abs(h) <= negligible:
            converged = True
            break
        if dh == 0.0:
            return False, 0.0, 0.0, 0.0, 0.0
        step = h / dh
        t -= step
        if abs(step) <= 1e-15:
            converged = True
            break
    if not converged or abs(t - theta) > 0.5:
        return False, 0.0, 0.0, 0.0, 0.0
    c, sn = math.cos(t), math.sin(t)
    F1, F2 = b1 - mu * (a11 * c + a12 * sn), b2 - mu * (a12 * c + a22 * sn)
    f = c * F1 + sn * F2
    dh = -f - mu * (a11 * sn * sn - 2.0 * a12 * sn * c + a22 * c * c)
    return True, t, f, dh, h0


@njit(cache=True, error_model="numpy")
def _snap(S: NDArray[np.float64], X: NDArray[np.float64], v1: float, v2: float, r: float
          ) -> tuple[bool, float, float]:
    """The invariant direction to continue straight along, if that is within the tolerance:
    (found, s₁, s₂).

    Continuing along s* instead of the turning û_t changes the friction direction by the angle δ
    between them, which near a stable s* decays over a normal impulse of about r / |h'(θ*)|, and
    leaves the transverse slip r δ in place (removed at the stop): accepted when
    δ (r + μ min(Δp, 2 r / |h'|)) ≤ rtol, Δp the length of that straight phase.
    """
    mu, rtol = S[MU], S[RTOL]
    theta = math.atan2(v2, v1)
    # one Newton step first: far from any invariant direction, no need to find it
    a11, a12, a22 = S[W11], S[W12], S[W22]
    c, sn = v1 / r, v2 / r
    F1, F2 = S[W13] - mu * (a11 * c + a12 * sn), S[W23] - mu * (a12 * c + a22 * sn)
    slope = -(c * F1 + sn * F2) - mu * (a11 * sn * sn - 2.0 * a12 * sn * c + a22 * c * c)
    h = abs(-sn * F1 + c * F2)
    if h * r > 10.0 * rtol * abs(slope) and h > 1e-15 * (S[BNORM] + mu * S[ANORM]):
        return False, 0.0, 0.0
    found, t, lam, dh, h0 = _fixed_point(S, theta)
    if not found:
        return False, 0.0, 0.0
    delta = abs(t - theta)
    # on it to rounding (the flow keeps an exactly invariant slip), or approaching a stable one
    if delta > 1e-14 and not (dh < 0.0 and (t - theta) * h0 > 0.0):
        return False, 0.0, 0.0
    if delta * r > rtol:
        return False, 0.0, 0.0
    s1, s2 = math.cos(t), math.sin(t)
    # the length of the straight phase: to the stop, or to the next stage event
    rho_n = _rate(S, -mu * s1, -mu * s2)[2]
    along = v1 * s1 + v2 * s2
    ds = _stage_length(S, X, _velocity(S, X)[2], rho_n)
    if lam < 0.0:
        ds = _min(ds, along / -lam)
    if delta > 1e-14:
        ds = _min(ds, 2.0 * r / -dh)
    if delta * (r + mu * ds) > rtol:
        return False, 0.0, 0.0
    return True, s1, s2


@njit(cache=True, error_model="numpy")
def _stable_direction(S: NDArray[np.float64], v1: float, v2: float) -> tuple[bool, float, float]:
    """:func:`_snap` for a slip u_t = (v1, v2) down at the noise of the state, where δ means nothing:
    the stable invariant direction close by, if any: (found, s₁, s₂)."""
    found, t, _lam, dh, _h0 = _fixed_point(S, math.atan2(v2, v1))
    if not found or not dh < 0.0:
        return False, 0.0, 0.0
    return True, math.cos(t), math.sin(t)


@njit(cache=True, error_model="numpy")
def _rhs(t: float, d1: float, d2: float, ub1: float, ub2: float, ub3: float, S: NDArray[np.float64]
         ) -> tuple[float, float, float]:
    """dP_t/dp = −μ û_t and u_n = dw/dp at s = p − p_b with ΔP_t = (d1, d2), from u_b at the base."""
    v1 = ub1 + S[W11] * d1 + S[W12] * d2 + S[W13] * t
    v2 = ub2 + S[W12] * d1 + S[W22] * d2 + S[W23] * t
    k = -S[MU] / py_hypot(v1, v2)
    return k * v1, k * v2, ub3 + S[W13] * d1 + S[W23] * d2 + S[W33] * t


@njit(cache=True, error_model="numpy")
def _step(S: NDArray[np.float64], t: float, y0: float, y1: float, y2: float, k0: float, k1: float, k2: float,
          h: float, ub1: float, ub2: float, ub3: float, base1: float, base2: float, K: NDArray[np.float64]
          ) -> tuple[float, float, float, float]:
    """One DOP853 step of the state y = (ΔP_t1, ΔP_t2, w) from (t, y) with f(t, y) = k: the new state
    and the error norm (≤ 1: accept), scaled on the impulses (P_b + ΔP_t, from the base impulse P_b).
    ``K`` (3, 12) holds the stages. The work w does not feed back into f: its stages are f's third
    component, and it is never an argument."""
    # each weighted sum of stages adds the tableau's non-zero terms only, in its order (the sums
    # of the unrolled float arithmetic this was first written as)
    K[0, 0], K[1, 0], K[2, 0] = k0, k1, k2
    for i in range(1, _NS):
        s0 = 0.0
        s1 = 0.0
        for j in range(i):
            a = _A[i, j]
            if a != 0.0:
                s0 += a * K[0, j]
                s1 += a * K[1, j]
        K[0, i], K[1, i], K[2, i] = _rhs(t + _C[i] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    rtol = S[RTOL]
    atol = 0.1 * rtol
    n5 = n3 = 0.0
    new0 = new1 = new2 = 0.0
    for c in range(3):
        sb = s5 = s3 = 0.0
        for j in range(_NS):
            kj = K[c, j]
            if _B[j] != 0.0:
                sb += _B[j] * kj
            if _E5[j] != 0.0:
                s5 += _E5[j] * kj
            if _E3[j] != 0.0:
                s3 += _E3[j] * kj
        if c == 0:
            base, old = base1, y0
        elif c == 1:
            base, old = base2, y1
        else:
            base, old = 0.0, y2
        nw = old + h * sb
        sc = atol + rtol * _max(abs(base + old), abs(base + nw))
        n5 += _square(s5 / sc, S)
        n3 += _square(s3 / sc, S)
        if c == 0:
            new0 = nw
        elif c == 1:
            new1 = nw
        else:
            new2 = nw
    if n5 == 0.0 and n3 == 0.0:
        return new0, new1, new2, 0.0
    return new0, new1, new2, abs(h) * n5 / math.sqrt((n5 + 0.01 * n3) * 3.0)


@njit(cache=True, error_model="numpy")
def _event(S: NDArray[np.float64], X: NDArray[np.float64], t: float, y0: float, y1: float, y2: float, k0: float,
           k1: float, ub3: float, wb: float) -> tuple[float, float]:
    """The stage's event function g (crosses 0 upwards) and dg/dp."""
    b1, b2, c = S[W13], S[W23], S[W33]
    un = ub3 + b1 * y0 + b2 * y1 + c * t
    if X[COMP] != 0.0:
        return un, c + b1 * k0 + b2 * k1
    kind = S[KIND]
    if kind == NEWTON:
        return un + S[E] * X[UN0], c + b1 * k0 + b2 * k1
    if kind == POISSON:
        return -1.0, 0.0  # its end is a value of p_n: the step is cut there
    return (wb + y2) - _target_work(S, X), un


@njit(cache=True, error_model="numpy")
def _locate(S: NDArray[np.float64], X: NDArray[np.float64], p: float, y0: float, y1: float, y2: float, k0: float,
            k1: float, k2: float, h: float, g0: float, dg0: float, g1: float, dg1: float, origin: float, ub1: float,
            ub2: float, ub3: float, base1: float, base2: float, wb: float, K: NDArray[np.float64]
            ) -> float:
    """The step length τ ∈ (0, h] at which the event function crosses 0.

    A cubic Hermite guess from both ends (the dense output), then Newton on τ with each g(τ) from a
    full step of length τ, bracketed by bisection, down to the rounding of the normal impulse
    origin + p + τ (``p`` is counted from ``origin``).
    """
    m0, m1 = dg0 * h, dg1 * h
    t = g0 / (g0 - g1)
    for _ in range(30):
        t2, t3 = t * t, t * t * t
        val = (2.0 * t3 - 3.0 * t2 + 1.0) * g0 + (t3 - 2.0 * t2 + t) * m0 + (-2.0 * t3 + 3.0 * t2) * g1 + (t3 - t2) * m1
        der = (6.0 * t2 - 6.0 * t) * g0 + (3.0 * t2 - 4.0 * t + 1.0) * m0 + (-6.0 * t2 + 6.0 * t) * g1 + (
            3.0 * t2 - 2.0 * t) * m1
        nt = t - val / der if der > 0.0 else t
        if not 0.0 < nt < 1.0 or abs(nt - t) <= 1e-15:
            break
        t = nt
    lo, hi = 0.0, h  # g(lo) < 0 <= g(hi)
    tau = t * h
    for _ in range(60):
        if not lo < tau < hi:
            tau = 0.5 * (lo + hi)
        n0, n1, n2, _err = _step(S, p, y0, y1, y2, k0, k1, k2, tau, ub1, ub2, ub3, base1, base2, K)
        X[STEPS] += 1.0
        f0, f1, _f2 = _rhs(p + tau, n0, n1, ub1, ub2, ub3, S)
        g, dg = _event(S, X, p + tau, n0, n1, n2, f0, f1, ub3, wb)
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


@njit(cache=True, error_model="numpy")
def _integrate(S: NDArray[np.float64], X: NDArray[np.float64], K: NDArray[np.float64]
               ) -> tuple[int, bool, int, bool, float, float]:
    """Integrate du_t/dp = b − μ W_tt û_t by DOP853 until the slip settles, stops or the impact ends.

    Returns (status, impact ended, next mode, straight direction found, s₁, s₂).

    The integration runs on increments from a base point (the phase start, then the end of
    compression): the clock s = p − p_b and the state y = (ΔP_t1, ΔP_t2, Δw), the normal work
    w = ∫u_n dp of the stage formed from the increments themselves, which carry their own relative
    precision (from the absolute impulses a small restitution target e² |W_c| would be located only
    to ~√ε in p_n).

    Steps never reach past where the slip, continued straight, would stop (r / |dr/dp|), and a step
    that turns u_t through 0 is refused, so no step straddles the discontinuity at u_t = 0. Near a
    stop the solution is self-similar (it scales with r = |u_t|), so step proposals shrink with r.
    Events (compression end, Newton's or Stronge's end) are located by :func:`_locate`; a stage whose
    event function is already ≥ 0 at its base point (a restitution target within rounding of where
    compression ended, e.g. e² W_c or e u_n⁻ below the smallest float for a tiny e) ends there, since
    no crossing from below would ever be seen.
    """
    mu, rtol = S[MU], S[RTOL]
    a11, a12, a22, b1, b2 = S[W11], S[W12], S[W22], S[W13], S[W23]
    poisson = S[KIND] == POISSON
    tol = 0.1 * rtol
    # the base point: p_b, P_t at it, the stage's work w_b there and the velocity u_b there
    pb, Pb1, Pb2, wb = X[P], X[PT1], X[PT2], X[WK]
    ub1, ub2, ub3 = _velocity(S, X)
    t, y0, y1, y2 = 0.0, 0.0, 0.0, 0.0
    k0, k1, k2 = _rhs(t, 0.0, 0.0, ub1, ub2, ub3, S)
    while _event(S, X, t, y0, y1, y2, k0, k1, ub3, wb)[0] >= 0.0:  # the stage has ended at its base point
        if _end_stage(S, X):
            return 0, True, SLIP, False, 0.0, 0.0
        wb = X[WK]  # 0: the work of restitution starts here
    v1 = ub1 + a11 * y0 + a12 * y1 + b1 * t
    v2 = ub2 + a12 * y0 + a22 * y1 + b2 * t
    r = py_hypot(v1, v2)
    h = 0.1 * r / _max(S[BNORM] + mu * S[ANORM], 1e-300)  # |du_t/dp| ≤ |b| + μ |W_tt|
    for _ in range(int(S[MAX_STEPS])):
        # the slip continued straight would stop after r / |dr/dp|: step a fraction of that at most
        dr = (v1 * (b1 + a11 * k0 + a12 * k1) + v2 * (b2 + a12 * k0 + a22 * k1)) / r
        if dr < 0.0:
            h = _min(h, 0.8 * r / -dr)
        end = math.inf
        if X[COMP] == 0.0 and poisson:
            end = _poisson_left(S, X, pb) - t
            if end <= 0.0:
                return 0, True, SLIP, False, 0.0, 0.0
            h = _min(h, end)
        n0, n1, n2, err = _step(S, t, y0, y1, y2, k0, k1, k2, h, ub1, ub2, ub3, Pb1, Pb2, K)
        X[STEPS] += 1.0
        t_new = t + h
        w1 = ub1 + a11 * n0 + a12 * n1 + b1 * t_new
        w2 = ub2 + a12 * n0 + a22 * n1 + b2 * t_new
        r_new = py_hypot(w1, w2)
        if not err <= 1.0 or w1 * v1 + w2 * v2 <= 0.0:  # refused (a turn through u_t = 0 too)
            h *= _max(0.2, 0.9 * err ** -0.125) if 1.0 < err < math.inf else 0.2
            if h <= 1e-15 * _max(pb + t, 1e-300):
                X[INFO], X[INFO + 1], X[INFO + 2] = pb + t, r, X[COMP]
                return STALLED, True, SLIP, False, 0.0, 0.0
            continue
        f0, f1, f2 = _rhs(t_new, n0, n1, ub1, ub2, ub3, S)
        g0, dg0 = _event(S, X, t, y0, y1, y2, k0, k1, ub3, wb)
        g1, dg1 = _event(S, X, t_new, n0, n1, n2, f0, f1, ub3, wb)
        ended = end == h
        if g1 >= 0.0 and g0 < 0.0:
            tau = _locate(S, X, t, y0, y1, y2, k0, k1, k2, h, g0, dg0, g1, dg1, pb, ub1, ub2, ub3, Pb1, Pb2, wb, K)
            if tau < h:
                t_new = t + tau
                n0, n1, n2, _err = _step(S, t, y0, y1, y2, k0, k1, k2, tau, ub1, ub2, ub3, Pb1, Pb2, K)
                f0, f1, f2 = _rhs(t_new, n0, n1, ub1, ub2, ub3, S)
            X[P], X[PT1], X[PT2], X[WK] = pb + t_new, Pb1 + n0, Pb2 + n1, wb + n2
            if _end_stage(S, X):
                return 0, True, SLIP, False, 0.0, 0.0
            # the work restarts from 0 at the end of compression: a new base point
            pb, Pb1, Pb2, wb = X[P], X[PT1], X[PT2], X[WK]
            ub1, ub2, ub3 = _velocity(S, X)
            t_new, n0, n1, n2 = 0.0, 0.0, 0.0, 0.0
            f0, f1, f2 = _rhs(0.0, 0.0, 0.0, ub1, ub2, ub3, S)
            w1 = ub1 + a11 * n0 + a12 * n1 + b1 * t_new
            w2 = ub2 + a12 * n0 + a22 * n1 + b2 * t_new
            r_new = py_hypot(w1, w2)
            if _event(S, X, 0.0, n0, n1, n2, f0, f1, ub3, wb)[0] >= 0.0:  # restitution ends where it starts
                _end_stage(S, X)
                return 0, True, SLIP, False, 0.0, 0.0
        elif ended:  # Poisson's end
            X[P], X[PT1], X[PT2], X[WK] = pb + t_new, Pb1 + n0, Pb2 + n1, wb + n2
            return 0, True, SLIP, False, 0.0, 0.0
        grow = _min(10.0, 0.9 * err ** -0.125) if err > 0.0 else 10.0
        h *= grow * _min(1.0, r_new / r)
        t, y0, y1, y2, k0, k1, k2, v1, v2, r = t_new, n0, n1, n2, f0, f1, f2, w1, w2, r_new
        X[P], X[PT1], X[PT2], X[WK] = pb + t, Pb1 + y0, Pb2 + y1, wb + y2
        # what u_t = u₋ + W_tt P_t + b p is worth: below that the slip has stopped for all we know
        floor = _max(S[STOP] * tol, rtol * (S[ANORM] * py_hypot(X[PT1], X[PT2]) + S[BNORM] * X[P]))
        if r <= floor:
            found, s1, s2 = _stable_direction(S, v1, v2)
            if not found:
                return 0, False, _stopped_mode(S, X), False, 0.0, 0.0
            return 0, False, SLIP, True, s1, s2
        found, s1, s2 = _snap(S, X, v1, v2, r)
        if found:
            return 0, False, SLIP, True, s1, s2
    X[INFO], X[INFO + 1] = pb + t, r
    return TOO_MANY_STEPS, True, SLIP, False, 0.0, 0.0


@njit(cache=True, error_model="numpy")
def _turning_slip(S: NDArray[np.float64], X: NDArray[np.float64], K: NDArray[np.float64]
                  ) -> tuple[int, bool, int, bool, float, float]:
    """A 3-D slip whose direction may turn: closed forms where possible, else integrate.

    Returns (status, impact ended, next mode, straight direction found, s₁, s₂).
    """
    v1, v2, _ = _velocity(S, X)
    r = py_hypot(v1, v2)
    if r <= S[STOP] * (0.1 * S[RTOL]):  # the stop tolerance, 0.1 rtol at unit speed
        return 0, False, _stopped_mode(S, X), False, 0.0, 0.0
    bound = _stops_in_compression(S, X, v1, v2)
    if bound >= 0.0:
        # jump over a slip that surely stops during compression to the sticking state
        # u_t = 0, P_t = P_t − W_tt⁻¹(u_t + b Δp), when nothing after depends on how it stopped
        b1, b2 = S[W13], S[W23]
        X[P] += bound
        X[PT1] = X[PT1] - (S[AI11] * (v1 + b1 * bound) + S[AI12] * (v2 + b2 * bound))
        X[PT2] = X[PT2] - (S[AI12] * (v1 + b1 * bound) + S[AI22] * (v2 + b2 * bound))
        X[WK] = math.nan  # not needed: no restitution hypothesis used here reads W_c
        return 0, False, STICK, False, 0.0, 0.0
    found, s1, s2 = _snap(S, X, v1, v2, r)
    if found:
        return 0, False, SLIP, True, s1, s2
    return _integrate(S, X, K)


# ---------------------------------------------------------------------- one impact, many
@njit(cache=True, error_model="numpy")
def _run(S: NDArray[np.float64], X: NDArray[np.float64], K: NDArray[np.float64]) -> int:
    """One impact from u₋ = X[U1, U2, UN0]: the impulse into X[PT1], X[PT2], X[P] (for W / tr W) and
    the integration steps into X[STEPS]; returns the status."""
    X[P] = X[PT1] = X[PT2] = X[WK] = X[PC] = X[WC] = X[STEPS] = 0.0
    X[COMP] = 1.0
    v1, v2 = X[U1], X[U2]
    r = math.sqrt(v1 * v1 + v2 * v2)
    if _whole_impact(S, X, r):
        return 0
    mu = S[MU]
    straight, d1, d2 = False, 0.0, 0.0  # the slip direction of a straight slip
    if mu == 0.0:
        mode = FREE
    elif r == 0.0:
        mode = STICK if S[CAN_STICK] != 0.0 else RESLIP_MODE
    elif S[D] == 2.0:
        mode, straight, d1 = SLIP, True, math.copysign(1.0, v1)
    else:
        mode = SLIP  # not straight: a 3-D slip that may turn
    for _ in range(int(S[MAX_PHASES])):
        if mode == SLIP and not straight:
            status, done, mode, straight, d1, d2 = _turning_slip(S, X, K)
            if status or done:
                return status
            continue
        status, done, stopped = _constant_phase(S, X, mode, d1, d2)
        if status or done:
            return status
        if mode == SLIP and stopped:
            mode, straight = _stopped_mode(S, X), False
    X[INFO] = X[P]
    return TOO_MANY_PHASES


@njit(cache=True, error_model="numpy")
def impact_rows(S: NDArray[np.float64], U: NDArray[np.float64], out: NDArray[np.float64], steps: NDArray[np.int64],
                info: NDArray[np.float64]) -> int:
    """Impacts from the unit velocities ``U`` (B, d), local frame, W / tr W as in ``S``.

    Writes the impulses into ``out`` (B, d) and the integration steps of each row into ``steps``
    (B,). Returns −1, or the first row that failed with its status in ``info[0]`` and its numbers
    in ``info[1:5]`` (the rows after it are not computed).
    """
    d = U.shape[1]
    X = np.zeros(ROW_SIZE)
    K = np.empty((3, _NS))
    for i in range(U.shape[0]):
        X[U1] = U[i, 0]
        X[U2] = U[i, 1] if d == 3 else 0.0
        X[UN0] = U[i, d - 1]
        status = _run(S, X, K)
        if status:
            info[0] = status
            for j in range(4):
                info[1 + j] = X[INFO + j]
            return i
        out[i, 0] = X[PT1]
        if d == 3:
            out[i, 1] = X[PT2]
        out[i, d - 1] = X[P]
        steps[i] = int(X[STEPS])
    return -1


@njit(cache=True, error_model="numpy")
def impact_one(S: NDArray[np.float64], u1: float, u2: float, un: float
               ) -> tuple[int, float, float, float, int, float, float, float, float]:
    """One impact from the unit velocity (u1, u2, un) (u2 = 0 for d = 2), local frame, W / tr W:
    (status, P_t1, P_t2, p_n, integration steps, the failure's four numbers)."""
    X = np.zeros(ROW_SIZE)
    K = np.empty((3, _NS))
    X[U1], X[U2], X[UN0] = u1, u2, un
    status = _run(S, X, K)
    return status, X[PT1], X[PT2], X[P], int(X[STEPS]), X[INFO], X[INFO + 1], X[INFO + 2], X[INFO + 3]


def jit_seconds() -> float:
    """Wall time to make the kernels callable in this process (numba's import excluded: importing
    this module does it): their machine code loaded from numba's on-disk cache (``__pycache__`` next
    to this file), or compiled when that cache is missing or stale. The first call pays it; later
    calls return near 0."""
    start = time.perf_counter()
    third = 1.0 / 3.0  # W / tr W = I / 3, μ = ½, Stronge's e = ½: a slip straight to its end
    setup = SimpleNamespace(d=3, tr=1.0, w11=third, w12=0.0, w13=0.0, w21=0.0, w22=third, w23=0.0, w31=0.0, w32=0.0,
                            w33=third, ai11=3.0, ai12=0.0, ai22=3.0, alpha_min=third, anorm=third, bnorm=0.0, g1=0.0,
                            g2=0.0, stick_norm=0.0, can_stick=True, mu=0.5)
    S = pack(setup, 0.5, ENERGETIC, 1e-10, 1e-14, 1e-12, 1e-2, 64, 100)
    impact_rows(S, np.array([[0.6, 0.0, -0.8]]), np.empty((1, 3)), np.zeros(1, dtype=np.int64), np.zeros(5))
    impact_one(S, 0.6, 0.0, -0.8)
    return time.perf_counter() - start

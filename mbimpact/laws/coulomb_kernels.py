"""The compiled core of :class:`~mbimpact.CoulombLaw`: one impact per row, phase by phase.

This is the algorithm the module docstring of :mod:`mbimpact.laws.coulomb` describes — closed
forms for the phases of constant tangential rate, a Dormand–Prince 8(5,3) integration of the
3-D slip that still turns, the hand-overs between them — compiled by numba (``njit``, cached on
disk). It is imported on first use only: numba costs ~0.3 s to import, more than ``import
mbimpact`` may take. :func:`jit_seconds` loads or compiles it and says how long that took.

Three entry points, one compiled call each (numba's dispatch costs ~20 ns a float and ~0.1 µs an
array): :func:`impact_one`, a whole single impact from W and the contact velocity as floats (the
setup, the unit velocity and the impulse); :func:`impact_local`, the same from the arrays W (d, d)
and U (1, d) that :meth:`mbimpact.CoulombLaw.single_impulse` takes (reading them here is cheaper
than their conversion to floats in Python); and :func:`impact_rows`, the rows of a batch.
:func:`impact_one` and :func:`impact_rows` take W as the tuple ``(d, w11, w12, w13, w21, w22, w23,
w31, w32, w33)`` (a planar W in the corners, the second tangential axis 0); all take the law as the
tuple of :data:`LAW_SIZE` floats ``(μ, e, restitution, rtol, jam, u_n zero, stop, max phases, max
steps, rank cut, degenerate)``.

Everything is in floats on two small arrays, for speed and so that the arithmetic is the same
operation for operation whatever runs it (CPython's ``math.hypot`` included where the closed forms
of :mod:`mbimpact.laws.coulomb` compute the same in Python, see :func:`py_hypot`; the integration,
which nothing in Python mirrors, takes the cheaper :func:`_norm`):

* the setup ``S`` (:data:`SETUP_SIZE` floats, what every row at one Delassus matrix shares, for
  W / tr W): the law and its tolerances, then the entries of W, W_tt⁺, the sticking rate, filled
  by :func:`_setup` — the same arithmetic as :mod:`mbimpact.laws.coulomb`'s ``_setup``; a planar
  contact (d = 2) is the spatial one with the second tangential axis absent (its entries 0, which
  adds exact zeros only);
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

import numpy as np
from numba import njit, types
from numpy.typing import NDArray

from ..metric.kernels import READY, finish_into, prepare_into

__all__ = ["impact_rows", "impact_one", "impact_local", "coulomb_batch", "jit_seconds", "py_hypot", "NEWTON", "POISSON",
           "ENERGETIC", "NOT_PREPARED", "MODES", "LAW_SIZE", "JAMMED", "NO_END", "INFINITE", "STALLED", "TOO_MANY_STEPS", "TOO_MANY_PHASES",
           "BAD_TRACE", "OUT_OF_REACH"]

# ---------------------------------------------------------------------- layouts
# the setup S: the law and its tolerances (the law tuple, as given), then d, tr W, the rows of W / tr W
# (t₁, t₂, n), W_tt⁺ (symmetric), its norms, the sticking rate g = −W_tt⁺ b with |g| and whether |g| ≤ μ,
# det(W / tr W), the slip direction kept by the flow from u_t = 0 when the contact cannot stick (and
# whether it has been computed), and 2.0 (see :func:`_square`)
(MU, E, KIND, RTOL, JAM, UN_ZERO, STOP, MAX_PHASES, MAX_STEPS, CUT, DEGENERATE,
 D, TR, W11, W12, W13, W21, W22, W23, W31, W32, W33, AI11, AI12, AI22, ALPHA_MIN, ANORM, BNORM, G1, G2,
 STICK_NORM, CAN_STICK, DET, RESLIP, RS1, RS2, TWO) = range(37)
LAW_SIZE = D
SETUP_SIZE = 37
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
# (p_n, |u_t|); too many phases (p_n); tr W not positive and finite (tr W). OUT_OF_REACH is no failure
# of the law: n⁰ᵀWn⁰ ≈ 0 or a rank-deficient W, which the caller's general route names or treats
JAMMED, NO_END, INFINITE, STALLED, TOO_MANY_STEPS, TOO_MANY_PHASES, BAD_TRACE, OUT_OF_REACH = 1, 2, 3, 4, 5, 6, 7, 8

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
    field = (np.float64(big).view(np.int64) >> 52) & 0x7FF  # big's biased exponent: frexp's is field − 1022
    normal = 1 <= field <= 2044
    if normal:
        # 2^−e and 2^e (e = field − 1022) from their bits, both normal floats: exact as ldexp is, without the
        # calls to frexp and ldexp, and the last division a product (all on the critical path of a stage)
        scale = float(np.int64((2045 - field) << 52).view(np.float64))
        inv = float(np.int64((field + 1) << 52).view(np.float64))
    else:  # big subnormal or ≥ 2¹⁰²²: CPython's own steps
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
        inv = 0.0
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
    # z / 2^−e and z · 2^e are the same correctly rounded number
    return (h + sq / (2.0 * h)) * inv if normal else (h + sq / (2.0 * h)) / scale


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


@njit(cache=True, error_model="numpy")
def _norm(x: float, y: float) -> float:
    """|(x, y)| as √(x² + y²) where no square over- or underflows, else :func:`py_hypot`.

    For the integration of the turning slip, where it is evaluated at every stage on the critical
    path: about five times cheaper than :func:`py_hypot`, within an ulp of it, and the same floats
    compiled or interpreted (only the closed forms must match CPython's ``math.hypot``).
    """
    s = x * x + y * y
    if 1e-290 < s < 1e290:  # the larger square is normal: the smaller one, if not, is below its rounding
        return math.sqrt(s)
    return py_hypot(x, y)


# ---------------------------------------------------------------------- the setup
@njit(cache=True, error_model="numpy")
def _setup(w: tuple[float, ...], law: tuple[float, ...]) -> NDArray[np.float64]:
    """The setup array S for W = ``w`` (the tuple of the module docstring) and the law tuple ``law``.

    The arithmetic of :mod:`mbimpact.laws.coulomb`'s ``_setup``, operation for operation (a single
    impact in floats and one through the kernels share their decisions and impulses to the last
    bit). S[TR] is tr W whatever it is: the caller tells BAD_TRACE by it (the rest is then unset).
    """
    S = np.empty(SETUP_SIZE)
    for i in range(LAW_SIZE):
        S[i] = law[i]
    S[RESLIP] = S[RS1] = S[RS2] = 0.0
    S[TWO] = 2.0
    d = w[0]
    w11, w12, w13, w21, w22, w23, w31, w32, w33 = w[1], w[2], w[3], w[4], w[5], w[6], w[7], w[8], w[9]
    S[D] = d
    S[TR] = tr = w11 + w22 + w33 if d == 3.0 else w11 + w33 + 0.0
    if not (tr > 0.0 and math.isfinite(tr)):
        return S
    cut, mu = S[CUT], S[MU]
    w11, w13, w31, w33 = w11 / tr, w13 / tr, w31 / tr, w33 / tr
    if d == 3.0:
        w12, w21, w22, w23, w32 = w12 / tr, w21 / tr, w22 / tr, w23 / tr, w32 / tr
    else:
        w12 = w21 = w22 = w23 = w32 = 0.0
    S[W11], S[W12], S[W13], S[W21], S[W22], S[W23] = w11, w12, w13, w21, w22, w23
    S[W31], S[W32], S[W33] = w31, w32, w33
    if d == 2.0:
        S[ALPHA_MIN] = w11 if w11 > cut else 0.0
        ai11, ai12, ai22 = (1.0 / w11 if w11 > cut else 0.0), 0.0, 0.0
        S[ANORM] = abs(w11)
        S[DET] = w11 * w33 - w13 * w31
    else:
        a11, a12, a22 = w11, w12, w22
        m, half = 0.5 * (a11 + a22), 0.5 * (a11 - a22)
        hi = m + py_hypot(half, a12)
        det = a11 * a22 - a12 * a12
        lo = _max(det / hi, 0.0) if hi > 0.0 else 0.0  # no cancellation in m − rad
        S[ANORM] = hi
        if lo > cut:
            S[ALPHA_MIN] = lo
            ai11, ai12, ai22 = a22 / det, -a12 / det, a11 / det
        else:  # rank ≤ 1: W_tt⁺ = q qᵀ / α along the one eigenvector left
            S[ALPHA_MIN] = 0.0
            phi = 0.5 * math.atan2(2.0 * a12, a11 - a22)
            q1, q2 = math.cos(phi), math.sin(phi)
            inv = 1.0 / hi if hi > cut else 0.0
            ai11, ai12, ai22 = q1 * q1 * inv, q1 * q2 * inv, q2 * q2 * inv
        S[DET] = (w11 * (w22 * w33 - w23 * w23) - w12 * (w12 * w33 - w23 * w13)
                  + w13 * (w12 * w23 - w22 * w13))
    S[AI11], S[AI12], S[AI22] = ai11, ai12, ai22
    g1, g2 = -(ai11 * w13 + ai12 * w23), -(ai12 * w13 + ai22 * w23)
    S[G1], S[G2] = g1, g2
    S[STICK_NORM] = stick_norm = math.sqrt(g1 * g1 + g2 * g2)
    S[BNORM] = math.sqrt(w13 * w13 + w23 * w23)
    S[CAN_STICK] = 1.0 if mu > 0.0 and stick_norm <= mu * (1.0 + 1e-12) else 0.0
    return S


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
    # one Newton step first: far from any invariant direction, no need to find it
    a11, a12, a22 = S[W11], S[W12], S[W22]
    c, sn = v1 / r, v2 / r
    F1, F2 = S[W13] - mu * (a11 * c + a12 * sn), S[W23] - mu * (a12 * c + a22 * sn)
    slope = -(c * F1 + sn * F2) - mu * (a11 * sn * sn - 2.0 * a12 * sn * c + a22 * c * c)
    h = abs(-sn * F1 + c * F2)
    if h * r > 10.0 * rtol * abs(slope) and h > 1e-15 * (S[BNORM] + mu * S[ANORM]):
        return False, 0.0, 0.0
    theta = math.atan2(v2, v1)
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
    k = -S[MU] / _norm(v1, v2)
    return k * v1, k * v2, ub3 + S[W13] * d1 + S[W23] * d2 + S[W33] * t


@njit(cache=True, error_model="numpy")
def _step(S: NDArray[np.float64], t: float, y0: float, y1: float, y2: float, k0_0: float, k1_0: float, k2_0: float,
          h: float, ub1: float, ub2: float, ub3: float, base1: float, base2: float
          ) -> tuple[float, float, float, float]:
    """One DOP853 step of the state y = (ΔP_t1, ΔP_t2, w) from (t, y) with f(t, y) = k_0: the new state
    and the error norm (≤ 1: accept), scaled on the impulses (P_b + ΔP_t, from the base impulse P_b).
    The work w does not feed back into f: its stages are f's third component, and it is never an
    argument.

    Written out stage by stage (k0_i, k1_i, k2_i: the components of stage i), each weighted sum adding
    the tableau's non-zero terms only, in its order: the stages stay in registers, where a loop over a
    stage array took ~12 % longer (the sums are the same operations, to the last bit).
    """
    s0 = 0.0 + _A[1, 0] * k0_0
    s1 = 0.0 + _A[1, 0] * k1_0
    k0_1, k1_1, k2_1 = _rhs(t + _C[1] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    s0 = 0.0 + _A[2, 0] * k0_0 + _A[2, 1] * k0_1
    s1 = 0.0 + _A[2, 0] * k1_0 + _A[2, 1] * k1_1
    k0_2, k1_2, k2_2 = _rhs(t + _C[2] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    s0 = 0.0 + _A[3, 0] * k0_0 + _A[3, 2] * k0_2
    s1 = 0.0 + _A[3, 0] * k1_0 + _A[3, 2] * k1_2
    k0_3, k1_3, k2_3 = _rhs(t + _C[3] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    s0 = 0.0 + _A[4, 0] * k0_0 + _A[4, 2] * k0_2 + _A[4, 3] * k0_3
    s1 = 0.0 + _A[4, 0] * k1_0 + _A[4, 2] * k1_2 + _A[4, 3] * k1_3
    k0_4, k1_4, k2_4 = _rhs(t + _C[4] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    s0 = 0.0 + _A[5, 0] * k0_0 + _A[5, 3] * k0_3 + _A[5, 4] * k0_4
    s1 = 0.0 + _A[5, 0] * k1_0 + _A[5, 3] * k1_3 + _A[5, 4] * k1_4
    k0_5, k1_5, k2_5 = _rhs(t + _C[5] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    s0 = 0.0 + _A[6, 0] * k0_0 + _A[6, 3] * k0_3 + _A[6, 4] * k0_4 + _A[6, 5] * k0_5
    s1 = 0.0 + _A[6, 0] * k1_0 + _A[6, 3] * k1_3 + _A[6, 4] * k1_4 + _A[6, 5] * k1_5
    k0_6, k1_6, k2_6 = _rhs(t + _C[6] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    s0 = 0.0 + _A[7, 0] * k0_0 + _A[7, 3] * k0_3 + _A[7, 4] * k0_4 + _A[7, 5] * k0_5 + _A[7, 6] * k0_6
    s1 = 0.0 + _A[7, 0] * k1_0 + _A[7, 3] * k1_3 + _A[7, 4] * k1_4 + _A[7, 5] * k1_5 + _A[7, 6] * k1_6
    k0_7, k1_7, k2_7 = _rhs(t + _C[7] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    s0 = 0.0 + _A[8, 0] * k0_0 + _A[8, 3] * k0_3 + _A[8, 4] * k0_4 + _A[8, 5] * k0_5 + _A[8, 6] * k0_6 + _A[8, 7] * k0_7
    s1 = 0.0 + _A[8, 0] * k1_0 + _A[8, 3] * k1_3 + _A[8, 4] * k1_4 + _A[8, 5] * k1_5 + _A[8, 6] * k1_6 + _A[8, 7] * k1_7
    k0_8, k1_8, k2_8 = _rhs(t + _C[8] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    s0 = (0.0 + _A[9, 0] * k0_0 + _A[9, 3] * k0_3 + _A[9, 4] * k0_4 + _A[9, 5] * k0_5 + _A[9, 6] * k0_6
          + _A[9, 7] * k0_7 + _A[9, 8] * k0_8)
    s1 = (0.0 + _A[9, 0] * k1_0 + _A[9, 3] * k1_3 + _A[9, 4] * k1_4 + _A[9, 5] * k1_5 + _A[9, 6] * k1_6
          + _A[9, 7] * k1_7 + _A[9, 8] * k1_8)
    k0_9, k1_9, k2_9 = _rhs(t + _C[9] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    s0 = (0.0 + _A[10, 0] * k0_0 + _A[10, 3] * k0_3 + _A[10, 4] * k0_4 + _A[10, 5] * k0_5 + _A[10, 6] * k0_6
          + _A[10, 7] * k0_7 + _A[10, 8] * k0_8 + _A[10, 9] * k0_9)
    s1 = (0.0 + _A[10, 0] * k1_0 + _A[10, 3] * k1_3 + _A[10, 4] * k1_4 + _A[10, 5] * k1_5 + _A[10, 6] * k1_6
          + _A[10, 7] * k1_7 + _A[10, 8] * k1_8 + _A[10, 9] * k1_9)
    k0_10, k1_10, k2_10 = _rhs(t + _C[10] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    s0 = (0.0 + _A[11, 0] * k0_0 + _A[11, 3] * k0_3 + _A[11, 4] * k0_4 + _A[11, 5] * k0_5 + _A[11, 6] * k0_6
          + _A[11, 7] * k0_7 + _A[11, 8] * k0_8 + _A[11, 9] * k0_9 + _A[11, 10] * k0_10)
    s1 = (0.0 + _A[11, 0] * k1_0 + _A[11, 3] * k1_3 + _A[11, 4] * k1_4 + _A[11, 5] * k1_5 + _A[11, 6] * k1_6
          + _A[11, 7] * k1_7 + _A[11, 8] * k1_8 + _A[11, 9] * k1_9 + _A[11, 10] * k1_10)
    k0_11, k1_11, k2_11 = _rhs(t + _C[11] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    sb0 = (0.0 + _B[0] * k0_0 + _B[5] * k0_5 + _B[6] * k0_6 + _B[7] * k0_7 + _B[8] * k0_8 + _B[9] * k0_9
           + _B[10] * k0_10 + _B[11] * k0_11)
    sb1 = (0.0 + _B[0] * k1_0 + _B[5] * k1_5 + _B[6] * k1_6 + _B[7] * k1_7 + _B[8] * k1_8 + _B[9] * k1_9
           + _B[10] * k1_10 + _B[11] * k1_11)
    sb2 = (0.0 + _B[0] * k2_0 + _B[5] * k2_5 + _B[6] * k2_6 + _B[7] * k2_7 + _B[8] * k2_8 + _B[9] * k2_9
           + _B[10] * k2_10 + _B[11] * k2_11)
    s50 = (0.0 + _E5[0] * k0_0 + _E5[5] * k0_5 + _E5[6] * k0_6 + _E5[7] * k0_7 + _E5[8] * k0_8 + _E5[9] * k0_9
           + _E5[10] * k0_10 + _E5[11] * k0_11)
    s51 = (0.0 + _E5[0] * k1_0 + _E5[5] * k1_5 + _E5[6] * k1_6 + _E5[7] * k1_7 + _E5[8] * k1_8 + _E5[9] * k1_9
           + _E5[10] * k1_10 + _E5[11] * k1_11)
    s52 = (0.0 + _E5[0] * k2_0 + _E5[5] * k2_5 + _E5[6] * k2_6 + _E5[7] * k2_7 + _E5[8] * k2_8 + _E5[9] * k2_9
           + _E5[10] * k2_10 + _E5[11] * k2_11)
    s30 = (0.0 + _E3[0] * k0_0 + _E3[5] * k0_5 + _E3[6] * k0_6 + _E3[7] * k0_7 + _E3[8] * k0_8 + _E3[9] * k0_9
           + _E3[10] * k0_10 + _E3[11] * k0_11)
    s31 = (0.0 + _E3[0] * k1_0 + _E3[5] * k1_5 + _E3[6] * k1_6 + _E3[7] * k1_7 + _E3[8] * k1_8 + _E3[9] * k1_9
           + _E3[10] * k1_10 + _E3[11] * k1_11)
    s32 = (0.0 + _E3[0] * k2_0 + _E3[5] * k2_5 + _E3[6] * k2_6 + _E3[7] * k2_7 + _E3[8] * k2_8 + _E3[9] * k2_9
           + _E3[10] * k2_10 + _E3[11] * k2_11)
    rtol = S[RTOL]
    atol = 0.1 * rtol
    new0, new1, new2 = y0 + h * sb0, y1 + h * sb1, y2 + h * sb2
    sc0 = atol + rtol * _max(abs(base1 + y0), abs(base1 + new0))
    sc1 = atol + rtol * _max(abs(base2 + y1), abs(base2 + new1))
    sc2 = atol + rtol * _max(abs(0.0 + y2), abs(0.0 + new2))
    # (products, not libm's pow as Python's ** would be: nothing in Python mirrors this step)
    e0, e1, e2, f0, f1, f2 = s50 / sc0, s51 / sc1, s52 / sc2, s30 / sc0, s31 / sc1, s32 / sc2
    n5 = 0.0 + e0 * e0 + e1 * e1 + e2 * e2
    n3 = 0.0 + f0 * f0 + f1 * f1 + f2 * f2
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
def _event_curvature(S: NDArray[np.float64], X: NDArray[np.float64], v1: float, v2: float, k0: float, k1: float
                     ) -> float:
    """d²g/dp² of the stage's event function where the slip is (v1, v2) and dP_t/dp = (k0, k1) = −μ û_t.

    Stronge's g'' is du_n/dp = c + bᵀk; the others' (u_n shifted) is bᵀ dk/dp, with
    dk/dp = −μ (I − û ûᵀ) (du_t/dp) / |u_t| and du_t/dp = b + W_tt k.
    """
    b1, b2 = S[W13], S[W23]
    if X[COMP] == 0.0 and S[KIND] == ENERGETIC:
        return S[W33] + b1 * k0 + b2 * k1
    d1 = b1 + S[W11] * k0 + S[W12] * k1
    d2 = b2 + S[W12] * k0 + S[W22] * k1
    r = _norm(v1, v2)
    c, s = v1 / r, v2 / r
    along = c * d1 + s * d2
    q = -S[MU] / r
    return b1 * (q * (d1 - c * along)) + b2 * (q * (d2 - s * along))


@njit(cache=True, error_model="numpy")
def _locate(S: NDArray[np.float64], X: NDArray[np.float64], p: float, y0: float, y1: float, y2: float, k0: float,
            k1: float, k2: float, h: float, g0: float, dg0: float, ddg0: float, g1: float, dg1: float, ddg1: float,
            origin: float, ub1: float, ub2: float, ub3: float, base1: float, base2: float, wb: float
            ) -> tuple[float, float, float, float, float, float, float]:
    """The step length τ ∈ (0, h] at which the event function crosses 0, with the state there.

    A guess from the quintic Hermite interpolant of g, g' and g'' at both ends (g'' from
    :func:`_event_curvature`: after the cubic one of g and g', most events took a third full step),
    then Newton on τ with each g(τ) from a full step of length τ, bracketed by bisection, down to the
    rounding of the normal impulse origin + p + τ (``p`` is counted from ``origin``).

    Returns (τ, y, f(p + τ, y)) with y the state after the full step of length τ, the one taken here
    last (the caller need not take it again); NaN when τ = h, a step the caller has taken itself.
    """
    # the interpolant on s = τ / h ∈ [0, 1]: Newton from the secant's root, kept in its bracket by bisection
    m0, m1, c0, c1 = dg0 * h, dg1 * h, ddg0 * h * h, ddg1 * h * h
    if not (math.isfinite(c0) and math.isfinite(c1)):
        c0 = c1 = 0.0
    t = g0 / (g0 - g1)
    a, b = 0.0, 1.0
    for _ in range(40):
        t2 = t * t
        t3 = t2 * t
        t4 = t3 * t
        t5 = t4 * t
        val = ((1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5) * g0 + (t - 6.0 * t3 + 8.0 * t4 - 3.0 * t5) * m0
               + (0.5 * t2 - 1.5 * t3 + 1.5 * t4 - 0.5 * t5) * c0 + (0.5 * t3 - t4 + 0.5 * t5) * c1
               + (-4.0 * t3 + 7.0 * t4 - 3.0 * t5) * m1 + (10.0 * t3 - 15.0 * t4 + 6.0 * t5) * g1)
        der = ((-30.0 * t2 + 60.0 * t3 - 30.0 * t4) * (g0 - g1) + (1.0 - 18.0 * t2 + 32.0 * t3 - 15.0 * t4) * m0
               + (t - 4.5 * t2 + 6.0 * t3 - 2.5 * t4) * c0 + (1.5 * t2 - 4.0 * t3 + 2.5 * t4) * c1
               + (-12.0 * t2 + 28.0 * t3 - 15.0 * t4) * m1)
        if val < 0.0:
            a = t
        else:
            b = t
        nt = t - val / der if der != 0.0 else 0.5 * (a + b)
        if not a < nt < b:
            nt = 0.5 * (a + b)
        if abs(nt - t) <= 1e-15 or b - a <= 1e-15:
            t = nt
            break
        t = nt
    lo, hi = 0.0, h  # g(lo) < 0 <= g(hi)
    at_hi = (math.nan, math.nan, math.nan, math.nan, math.nan, math.nan)
    tau = t * h
    for _ in range(60):
        if not lo < tau < hi:
            tau = 0.5 * (lo + hi)
        n0, n1, n2, _err = _step(S, p, y0, y1, y2, k0, k1, k2, tau, ub1, ub2, ub3, base1, base2)
        X[STEPS] += 1.0
        f0, f1, f2 = _rhs(p + tau, n0, n1, ub1, ub2, ub3, S)
        g, dg = _event(S, X, p + tau, n0, n1, n2, f0, f1, ub3, wb)
        if g >= 0.0:
            hi = tau
            at_hi = (n0, n1, n2, f0, f1, f2)
        else:
            lo = tau
        ulp = 4e-16 * (origin + p + hi)
        if hi - lo <= ulp:
            break
        if not dg > 0.0:
            tau = 0.5 * (lo + hi)
            continue
        nxt = tau - g / dg
        if g >= 0.0 and tau - nxt <= ulp:
            break  # converged from above: hi = tau
        # aim half the rounding above the root: the iterate that lands on it then has g ≥ 0 and ends the
        # search (aimed at the root itself, it lands below as often as above, and costs another full step)
        tau = nxt + 0.5 * ulp
    return hi, at_hi[0], at_hi[1], at_hi[2], at_hi[3], at_hi[4], at_hi[5]


@njit(cache=True, error_model="numpy")
def _integrate(S: NDArray[np.float64], X: NDArray[np.float64]) -> tuple[int, bool, int, bool, float, float]:
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
    r = _norm(v1, v2)
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
        n0, n1, n2, err = _step(S, t, y0, y1, y2, k0, k1, k2, h, ub1, ub2, ub3, Pb1, Pb2)
        X[STEPS] += 1.0
        t_new = t + h
        w1 = ub1 + a11 * n0 + a12 * n1 + b1 * t_new
        w2 = ub2 + a12 * n0 + a22 * n1 + b2 * t_new
        r_new = _norm(w1, w2)
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
            ddg0 = _event_curvature(S, X, v1, v2, k0, k1)
            ddg1 = _event_curvature(S, X, w1, w2, f0, f1)
            tau, m0, m1, m2, q0, q1, q2 = _locate(S, X, t, y0, y1, y2, k0, k1, k2, h, g0, dg0, ddg0, g1, dg1, ddg1,
                                                  pb, ub1, ub2, ub3, Pb1, Pb2, wb)
            if tau < h:  # the state at t + τ: the full step from t that _locate took last (the same floats)
                t_new = t + tau
                n0, n1, n2, f0, f1, f2 = m0, m1, m2, q0, q1, q2
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
            r_new = _norm(w1, w2)
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
        floor = _max(S[STOP] * tol, rtol * (S[ANORM] * _norm(X[PT1], X[PT2]) + S[BNORM] * X[P]))
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
def _turning_slip(S: NDArray[np.float64], X: NDArray[np.float64]) -> tuple[int, bool, int, bool, float, float]:
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
    return _integrate(S, X)


# ---------------------------------------------------------------------- one impact, many
@njit(cache=True, error_model="numpy")
def _run(S: NDArray[np.float64], X: NDArray[np.float64]) -> int:
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
            status, done, mode, straight, d1, d2 = _turning_slip(S, X)
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
def impact_rows(w: tuple[float, ...], law: tuple[float, ...], U: NDArray[np.float64], out: NDArray[np.float64],
                error: NDArray[np.float64]) -> tuple[int, int, int, float, float, float, float]:
    """Impacts from the unit velocities ``U`` (B, d), local frame, at the Delassus matrix ``w``.

    Writes the impulses into ``out`` (B, d) (for W itself: the core's, for W / tr W, divided by tr W)
    and the error estimates into ``error`` (B,): rtol where a turning slip was integrated, else 0.
    Returns (row, status, the most integration steps a row took, the four numbers of the failure's
    message): row −1 when every row was computed, else the first that failed (the rows after it are
    not computed); BAD_TRACE (tr W) comes before any row.
    """
    S = _setup(w, law)
    tr = S[TR]
    if not (tr > 0.0 and math.isfinite(tr)):
        return 0, BAD_TRACE, 0, tr, 0.0, 0.0, 0.0
    d = U.shape[1]
    X = np.zeros(ROW_SIZE)
    most = 0
    for i in range(U.shape[0]):
        X[U1] = U[i, 0]
        X[U2] = U[i, 1] if d == 3 else 0.0
        X[UN0] = U[i, d - 1]
        status = _run(S, X)
        if status:
            return i, status, most, X[INFO], X[INFO + 1], X[INFO + 2], X[INFO + 3]
        out[i, 0] = X[PT1] / tr
        if d == 3:
            out[i, 1] = X[PT2] / tr
        out[i, d - 1] = X[P] / tr
        steps = int(X[STEPS])
        error[i] = S[RTOL] if steps > 0 else 0.0
        most = max(most, steps)
    return -1, 0, most, 0.0, 0.0, 0.0, 0.0


@njit(cache=True, error_model="numpy")
def impact_one(w: tuple[float, ...], law: tuple[float, ...], x1: float, x2: float, xn: float
               ) -> tuple[int, float, float, float, int, float, float, float, float, float, float]:
    """A whole single impact in one call: from the contact velocity (x1, x2, xn) (x2 = 0 when d = 2),
    local frame, and the Delassus matrix ``w``, what :meth:`mbimpact.CoulombLaw.apply_metric` needs.

    Returns (status, P_t1, P_t2, p_n, integration steps, |u| / tr W, |u|, the failure's four numbers):
    the impulse of the unit velocity u / |u| at W / tr W (the impact's is |u| / tr W times it). Before
    any impact, status BAD_TRACE (tr W in the first number), or OUT_OF_REACH for what the caller's general
    route names or treats: n⁰ᵀWn⁰ ≈ 0 (``ImpactLaw.impulses``' test) or det(W / tr W) ≤ 1e-12, a
    rank-deficient W (``ContactMetric.range_projector``'s).
    """
    S = _setup(w, law)
    tr = S[TR]
    if not (tr > 0.0 and math.isfinite(tr)):
        return BAD_TRACE, 0.0, 0.0, 0.0, 0, 0.0, 0.0, tr, 0.0, 0.0, 0.0
    if not S[W33] > S[DEGENERATE] or not S[DET] > 1e-12:
        return OUT_OF_REACH, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    # the unit velocity, scaled first (no over- or underflow); the squares by libm's pow, as Python's **
    if S[D] == 3.0:
        big = _max(_max(abs(x1), abs(x2)), abs(xn))
        speed = big * math.sqrt(_square(x1 / big, S) + _square(x2 / big, S) + _square(xn / big, S))
    else:
        big = _max(abs(x1), abs(xn))
        speed = big * math.sqrt(_square(x1 / big, S) + _square(xn / big, S))
    X = np.zeros(ROW_SIZE)
    X[U1], X[U2], X[UN0] = x1 / speed, x2 / speed, xn / speed
    status = _run(S, X)
    return (status, X[PT1], X[PT2], X[P], int(X[STEPS]), speed / tr, speed, X[INFO], X[INFO + 1], X[INFO + 2],
            X[INFO + 3])


# impact_local's types, compiled when this module is imported (from numba's cache): any float64 2-D W and U
# (C- or F-ordered, strided, read-only) convert to the read-only "A" arrays, so that no caller's layout
# compiles another specialisation at its first call; the law tuple is LAW_SIZE floats
_ANY = types.Array(types.float64, 2, "A", readonly=True)
_LOCAL_SIGNATURE = types.Tuple((types.int64, types.int64))(_ANY, _ANY, types.UniTuple(types.float64, LAW_SIZE),
                                                           types.Array(types.float64, 2, "C"))


@njit([_LOCAL_SIGNATURE], cache=True, error_model="numpy")
def impact_local(W: NDArray[np.float64], U: NDArray[np.float64], law: tuple[float, ...], out: NDArray[np.float64]
                 ) -> tuple[int, int]:
    """:func:`impact_one` on the arrays :meth:`mbimpact.CoulombLaw.single_impulse` takes: the Delassus
    matrix ``W`` (d, d) and the velocity ``U`` (1, d) in the local frame, d = 2 or 3.

    Writes the impulse into ``out`` (1, d) — the unit velocity's at W / tr W times |u| / tr W, the same
    floats as :func:`impact_one`'s — and returns (status, integration steps); ``out`` is unset unless
    the status is 0. A status of −1 is a shape other than these (nothing computed). Reading the arrays
    here saves the caller their conversion to floats and their passing one by one (~1 µs of a call).
    """
    d = W.shape[0]
    if not ((d == 3 or d == 2) and W.shape[1] == d and U.shape[0] == 1 and U.shape[1] == d and out.shape[0] == 1
            and out.shape[1] == d):
        return -1, 0
    if d == 3:
        w = (3.0, W[0, 0], W[0, 1], W[0, 2], W[1, 0], W[1, 1], W[1, 2], W[2, 0], W[2, 1], W[2, 2])
        x1, x2, xn = U[0, 0], U[0, 1], U[0, 2]
    else:
        w = (2.0, W[0, 0], 0.0, W[0, 1], 0.0, 0.0, 0.0, W[1, 0], 0.0, W[1, 1])
        x1, x2, xn = U[0, 0], 0.0, U[0, 1]
    result = impact_one(w, law, x1, x2, xn)
    status, steps, scale = result[0], result[4], result[5]
    if status == 0:
        out[0, 0] = result[1] * scale
        if d == 3:
            out[0, 1] = result[2] * scale
        out[0, d - 1] = result[3] * scale
    return status, steps


# coulomb_batch's types: the stacks of impact_batch at any strides, its outputs C-contiguous
_IN2, _IN3 = types.Array(types.float64, 2, "A", readonly=True), types.Array(types.float64, 3, "A", readonly=True)
_OUT2 = types.float64[:, ::1]
_BATCH_SIGNATURE = types.none(_IN3, _IN2, _IN3, _IN2, _IN3, types.float64, types.float64,
                              types.UniTuple(types.float64, LAW_SIZE), _OUT2, types.int64[::1], types.int64[::1], _OUT2)

#: :func:`coulomb_batch`'s status of a row the metric did not prepare (the others are :func:`impact_one`'s).
NOT_PREPARED = -1


@njit([_BATCH_SIGNATURE], cache=True, error_model="numpy", nogil=True)
def coulomb_batch(U: NDArray[np.float64], D: NDArray[np.float64], J: NDArray[np.float64], V: NDArray[np.float64],
                  R: NDArray[np.float64], degenerate: float, rank_floor: float, law: tuple[float, ...],
                  buf: NDArray[np.float64], status: NDArray[np.int64], steps: NDArray[np.int64],
                  stats: NDArray[np.float64]) -> None:  # pragma: no cover — compiled
    """B spatial impacts of a mechanism, each at its own configuration, in one call: row i is the compiled
    single impact of :class:`~mbimpact.CoulombLaw` (:func:`mbimpact.metric.kernels.prepare_factor`,
    :func:`impact_local`, :func:`mbimpact.metric.kernels.finish`) on ``U[i], D[i], J[i], V[i], R[i]``
    and ``buf[i]``: the same arithmetic, so the same result to the bit.

    Parameters
    ----------
    U, D, J, V, R : ndarray, shapes (B, n, n), (B, n), (B, 3, n), (B, n), (B, 3, 3)
        Each row's factor A = U D Uᵀ, contact Jacobian, velocity and contact frame.
    degenerate, rank_floor : float
        As for ``prepare_factor``.
    law : tuple
        The law tuple (:meth:`mbimpact.CoulombLaw._law`).
    buf : ndarray, shape (B, 6n + 33)
        Each row's single-impact buffer; its head is the row's result where ``status`` is 0.
    status, steps : ndarray of int, shape (B,)
        Output: 0 where the row's result is in ``buf``, :data:`NOT_PREPARED`, or :func:`impact_one`'s
        status (what the caller's row-by-row route names or treats); the integration steps.
    stats : ndarray, shape (B, 5)
        Output: the error estimate (rtol where a turning slip was integrated, else 0), |u₋|, tr(RᵀWR),
        n⁰ · u₊, and 1.0 where P, v₊ and u₊ are finite (else 0.0).
    """
    w0 = 3 * V.shape[1] + 21  # W_local (row-major), then U_local (mbimpact.metric.kernels.local_views)
    P = np.empty((1, 3))
    for i in range(V.shape[0]):
        row = buf[i]
        prepared, speed, w_scale = prepare_into(U[i], D[i], J[i], V[i], R[i], degenerate, rank_floor, row)
        steps[i] = 0
        if prepared != READY:
            status[i] = NOT_PREPARED
            continue
        w = (3.0, row[w0], row[w0 + 1], row[w0 + 2], row[w0 + 3], row[w0 + 4], row[w0 + 5], row[w0 + 6],
             row[w0 + 7], row[w0 + 8])
        result = impact_one(w, law, row[w0 + 9], row[w0 + 10], row[w0 + 11])
        status[i], steps[i] = result[0], result[4]
        if result[0] != 0:
            continue
        scale = result[5]  # impact_local's impulse
        P[0, 0], P[0, 1], P[0, 2] = result[1] * scale, result[2] * scale, result[3] * scale
        finite, un_plus = finish_into(P, R[i], speed / w_scale, row)
        stats[i, 0] = law[RTOL] if result[4] > 0 else 0.0  # CoulombLaw.single_impulse's error estimate
        stats[i, 1], stats[i, 2], stats[i, 3] = speed, w_scale, un_plus
        stats[i, 4] = 1.0 if finite else 0.0


def jit_seconds() -> float:
    """Wall time to make the kernels callable in this process (numba's import excluded: importing
    this module does it, and loads :func:`impact_local`, whose signature is given, with what it calls):
    their machine code loaded from numba's on-disk cache (``__pycache__`` next to this file), or
    compiled when that cache is missing or stale. The first call pays it; later calls return near 0."""
    start = time.perf_counter()
    third = 1.0 / 3.0  # W = I / 3, μ = ½, Stronge's e = ½: a slip straight to its end
    w = (3.0, third, 0.0, 0.0, 0.0, third, 0.0, 0.0, 0.0, third)
    law = (0.5, 0.5, float(ENERGETIC), 1e-10, 1e-14, 1e-12, 1e-2, 64.0, 100.0, 1e-12, 1e-14)
    impact_rows(w, law, np.array([[0.6, 0.0, -0.8]]), np.empty((1, 3)), np.empty(1))
    impact_one(w, law, 0.6, 0.0, -0.8)
    impact_local(np.array([w[1:4], w[4:7], w[7:]]), np.array([[0.6, 0.0, -0.8]]), law, np.empty((1, 3)))
    return time.perf_counter() - start

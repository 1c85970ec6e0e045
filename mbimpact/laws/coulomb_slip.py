"""The Coulomb impact's turning 3-D slip: du_t/dp = b − μ W_tt û_t integrated by Dormand–Prince 8(5,3),
its events located exactly, and the hand-over to a straight slip along an invariant direction
(:mod:`mbimpact.laws.coulomb` describes the algorithm; the state's layout is :mod:`~mbimpact.laws.coulomb_core`'s).

Compiled by numba into the kernels of :mod:`mbimpact.laws.coulomb_kernels`; run with
``NUMBA_DISABLE_JIT=1``, the same source runs interpreted.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .coulomb_core import (AI11, AI12, AI22, ANORM, BNORM, COMP, E, ENERGETIC, INFO, KIND, MAX_STEPS, MU, NEWTON, P,
                           POISSON, PT1, PT2, RTOL, SLIP, STALLED, STEPS, STICK, STOP, TOO_MANY_STEPS, UN0, W11, W12,
                           W13, W22, W23, W33, WK, end_stage, fmax, fmin, poisson_left, rate, stage_length,
                           stopped_mode, stops_in_compression, target_work, velocity)

__all__ = ["turning_slip"]


@njit(cache=True, error_model="numpy", inline="always")
def _norm(x: float, y: float) -> float:
    """|(x, y)|: √(x² + y²) where no square over- or underflows (evaluated at every stage on the critical
    path, several times cheaper than hypot), else math.hypot."""
    s = x * x + y * y
    if 1e-290 < s < 1e290:  # the larger square is normal: the smaller one, if not, is below its rounding
        return math.sqrt(s)
    return math.hypot(x, y)

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
    rho_n = rate(S, -mu * s1, -mu * s2)[2]
    along = v1 * s1 + v2 * s2
    ds = stage_length(S, X, velocity(S, X)[2], rho_n)
    if lam < 0.0:
        ds = fmin(ds, along / -lam)
    if delta > 1e-14:
        ds = fmin(ds, 2.0 * r / -dh)
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
def _step(S: NDArray[np.float64], t: float, y0: float, y1: float, y2: float, K: NDArray[np.float64], h: float,
          ub1: float, ub2: float, ub3: float, base1: float, base2: float) -> tuple[float, float, float, float]:
    """One DOP853 step of the state y = (ΔP_t1, ΔP_t2, w) from (t, y), with ``K[0]`` = f(t, y) given and the
    other stages written into ``K`` (12, 3): the new state and the error norm (≤ 1: accept), scaled on the
    impulses (P_b + ΔP_t, from the base impulse P_b). The work w does not feed back into f: its stages are
    f's third component, and it is never an argument."""
    for i in range(1, _NS):
        s0, s1 = 0.0, 0.0
        for j in range(i):
            a = _A[i, j]
            s0 += a * K[j, 0]
            s1 += a * K[j, 1]
        K[i, 0], K[i, 1], K[i, 2] = _rhs(t + _C[i] * h, y0 + h * s0, y1 + h * s1, ub1, ub2, ub3, S)
    sb0 = sb1 = sb2 = s50 = s51 = s52 = s30 = s31 = s32 = 0.0
    for i in range(_NS):
        b, e5, e3 = _B[i], _E5[i], _E3[i]
        k0, k1, k2 = K[i, 0], K[i, 1], K[i, 2]
        sb0, sb1, sb2 = sb0 + b * k0, sb1 + b * k1, sb2 + b * k2
        s50, s51, s52 = s50 + e5 * k0, s51 + e5 * k1, s52 + e5 * k2
        s30, s31, s32 = s30 + e3 * k0, s31 + e3 * k1, s32 + e3 * k2
    rtol = S[RTOL]
    atol = 0.1 * rtol
    new0, new1, new2 = y0 + h * sb0, y1 + h * sb1, y2 + h * sb2
    sc0 = atol + rtol * fmax(abs(base1 + y0), abs(base1 + new0))
    sc1 = atol + rtol * fmax(abs(base2 + y1), abs(base2 + new1))
    sc2 = atol + rtol * fmax(abs(y2), abs(new2))
    e0, e1, e2, f0, f1, f2 = s50 / sc0, s51 / sc1, s52 / sc2, s30 / sc0, s31 / sc1, s32 / sc2
    n5 = e0 * e0 + e1 * e1 + e2 * e2
    n3 = f0 * f0 + f1 * f1 + f2 * f2
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
    return (wb + y2) - target_work(S, X), un


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
            origin: float, ub1: float, ub2: float, ub3: float, base1: float, base2: float, wb: float,
            K: NDArray[np.float64]) -> tuple[float, float, float, float, float, float, float]:
    """The step length τ ∈ (0, h] at which the event function crosses 0, with the state there.

    A guess from the quintic Hermite interpolant of g, g' and g'' at both ends (g'' from
    :func:`_event_curvature`: after the cubic one of g and g', most events took a third full step),
    then Newton on τ with each g(τ) from a full step of length τ, bracketed by bisection, down to the
    rounding of the normal impulse origin + p + τ (``p`` is counted from ``origin``). ``K`` is the
    steps' work array (:func:`_step`).

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
        K[0, 0], K[0, 1], K[0, 2] = k0, k1, k2
        n0, n1, n2, _err = _step(S, p, y0, y1, y2, K, tau, ub1, ub2, ub3, base1, base2)
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
    ub1, ub2, ub3 = velocity(S, X)
    t, y0, y1, y2 = 0.0, 0.0, 0.0, 0.0
    k0, k1, k2 = _rhs(t, 0.0, 0.0, ub1, ub2, ub3, S)
    K = np.empty((_NS, 3))  # the stages of a step
    while _event(S, X, t, y0, y1, y2, k0, k1, ub3, wb)[0] >= 0.0:  # the stage has ended at its base point
        if end_stage(S, X):
            return 0, True, SLIP, False, 0.0, 0.0
        wb = X[WK]  # 0: the work of restitution starts here
    v1 = ub1 + a11 * y0 + a12 * y1 + b1 * t
    v2 = ub2 + a12 * y0 + a22 * y1 + b2 * t
    r = _norm(v1, v2)
    h = 0.1 * r / fmax(S[BNORM] + mu * S[ANORM], 1e-300)  # |du_t/dp| ≤ |b| + μ |W_tt|
    for _ in range(int(S[MAX_STEPS])):
        # the slip continued straight would stop after r / |dr/dp|: step a fraction of that at most
        dr = (v1 * (b1 + a11 * k0 + a12 * k1) + v2 * (b2 + a12 * k0 + a22 * k1)) / r
        if dr < 0.0:
            h = fmin(h, 0.8 * r / -dr)
        end = math.inf
        if X[COMP] == 0.0 and poisson:
            end = poisson_left(S, X, pb) - t
            if end <= 0.0:
                return 0, True, SLIP, False, 0.0, 0.0
            h = fmin(h, end)
        K[0, 0], K[0, 1], K[0, 2] = k0, k1, k2
        n0, n1, n2, err = _step(S, t, y0, y1, y2, K, h, ub1, ub2, ub3, Pb1, Pb2)
        X[STEPS] += 1.0
        t_new = t + h
        w1 = ub1 + a11 * n0 + a12 * n1 + b1 * t_new
        w2 = ub2 + a12 * n0 + a22 * n1 + b2 * t_new
        r_new = _norm(w1, w2)
        if not err <= 1.0 or w1 * v1 + w2 * v2 <= 0.0:  # refused (a turn through u_t = 0 too)
            h *= fmax(0.2, 0.9 * err ** -0.125) if 1.0 < err < math.inf else 0.2
            if h <= 1e-15 * fmax(pb + t, 1e-300):
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
                                                  pb, ub1, ub2, ub3, Pb1, Pb2, wb, K)
            if tau < h:  # the state at t + τ: the full step from t that _locate took last (the same floats)
                t_new = t + tau
                n0, n1, n2, f0, f1, f2 = m0, m1, m2, q0, q1, q2
            X[P], X[PT1], X[PT2], X[WK] = pb + t_new, Pb1 + n0, Pb2 + n1, wb + n2
            if end_stage(S, X):
                return 0, True, SLIP, False, 0.0, 0.0
            # the work restarts from 0 at the end of compression: a new base point
            pb, Pb1, Pb2, wb = X[P], X[PT1], X[PT2], X[WK]
            ub1, ub2, ub3 = velocity(S, X)
            t_new, n0, n1, n2 = 0.0, 0.0, 0.0, 0.0
            f0, f1, f2 = _rhs(0.0, 0.0, 0.0, ub1, ub2, ub3, S)
            w1 = ub1 + a11 * n0 + a12 * n1 + b1 * t_new
            w2 = ub2 + a12 * n0 + a22 * n1 + b2 * t_new
            r_new = _norm(w1, w2)
            if _event(S, X, 0.0, n0, n1, n2, f0, f1, ub3, wb)[0] >= 0.0:  # restitution ends where it starts
                end_stage(S, X)
                return 0, True, SLIP, False, 0.0, 0.0
        elif ended:  # Poisson's end
            X[P], X[PT1], X[PT2], X[WK] = pb + t_new, Pb1 + n0, Pb2 + n1, wb + n2
            return 0, True, SLIP, False, 0.0, 0.0
        grow = fmin(10.0, 0.9 * err ** -0.125) if err > 0.0 else 10.0
        h *= grow * fmin(1.0, r_new / r)
        t, y0, y1, y2, k0, k1, k2, v1, v2, r = t_new, n0, n1, n2, f0, f1, f2, w1, w2, r_new
        X[P], X[PT1], X[PT2], X[WK] = pb + t, Pb1 + y0, Pb2 + y1, wb + y2
        # what u_t = u₋ + W_tt P_t + b p is worth: below that the slip has stopped for all we know
        floor = fmax(S[STOP] * tol, rtol * (S[ANORM] * _norm(X[PT1], X[PT2]) + S[BNORM] * X[P]))
        if r <= floor:
            found, s1, s2 = _stable_direction(S, v1, v2)
            if not found:
                return 0, False, stopped_mode(S, X), False, 0.0, 0.0
            return 0, False, SLIP, True, s1, s2
        found, s1, s2 = _snap(S, X, v1, v2, r)
        if found:
            return 0, False, SLIP, True, s1, s2
    X[INFO], X[INFO + 1] = pb + t, r
    return TOO_MANY_STEPS, True, SLIP, False, 0.0, 0.0


@njit(cache=True, error_model="numpy")
def turning_slip(S: NDArray[np.float64], X: NDArray[np.float64]) -> tuple[int, bool, int, bool, float, float]:
    """A 3-D slip whose direction may turn: closed forms where possible, else integrate.

    Returns (status, impact ended, next mode, straight direction found, s₁, s₂).
    """
    v1, v2, _ = velocity(S, X)
    r = math.hypot(v1, v2)
    if r <= S[STOP] * (0.1 * S[RTOL]):  # the stop tolerance, 0.1 rtol at unit speed
        return 0, False, stopped_mode(S, X), False, 0.0, 0.0
    bound = stops_in_compression(S, X, v1, v2)
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



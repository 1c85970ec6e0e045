"""The Coulomb impact's core: the layouts of its state, the setup per Delassus matrix, and the phases
of constant tangential rate in closed form (:mod:`mbimpact.laws.coulomb` describes the algorithm).

Everything is in floats on two small arrays: the setup ``S`` (:data:`SETUP_SIZE` floats, what every row
at one Delassus matrix shares, for W / tr W: the law and its tolerances, then the entries of W, W_tt⁺,
the sticking rate; a planar contact (d = 2) is the spatial one with the second tangential axis absent,
its entries 0), and the row state ``X`` (:data:`ROW_SIZE` floats: the unit pre-impact velocity u₋, the
normal impulse p (the clock), the tangential impulse P_t, the normal work of the current stage, the
stage and, for an error, what its message reports). A failure is a status code (:data:`JAMMED` …) with
the numbers its message reports. Divisions follow IEEE (numba's ``error_model="numpy"``).

Compiled by numba into the kernels of :mod:`mbimpact.laws.coulomb_kernels`; run with
``NUMBA_DISABLE_JIT=1``, the same source runs interpreted.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

# ---------------------------------------------------------------------- layouts
# the setup S: the law and its tolerances (the law tuple, as given), then d, tr W, the rows of W / tr W
# (t₁, t₂, n), W_tt⁺ (symmetric), its norms, the sticking rate g = −W_tt⁺ b with |g| and whether |g| ≤ μ,
# det(W / tr W), the slip direction kept by the flow from u_t = 0 when the contact cannot stick (and
# whether it has been computed)
(MU, E, KIND, RTOL, JAM, UN_ZERO, STOP, MAX_PHASES, MAX_STEPS, CUT, DEGENERATE,
 D, TR, W11, W12, W13, W21, W22, W23, W31, W32, W33, AI11, AI12, AI22, ALPHA_MIN, ANORM, BNORM, G1, G2,
 STICK_NORM, CAN_STICK, DET, RESLIP, RS1, RS2) = range(36)
LAW_SIZE = D
SETUP_SIZE = 36
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


@njit(cache=True, error_model="numpy")
def fmax(a: float, b: float) -> float:
    """a unless b > a: a NaN in a stays (max of floats in the order the comparisons need)."""
    return b if b > a else a


@njit(cache=True, error_model="numpy")
def fmin(a: float, b: float) -> float:
    """a unless b < a."""
    return b if b < a else a


# ---------------------------------------------------------------------- the setup
@njit(cache=True, error_model="numpy")
def setup(w: tuple[float, ...], law: tuple[float, ...]) -> NDArray[np.float64]:
    """The setup array S for W = ``w`` (the tuple of the module docstring) and the law tuple ``law``.

    S[TR] is tr W whatever it is: the caller tells BAD_TRACE by it (the rest is then unset).
    """
    S = np.empty(SETUP_SIZE)
    for i in range(LAW_SIZE):
        S[i] = law[i]
    S[RESLIP] = S[RS1] = S[RS2] = 0.0
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
        hi = m + math.hypot(half, a12)
        det = a11 * a22 - a12 * a12
        lo = fmax(det / hi, 0.0) if hi > 0.0 else 0.0  # no cancellation in m − rad
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
def invariant_slip(S: NDArray[np.float64]) -> None:
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
        ta0, tb0, n_terms = fmax(al0, 0.0) * mu, bt0, 1
    if bt1 != 0.0:
        if n_terms == 0:
            ta0, tb0 = fmax(al1, 0.0) * mu, bt1
        else:
            ta1, tb1 = fmax(al1, 0.0) * mu, bt1
        n_terms += 1
    lo, hi = 0.0, fmax(S[BNORM], 1e-300)
    lam = 0.0
    for _ in range(200):
        # φ and φ' on ratios, which neither under- nor overflow
        r0 = tb0 / (ta0 + lam) if ta0 + lam > 0.0 else math.copysign(math.inf, tb0)
        if n_terms == 2:
            r1 = tb1 / (ta1 + lam) if ta1 + lam > 0.0 else math.copysign(math.inf, tb1)
            n = math.hypot(r0, r1)
        else:
            r1 = 0.0
            n = abs(r0)
        if not math.isfinite(n):
            val, der = -1.0, 0.0
        else:
            val = 1.0 / n - 1.0
            der = (r0 / n) * (r0 / n) / (ta0 + lam)
            if n_terms == 2:
                der = der + (r1 / n) * (r1 / n) / (ta1 + lam)
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
    st0 = bt0 / (fmax(al0, 0.0) * mu + lam)
    st1 = bt1 / (fmax(al1, 0.0) * mu + lam)
    x = q00 * st0 + q10 * st1
    z = q01 * st0 + q11 * st1
    norm = math.hypot(x, z)
    S[RS1], S[RS2] = x / norm, z / norm


# ---------------------------------------------------------------------- helpers of one impact
@njit(cache=True, error_model="numpy")
def velocity(S: NDArray[np.float64], X: NDArray[np.float64]) -> tuple[float, float, float]:
    """u = u₋ + W P at the current state."""
    q1, q2, p = X[PT1], X[PT2], X[P]
    # summed from +0.0 as Python's sum() is: the sign of a zero slip component reaches atan2
    return (X[U1] + (0.0 + S[W11] * q1 + S[W12] * q2 + S[W13] * p),
            X[U2] + (0.0 + S[W21] * q1 + S[W22] * q2 + S[W23] * p),
            X[UN0] + (0.0 + S[W31] * q1 + S[W32] * q2 + S[W33] * p))


@njit(cache=True, error_model="numpy")
def rate(S: NDArray[np.float64], g1: float, g2: float) -> tuple[float, float, float]:
    """W [g; 1]: du/dp_n at tangential impulse rate g."""
    return (S[W11] * g1 + S[W12] * g2 + S[W13], S[W21] * g1 + S[W22] * g2 + S[W23],
            S[W31] * g1 + S[W32] * g2 + S[W33])


@njit(cache=True, error_model="numpy")
def target_work(S: NDArray[np.float64], X: NDArray[np.float64]) -> float:
    """Stronge: restitution ends when its work reaches −e² W_c."""
    e = S[E]
    return 0.0 if e == 0.0 else -e * e * X[WC]


@njit(cache=True, error_model="numpy")
def poisson_left(S: NDArray[np.float64], X: NDArray[np.float64], p: float) -> float:
    """Normal impulse from p to Poisson's end (1 + e) p_c, as e p_c + (p_c − p): exact for a tiny e."""
    return S[E] * X[PC] + (X[PC] - p)


@njit(cache=True, error_model="numpy")
def stage_length(S: NDArray[np.float64], X: NDArray[np.float64], un: float, rho_n: float) -> float:
    """Normal impulse until compression or the impact ends in a phase of constant rate."""
    if X[COMP] != 0.0:
        if un >= 0.0:
            return 0.0
        return -un / rho_n if rho_n > 0.0 else math.inf
    kind = S[KIND]
    if kind == POISSON:
        return fmax(poisson_left(S, X, X[P]), 0.0)
    if kind == NEWTON:
        gap = -S[E] * X[UN0] - un
        if gap <= 0.0:
            return 0.0
        return gap / rho_n if rho_n > 0.0 else math.inf
    rem = target_work(S, X) - X[WK]  # energetic: w + un s + rho_n s²/2 = target
    if rem <= 0.0:
        return 0.0
    disc = un * un + 2.0 * rho_n * rem
    if rho_n > 0.0 and un < 0.0:
        return (-un + math.sqrt(disc)) / rho_n
    if disc >= 0.0 and un + math.sqrt(disc) > 0.0:
        return 2.0 * rem / (un + math.sqrt(disc))  # the smaller root, without cancellation
    return math.inf


@njit(cache=True, error_model="numpy")
def end_stage(S: NDArray[np.float64], X: NDArray[np.float64]) -> bool:
    """Compression ended (start restitution, return False) or the impact did (True)."""
    if X[COMP] != 0.0:
        X[COMP] = 0.0
        X[PC], X[WC], X[WK] = X[P], X[WK], 0.0
        return S[E] == 0.0  # every hypothesis ends a plastic impact at maximum compression
    return True


@njit(cache=True, error_model="numpy")
def stopped_mode(S: NDArray[np.float64], X: NDArray[np.float64]) -> int:
    """The mode after the slip stopped: stick (removing the residual slip) or slip on."""
    if S[CAN_STICK] != 0.0:
        # the residual slip (what an exact stop would have removed, ≤ the tolerance) goes with the
        # tangential impulse −W_tt⁺ u_t: it only dissipates, ½ u_tᵀ W_tt⁺ u_t
        v1, v2, _ = velocity(S, X)
        X[PT1] = X[PT1] - (S[AI11] * v1 + S[AI12] * v2)
        X[PT2] = X[PT2] - (S[AI12] * v1 + S[AI22] * v2)
        return STICK
    return RESLIP_MODE


# ---------------------------------------------------------------------- closed forms
@njit(cache=True, error_model="numpy")
def stops_in_compression(S: NDArray[np.float64], X: NDArray[np.float64], v1: float, v2: float
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
    bound = 1.000001 * math.sqrt(fmax(V, 0.0)) / (margin * math.sqrt(S[ALPHA_MIN]))
    un = velocity(S, X)[2]
    earliest = -un / (S[W33] + mu * S[BNORM])
    return bound if bound < 0.5 * earliest else -1.0


@njit(cache=True, error_model="numpy")
def whole_impact(S: NDArray[np.float64], X: NDArray[np.float64], r: float) -> bool:
    """The impulse in one formula when the tangential rate never changes, or ends up not mattering
    (into X[P], X[PT1], X[PT2]); False otherwise (or for a jam, k ≈ 0).

    With a constant rate g the normal velocity is linear, u_n = u_n⁻ + k p (k = c + bᵀg), so all
    three hypotheses end at p = (1 + e) |u_n⁻| / k: without friction (g = 0), sticking from normal
    incidence (g = −W_tt⁺ b, k the Schur complement), slipping from normal incidence along the
    invariant direction (g = −μ s). A slip certain to stop during compression
    (:func:`stops_in_compression`) leaves the sticking state u_t = 0, P_t = −W_tt⁻¹(u_t⁻ + b p), at
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
                invariant_slip(S)
            g1, g2 = -mu * S[RS1], -mu * S[RS2]
        k = rate(S, g1, g2)[2]
        if not k > S[JAM] * (1.0 + (g1 * g1 + g2 * g2)):
            return False
        p = (1.0 + e) * -un0 / k
        X[PT1], X[PT2], X[P] = g1 * p, g2 * p, p
        return True
    if S[D] != 3.0:
        return False
    v1, v2 = X[U1], X[U2]
    bound = stops_in_compression(S, X, v1, v2)
    if not bound > 0.0:
        return False
    b1, b2 = S[W13], S[W23]
    schur = S[W33] + b1 * S[G1] + b2 * S[G2]
    if not schur > S[JAM] * (1.0 + S[STICK_NORM]) * (1.0 + S[STICK_NORM]):
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
def constant_phase(S: NDArray[np.float64], X: NDArray[np.float64], mode: int, d1: float, d2: float
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
            invariant_slip(S)
        g1, g2 = -mu * S[RS1], -mu * S[RS2]
    else:
        g1, g2 = -mu * d1, -mu * d2
    rho1, rho2, rho_n = rate(S, g1, g2)
    u1, u2, un = velocity(S, X)
    gnorm = math.sqrt(g1 * g1 + g2 * g2)
    # W [g; 1] errs by ~ε (1 + |g|)² (g = −W_tt⁺ b itself carries ε |g| cond W_tt), and
    # u = u₋ + W P by ~ε (1 + |P|)
    noise = fmax(S[UN_ZERO], S[JAM] * (1.0 + X[P] + math.sqrt(X[PT1] * X[PT1] + X[PT2] * X[PT2])))
    if math.sqrt(rho1 * rho1 + rho2 * rho2 + rho_n * rho_n) <= S[JAM] * (1.0 + gnorm) * (1.0 + gnorm):
        # a jam: the impulse lies in null(Jᵀ), so u — and v₊, I = JᵀP — can no longer change;
        # any further impulse is invisible and the impact ends here, for every hypothesis
        if X[COMP] != 0.0 and un < -noise:  # energy forbids it
            X[INFO], X[INFO + 1], X[INFO + 2] = un, X[P], mode
            return JAMMED, True, False
        if X[COMP] != 0.0:
            end_stage(S, X)
        return 0, True, False
    length = stage_length(S, X, un, rho_n)
    stop = math.inf
    if mode == SLIP:
        along = u1 * d1 + u2 * d2  # slip speed along the (invariant) direction
        lam = rho1 * d1 + rho2 * d2
        if along <= 0.0:
            stop = 0.0
        elif lam < 0.0:
            stop = along / -lam
    ds = fmin(length, stop)
    if ds == math.inf:
        # the velocity moves but never reaches the event (u_n falling, or Newton's target above
        # where it levels off): energy forbids it in compression; in restitution the target is out
        # of reach and the impact ends here
        if X[COMP] != 0.0:
            if un < -noise:
                X[INFO], X[INFO + 1], X[INFO + 2], X[INFO + 3] = un, rho_n, X[P], mode
                return NO_END, True, False
            end_stage(S, X)  # the contact has stopped to rounding: a jam in all but name
        return 0, True, False
    if not math.isfinite(ds * (1.0 + gnorm)):
        X[INFO] = X[P]
        return INFINITE, True, False
    X[P] += ds
    X[PT1] = X[PT1] + g1 * ds
    X[PT2] = X[PT2] + g2 * ds
    X[WK] += ds * (un + 0.5 * rho_n * ds)
    if length <= stop:
        return 0, end_stage(S, X), False
    return 0, False, True



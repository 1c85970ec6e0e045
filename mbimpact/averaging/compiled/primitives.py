"""The numeric primitives the compiled averaging backends share.

* **Status codes** of every compiled rule (those of :mod:`~mbimpact.averaging.compiled.codes`).
* **Sums.** :func:`compensated_add` (Neumaier), :func:`two_product` (Dekker) and :func:`dot2`
  (Ogita, Rump and Oishi's Dot2): a level of thousands of nodes summed plainly errs by ~ m ε, which
  the error estimate of two levels, amplified by |W| |P| / |W P|, turns into a difference above rtol.
* **The stopping rule** of the adaptive and graded rules for one velocity, :func:`level_decision`
  (the compiled form of :func:`mbimpact.averaging.refinement.refine`'s test), and the rounding floor
  of an impulse, :func:`rounding_floor`.
* **Elementary functions** as polynomials (:func:`cos_sin`, :func:`sin_cos_tilt`, :func:`exp_neg`,
  :func:`acos_unit`): numba calls libm one value at a time, while these run in SIMD lanes inside the
  loops over nodes. They are accurate to an ulp or two, as libm is, so that a compiled rule differs
  from its numpy reference by rounding only.

Compiled by numba (``njit``, cached on disk) into the kernels that call them; run with
``NUMBA_DISABLE_JIT=1``, the same source runs interpreted.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .codes import (CAPPED, DEGENERATE_FACET, NEED_TABLE, NOT_FACING, NOT_PEAKED, NOT_SETTLED, SETTLED, STALLED,
                    UNRESOLVED)

__all__ = ["SETTLED", "DEGENERATE_FACET", "NOT_FACING", "NOT_SETTLED", "STALLED", "CAPPED", "NOT_PEAKED",
           "UNRESOLVED", "NEED_TABLE", "EPS", "compensated_add", "two_product", "dot2", "level_decision",
           "rounding_floor", "cos_sin", "sin_cos_tilt", "exp_neg", "acos_unit"]

#: Machine epsilon (a constant of float64, safe to freeze into the compiled code).
EPS = float(np.finfo(float).eps)

# Veltkamp's splitting constant 2^27 + 1: a double's product with it splits it into two 26-bit halves
_SPLIT = 134217729.0


# ---------------------------------------------------------------------- sums
@njit(cache=True, error_model="numpy", inline="always")
def compensated_add(total: float, compensation: float, x: float) -> tuple[float, float]:  # pragma: no cover
    """Neumaier's compensated sum: total + x, and the rounding error it made added to the compensation
    (the sum is total + compensation at the end)."""
    t = total + x
    if abs(total) >= abs(x):
        compensation += (total - t) + x
    else:
        compensation += (x - t) + total
    return t, compensation


@njit(cache=True, error_model="numpy", inline="always")
def two_product(x: float, y: float) -> tuple[float, float]:  # pragma: no cover — compiled
    """x y = p + e exactly (Dekker's product, with Veltkamp's split: no fused multiply-add needed)."""
    p = x * y
    t = _SPLIT * x
    xh = t - (t - x)
    xl = x - xh
    t = _SPLIT * y
    yh = t - (t - y)
    yl = y - yh
    return p, ((xh * yh - p) + xh * yl + xl * yh) + xl * yl


@njit(cache=True, error_model="numpy")
def dot2(terms: tuple[tuple[float, float, float], ...]) -> float:  # pragma: no cover — compiled
    """Σ x y z over the triples, as if summed in twice the working precision and rounded once (Dot2: each
    x y exact, its product with z exact to ε², the sum compensated)."""
    total, compensation = 0.0, 0.0
    for x, y, z in terms:
        h, low = two_product(x, y)
        p, e = two_product(h, z)
        total, compensation = compensated_add(total, compensation, p)
        compensation += e + low * z
    return total + compensation


# ---------------------------------------------------------------------- the stopping rule
@njit(cache=True, error_model="numpy", inline="always")
def level_decision(coarse: NDArray[np.float64], fine: NDArray[np.float64], W: NDArray[np.float64], rtol: float,
                   facets: float, previous: float, P: NDArray[np.float64],
                   error: NDArray[np.float64]) -> tuple[int, float]:  # pragma: no cover — compiled
    """:func:`mbimpact.averaging.refinement.refine`'s test on two successive levels of one velocity.

    Their relative difference by the velocity change W P they make (defined even where J is
    rank-deficient, where P is not) is settled within rtol or the rounding floor 100 ε √K of a K-facet
    sum; stalled where it is rounding amplified by |W| |P| / |W P| and did not shrink tenfold since
    the ``previous`` level (an ill-conditioned contact). Once settled, the fine
    level's impulse and the difference are written to ``P`` (1, 3) and ``error`` (1,).

    Returns
    -------
    (status, error) : (int, float)
        :data:`SETTLED`, :data:`STALLED` or :data:`NOT_SETTLED` (refine on), and the difference.
    """
    diff, ref, norm = 0.0, 0.0, 0.0
    for i in range(3):
        dw = (fine[0] - coarse[0]) * W[0, i] + (fine[1] - coarse[1]) * W[1, i] + (fine[2] - coarse[2]) * W[2, i]
        fw = fine[0] * W[0, i] + fine[1] * W[1, i] + fine[2] * W[2, i]
        diff += dw * dw
        ref += fw * fw
        norm += fine[i] * fine[i]
    err = math.sqrt(diff / ref)
    rounding = 100 * EPS * math.sqrt(facets)
    if err <= max(rtol, rounding):
        P[0, 0], P[0, 1], P[0, 2] = fine[0], fine[1], fine[2]
        error[0] = err
        return SETTLED, err
    trace = W[0, 0] + W[1, 1] + W[2, 2]
    if err <= rounding * (trace * math.sqrt(norm / ref)) and err > 0.1 * previous:
        return STALLED, err
    return NOT_SETTLED, err


@njit(cache=True, error_model="numpy", inline="always")
def rounding_floor(P: NDArray[np.float64], W: NDArray[np.float64]) -> float:  # pragma: no cover — compiled
    """ε tr(W) |P| / |W P| for P (1, 3): the relative error by W P that P's own rounding (ε |P|) can make
    where W nearly annihilates P. No rule computed in float64 certifies less
    (:func:`mbimpact.averaging.refinement.rounding_floor`)."""
    p2, wp2 = 0.0, 0.0
    for i in range(3):
        wp = P[0, 0] * W[0, i] + P[0, 1] * W[1, i] + P[0, 2] * W[2, i]
        p2 += P[0, i] * P[0, i]
        wp2 += wp * wp
    if not wp2 > 0.0:
        return math.inf
    return EPS * (W[0, 0] + W[1, 1] + W[2, 2]) * math.sqrt(p2 / wp2)


# ---------------------------------------------------------------------- elementary functions
# Taylor coefficients of sin z / z and of cos z in z², for |z| ≤ π/2: the first terms left out,
# (π/2)²³ / 23! and (π/2)²⁴ / 24!, are below 2e-18
(_S0, _S1, _S2, _S3, _S4, _S5, _S6, _S7, _S8, _S9, _S10) = ((-1.0) ** k / math.factorial(2 * k + 1) for k in range(11))
(_C0, _C1, _C2, _C3, _C4, _C5, _C6, _C7, _C8, _C9, _C10, _C11) = (
    (-1.0) ** k / math.factorial(2 * k) for k in range(12))
# Taylor coefficients of eʳ, |r| ≤ ln 2 / 2: the first term left out, (ln 2 / 2)¹⁴ / 14!, is below 5e-18
(_E0, _E1, _E2, _E3, _E4, _E5, _E6, _E7, _E8, _E9, _E10, _E11, _E12, _E13) = (
    1.0 / math.factorial(k) for k in range(14))
# Cody–Waite splittings: π/2 = _PIO2_HI + _PIO2_LO, ln 2 = _LN2_HI + _LN2_LO with the last 32 bits of
# _LN2_HI zero (k ln 2_hi is exact for |k| < 2²⁰); fdlibm's constants
_PIO2_HI = 1.5707963267948966
_PIO2_LO = 6.123233995736766e-17
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.4426950408889634
# 2^(−2ᵇ), b = 0 … 9, whose products make any 2⁻ᵐ, m < 1024 (:func:`exp_neg`)
(_B0, _B1, _B2, _B3, _B4, _B5, _B6, _B7, _B8, _B9) = (2.0 ** -(1 << b) for b in range(10))
_PI_HI, _PI_LO = 2.0 * _PIO2_HI, 2.0 * _PIO2_LO  # π, split as π/2 (doubling is exact)
# fdlibm's rational approximation of asin(x) = x + x R(x²), |x| ≤ 1/2 (its __ieee754_acos)
_PS0, _PS1, _PS2 = 1.66666666666666657415e-01, -3.25565818622400915405e-01, 2.01212532134862925881e-01
_PS3, _PS4, _PS5 = -4.00555345006794114027e-02, 7.91534994289814532176e-04, 3.47933107596021167570e-05
_QS1, _QS2, _QS3 = -2.40339491173441421878e+00, 2.02094576023350569471e+00, -6.88283971605453293030e-01
_QS4 = 7.70381505559019352791e-02


@njit(cache=True, error_model="numpy", inline="always")
def _taylor_sin_cos(z: float) -> tuple[float, float]:  # pragma: no cover — compiled
    """sin z and cos z for |z| ≤ π/2, by their Taylor polynomials in Estrin's scheme (short chains
    of dependent products); an ulp or two."""
    t = z * z
    t2 = t * t
    t4 = t2 * t2
    t8 = t4 * t4
    sn = z * (((_S0 + _S1 * t) + (_S2 + _S3 * t) * t2) + ((_S4 + _S5 * t) + (_S6 + _S7 * t) * t2) * t4
              + ((_S8 + _S9 * t) + _S10 * t2) * t8)
    cs = (((_C0 + _C1 * t) + (_C2 + _C3 * t) * t2) + ((_C4 + _C5 * t) + (_C6 + _C7 * t) * t2) * t4
          + ((_C8 + _C9 * t) + (_C10 + _C11 * t) * t2) * t8)
    return sn, cs


@njit(cache=True, error_model="numpy")
def cos_sin(y: float) -> tuple[float, float]:  # pragma: no cover — compiled
    """cos y and sin y for |y| ≤ π, to an ulp or two of 1 (an azimuth node's position): beyond π/2
    from y ∓ π (split Cody–Waite, the first difference exact). A function of its own, so that it keeps
    its exact instructions where the compiler inlines it into sums compiled with fast-math flags."""
    far = abs(y) > 0.5 * math.pi
    shift = (y - _PI_HI) - _PI_LO if y > 0.0 else (y + _PI_HI) + _PI_LO
    sn, cs = _taylor_sin_cos(shift if far else y)
    return (-cs, -sn) if far else (cs, sn)


@njit(cache=True, error_model="numpy", inline="always")
def sin_cos_tilt(alpha: float) -> tuple[float, float]:  # pragma: no cover — compiled
    """sin α and cos α for 0 ≤ α ≤ π/2, each to an ulp or two of itself (cos α near π/2 too: from
    π/2 − α, split Cody–Waite, beyond π/4)."""
    beta = (_PIO2_HI - alpha) + _PIO2_LO  # exact first difference for α ≥ π/4 (Sterbenz)
    low = alpha <= 0.25 * math.pi
    sn, cs = _taylor_sin_cos(alpha if low else beta)
    return (sn, cs) if low else (cs, sn)


@njit(cache=True, error_model="numpy", inline="always")
def exp_neg(v: float) -> float:  # pragma: no cover — compiled
    """eᵛ for v ≤ 0, to an ulp or two (0 below −708, where eᵛ leaves the normal floats): eᵛ = 2⁻ᵐ eʳ,
    m = round(−v / ln 2) ≤ 1022, r = v + m ln 2 (Cody–Waite), eʳ by its Taylor polynomial, and 2⁻ᵐ
    the product of the powers 2^(−2ᵇ) of m's bits (exact; numba has no bit casts to build it at
    once, and a table lookup would not run in SIMD lanes)."""
    k = np.floor(max(v, -708.0) * _INV_LN2 + 0.5)  # a float (math.floor would give an int)
    r = (v - k * _LN2_HI) - k * _LN2_LO
    r2 = r * r
    r4 = r2 * r2
    r8 = r4 * r4
    er = (((_E0 + _E1 * r) + (_E2 + _E3 * r) * r2) + ((_E4 + _E5 * r) + (_E6 + _E7 * r) * r2) * r4
          + (((_E8 + _E9 * r) + (_E10 + _E11 * r) * r2) + (_E12 + _E13 * r) * r4) * r8)
    # the bits of m = −k ≤ 1022 from the top, in floats (vectors of 64-bit integers are not AVX2's)
    m = -k
    s9, m = (_B9, m - 512.0) if m >= 512.0 else (1.0, m)
    s8, m = (_B8, m - 256.0) if m >= 256.0 else (1.0, m)
    s7, m = (_B7, m - 128.0) if m >= 128.0 else (1.0, m)
    s6, m = (_B6, m - 64.0) if m >= 64.0 else (1.0, m)
    s5, m = (_B5, m - 32.0) if m >= 32.0 else (1.0, m)
    s4, m = (_B4, m - 16.0) if m >= 16.0 else (1.0, m)
    s3, m = (_B3, m - 8.0) if m >= 8.0 else (1.0, m)
    s2, m = (_B2, m - 4.0) if m >= 4.0 else (1.0, m)
    s1, m = (_B1, m - 2.0) if m >= 2.0 else (1.0, m)
    s0 = _B0 if m >= 1.0 else 1.0
    scale = ((s9 * s8) * (s7 * s6)) * ((s5 * s4) * (s3 * s2)) * (s1 * s0)
    return er * scale if v >= -708.0 else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def acos_unit(x: float) -> float:  # pragma: no cover — compiled
    """acos x for 0 ≤ x ≤ 1 to ~2e-16 (absolute: an arc's half-width), fdlibm's way: π/2 − asin x
    below 1/2, 2 asin √((1 − x)/2) above (1 − x exact there), asin z = z + z R(z²)."""
    low = x <= 0.5
    z = x * x if low else 0.5 * (1.0 - x)
    r = z * (_PS0 + z * (_PS1 + z * (_PS2 + z * (_PS3 + z * (_PS4 + z * _PS5))))) / (
        1.0 + z * (_QS1 + z * (_QS2 + z * (_QS3 + z * _QS4))))
    s = math.sqrt(z)
    return _PIO2_HI - (x - (_PIO2_LO - x * r)) if low else 2.0 * (s + s * r)

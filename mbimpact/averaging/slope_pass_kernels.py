"""The compiled core of :class:`~mbimpact.averaging.slope_pass.SlopePass`: the adaptive rule of an
isotropic tilt density for one velocity, every level in one call.

This is :func:`mbimpact.averaging.refinement.refine` on one row of the measure's own rule
(:meth:`mbimpact.IsotropicSlopes.rule_batch`), compiled by numba (``njit``, cached on disk), so
that a single impact costs its floating-point work rather than a few numpy calls for every array
of every level. It is imported on first use only: numba costs ~0.3 s to import, more than
``import mbimpact`` may take; :func:`jit_seconds` loads or compiles it and says how long that took.

The nodes are those of the rule, level after level (n, 2n, 4n, … nodes a piece):

* spatial (d = 3): Gauss–Legendre tilts on [lo, α*] and, through α = o + t², on [α*, hi]
  (:func:`mbimpact.quadrature.rules.tilt_segments`), times, on each ring, the periodic
  trapezoid rule from the velocity's azimuth ψ when the whole ring faces u, else Gauss–Legendre
  on the facing arc ψ + π ± h (:func:`mbimpact.quadrature.rules.azimuth_rule`);
* planar (d = 2): Gauss–Legendre tilts on [lo, hi] on the side away from the motion and on
  [lo, α*] on the other (:meth:`mbimpact.IsotropicSlopes.rule_batch`).

On a ring of tilt α (s = sin α, c = cos α), with the azimuth measured from ψ, θ = φ − ψ, and
the velocity and W turned into that frame once (u' = (|u_t|, 0, u_n), W'), a facet
m' = (s cos θ, s sin θ, c) has

    mᵀu = s |u_t| cos θ + c u_n,    mᵀWm = m'ᵀW'm', a quadratic form in (cos θ, sin θ),

so that a node costs a few multiply-adds: cos θ and sin θ are tabulated on a whole ring
(θ = 2πj/n) and a short polynomial on an arc. The facet weights and the Newton impulse are
those of :func:`mbimpact.averaging.kernels.facet_terms`, (2.7)–(2.8): w = p (−mᵀu) ("physical")
or p (−mᵀu) / √(mᵀWm) ("configuration"), c = −mᵀu / mᵀWm, facets with mᵀu ≥ 0 or
mᵀWm ≤ DEGENERATE tr W left out, and P = (1+e) Σ w c m / Σ w at each level.

Where the time goes, and what is done about it (~10⁴ facets, ~25 µs for a typical impact): the
rings' sin α, cos α, density and facing half-width are computed for all rings of a level first,
in loops without calls (polynomials in place of libm: :func:`_sin_cos_tilt`, :func:`exp_neg`,
:func:`_acos`), so that they run in SIMD lanes; so do the azimuth sums of a ring (their sums
reassociated: ``fastmath`` flags ``reassoc`` and ``contract``), in pairs of nodes that share most
of their arithmetic and one division. No array is passed to a compiled function per ring (each
would cost atomic reference counts). The polynomials are accurate to an ulp or two, as libm is,
so that the result differs from the numpy rule's by rounding only.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit
from numpy.typing import NDArray

from ..quadrature.rules import gauss_legendre

__all__ = ["slope_pass", "tilt_nodes", "level_table", "level_count", "cos_sin", "exp_neg", "jit_seconds", "DONE",
           "STALLED", "CAPPED", "EMPTY", "NEED_TABLE", "TABULATED", "GAUSSIAN"]

#: Status codes of :func:`slope_pass`: converged to ``rtol`` (or to the rounding floor); stopped
#: above ``rtol`` by rounding amplified by |W| |P| / |W P|; stopped by ``max_nodes``; a level
#: with no facing facet (total weight 0); the level table ends before the next level.
DONE, STALLED, CAPPED, EMPTY, NEED_TABLE = 0, 1, 2, 3, 4

#: Kinds of tilt density: values given at the nodes of :func:`tilt_nodes`, or the density of
#: :class:`mbimpact.roughness.slopes.GaussianTiltDensity` in closed form.
TABULATED, GAUSSIAN = 0, 1

# machine epsilon (a constant of float64, safe to freeze into the compiled code)
_EPS = float(np.finfo(float).eps)

# fast-math flags of the functions that sum over nodes: their sums may be reassociated (run in
# SIMD lanes) and their products fused; NaN, infinities and signed zeros keep their IEEE meaning.
# The elementary functions below must not get them (their Cody–Waite splittings would be folded
# away): numba inlines them ("always") into _prepare, compiled without, and cos_sin, a function
# of its own, keeps its exact instructions where the compiler inlines it into the ring sums.
_FAST = {"reassoc", "contract"}

# ---------------------------------------------------------------------- constants of the polynomials
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


def level_table(n0: int, count: int) -> NDArray[np.float64]:
    """The nodes of ``count`` levels of n0, 2 n0, 4 n0, … nodes, concatenated.

    Parameters
    ----------
    n0 : int
        Nodes a piece of the first level.
    count : int
        Levels; level k (n = n0 2ᵏ nodes) starts at column n0 (2ᵏ − 1).

    Returns
    -------
    ndarray, shape (4, n0 (2^count − 1))
        Rows: the Gauss–Legendre nodes and weights on [−1, 1] of
        :func:`mbimpact.quadrature.rules.gauss_legendre` (the rule's own floats), and cos and sin
        of the offsets 2πj/n of a whole ring's azimuths. Read-only.
    """
    out = np.empty((4, n0 * ((1 << count) - 1)))
    for k in range(count):
        n, off = n0 << k, n0 * ((1 << k) - 1)
        x, w = gauss_legendre(n)
        theta = 2.0 * np.pi * np.arange(n) / n  # the offsets of azimuth_rule, the same floats
        out[0, off:off + n], out[1, off:off + n] = x, w
        out[2, off:off + n], out[3, off:off + n] = np.cos(theta), np.sin(theta)
    out.flags.writeable = False  # cached and shared by every call; numba then types it read-only, always
    return out


@njit(cache=True, error_model="numpy")
def level_count(table: NDArray[np.float64], n0: int) -> int:
    """The number of levels of a :func:`level_table` of first level ``n0``."""
    count = 0
    while n0 * ((1 << (count + 1)) - 1) <= table.shape[1]:
        count += 1
    return count


# ---------------------------------------------------------------------- elementary functions
# Polynomials in place of libm's sin, cos, exp and acos, which numba can only call one value at a
# time: these run in SIMD lanes inside the loops over nodes and rings.
@njit(cache=True, error_model="numpy", inline="always")
def _taylor_sin_cos(z: float) -> tuple[float, float]:
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
def cos_sin(y: float) -> tuple[float, float]:
    """cos y and sin y for |y| ≤ π, to an ulp or two of 1 (an azimuth node's position): beyond π/2
    from y ∓ π (split Cody–Waite, the first difference exact)."""
    far = abs(y) > 0.5 * math.pi
    shift = (y - _PI_HI) - _PI_LO if y > 0.0 else (y + _PI_HI) + _PI_LO
    sn, cs = _taylor_sin_cos(shift if far else y)
    return (-cs, -sn) if far else (cs, sn)


@njit(cache=True, error_model="numpy", inline="always")
def _sin_cos_tilt(alpha: float) -> tuple[float, float]:
    """sin α and cos α for 0 ≤ α ≤ π/2, each to an ulp or two of itself (cos α near π/2 too: from
    π/2 − α, split Cody–Waite, beyond π/4)."""
    beta = (_PIO2_HI - alpha) + _PIO2_LO  # exact first difference for α ≥ π/4 (Sterbenz)
    low = alpha <= 0.25 * math.pi
    sn, cs = _taylor_sin_cos(alpha if low else beta)
    return (sn, cs) if low else (cs, sn)


@njit(cache=True, error_model="numpy", inline="always")
def exp_neg(v: float) -> float:
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
def _acos(x: float) -> float:
    """acos x for 0 ≤ x ≤ 1 to ~2e-16 (absolute: an arc's half-width), fdlibm's way: π/2 − asin x
    below 1/2, 2 asin √((1 − x)/2) above (1 − x exact there), asin z = z + z R(z²)."""
    low = x <= 0.5
    z = x * x if low else 0.5 * (1.0 - x)
    r = z * (_PS0 + z * (_PS1 + z * (_PS2 + z * (_PS3 + z * (_PS4 + z * _PS5))))) / (
        1.0 + z * (_QS1 + z * (_QS2 + z * (_QS3 + z * _QS4))))
    s = math.sqrt(z)
    return _PIO2_HI - (x - (_PIO2_LO - x * r)) if low else 2.0 * (s + s * r)


# ---------------------------------------------------------------------- tilt nodes and density
@njit(cache=True, error_model="numpy")
def _split(u: NDArray[np.float64]) -> float:
    """α* = atan(|u_n| / |u_t|) (:func:`mbimpact.common.geometry.incidence_split`)."""
    d = u.shape[0]
    ut = math.sqrt(u[0] * u[0] + u[1] * u[1]) if d == 3 else abs(u[0])
    return math.atan2(abs(u[d - 1]), ut)


@njit(cache=True, error_model="numpy", inline="always")
def _segments(lo: float, hi: float, split: float) -> tuple[float, float, float, float]:
    """What every tilt node of a level shares (:func:`mbimpact.quadrature.rules.tilt_segments`): the
    split a = α* clipped into [lo, hi], and the onset o = min(α*, a) of the upper segment
    α = o + t², t ∈ [√(a − o), √(hi − o)]."""
    a = min(max(split, lo), hi)  # np.clip(split, lo, hi)
    origin = min(split, a)
    return a, origin, math.sqrt(a - origin), math.sqrt(hi - origin)


@njit(cache=True, error_model="numpy", inline="always")
def _lower_tilt(x: float, w: float, lo: float, a: float) -> tuple[float, float]:
    """A tilt node on [lo, a] and its weight dα, from the Gauss–Legendre node x and weight w on
    [−1, 1] (the float operations of tilt_segments)."""
    return lo + (a - lo) * (x + 1.0) / 2.0, (a - lo) / 2.0 * w


@njit(cache=True, error_model="numpy", inline="always")
def _upper_tilt(x: float, w: float, origin: float, t0: float, tmax: float) -> tuple[float, float]:
    """A tilt node α = o + t² on [a, hi] and its weight dα (tilt_segments'), t ∈ [t0, tmax]."""
    t = t0 + (tmax - t0) * (x + 1.0) / 2.0
    return origin + t * t, (tmax - t0) / 2.0 * w * 2.0 * t


@njit(cache=True, error_model="numpy")
def _tilt(i: int, n: int, x: float, w: float, lo: float, hi: float, a: float, origin: float, t0: float,
          tmax: float, planar: bool) -> tuple[float, float]:
    """Tilt node i of a level of n nodes a piece and its weight dα, from the level's
    :func:`_segments`. Spatial: nodes 0 … n−1 on [lo, a] and n … 2n−1 on [a, hi]. Planar
    (:meth:`mbimpact.IsotropicSlopes.rule_batch`): nodes 0 … n−1 on [lo, hi], n … 2n−1 on [lo, a],
    each weight halved (one of two sides)."""
    if planar:
        alpha, dalpha = _lower_tilt(x, w, lo, hi if i < n else a)
        return alpha, dalpha / 2.0
    if i < n:
        return _lower_tilt(x, w, lo, a)
    return _upper_tilt(x, w, origin, t0, tmax)


@njit(cache=True, error_model="numpy")
def tilt_nodes(U: NDArray[np.float64], lo: float, hi: float, table: NDArray[np.float64], n0: int
               ) -> NDArray[np.float64]:
    """The tilt nodes of the rule for the velocity ``u`` at every level of ``table``: where the
    density is a Python callable, its values there are :func:`slope_pass`'s ``density``.

    Parameters
    ----------
    U : ndarray, shape (1, d)
        Unit contact velocity u, local frame, u_n < 0.
    lo, hi : float
        The density's support.
    table : ndarray, shape (4, K)
        :func:`level_table` with first level ``n0``.
    n0 : int
        Nodes a piece of the first level.

    Returns
    -------
    ndarray, shape (2 K,)
        The 2n tilts of each level of n nodes a piece, in :func:`_tilt`'s order, level after level.
    """
    a, origin, t0, tmax = _segments(lo, hi, _split(U[0]))
    planar = U.shape[1] == 2
    out = np.empty(2 * table.shape[1])
    for k in range(level_count(table, n0)):
        n, off = n0 << k, n0 * ((1 << k) - 1)
        for i in range(2 * n):
            j = off + i % n
            out[2 * off + i] = _tilt(i, n, table[0, j], table[1, j], lo, hi, a, origin, t0, tmax, planar)[0]
    return out


@njit(cache=True, error_model="numpy", inline="always")
def _gaussian(s: float, c: float, inv_sigma: float, radial: bool) -> float:
    """:class:`mbimpact.roughness.slopes.GaussianTiltDensity` at sin α = s, cos α = c (unnormalised):
    x e^{−x²/2} / cos³α (spatial, ``radial``) or e^{−x²/2} / cos³α (planar), x = tan α / σ."""
    ic = 1.0 / c
    x = s * ic * inv_sigma
    g = exp_neg(-0.5 * x * x)
    return (g * x if radial else g) * (ic * ic * ic)


# ---------------------------------------------------------------------- one ring of facets
@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _terms(su1: float, su2: float, q1: float, q2: float, thr: float, configuration: bool
           ) -> tuple[float, float, float, float]:
    """The flux w of (2.7) (without the ring's probability) and w c, c = −mᵀu / mᵀWm, of two facets
    with mᵀu = su and mᵀWm = q (in units of tr W): w₁, w₁ c₁, w₂, w₂ c₂.

    A facet off G* (mᵀu ≥ 0) or that the mechanism cannot push (mᵀWm ≤ thr) adds nothing
    (:func:`mbimpact.averaging.kernels.facet_terms`). The two share one division: of the product of
    their mᵀWm, each at least thr (a left-out facet's value does not matter) and at most ~1 (units of
    tr W), which therefore neither under- nor overflows.
    """
    ok1 = (su1 < 0.0) & (q1 > thr)
    ok2 = (su2 < 0.0) & (q2 > thr)
    q1, q2 = max(q1, thr), max(q2, thr)
    if configuration:  # w = −mᵀu / √q
        h1, h2 = math.sqrt(q1), math.sqrt(q2)
        rho = 1.0 / (h1 * h2)
        f1, f2 = -su1 * (h2 * rho), -su2 * (h1 * rho)
        r1, r2 = (h2 * rho) * (h2 * rho), (h1 * rho) * (h1 * rho)
    else:  # w = −mᵀu
        rho = 1.0 / (q1 * q2)
        f1, f2 = -su1, -su2
        r1, r2 = q2 * rho, q1 * rho
    return ((f1 if ok1 else 0.0), (f1 * (-su1 * r1) if ok1 else 0.0),
            (f2 if ok2 else 0.0), (f2 * (-su2 * r2) if ok2 else 0.0))


@njit(cache=True, error_model="numpy", fastmath=_FAST, inline="always")
def _ring(xs: NDArray[np.float64], gs: NDArray[np.float64], cs: NDArray[np.float64], sn: NDArray[np.float64],
          h: float, a: float, b: float, q11: float, q12: float, q22: float, q13: float, q23: float, q33: float,
          thr: float, configuration: bool) -> tuple[float, float, float, float]:
    """:func:`_ring_sums` with the flux a constant in its loops (two copies, neither with a branch on it)."""
    if configuration:
        return _ring_sums(xs, gs, cs, sn, h, a, b, q11, q12, q22, q13, q23, q33, thr, True)
    return _ring_sums(xs, gs, cs, sn, h, a, b, q11, q12, q22, q13, q23, q33, thr, False)


@njit(cache=True, error_model="numpy", fastmath=_FAST, inline="always")
def _ring_sums(xs: NDArray[np.float64], gs: NDArray[np.float64], cs: NDArray[np.float64], sn: NDArray[np.float64],
               h: float, a: float, b: float, q11: float, q12: float, q22: float, q13: float, q23: float, q33: float,
               thr: float, configuration: bool) -> tuple[float, float, float, float]:
    """Σ g w, Σ g w c cos θ, Σ g w c sin θ, Σ g w c (:func:`_terms`) over the n azimuth nodes of one ring.

    With h = π (the whole ring faces u) the nodes are θ = 2πj/n, whose cos and sin are ``cs`` and
    ``sn``, and g = 1; on an arc of half-width h < π they are θ = π + h xⱼ, ``xs``, with the
    Gauss–Legendre weights g = gⱼ, ``gs`` (the level's columns of :func:`level_table`). For an even n
    both rules come in pairs that share most of the work, taken together: θ and θ + π on the whole
    ring, θ and −θ on the arc (the Gauss–Legendre nodes ±x, exactly, with the same weight). Per node
    mᵀu = a cos θ + b and mᵀWm = (q11 cos θ + q12 sin θ + q13) cos θ + (q22 sin θ + q23) sin θ + q33
    (units of tr W).
    """
    n = xs.shape[0]
    d = x = y = z = 0.0
    full = h == math.pi
    if n % 2 == 1:  # a first level of an odd node count (max_nodes // 2): node by node
        for j in range(n):
            if full:
                C, S, g = cs[j], sn[j], 1.0
            else:
                cy, sy = cos_sin(h * xs[j])
                C, S, g = -cy, -sy, gs[j]
            su = a * C + b
            q = (q11 * C + q12 * S + q13) * C + (q22 * S + q23) * S + q33
            w, wc, _, _ = _terms(su, su, q, q, thr, configuration)
            d += g * w
            x += g * wc * C
            y += g * wc * S
            z += g * wc
        return d, x, y, z
    if full:  # θ and θ + π: cos θ and sin θ change sign, so do mᵀu − b and the odd part of mᵀWm
        for j in range(n // 2):
            C, S = cs[j], sn[j]
            aC = a * C
            even = (q11 * C + q12 * S) * C + q22 * S * S + q33
            odd = q13 * C + q23 * S
            w1, c1, w2, c2 = _terms(b + aC, b - aC, even + odd, even - odd, thr, configuration)
            d += w1 + w2
            x += C * (c1 - c2)
            y += S * (c1 - c2)
            z += c1 + c2
        return d, x, y, z
    # θ = π ± h x (x < 0 on the first half): cos θ = −cos(h x), sin θ = ∓sin(h x); mᵀu is the same
    # at both, and mᵀWm but for its part odd in sin θ
    for j in range(n // 2):
        cy, sy = cos_sin(h * xs[j])
        C, S, g = -cy, -sy, gs[j]
        su = a * C + b
        even = (q11 * C + q13) * C + q22 * S * S + q33
        odd = (q12 * C + q23) * S
        w1, c1, w2, c2 = _terms(su, su, even + odd, even - odd, thr, configuration)
        d += g * (w1 + w2)
        x += g * C * (c1 + c2)
        y += g * S * (c1 - c2)
        z += g * (c1 + c2)
    return d, x, y, z


# ---------------------------------------------------------------------- one level of the rule
@njit(cache=True, error_model="numpy", inline="always")
def _ring_weight(alpha: float, dalpha: float, density: float, gaussian: bool, inv_sigma: float, radial: bool,
                 inv_mass: float, ut: float, un: float, n: int) -> tuple[float, float, float, float]:
    """sin α, cos α, the facing half-width h and the probability of one azimuth node of the ring
    of tilt α (its share p of the measure times azimuth_rule's w_az: 1/n on a whole ring, h/2π
    times the node's Gauss–Legendre weight on an arc; 0 when p is not > 0, as in facet_terms).
    ``density``: the tabulated density, unless ``gaussian`` (both are computed: a select, not a branch)."""
    s, c = _sin_cos_tilt(alpha)
    closed = _gaussian(s, c, inv_sigma, radial) * inv_mass
    p = (closed if gaussian else density) * dalpha
    # facing_half_width: the whole ring when tan α |u_t| ≤ |u_n|; azimuth_rule's whole ring is h == π
    h = math.pi if s * ut <= c * un else math.pi - _acos(min(1.0, c * un / (s * ut)))
    weight = p / n if h == math.pi else p * h / (2.0 * math.pi)
    return s, c, h, (weight if p > 0.0 else 0.0)


@njit(cache=True, error_model="numpy")
def _prepare(rings: NDArray[np.float64], xs: NDArray[np.float64], gs: NDArray[np.float64],
             density: NDArray[np.float64], lo: float, hi: float, split: float, gaussian: bool, inv_sigma: float,
             radial: bool, inv_mass: float, ut: float, un: float) -> None:
    """:func:`_ring_weight` of the 2n rings of a level into ``rings`` (4, ≥ 2n): sin α, cos α, h and
    the probability of a node, ring after ring. ``density`` (≥ 2n,): the tabulated density at the
    level's tilts, unless ``gaussian`` (then any values).

    A function of its own, compiled without fast-math flags: its polynomials (inlined) keep their
    Cody–Waite splittings. One loop per segment of tilts, without calls or branches (both
    densities are computed, one kept): they run in SIMD lanes.
    """
    n = xs.shape[0]
    a, origin, t0, tmax = _segments(lo, hi, split)
    # 1-D views, whose indices the compiler proves in bounds (stores in SIMD lanes)
    lower = (rings[0, :n], rings[1, :n], rings[2, :n], rings[3, :n])
    upper = (rings[0, n:2 * n], rings[1, n:2 * n], rings[2, n:2 * n], rings[3, n:2 * n])
    _prepare_segment(lower, xs, gs, density[:n], lo, a, origin, t0, tmax, False, gaussian, inv_sigma, radial,
                     inv_mass, ut, un)
    _prepare_segment(upper, xs, gs, density[n:2 * n], lo, a, origin, t0, tmax, True, gaussian, inv_sigma, radial,
                     inv_mass, ut, un)


@njit(cache=True, error_model="numpy", inline="always")
def _prepare_segment(out: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
                     xs: NDArray[np.float64], gs: NDArray[np.float64], density: NDArray[np.float64], lo: float,
                     a: float, origin: float, t0: float, tmax: float, upper: bool, gaussian: bool, inv_sigma: float,
                     radial: bool, inv_mass: float, ut: float, un: float) -> None:
    """:func:`_prepare` on one segment of tilts (``upper`` a constant)."""
    sines, cosines, halves, weights = out
    n = xs.shape[0]
    for i in range(n):
        if upper:
            alpha, dalpha = _upper_tilt(xs[i], gs[i], origin, t0, tmax)
        else:
            alpha, dalpha = _lower_tilt(xs[i], gs[i], lo, a)
        sines[i], cosines[i], halves[i], weights[i] = _ring_weight(
            alpha, dalpha, density[i], gaussian, inv_sigma, radial, inv_mass, ut, un, n)


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _spatial_level(k: int, u: NDArray[np.float64], W: NDArray[np.float64], table: NDArray[np.float64], n0: int,
                   density: NDArray[np.float64], kind: int, lo: float, hi: float, sigma: float, radial: bool,
                   mass: float, configuration: bool, e: float, degenerate: float, rings: NDArray[np.float64]
                   ) -> tuple[bool, float, float, float]:
    """(2.8) by level k of the spatial rule: whether a facet faces u, and P (3 floats); ``rings`` is
    scratch space, (4, ≥ 2n)."""
    n, off = n0 << k, n0 * ((1 << k) - 1)
    ux, uy, uz = u[0], u[1], u[2]
    ut = math.hypot(ux, uy)
    un = abs(uz)
    cp, sp = (ux / ut, uy / ut) if ut > 0.0 else (1.0, 0.0)  # the azimuth ψ of u_t
    # W' = Rᵀ W R / tr W in the frame (e_ψ, e_ψ⊥, n⁰) of the ring's θ = φ − ψ: mᵀWm in units of
    # tr W is of order one (see _terms), and P = (1+e) N / D in those units is tr W times P
    trace = W[0, 0] + W[1, 1] + W[2, 2]
    w11 = (cp * (cp * W[0, 0] + sp * W[1, 0]) + sp * (cp * W[0, 1] + sp * W[1, 1])) / trace
    w12 = (cp * (-sp * W[0, 0] + cp * W[1, 0]) + sp * (-sp * W[0, 1] + cp * W[1, 1])) / trace
    w22 = (-sp * (-sp * W[0, 0] + cp * W[1, 0]) + cp * (-sp * W[0, 1] + cp * W[1, 1])) / trace
    w13 = (cp * W[0, 2] + sp * W[1, 2]) / trace
    w23 = (-sp * W[0, 2] + cp * W[1, 2]) / trace
    w33 = W[2, 2] / trace
    # the level's columns as views indexed from 0, made once (a view costs two atomic reference
    # counts): an index from 0 is one the compiler proves non-negative, so that it loads a ring's
    # nodes as vectors instead of wrapping each index around
    xs, gs = table[0, off:off + n], table[1, off:off + n]
    cs, sn = table[2, off:off + n], table[3, off:off + n]
    _prepare(rings, xs, gs, density[2 * off:2 * off + 2 * n], lo, hi, _split(u), kind == GAUSSIAN, 1.0 / sigma, radial,
             1.0 / mass, ut, un)
    D = X = Y = Z = 0.0
    for i in range(2 * n):
        pr = rings[3, i]
        if not pr > 0.0:
            continue
        s, c = rings[0, i], rings[1, i]
        ss, sc = s * s, 2.0 * s * c
        rd, rx, ry, rz = _ring(xs, gs, cs, sn, rings[2, i], s * ut, c * uz, ss * w11, 2.0 * ss * w12, ss * w22,
                               sc * w13, sc * w23, c * c * w33, degenerate, configuration)
        D += pr * rd
        X += pr * s * rx
        Y += pr * s * ry
        Z += pr * c * rz
    if not D > 0.0:
        return False, 0.0, 0.0, 0.0
    k1 = (1.0 + e) / (D * trace)
    return True, k1 * (cp * X - sp * Y), k1 * (sp * X + cp * Y), k1 * Z


@njit(cache=True, error_model="numpy")
def _planar_level(k: int, u: NDArray[np.float64], W: NDArray[np.float64], table: NDArray[np.float64], n0: int,
                  density: NDArray[np.float64], kind: int, lo: float, hi: float, sigma: float, radial: bool,
                  mass: float, configuration: bool, e: float, degenerate: float) -> tuple[bool, float, float, float]:
    """(2.8) by level k of the planar rule: whether a facet faces u, and P (2 floats and a 0); its
    2n facets in one loop."""
    n, off = n0 << k, n0 * ((1 << k) - 1)
    u0, u1 = u[0], u[1]
    side = 1.0 if u0 >= 0.0 else -1.0  # the sign of u_t: tilting "with" the motion
    thr = degenerate * (W[0, 0] + W[1, 1])
    a, origin, t0, tmax = _segments(lo, hi, _split(u))
    xs, gs = table[0, off:off + n], table[1, off:off + n]
    inv_sigma = 1.0 / sigma
    D = N0 = N1 = 0.0
    for i in range(2 * n):
        j = i if i < n else i - n
        alpha, dalpha = _tilt(i, n, xs[j], gs[j], lo, hi, a, origin, t0, tmax, True)
        s, c = _sin_cos_tilt(alpha)
        p = (density[2 * off + i] if kind == TABULATED else _gaussian(s, c, inv_sigma, radial) / mass) * dalpha
        m0 = (-side if i < n else side) * s
        su = m0 * u0 + c * u1
        q = (m0 * W[0, 0] + c * W[1, 0]) * m0 + (m0 * W[0, 1] + c * W[1, 1]) * c
        if not (su < 0.0 and q > thr and p > 0.0):
            continue
        w = p * (-su / math.sqrt(q) if configuration else -su)
        wc = w * (-su / q)
        D += w
        N0 += wc * m0
        N1 += wc * c
    if not D > 0.0:
        return False, 0.0, 0.0, 0.0
    k1 = (1.0 + e) / D
    return True, k1 * N0, k1 * N1, 0.0


@njit(cache=True, error_model="numpy")
def _level(k: int, u: NDArray[np.float64], W: NDArray[np.float64], table: NDArray[np.float64], n0: int,
           density: NDArray[np.float64], kind: int, lo: float, hi: float, sigma: float, radial: bool, mass: float,
           configuration: bool, e: float, degenerate: float, rings: NDArray[np.float64]
           ) -> tuple[bool, float, float, float]:
    """(2.8) by level k of the rule (:func:`_spatial_level`, :func:`_planar_level`)."""
    if u.shape[0] == 2:
        return _planar_level(k, u, W, table, n0, density, kind, lo, hi, sigma, radial, mass, configuration, e,
                             degenerate)
    return _spatial_level(k, u, W, table, n0, density, kind, lo, hi, sigma, radial, mass, configuration, e,
                          degenerate, rings)


@njit(cache=True, error_model="numpy")
def _times_W(W: NDArray[np.float64], x0: float, x1: float, x2: float) -> tuple[float, float, float]:
    """x W for a row x of 2 or 3 entries (x2 = 0 when d = 2)."""
    if W.shape[0] == 2:
        return x0 * W[0, 0] + x1 * W[1, 0], x0 * W[0, 1] + x1 * W[1, 1], 0.0
    return (x0 * W[0, 0] + x1 * W[1, 0] + x2 * W[2, 0], x0 * W[0, 1] + x1 * W[1, 1] + x2 * W[2, 1],
            x0 * W[0, 2] + x1 * W[1, 2] + x2 * W[2, 2])


# ---------------------------------------------------------------------- the refinement
@njit(cache=True, error_model="numpy")
def slope_pass(U: NDArray[np.float64], W: NDArray[np.float64], table: NDArray[np.float64], n0: int,
               density: NDArray[np.float64], kind: int, lo: float, hi: float, sigma: float, radial: bool,
               mass: float, e: float, configuration: bool, rtol: float, max_nodes: int, degenerate: float,
               P: NDArray[np.float64], state: NDArray[np.float64], start: int) -> int:
    """The adaptive rule of :func:`mbimpact.averaging.refinement.refine` for one velocity.

    Levels n0, 2 n0, … of the measure's rule until two successive ones agree to
    max(rtol, 100 ε √K) (K facets of the finer) in the relative change of W P
    (:func:`mbimpact.averaging.kernels.relative_change`).

    Parameters
    ----------
    U : ndarray, shape (1, d)
        Unit contact velocity u, local frame, u_n < 0 (d = 2 or 3).
    W : ndarray, shape (d, d)
        Delassus matrix, local frame.
    table : ndarray, shape (4, K)
        :func:`level_table` from level n0 on.
    n0 : int
        Nodes a piece of the first level.
    density : ndarray, shape (2 K,)
        ``kind`` TABULATED: the normalised tilt density at :func:`tilt_nodes`; else read but unused
        (any values: the closed form is selected after both are computed).
    kind : int
        TABULATED or GAUSSIAN.
    lo, hi : float
        The density's support.
    sigma, radial, mass : float, bool, float
        GAUSSIAN: the RMS slope, whether the slope density is the spatial one (x e^{−x²/2}), and
        the integral of the unnormalised density.
    e : float
        Facet restitution.
    configuration : bool
        The "configuration" flux of (2.7) (else "physical").
    rtol : float
        Relative accuracy.
    max_nodes : int
        Nodes a piece at which refinement stops.
    degenerate : float
        A facet with mᵀWm ≤ degenerate · tr W cannot be pushed by the mechanism: left out
        (:data:`mbimpact.common.geometry.DEGENERATE`).
    P : ndarray, shape (1, d)
        Out: the impulse of the last level, (2.8), local frame. In, when ``start`` ≥ 0: the impulse
        of level ``start`` (a call resumed after NEED_TABLE).
    state : ndarray, shape (2,)
        Out: the last level compared with the one before (its index, as a float) and that error
        estimate. In, when ``start`` ≥ 0: level ``start``'s, as left by the call that returned
        NEED_TABLE.
    start : int
        −1 for a new velocity; else the level the call that returned NEED_TABLE ended with.

    Returns
    -------
    int
        DONE, STALLED, CAPPED (``P`` and ``state`` hold the last level), EMPTY or NEED_TABLE
        (extend ``table``, and ``density`` for TABULATED, and call again).
    """
    u = U[0]
    d = u.shape[0]
    count = level_count(table, n0)
    trace = W[0, 0] + W[1, 1] + (W[2, 2] if d == 3 else 0.0)
    rings = np.empty((4, 2 * (n0 << (count - 1)) if d == 3 and count > 0 else 0))  # _spatial_level's scratch
    k = start
    # the coarse level's impulse c, and the error estimate before this one
    c0, c1, c2 = (P[0, 0], P[0, 1], (P[0, 2] if d == 3 else 0.0)) if k >= 0 else (0.0, 0.0, 0.0)
    previous = state[1] if k >= 0 else math.inf
    while True:
        k += 1
        if k >= count:  # (after level 0 alone a resumed call starts again from −1)
            state[0] = k - 1 if k > 1 else -1.0
            return NEED_TABLE
        # (one call site of the level: the compiler inlines it once at most)
        ok, f0, f1, f2 = _level(k, u, W, table, n0, density, kind, lo, hi, sigma, radial, mass, configuration, e,
                                degenerate, rings)
        if not ok:
            return EMPTY
        if k == 0:  # the first level: no comparison yet
            c0, c1, c2 = f0, f1, f2
            continue
        # relative_change: |(fine − coarse) W| / |fine W|
        g0, g1, g2 = _times_W(W, f0 - c0, f1 - c1, f2 - c2)
        r0, r1, r2 = _times_W(W, f0, f1, f2)
        err = math.sqrt((g0 * g0 + g1 * g1 + g2 * g2) / (r0 * r0 + r1 * r1 + r2 * r2))
        P[0, 0], P[0, 1] = f0, f1
        if d == 3:
            P[0, 2] = f2
        state[0], state[1] = k, err
        nodes = n0 << k
        floor = 100.0 * _EPS * math.sqrt(2.0 * nodes * (nodes if d == 3 else 1))  # the level's facets
        if not err > max(rtol, floor):
            return DONE
        # the adaptive rule's test for results stalled at rounding amplified by |W| |P| / |W P|
        amplification = trace * math.sqrt((f0 * f0 + f1 * f1 + f2 * f2) / (r0 * r0 + r1 * r1 + r2 * r2))
        if err <= floor * amplification and err > 0.1 * previous:
            return STALLED
        if nodes * 2 > max_nodes:
            return CAPPED
        c0, c1, c2, previous = f0, f1, f2, err


def jit_seconds() -> float:
    """Wall time to make the kernels callable in this process (numba's import excluded: importing
    this module does it): their machine code loaded from numba's on-disk cache (``__pycache__`` next
    to this file), or compiled when that cache is missing or stale. The first call pays it; later
    calls return near 0."""
    start = time.perf_counter()
    table = level_table(2, 2)
    for d in (3, 2):
        U = np.full((1, d), -1.0 / math.sqrt(d))
        U[0, 0] = -U[0, 0]
        density = np.ones(2 * table.shape[1])
        tilt_nodes(U, 0.0, 1.0, table, 2)
        for kind in (TABULATED, GAUSSIAN):
            slope_pass(U, np.eye(d), table, 2, density, kind, 0.0, 1.0, 0.5, True, 1.0, 0.5, False, 1e-12, 8, 1e-14,
                       np.empty((1, d)), np.empty(2), -1)
    return time.perf_counter() - start

"""The nodes of an isotropic tilt density's product rule for one velocity, and one ring's sums: the
building blocks of its compiled adaptive rule (:mod:`~mbimpact.averaging.compiled.slopes`).

The nodes are those of the measure's own rule (:meth:`mbimpact.IsotropicSlopes.rule_batch`), level
after level (n, 2n, 4n, … nodes a piece):

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
those of :func:`mbimpact.averaging.integrand.facet_terms`, (2.7)–(2.8): w = p (−mᵀu) ("physical")
or p (−mᵀu) / √(mᵀWm) ("configuration"), c = −mᵀu / mᵀWm, facets with mᵀu ≥ 0 or
mᵀWm ≤ DEGENERATE tr W left out.

The rings' sin α, cos α, density and facing half-width are computed for all rings of a level first,
in loops without calls (:func:`prepare_rings`; polynomials in place of libm,
:mod:`~mbimpact.averaging.compiled.primitives`), so that they run in SIMD lanes; so do the azimuth
sums of a ring (:func:`ring_sums`; reassociated: ``fastmath`` flags ``reassoc`` and ``contract``), in
pairs of nodes that share most of their arithmetic and one division.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from ...quadrature.rules import gauss_legendre
from .primitives import acos_unit, cos_sin, exp_neg, sin_cos_tilt

__all__ = ["level_table", "level_count", "split_tilt", "segments", "tilt", "tilt_nodes", "gaussian_density",
           "ring_sums", "prepare_rings", "FAST"]

#: Fast-math flags of the functions that sum over nodes: their sums may be reassociated (run in SIMD
#: lanes) and their products fused; NaN, infinities and signed zeros keep their IEEE meaning. The
#: elementary functions must not get them (their Cody–Waite splittings would be folded away): numba
#: inlines them ("always") into :func:`prepare_rings`, compiled without, and ``cos_sin``, a function of
#: its own, keeps its exact instructions where the compiler inlines it into the ring sums.
FAST = {"reassoc", "contract"}


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


# ---------------------------------------------------------------------- tilt nodes and density
@njit(cache=True, error_model="numpy")
def split_tilt(u: NDArray[np.float64]) -> float:
    """α* = atan(|u_n| / |u_t|) (:func:`mbimpact.common.geometry.incidence_split`)."""
    d = u.shape[0]
    ut = math.sqrt(u[0] * u[0] + u[1] * u[1]) if d == 3 else abs(u[0])
    return math.atan2(abs(u[d - 1]), ut)


@njit(cache=True, error_model="numpy", inline="always")
def segments(lo: float, hi: float, split: float) -> tuple[float, float, float, float]:
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
def tilt(i: int, n: int, x: float, w: float, lo: float, hi: float, a: float, origin: float, t0: float,
          tmax: float, planar: bool) -> tuple[float, float]:
    """Tilt node i of a level of n nodes a piece and its weight dα, from the level's
    :func:`segments`. Spatial: nodes 0 … n−1 on [lo, a] and n … 2n−1 on [a, hi]. Planar
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
    density is a Python callable, its values there are the ``density`` of
    :func:`~mbimpact.averaging.compiled.slopes.slope_adaptive`.

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
        The 2n tilts of each level of n nodes a piece, in :func:`tilt`'s order, level after level.
    """
    a, origin, t0, tmax = segments(lo, hi, split_tilt(U[0]))
    planar = U.shape[1] == 2
    out = np.empty(2 * table.shape[1])
    for k in range(level_count(table, n0)):
        n, off = n0 << k, n0 * ((1 << k) - 1)
        for i in range(2 * n):
            j = off + i % n
            out[2 * off + i] = tilt(i, n, table[0, j], table[1, j], lo, hi, a, origin, t0, tmax, planar)[0]
    return out


@njit(cache=True, error_model="numpy", inline="always")
def gaussian_density(s: float, c: float, inv_sigma: float, radial: bool) -> float:
    """:class:`mbimpact.roughness.slopes.GaussianTiltDensity` at sin α = s, cos α = c (unnormalised):
    x e^{−x²/2} / cos³α (spatial, ``radial``) or e^{−x²/2} / cos³α (planar), x = tan α / σ."""
    ic = 1.0 / c
    x = s * ic * inv_sigma
    g = exp_neg(-0.5 * x * x)
    return (g * x if radial else g) * (ic * ic * ic)


# ---------------------------------------------------------------------- one ring of facets
@njit(cache=True, error_model="numpy", fastmath=FAST)
def _terms(su1: float, su2: float, q1: float, q2: float, thr: float, configuration: bool
           ) -> tuple[float, float, float, float]:
    """The flux w of (2.7) (without the ring's probability) and w c, c = −mᵀu / mᵀWm, of two facets
    with mᵀu = su and mᵀWm = q (in units of tr W): w₁, w₁ c₁, w₂, w₂ c₂.

    A facet off G* (mᵀu ≥ 0) or that the mechanism cannot push (mᵀWm ≤ thr) adds nothing
    (:func:`mbimpact.averaging.integrand.facet_terms`). The two share one division: of the product of
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


@njit(cache=True, error_model="numpy", fastmath=FAST, inline="always")
def ring_sums(xs: NDArray[np.float64], gs: NDArray[np.float64], cs: NDArray[np.float64], sn: NDArray[np.float64],
          h: float, a: float, b: float, q11: float, q12: float, q22: float, q13: float, q23: float, q33: float,
          thr: float, configuration: bool) -> tuple[float, float, float, float]:
    """:func:`_ring_pairs` with the flux a constant in its loops (two copies, neither with a branch on it)."""
    if configuration:
        return _ring_pairs(xs, gs, cs, sn, h, a, b, q11, q12, q22, q13, q23, q33, thr, True)
    return _ring_pairs(xs, gs, cs, sn, h, a, b, q11, q12, q22, q13, q23, q33, thr, False)


@njit(cache=True, error_model="numpy", fastmath=FAST, inline="always")
def _ring_pairs(xs: NDArray[np.float64], gs: NDArray[np.float64], cs: NDArray[np.float64], sn: NDArray[np.float64],
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
    s, c = sin_cos_tilt(alpha)
    closed = gaussian_density(s, c, inv_sigma, radial) * inv_mass
    p = (closed if gaussian else density) * dalpha
    # facing_half_width: the whole ring when tan α |u_t| ≤ |u_n|; azimuth_rule's whole ring is h == π
    h = math.pi if s * ut <= c * un else math.pi - acos_unit(min(1.0, c * un / (s * ut)))
    weight = p / n if h == math.pi else p * h / (2.0 * math.pi)
    return s, c, h, (weight if p > 0.0 else 0.0)


@njit(cache=True, error_model="numpy")
def prepare_rings(rings: NDArray[np.float64], xs: NDArray[np.float64], gs: NDArray[np.float64],
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
    a, origin, t0, tmax = segments(lo, hi, split)
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
    """:func:`prepare_rings` on one segment of tilts (``upper`` a constant)."""
    sines, cosines, halves, weights = out
    n = xs.shape[0]
    for i in range(n):
        if upper:
            alpha, dalpha = _upper_tilt(xs[i], gs[i], origin, t0, tmax)
        else:
            alpha, dalpha = _lower_tilt(xs[i], gs[i], lo, a)
        sines[i], cosines[i], halves[i], weights[i] = _ring_weight(
            alpha, dalpha, density[i], gaussian, inv_sigma, radial, inv_mass, ut, un, n)



"""The node sums of the compiled graded rules, one half-piece at a time: shared by a cone's
(:mod:`~mbimpact.averaging.compiled.graded_cone`) and a tilt density's
(:mod:`~mbimpact.averaging.compiled.graded_slopes`).

The graded rule of :func:`mbimpact.quadrature.graded.graded_azimuth_rule` cuts the facing interval
of a ring at the minima of q = mᵀWm, halves every piece and maps each half onto its graded end a by
φ = a ± ε sinh t, Gauss–Legendre in t. A half-piece's m nodes are computed by
:func:`half_piece_nodes` (cos θ, sin θ and the weight, θ the azimuth in the caller's frame: W's own for
a cone, the facing interval's centre for a ring of a tilt density) and summed by :func:`half_piece_sums` (the integrands of (2.8) with the flux weights of (2.7)). Both
loops run in SIMD lanes: polynomials in place of libm
(:func:`~mbimpact.averaging.compiled.primitives.cos_sin`,
:func:`~mbimpact.averaging.compiled.primitives.exp_neg`), no calls, no early exits, and the sums
reassociated; the callers add the half-pieces' sums with compensation
(:func:`~mbimpact.averaging.compiled.primitives.compensated_add`). The result is the per-node loop's to a
few ulps of each half-piece's sum, at a fraction of its cost.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .primitives import cos_sin, exp_neg

__all__ = ["half_piece_nodes", "half_piece_sums", "NODE_PLUS_ONE", "WEIGHT"]

#: Rows of :func:`mbimpact.averaging.compiled.graded_cone.rule_table`: x + 1 and w of the Gauss–Legendre
#: nodes of each level in turn.
NODE_PLUS_ONE, WEIGHT = 0, 1

# fast-math flags of the node sums: reassociated into SIMD lanes, products fused (no finite-math
# assumptions: a NaN must stay one)
_FAST = {"reassoc", "contract"}


@njit(cache=True, error_model="numpy")
def half_piece_nodes(start: int, m: int, table: NDArray[np.float64], offset: float, sign: float, width: float,
                     T: float, scale: float, cs: NDArray[np.float64], sn: NDArray[np.float64],
                     pw: NDArray[np.float64]) -> None:  # pragma: no cover — compiled
    """The ``m`` nodes of one half-piece (columns ``start`` … ``start + m`` of the table).

    θ = offset ± δ is the node's azimuth, δ = ε sinh t, t = T (x + 1) / 2, ε = ``width``, ± = ``sign``;
    its weight is ``scale`` · ε cosh t (T/2) w / 2π (``scale`` = p(α) dα for a ring of a tilt density,
    1 for a cone). One exponential gives sinh and cosh. cos θ and sin θ come from those of the
    offset (libm, once) and of δ (|δ| ≤ π, polynomials): the nodes then sit where they should
    relative to the half-piece's graded end to the precision of δ itself, which the kernels' narrow
    peaks need there (polynomials of θ whole err by an ulp of 1 wherever θ is, and near a minimum of
    q the sums then stop short of rtol with the configuration flux).

    Parameters
    ----------
    table : ndarray, shape (2, K)
        :func:`mbimpact.averaging.compiled.graded_cone.rule_table`.
    cs, sn, pw : ndarray, shape (≥ m,)
        Output: cos θ, sin θ and the weights.
    """
    co, so = math.cos(offset), math.sin(offset)
    for j in range(m):
        i = start + j
        t = T * table[NODE_PLUS_ONE, i] / 2.0
        y = exp_neg(-t)
        x = 1.0 / y
        cd, sd = cos_sin(sign * width * (0.5 * (x - y)))
        cs[j], sn[j] = co * cd - so * sd, so * cd + co * sd
        pw[j] = width * (0.5 * (x + y)) * (T / 2.0) * table[WEIGHT, i] / (2.0 * math.pi) * scale


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def half_piece_sums(m: int, cs: NDArray[np.float64], sn: NDArray[np.float64], pw: NDArray[np.float64], s: float,
                    c: float, ux: float, uy: float, uz: float, w00: float, w01: float, w11: float, w02: float,
                    w12: float, w22: float, thr: float, configuration: bool
                    ) -> tuple[float, float, float, float, int, int]:  # pragma: no cover — compiled
    """Sums over the ``m`` nodes of a half-piece (:func:`half_piece_nodes`) on the ring
    m = (s cos θ, s sin θ, c), in the frame that θ is measured in: u = (ux, uy, uz), W = w..

    Returns
    -------
    D, N₀, N₁, N₂ : float
        D = Σ w and N = Σ w (−mᵀu / mᵀWm) m over the facing nodes, w the flux weight of (2.7):
        p (−mᵀu) / √(mᵀWm) if ``configuration``, else p (−mᵀu).
    count : int
        Nodes of positive weight (the numpy rule's facets).
    bad : int
        Facing nodes the mechanism cannot push (mᵀWm ≤ ``thr``), left out of the sums.
    """
    d, n0, n1, n2 = 0.0, 0.0, 0.0, 0.0
    count, bad = 0, 0
    for j in range(m):
        m0, m1, p = s * cs[j], s * sn[j], pw[j]
        sweep = -(m0 * ux + m1 * uy + c * uz)  # −mᵀu > 0 on G*
        q = m0 * (m0 * w00 + 2.0 * m1 * w01 + 2.0 * c * w02) + m1 * (m1 * w11 + 2.0 * c * w12) + c * c * w22
        facing = (sweep > 0.0) & (p > 0.0)
        count += p > 0.0
        bad += facing & (not q > thr)
        ok = facing & (q > thr)
        q = max(q, thr)  # no division by 0 in the lanes left out
        weight = p * (sweep / math.sqrt(q) if configuration else sweep)
        wc = weight * (sweep / q)
        d += weight if ok else 0.0
        n0 += wc * m0 if ok else 0.0
        n1 += wc * m1 if ok else 0.0
        n2 += wc * c if ok else 0.0
    return d, n0, n1, n2, count, bad

"""Contact-space geometry shared by the roughness measures and the averaging rules.

A facet of the microrelief with tilt α from the base normal n⁰ and azimuth φ has
the unit normal m = (sin α cos φ, sin α sin φ, cos α) in the local frame of the
base surface (last axis along n⁰). For a contact velocity u of azimuth ψ, with
u_t its part across n⁰ and u_n < 0 its part along n⁰, the facet faces u (belongs
to G* of (2.7)) iff mᵀu < 0, i.e. iff

    sin α |u_t| cos(φ − ψ) < cos α |u_n|.

That set is the whole ring of tilt α when tan α |u_t| ≤ |u_n|, and otherwise the
arc φ ∈ ψ + π ± h with cos h = −cot α |u_n| / |u_t| (:func:`facing_half_width`).
Rings with α below α* = atan(|u_n| / |u_t|) are whole, rings above it are cut
(:func:`incidence_split`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "DEGENERATE",
    "EPS",
    "facing_half_width",
    "facing_half_width_scalar",
    "incidence_split",
    "offset_point_jacobian",
    "ring_quadratic_form",
    "ring_coefficients",
    "scaled_norm",
]

#: A facet (or base normal) with mᵀWm ≤ DEGENERATE · trace(W) cannot be moved along by the
#: mechanism (Jᵀm ≈ 0): it carries no flux and is skipped by every rule.
DEGENERATE = 1e-14

#: Machine epsilon of float64.
EPS = float(np.finfo(float).eps)


def facing_half_width(sin_tilt: Any, cos_tilt: Any, ut: Any, un: Any) -> NDArray[np.float64]:
    """Half-width h of the arc of a ring of facets that faces the velocity (arrays).

    Parameters
    ----------
    sin_tilt, cos_tilt : array_like
        sin α and cos α of the ring(s).
    ut, un : array_like
        |u_t| ≥ 0 and |u_n| > 0 of the velocity (broadcast against the tilts).

    Returns
    -------
    ndarray
        h ∈ (π/2, π]: the facing set is φ ∈ ψ + π ± h; h = π is the whole ring.
    """
    s, c, ut, un = (np.asarray(x, dtype=float) for x in (sin_tilt, cos_tilt, ut, un))
    full = s * ut <= c * un
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(full, 1.0, c * un / np.where(full, 1.0, s * ut))
    return np.where(full, math.pi, math.pi - np.arccos(np.clip(ratio, -1.0, 1.0)))


def facing_half_width_scalar(sin_tilt: float, cos_tilt: float, ut: float, un: float) -> float:
    """:func:`facing_half_width` for one ring and one velocity, in float arithmetic (hot paths)."""
    if sin_tilt * ut <= cos_tilt * un:
        return math.pi
    return math.pi - math.acos(min(1.0, cos_tilt * un / (sin_tilt * ut)))


def incidence_split(U: NDArray[np.float64]) -> NDArray[np.float64]:
    """α* = atan(|u_n| / |u_t|) per row of local-frame velocities U (B, d): rings of facets
    tilted by less than α* face the velocity whole, those tilted more are cut (π/2 − α* is
    the incidence β of the velocity)."""
    return np.arctan2(np.abs(U[:, -1]), np.linalg.norm(U[:, :-1], axis=1))


def ring_quadratic_form(s: Any, c: Any, W: NDArray[np.float64] | list[list[float]]) -> tuple[Any, Any, Any, Any, Any]:
    """q(φ) = mᵀWm on the ring of tilt α (s = sin α, c = cos α; floats or arrays) as
    q₀ + a₁ cos φ + b₁ sin φ + a₂ cos 2φ + b₂ sin 2φ: the coefficients (q₀, a₁, b₁, a₂, b₂)
    for a local-frame Delassus matrix W (3, 3), an array or its ``tolist()``."""
    return ring_coefficients(s, c, W if isinstance(W, list) else W.tolist())


def ring_coefficients(s: Any, c: Any, w: Any) -> tuple[Any, Any, Any, Any, Any]:
    """:func:`ring_quadratic_form` on any ``w`` indexed as ``w[i][j]``: the arithmetic alone, which the
    compiled rules compile as it stands."""
    return (0.5 * s * s * (w[0][0] + w[1][1]) + c * c * w[2][2], 2 * s * c * w[0][2], 2 * s * c * w[1][2],
            0.5 * s * s * (w[0][0] - w[1][1]), s * s * w[0][1])


def scaled_norm(x: NDArray[np.float64], axis: int = -1) -> Any:
    """Euclidean norm along ``axis`` without overflow or underflow of the squares (|x| up to the
    largest float): the vectors are divided by their largest entry first."""
    x = np.asarray(x, dtype=float)
    big = np.abs(x).max(axis=axis, keepdims=True)
    safe = np.where(big > 0.0, big, 1.0)
    out = np.squeeze(big, axis=axis) * np.linalg.norm(x / safe, axis=axis)
    return float(out) if out.ndim == 0 else out


def offset_point_jacobian(J6: NDArray[np.float64], r: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """Translational Jacobian (3, nv) of a point at world-axis offset ``r`` from a frame origin.

    ``J6`` (6, nv) is the frame's LOCAL_WORLD_ALIGNED Jacobian (linear rows first);
    the point moves with v_p = v_o + ω × r, so J_p = J_lin − [r]ₓ J_ang.
    """
    if r is None or not (r[0] or r[1] or r[2]):
        return J6[:3].copy()
    x, y, z = float(r[0]), float(r[1]), float(r[2])
    ang = J6[3:]
    lin = J6[:3].copy()
    lin[0] -= y * ang[2] - z * ang[1]
    lin[1] -= z * ang[0] - x * ang[2]
    lin[2] -= x * ang[1] - y * ang[0]
    return lin

"""Arc integrals over a ring of facets at a fixed Delassus matrix: (2.8) for batches.

For a cone of facets m(φ) = (sin α cos φ, sin α sin φ, cos α) (local frame) and
a fixed W, the two integrals of (2.8) over the facing arc are

    N(u) = ∫_arc (mᵀu)² m / (mᵀWm)^γ dφ/2π,    D(u) = ∫_arc (−mᵀu) / (mᵀWm)^δ dφ/2π,

with (γ, δ) of :func:`mbimpact.averaging.integrand.kernel_powers` ((1, 0) for the
physical flux, (3/2, 1/2) for the configuration flux).
mᵀu = a + b cos φ + c sin φ, so (mᵀu)² is a combination of the six monomials
1, cos, sin, cos², cos sin, sin² whose coefficients depend on u only, and the
integrals are combinations of the antiderivatives of monomial × kernel. Those
kernels depend on W and α only: they are expanded once in Fourier series (FFT,
refined until the tail is below rounding), integrated term by term, and then
every velocity of a batch costs one evaluation of the series at the two end
points of its facing arc — or nothing but the mean when the whole ring faces u.
The arc end points are the closed-form ones of
:func:`mbimpact.common.geometry.facing_half_width`.

This is exact up to the truncation of the series (reported), and it is what
makes batches of rough impacts cheap (:class:`Ring`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import DEGENERATE, EPS, facing_half_width
from ..results.impact import ContactImpulses
from .base import SKIP, Averaging
from .integrand import AveragingSpec, Flux, kernel_powers, quotient

__all__ = ["Ring", "RingExpansion", "ring_expansion", "unit_powers"]

# The series is accepted when every coefficient of its last quarter is below this
# fraction of the kernel's size (FFT rounding sits near 1e-16); beyond _MAX_DEGREE
# the kernel is too peaked (a nearly singular W) and the law falls back on
# adaptive quadrature.
_TAIL = 1e-15
_MAX_DEGREE = 1024
# Rows × degree per evaluation chunk: keeps the (rows, L) complex work arrays small.
_CHUNK = 1 << 16
# Powers z^l are built as z^(lo) · z^(BLOCK·hi): one complex product per term.
_BLOCK = 8


@dataclass(frozen=True, eq=False)
class RingExpansion:
    """Antiderivatives of the (2.8) kernels on one ring of facets, fixed W.

    Attributes
    ----------
    alpha : float
        Tilt of the ring.
    mean : ndarray, shape (21,)
        Mean over the full circle of the 18 numerator kernels (6 monomials × 3
        components, monomial-major) and the 3 denominator kernels (1, cos, sin).
    coef : ndarray, shape (2 L, 21)
        Rows l − 1 and L + l − 1: coefficients of Im and Re of
        (e^{ilφ₂} − e^{ilφ₁}) in the arc integral ∫_{φ₁}^{φ₂} · dφ/2π.
    degree : int
        L, the degree kept.
    tail : float
        Largest relative coefficient beyond ``degree`` (truncation estimate).
    """

    alpha: float
    mean: NDArray[np.float64]
    coef: NDArray[np.float64]
    degree: int
    tail: float

    def integrals(self, U: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """N (B, 3) and D (B,) of (2.8) for unit local-frame velocities U (B, 3), U[:, 2] < 0."""
        s, c = math.sin(self.alpha), math.cos(self.alpha)
        a, b, cc = c * U[:, 2], s * U[:, 0], s * U[:, 1]
        half = facing_half_width(s, c, np.hypot(U[:, 0], U[:, 1]), -U[:, 2])
        I = np.broadcast_to(self.mean, (len(U), 21)).copy()  # the whole ring faces u: the means
        cut = np.flatnonzero(half < math.pi)
        if cut.size:
            I[cut] = self._arcs(U[cut], half[cut])
        mono = np.stack([a * a, 2 * a * b, 2 * a * cc, b * b, 2 * b * cc, cc * cc], axis=1)  # (B, 6)
        N = np.einsum("bk,bkj->bj", mono, I[:, :18].reshape(-1, 6, 3))
        D = -(a * I[:, 18] + b * I[:, 19] + cc * I[:, 20])
        return N, D

    def _arcs(self, U: NDArray[np.float64], half: NDArray[np.float64]) -> NDArray[np.float64]:
        """Integrals over the facing arcs ψ + π ± h."""
        centre = np.arctan2(U[:, 1], U[:, 0]) + math.pi
        L = self.degree
        out = np.outer(half / math.pi, self.mean)  # mean term: a₀ (φ₂ − φ₁) / 2π
        rows = max(1, _CHUNK // L)
        for start in range(0, len(U), rows):
            part = slice(start, start + rows)
            ends = np.exp(1j * (centre[part] + half[part])), np.exp(1j * (centre[part] - half[part]))
            diff = unit_powers(ends[0], L) - unit_powers(ends[1], L)
            out[part] += np.concatenate([diff.imag, diff.real], axis=1) @ self.coef
        return out


def unit_powers(z: NDArray[np.complex128], L: int) -> NDArray[np.complex128]:
    """z^l for l = 1..L, shape (B, L), by blocks (accurate to a few ulps, vectorised)."""
    hi_count = -(-L // _BLOCK)
    lo = np.cumprod(np.repeat(z[:, None], _BLOCK, axis=1), axis=1)  # z^1..z^BLOCK
    step = lo[:, -1]
    hi = np.empty((len(z), hi_count), dtype=np.complex128)
    hi[:, 0] = 1.0
    if hi_count > 1:
        hi[:, 1:] = np.cumprod(np.repeat(step[:, None], hi_count - 1, axis=1), axis=1)
    out: NDArray[np.complex128] = (hi[:, :, None] * lo[:, None, :]).reshape(len(z), -1)[:, :L]
    return out


def _kernels(alpha: float, W: NDArray[np.float64], flux: Flux, M: int) -> NDArray[np.float64] | None:
    """The 21 kernels sampled at φ_j = 2πj/M, shape (M, 21); None if mᵀWm ≤ 0 somewhere."""
    phi = 2.0 * math.pi * np.arange(M) / M
    s, c = math.sin(alpha), math.cos(alpha)
    cos, sin = np.cos(phi), np.sin(phi)
    m = np.column_stack([s * cos, s * sin, np.full(M, c)])
    q = np.einsum("kd,de,ke->k", m, W, m)
    if not np.all(q > DEGENERATE * np.trace(W)):
        return None
    gamma, delta = kernel_powers(flux)
    num = m / (q**gamma)[:, None]
    den = q**-delta
    mono = np.column_stack([np.ones(M), cos, sin, cos * cos, cos * sin, sin * sin])
    return np.concatenate([(mono[:, :, None] * num[:, None, :]).reshape(M, 18), mono[:, :3] * den[:, None]], axis=1)


@functools.lru_cache(maxsize=16)
def _cached(alpha: float, W_bytes: bytes, flux: Flux) -> RingExpansion | None:
    W = np.frombuffer(W_bytes).reshape(3, 3)
    M = 64
    while M // 2 <= _MAX_DEGREE:
        samples = _kernels(alpha, W, flux, M)
        if samples is None:
            return None
        F = np.fft.rfft(samples, axis=0) / M  # F[l] = (a_l − i b_l)/2 for l ≥ 1, F[0] = a₀
        scale = np.abs(F[0]).max() + np.abs(F[1:]).max()
        tail = float(np.abs(F[3 * M // 8 :]).max() / scale)
        if tail <= _TAIL:
            L = int(np.max(np.flatnonzero(np.abs(F).max(axis=1) > _TAIL * scale)))
            L = max(L, 1)
            l = np.arange(1, L + 1)[:, None]
            # ∫ (a cos lφ + b sin lφ) dφ/2π = (a sin lφ − b cos lφ) / (2π l)
            # = Im[(a − i b) e^{ilφ}] / (2π l) … written on e^{ilφ} = cos + i sin:
            ab = 2.0 * F[1 : L + 1]  # a_l − i b_l
            coef = np.concatenate([ab.real / l, ab.imag / l], axis=0) / (2.0 * math.pi)
            return RingExpansion(alpha, F[0].real.copy(), coef, L, tail)
        M *= 2
    return None


def ring_expansion(alpha: float, W: NDArray[np.float64], flux: Flux) -> RingExpansion | None:
    """The cached :class:`RingExpansion` of a cone of tilt ``alpha`` for Delassus matrix ``W`` (3, 3).

    Returns None when the kernels are not smooth enough for a series of degree
    ≤ 1024 to reach rounding accuracy (W nearly singular on the ring, or facets
    with mᵀWm = 0): the caller then uses adaptive quadrature.
    """
    return _cached(float(alpha), np.ascontiguousarray(W, dtype=float).tobytes(), flux)


class Ring(Averaging):
    """A cone of facets at a fixed W by its ring expansion: exact to rounding, O(degree) work per
    truncated velocity after a one-off FFT (cached per (α, W, flux)); ``nodes`` on the result
    counts the Fourier terms. Declines kernels too peaked for a series of degree ≤ 1024.

    Attributes
    ----------
    min_rows : int
        ``"auto"`` uses the expansion for batches of at least this many velocities.
    """

    name: ClassVar[str] = "ring"
    min_rows: ClassVar[int] = 32

    def supports(self, spec: AveragingSpec) -> bool:
        return super().supports(spec) and getattr(spec.roughness, "alpha", 0.0) > 0.0

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        return spec.nodes is None and len(U) >= self.min_rows

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        ring = ring_expansion(spec.roughness.alpha, W, spec.flux)  # type: ignore[attr-defined]
        if ring is None:
            return None
        bound = (ring.tail + EPS) * ring.degree  # truncation plus the rounding of `degree` terms
        N, D = ring.integrals(U)
        return ContactImpulses(quotient(spec, N, D, U), np.full(len(U), bound), 2 * ring.degree + 1, self.name)

    def reason(self, spec: AveragingSpec) -> str:
        return "the ring's kernels are too peaked for a series of degree ≤ 1024 (a nearly singular W); use 'graded'"

    def cone_step(self, spec: AveragingSpec) -> int | None:
        return SKIP if self.min_rows > 1 else None  # a series for batches

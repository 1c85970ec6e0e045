"""(2.8) for an isotropic tilt density at a fixed Delassus matrix, tabulated in the incidence.

For facets m(α, φ) = (sin α cos φ, sin α sin φ, cos α) with tilt density p(α) and
uniform azimuth, and a unit contact velocity u of incidence β and azimuth ψ
(local frame), write mᵀu = b cos θ − a with θ = φ − ψ, a = cos α cos β,
b = sin α sin β. The kernels of (2.8) at fixed W,

    g_j(α, φ) = m_j / (mᵀWm)^γ  (j = 0, 1, 2),     g_3(α, φ) = (mᵀWm)^(−δ),

((γ, δ) of :func:`mbimpact.averaging.integrand.kernel_powers`: (1, 0) for the
physical flux, (3/2, 1/2) for the configuration flux) have
Fourier series Σ_l G_jl(α) e^{ilφ}. The facing set {b cos θ < a} is symmetric in
θ, so its integrals against e^{ilθ} are closed forms K_l(α, β) (real, even in l), and

    N_j(u) = Σ_l e^{ilψ} H_jl(β),     H_jl(β) = ∫ p(α) G_jl(α) K_l(α, β) dα,

and likewise D(u) with K'_l. The functions H_jl depend on the incidence β only:
they are tabulated once per (measure, W) as Chebyshev series in τ, β = β_h + τ²,
where β_h = π/2 − α_max is the incidence below which no facet is hidden (there the
α-integral is a closed form in cos β, sin β). A support that starts at α_min > 0
adds a second kink at β_l = π/2 − α_min, beyond which every ring is cut; H behaves
like (β − β_l)^{5/2} there, so a second series in σ, β = β_l + σ², covers
[β_l, π/2]. Each velocity of a batch then costs one Chebyshev evaluation and one
Fourier sum in ψ.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import DEGENERATE, EPS, facing_half_width
from ..quadrature.rules import gauss_legendre
from ..results.impact import ContactImpulses
from .base import Averaging
from .integrand import AveragingSpec, Flux, in_blocks, kernel_powers, quotient
from .laplace import Laplace
from .ring import unit_powers

if TYPE_CHECKING:
    from ..roughness.slopes import IsotropicSlopes

__all__ = ["TiltTableMethod", "TiltTable", "tilt_table"]

# Accept a series when its tail is below this fraction of its size; beyond the
# limits the measure is too rough for a table and the law uses its quadrature.
_TAIL = 1e-14
# The series in the incidence is fitted to sampled H_jl, sums of 1e4–1e6 kernel values whose
# rounding leaves a floor near 1e-14 in its coefficients on a strongly anisotropic W: accept
# a tail a little above it (the error estimate carries the tail).
_TAIL_CHEBYSHEV = 5e-14
_MAX_FOURIER = 2048
_MAX_CHEBYSHEV = 512
# Gauss–Legendre nodes in tilt on each side of α* = π/2 − β: the first count whose
# moments agree with twice as many to _TAIL (a W with a small eigenvalue inside the
# support makes the kernels peak in tilt as well as in azimuth), doubled for safety.
_MIN_TILT_NODES, _MAX_TILT_NODES = 32, 1024
# Kernel samples (β nodes × tilt nodes × azimuth samples) a table may cost to build: at
# least _BUDGET (~2 s), and more for a larger batch, _BUDGET_PER_ROW a velocity. A sample
# costs ~0.15 µs; the quadrature that a refused table leaves costs 10–75 ms a velocity on
# a strongly anisotropic W (2–5e5 samples), so a table is built whenever it costs no
# more: peaked kernels (cond W ~ 1e3: 1–1.5e8 samples, 10–20 s) are tabulated for
# batches of ~1000 rows and more, and then cost microseconds a row.
_BUDGET = 2e7
_BUDGET_PER_ROW = 2e5
# Kernel samples that cost what the Laplace reduction spends on a velocity beyond a table's lookup (~4 µs at
# ~0.15 µs a sample): where it applies, a table is built once the velocities averaged at its W cost the
# reduction what the table is found to cost at the least. A build stopped by that budget is tried again
# once the budget has doubled: what failed builds waste stays within what the rows cost the reduction
_LAPLACE_ROW = 30.0


@dataclass(frozen=True, eq=False)
class TiltTable:
    """Chebyshev tables of H_jl(β) for one isotropic measure and one W.

    Attributes
    ----------
    beta_h : float
        Incidence below which every facet faces u (π/2 − α_max).
    moments : ndarray, shape (4, 3, 5)
        For β ≤ β_h: ∫ p G_jl (cos²α, sin²α, sin α cos α, cos α, sin α) dα for l = 0, 1, 2.
    pieces : tuple of (beta0, tau_max, cheb)
        One series per interval of β between the kinks: β = β₀ + τ², τ ∈ [0, τ_max],
        and ``cheb`` (D, 4, L + 1), complex, the Chebyshev coefficients of H_jl in
        x ∈ [−1, 1], τ = τ_max (x + 1) / 2.
    tail : float
        Largest relative coefficient dropped (Fourier in φ, Chebyshev in τ).
    """

    beta_h: float
    moments: NDArray[np.complex128]
    pieces: tuple[tuple[float, float, NDArray[np.complex128]], ...]
    tail: float

    @property
    def degree(self) -> int:
        """Fourier degree L in the azimuth."""
        return self.pieces[0][2].shape[2] - 1

    @property
    def terms(self) -> int:
        """Chebyshev terms of the longest series (their rounding adds up)."""
        return max(cheb.shape[0] for _, _, cheb in self.pieces)

    def integrals(self, U: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """N (B, 3) and D (B,) of (2.8) for unit local-frame velocities U (B, 3), U[:, 2] < 0."""
        ut = np.hypot(U[:, 0], U[:, 1])
        beta = np.arctan2(ut, -U[:, 2])
        H = np.empty((len(U), 4, self.degree + 1), dtype=complex)
        low = beta <= self.beta_h
        if low.any():
            H[low] = self._full(beta[low])
        for k, (beta0, tau_max, cheb) in enumerate(self.pieces):
            rows = ~low & (beta >= beta0)
            if k + 1 < len(self.pieces):
                rows &= beta < self.pieces[k + 1][0]
            if rows.any():
                x = 2.0 * np.sqrt(beta[rows] - beta0) / tau_max - 1.0
                T = _chebyshev_basis(np.clip(x, -1.0, 1.0), cheb.shape[0])
                flat = cheb.reshape(cheb.shape[0], -1)
                H[rows] = ((T @ flat.real) + 1j * (T @ flat.imag)).reshape(-1, 4, self.degree + 1)
        # N_j = H_j0 + 2 Re Σ_{l ≥ 1} e^{ilψ} H_jl
        psi = np.arctan2(U[:, 1], U[:, 0])
        total = H[:, :, 0].real.copy()
        if self.degree:
            total += 2.0 * np.einsum("bl,bjl->bj", unit_powers(np.exp(1j * psi), self.degree), H[:, :, 1:]).real
        return total[:, :3], total[:, 3]

    def _full(self, beta: NDArray[np.float64]) -> NDArray[np.complex128]:
        """H_jl for incidences at which every facet faces u: l = 0, 1, 2 only."""
        cb, sb = np.cos(beta), np.sin(beta)
        mo = self.moments  # (4, 3, 5): c², s², sc, c, s
        H = np.zeros((len(beta), 4, self.degree + 1), dtype=complex)
        # numerator kernels: K_0 = a² + b²/2, K_1 = −ab, K_2 = b²/4 (a = c cos β, b = s sin β)
        H[:, :3, 0] = cb[:, None] ** 2 * mo[None, :3, 0, 0] + 0.5 * sb[:, None] ** 2 * mo[None, :3, 0, 1]
        if self.degree >= 1:
            H[:, :3, 1] = -(cb * sb)[:, None] * mo[None, :3, 1, 2]
            # denominator kernel: K'_0 = a, K'_1 = −b/2
            H[:, 3, 1] = -0.5 * sb * mo[3, 1, 4]
        if self.degree >= 2:
            H[:, :3, 2] = 0.25 * sb[:, None] ** 2 * mo[None, :3, 2, 1]
        H[:, 3, 0] = cb * mo[3, 0, 3]
        return H


def _chebyshev_basis(x: NDArray[np.float64], D: int) -> NDArray[np.float64]:
    """T_0 … T_{D−1} at x, shape (len(x), D), by the three-term recurrence."""
    T = np.empty((len(x), D))
    T[:, 0] = 1.0
    if D > 1:
        T[:, 1] = x
    for k in range(2, D):
        T[:, k] = 2.0 * x * T[:, k - 1] - T[:, k - 2]
    return T


def _arc_weights(theta0: NDArray[np.float64], L: int) -> tuple[NDArray[np.float64], ...]:
    """E_l[1], E_l[cos θ], E_l[cos² θ] over the facing set (θ0, 2π − θ0) / 2π, l = 0..L."""
    m = np.arange(0, L + 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        Jm = np.where(m == 0, (math.pi - theta0[..., None]) / math.pi,
                      -np.sin(m * theta0[..., None]) / (math.pi * np.where(m == 0, 1, m)))
    J = lambda k: Jm[..., np.abs(k)]  # noqa: E731 — J_{−m} = J_m
    l = np.arange(L + 1)
    e0 = J(l)
    e1 = 0.5 * (J(l - 1) + J(l + 1))
    e2 = 0.25 * (J(l - 2) + 2.0 * J(l) + J(l + 2))
    return e0, e1, e2


def _fourier(alpha: NDArray[np.float64], W: NDArray[np.float64], flux: Flux, M: int) -> NDArray[np.complex128] | None:
    """G_jl(α) for l = 0 … M/2 at the tilts ``alpha`` (A,), shape (A, 4, M/2 + 1); None if mᵀWm ≤ 0."""
    phi = 2.0 * math.pi * np.arange(M) / M
    s, c = np.sin(alpha)[:, None], np.cos(alpha)[:, None]
    m = np.stack([s * np.cos(phi), s * np.sin(phi), np.broadcast_to(c, (len(alpha), M))], axis=-1)  # (A, M, 3)
    q = np.einsum("amd,de,ame->am", m, W, m)
    if not np.all(q > DEGENERATE * np.trace(W)):
        return None
    gamma, delta = kernel_powers(flux)
    g = np.concatenate([m / (q**gamma)[..., None], (q**-delta)[..., None]], axis=-1)  # (A, M, 4)
    # G_jl = (1/M) Σ_k g(φ_k) e^{−ilφ_k}: the coefficient of e^{ilφ}
    return np.moveaxis(np.fft.rfft(g, axis=1) / M, 1, 2)


def _tilt_nodes(lo: float, hi: float, a_star: float, n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """n tilt nodes and weights on [lo, α*] (full rings) and n on [α*, hi] (cut rings,
    α = α* + t², also when α* < lo: the onset (α − α*)^{3/2} then lies just outside)."""
    x, w = gauss_legendre(n)
    a = min(max(a_star, lo), hi)
    full = lo + (a - lo) * (x + 1) / 2, (a - lo) / 2 * w
    origin = min(a_star, a)
    t0, t1 = math.sqrt(a - origin), math.sqrt(hi - origin)
    t = t0 + (t1 - t0) * (x + 1) / 2
    cut = origin + t * t, (t1 - t0) / 2 * w * 2 * t
    return np.concatenate([full[0], cut[0]]), np.concatenate([full[1], cut[1]])


def _H(beta: float, rough: IsotropicSlopes, W: NDArray[np.float64], flux: Flux, M: int, n: int
       ) -> tuple[NDArray[np.complex128], float] | None:
    """H_jl(β) for l = 0 … M/2 by Gauss–Legendre in the tilt (n nodes a side), split at α* = π/2 − β."""
    lo, hi = rough.support
    alpha, dalpha = _tilt_nodes(lo, hi, math.pi / 2 - beta, n)
    G = _fourier(alpha, W, flux, M)
    if G is None:
        return None
    L = M // 2
    a = np.cos(alpha) * math.cos(beta)
    b = np.sin(alpha) * math.sin(beta)
    theta0 = math.pi - facing_half_width(np.sin(alpha), np.cos(alpha), math.sin(beta), math.cos(beta))
    e0, e1, e2 = _arc_weights(theta0, L)
    K_num = a[:, None] ** 2 * e0 - 2 * (a * b)[:, None] * e1 + b[:, None] ** 2 * e2  # (A, L + 1)
    K_den = a[:, None] * e0 - b[:, None] * e1
    weight = rough.density(alpha) * dalpha
    H = np.empty((4, L + 1), dtype=complex)
    H[:3] = np.einsum("a,ajl,al->jl", weight, G[:, :3], K_num)
    H[3] = np.einsum("a,al,al->l", weight, G[:, 3], K_den)
    tail = float(np.abs(G[:, :, 3 * L // 4 :]).max() / np.abs(G[:, :, 0]).max())
    return H, tail


def _build(rough: IsotropicSlopes, W: NDArray[np.float64], flux: Flux, budget: float = _BUDGET,
           series_budget: float | None = None, retry: float = 1.0) -> tuple[TiltTable | None, float]:
    """The table, or None where it is too rough, would cost more than ``budget`` kernel samples at the
    least, or its series more than ``series_budget`` (default: ``budget``); and what a later budget must
    reach for a refused table to be tried again: the least it costs, or ``retry`` times this budget where
    the series ran out of it (inf where it can never be built)."""
    lo, hi = rough.support
    # Fourier degree in φ: enough for the sharpest ring of the support
    probe = np.linspace(lo, hi, 65)
    M = 64
    while True:
        G = _fourier(probe, W, flux, M)
        if G is None:
            return None, math.inf
        if np.all(np.abs(G[:, :, 3 * M // 8 :]).max(axis=(1, 2)) <= _TAIL * np.abs(G).max(axis=(1, 2))):
            break
        M *= 2
        if M // 2 > _MAX_FOURIER:
            return None, math.inf
        if 33 * 4 * _MIN_TILT_NODES * M > budget:  # the least a series costs
            return None, 33 * 4 * _MIN_TILT_NODES * M
    # moments for β ≤ β_h (all rings full): l = 0, 1, 2; they also fix the tilt node count
    def moments_with(n: int) -> NDArray[np.complex128] | None:
        x, w = gauss_legendre(n)
        alpha = lo + (hi - lo) * (x + 1) / 2
        weight = rough.density(alpha) * (hi - lo) / 2 * w
        Gm = _fourier(alpha, W, flux, M)
        if Gm is None:
            return None
        c, s = np.cos(alpha), np.sin(alpha)
        basis = np.stack([c * c, s * s, s * c, c, s], axis=1)  # (A, 5)
        return np.einsum("a,ajl,ak->jlk", weight, Gm[:, :, :3], basis)

    n = _MIN_TILT_NODES
    coarse = moments_with(n)
    while True:
        moments = moments_with(2 * n)
        if coarse is None or moments is None:
            return None, math.inf
        if np.abs(moments - coarse).max() <= _TAIL * np.abs(moments).max():
            break
        n, coarse = 2 * n, moments
        if 2 * n > _MAX_TILT_NODES:
            return None, math.inf
    n_tilt = 2 * n
    beta_h = math.pi / 2 - hi
    ends = [beta_h, math.pi / 2 - lo, math.pi / 2] if lo > 0.0 else [beta_h, math.pi / 2]
    # what its series cost at the least: the second level of each (65 incidences), seldom fewer
    least = (len(ends) - 1) * 65 * 2 * n_tilt * M
    if least > budget:
        return None, least
    left = [budget if series_budget is None else series_budget]  # kernel samples left for all the pieces
    pieces, tail = [], 0.0
    for beta0, beta1 in zip(ends[:-1], ends[1:]):
        piece = _series(rough, W, flux, M, n_tilt, beta0, math.sqrt(beta1 - beta0), left)
        if piece is None:
            # too rough, or more than allowed
            return None, math.inf if left[0] >= 0 else max(least, retry * budget, budget + 1.0)
        pieces.append(piece[0])
        tail = max(tail, piece[1])
    # keep the azimuthal terms that matter in any piece, the same L for all
    scale = max(float(np.abs(cheb).max()) for _, _, cheb in pieces)
    L = max(2, max(int(np.flatnonzero((np.abs(cheb) > 0.1 * _TAIL * scale).any(axis=(0, 1))).max())
                   for _, _, cheb in pieces))
    return TiltTable(beta_h, moments, tuple((b, t, np.ascontiguousarray(c[:, :, : L + 1])) for b, t, c in pieces),
                     tail), least


def _series(rough: IsotropicSlopes, W: NDArray[np.float64], flux: Flux, M: int, n_tilt: int, beta0: float,
            tau_max: float, budget: list[float]) -> tuple[tuple[float, float, NDArray[np.complex128]], float] | None:
    """Chebyshev series of H_jl(β₀ + τ²) on τ ∈ [0, τ_max], refined until its tail is below
    _TAIL_CHEBYSHEV; None past _MAX_CHEBYSHEV or past the kernel-sample ``budget`` (decremented)."""
    # Chebyshev points of the second kind, x_k = cos(πk/N): doubling N reuses every value
    N = 32
    values: dict[int, NDArray[np.complex128]] = {}  # by k at resolution _MAX_CHEBYSHEV
    tail_f = 0.0
    while N <= _MAX_CHEBYSHEV:
        stride = _MAX_CHEBYSHEV // N
        new = [k for k in range(N + 1) if k * stride not in values]
        budget[0] -= len(new) * 2 * n_tilt * M
        if budget[0] < 0:
            return None  # too rough a table to be worth building: the product rule takes over
        for k in new:
            tau = tau_max * (math.cos(math.pi * k / N) + 1) / 2
            out = _H(beta0 + tau * tau, rough, W, flux, M, n_tilt)
            if out is None:
                return None
            values[k * stride], tail_f = out[0], max(tail_f, out[1])
        V = np.array([values[k * stride] for k in range(N + 1)], dtype=np.complex128)  # (N + 1, 4, L + 1)
        # coefficients by the DCT-I on those points (end terms halved)
        idx = np.arange(N + 1)
        T = np.cos(np.pi * np.outer(idx, idx) / N)
        V_half = V.copy()
        V_half[0] /= 2
        V_half[-1] /= 2
        coef = np.asarray((2.0 / N) * np.tensordot(T, V_half, axes=1), dtype=np.complex128)
        coef[0] /= 2
        coef[-1] /= 2
        scale = np.abs(coef).max()
        tail_c = float(np.abs(coef[3 * N // 4 :]).max() / scale)
        if tail_c <= _TAIL_CHEBYSHEV:
            Dk = int(np.flatnonzero((np.abs(coef) > 0.1 * _TAIL * scale).any(axis=(1, 2))).max()) + 1
            return (beta0, tau_max, coef[:Dk]), max(tail_f, tail_c)
        N *= 2
    return None


# The last few tables (or refusals, with the budget they were refused under), by (measure,
# W, flux): a batch is split into blocks of rows that share W, and a table is worth
# building once per batch only; a larger batch may retry what a smaller one refused.
_CACHE: OrderedDict[tuple[int, bytes, str], tuple[IsotropicSlopes, TiltTable | None, float, float]] = OrderedDict()
_CACHE_SIZE = 8
_LOCK = threading.Lock()


# Velocities averaged so far at the last few (measure, W, flux) without a table (TiltTableMethod.worthwhile)
_SEEN: OrderedDict[tuple[int, bytes, str], tuple[object, int]] = OrderedDict()


def _count_rows(rough: object, W: NDArray[np.float64], flux: Flux, rows: int) -> int:
    """The velocities averaged at (measure, W, flux) so far, ``rows`` more included."""
    key = (id(rough), np.ascontiguousarray(W, dtype=float).tobytes(), str(flux))
    with _LOCK:
        seen = _SEEN.get(key)
        total = rows + (seen[1] if seen is not None and seen[0] is rough else 0)
        _SEEN[key] = (rough, total)  # the measure is kept alive, so its id stays unique
        _SEEN.move_to_end(key)
        while len(_SEEN) > _CACHE_SIZE:
            _SEEN.popitem(last=False)
    return total


def tilt_table(rough: IsotropicSlopes, W: NDArray[np.float64], flux: Flux, build: bool = True, rows: int = 0,
               budget: float | None = None) -> TiltTable | None:
    """The cached :class:`TiltTable` of a spatial isotropic measure for Delassus matrix ``W`` (3, 3).

    Parameters
    ----------
    rough : IsotropicSlopes
        A spatial isotropic tilt density.
    W : ndarray, shape (3, 3)
        The Delassus matrix in the local contact frame.
    flux : str
        The facet weight of (2.7)–(2.8).
    build : bool
        With False only a table already built is returned (a small block of a batch
        reuses it but does not pay for one).
    rows : int
        Velocities the table will serve: a larger batch affords a costlier table (the
        peaked kernels of a strongly anisotropic W need finer series).
    budget : float, optional
        Instead: the kernel samples the table may cost at the least (its series then get four
        times that); a table refused is tried again once the budget reaches what it was found to
        cost at the least.

    Returns
    -------
    TiltTable or None
        None when the kernels are too peaked (nearly singular W) for series within
        the limits and the budget of ``rows``: the law then uses its quadrature.
    """
    if not build and not _CACHE:  # no table was ever built (single impacts): nothing to look up
        return None
    W = np.ascontiguousarray(W, dtype=float)
    key = (id(rough), W.tobytes(), str(flux))
    least = budget is not None  # the budget bounds the series' whole cost as well
    budget = max(_BUDGET, _BUDGET_PER_ROW * rows) if budget is None else budget
    with _LOCK:
        hit = _CACHE.get(key)
        # a table; or a refusal under a budget at least this one, or short of what the refused table was
        # found to cost at the least
        if hit is not None and hit[0] is rough and (hit[1] is not None or hit[2] >= budget or hit[3] > budget
                                                     or not build):
            _CACHE.move_to_end(key)
            return hit[1]
    if not build:
        return None
    table, cost = _build(rough, W, flux, budget, budget, retry=2.0 if least else 1.0)
    with _LOCK:
        _CACHE[key] = (rough, table, budget, cost)  # the measure is kept alive, so its id stays unique
        _CACHE.move_to_end(key)
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.popitem(last=False)
    return table


class TiltTableMethod(Averaging):
    """A spatial isotropic tilt density at a fixed W by its table in the incidence: built once
    per (measure, W, flux) in 0.1–10 s (up to ~1e-3 s a velocity of the batch on a strongly
    anisotropic W), then microseconds per velocity. Declines measures too rough for a table
    within its limits and that budget (a nearly singular W, or a small batch on a strongly
    anisotropic one).

    Attributes
    ----------
    min_rows : int
        ``"auto"`` builds a table for batches of at least this many velocities; smaller
        blocks of the same batch reuse a table already built.
    rows_before_table : int
        Where the Laplace reduction averages the measure (Gaussian slopes, the physical flux:
        :class:`~mbimpact.averaging.Laplace`, exact to rtol at a few microseconds a velocity),
        ``"auto"`` builds a table once the velocities averaged at one W (this batch's included) cost
        the reduction what the table costs at the least: a table pays for its build over many rows,
        and below that the reduction is cheaper.
    """

    name: ClassVar[str] = "tilt-table"
    min_rows: ClassVar[int] = 1024

    def supports(self, spec: AveragingSpec) -> bool:
        return super().supports(spec) and spec.roughness.dim == 3

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        """A table already built for this W, or a batch of at least :attr:`min_rows` rows; where the
        Laplace reduction applies, a table that pays against it (built here, then, at its least cost)."""
        if spec.nodes is not None:
            return False
        rough = spec.roughness
        if tilt_table(rough, W, spec.flux, build=False) is not None:  # type: ignore[arg-type]
            return True
        if len(U) < self.min_rows:
            return False
        if not Laplace().supports(spec):
            return True
        budget = _LAPLACE_ROW * _count_rows(rough, W, spec.flux, len(U))  # what these rows cost the reduction
        return tilt_table(rough, W, spec.flux, rows=len(U), budget=budget) is not None  # type: ignore[arg-type]

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        table = tilt_table(spec.roughness, W, spec.flux, rows=len(U))  # type: ignore[arg-type]
        if table is None:
            return None
        bound = table.tail + EPS * table.terms

        def block(rows: NDArray[np.float64]) -> ContactImpulses:
            N, D = table.integrals(rows)
            return ContactImpulses(quotient(spec, N, D, rows), np.full(len(rows), bound), 2 * table.degree + 1,
                                   self.name)

        return in_blocks(block, U)

    def reason(self, spec: AveragingSpec) -> str:
        return "the measure's kernels are too peaked for a table within its limits (a strongly anisotropic W)"

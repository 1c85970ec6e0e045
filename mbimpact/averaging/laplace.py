"""Gaussian slopes with the physical flux: (2.8) reduced to one integral over τ, in one compiled call.

On a :class:`~mbimpact.GaussianSlopes` measure the two integrals of (2.8), written over the facets'
slopes s (m ∝ (s, 1)), are a Gaussian times polynomials over the half-plane of slopes that face the
velocity (G*), except for the kernel 1/mᵀWm of the facets' Newton impulses. Written as a Laplace
integral, 1/q = ∫₀^∞ e^{−τq} dτ, it leaves Gaussian integrals over a half-plane, which are closed forms
(one erfc each), and a single integral over τ, computed by the trapezoid rule after a
double-exponential map (:mod:`mbimpact.averaging.compiled.laplace`). Where a nearly singular W makes the
kernels peak over slopes as narrow as sqrt(λ₁/λ₃) (a stretched arm), the integrand in τ only decays
more slowly, as e^{−τ q_min}: the cost grows with log(1/q_min), not with the peak's sharpness. A
velocity takes 60–300 evaluations of the closed form, against 10⁴–10⁵ facets for the graded product
rule on the same case, and the rule halves its step until two levels agree to ``rtol``.

It applies to the physical flux only (with the configuration flux the weights keep a factor |s̃| that
has no Gaussian closed form), to Newton facets, and to the spatial measure. It declines, and ``"auto"``
goes on to the product rules, where the slope at which mᵀWm is least is a facet the mechanism cannot
push, or where the levels do not settle.
"""

from __future__ import annotations

import functools
import math
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.compiled import kernel_array
from ..common.threads import over_rows
from ..common.geometry import DEGENERATE
from ..results.impact import ContactImpulses
from ..roughness.slopes import GaussianSlopes, GaussianTiltDensity
from .base import Averaging
from .compiled import LAPLACE
from .compiled.codes import SETTLED
from .integrand import AveragingSpec, general_facets

__all__ = ["Laplace"]


@functools.lru_cache(maxsize=64)
def _sigma(spec: AveragingSpec) -> float | None:
    """The RMS slope of the spec's measure if :class:`Laplace` can average it, else None (a spec is
    compared by identity, and immutable)."""
    rough = spec.roughness
    if not (isinstance(rough, GaussianSlopes) and rough.dim == 3 and spec.flux == "physical"
            and not general_facets(spec)):
        return None
    lo, hi = rough.support
    # the closed form integrates the whole slope plane: the measure's support must not cut the density
    if (type(rough.pdf) is not GaussianTiltDensity or not Laplace.min_sigma <= rough.sigma <= Laplace.max_sigma
            or lo != 0.0 or math.tan(hi) < 10.0 * rough.sigma):
        return None
    return float(rough.sigma)


class Laplace(Averaging):
    """(2.8) on spatial :class:`~mbimpact.GaussianSlopes` with the physical flux and Newton facets: the
    facet average in closed form for each τ of 1/mᵀWm = ∫ e^{−τ mᵀWm} dτ, the τ-integral by a
    double-exponential trapezoid rule halved until two levels agree to ``rtol``; any number of
    velocities. ``result.nodes`` counts the τ nodes of the last level.

    The reported error is the largest of the last level difference, the shift of the answer that the
    rounding of W's entries can make through the least value of mᵀWm, and the rounding of the sums
    (each by the velocity change W P); no level reduces the last two, and where they exceed ``rtol`` the
    estimate says so, as the graded rule's does. Declines where the facet at which mᵀWm is least cannot
    be pushed (mᵀWm ≤ :data:`~mbimpact.common.geometry.DEGENERATE` tr W), where 7 levels do not settle
    (or their differences stop shrinking at rounding above ``rtol``), and for RMS slopes outside
    [:attr:`min_sigma`, :attr:`max_sigma`]. ``nodes`` and ``max_nodes`` do not apply: ``"auto"`` uses it
    for every velocity without a fixed node count, after ``tilt-table``."""

    name: ClassVar[str] = "laplace"
    #: RMS slopes it treats: below, a² = σ⁻⁴ leaves the float range's comfort; above, the measure's
    #: support (tilts below π/2 (1 − 10⁻⁹)) cuts the Gaussian's tail where it still counts.
    min_sigma: ClassVar[float] = 1e-8
    max_sigma: ClassVar[float] = 1e7

    def supports(self, spec: AveragingSpec) -> bool:
        return super().supports(spec) and _sigma(spec) is not None

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        return spec.nodes is None and W.shape == (3, 3)

    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        sigma = _sigma(spec)
        if sigma is None or W.shape != (3, 3) or U.ndim != 2 or U.shape[1] != 3:
            return None
        kernel = LAPLACE.get().laplace_average
        P, error = np.empty(U.shape), np.empty(len(U))  # written by the kernel
        W, U = kernel_array(W), kernel_array(U)
        e, rtol = float(spec.e), float(spec.rtol)
        if len(U) == 1:
            status, nodes = kernel(W, U, sigma, e, rtol, DEGENERATE, P, error)
            return ContactImpulses(P, error, int(nodes), self.name) if status == SETTLED else None
        outcomes: list[tuple[int, int]] = []  # each block's (status, nodes); list.append is atomic

        def rows(a: int, b: int) -> None:
            outcomes.append(kernel(W, U[a:b], sigma, e, rtol, DEGENERATE, P[a:b], error[a:b]))

        over_rows(rows, len(U))  # the rows are independent: on the kernel threads, the GIL released
        if any(status != SETTLED for status, _ in outcomes):
            return None
        return ContactImpulses(P, error, max(int(nodes) for _, nodes in outcomes), self.name)

    def reason(self, spec: AveragingSpec) -> str:
        return ("the Laplace reduction applies to spatial GaussianSlopes (RMS slope within "
                f"[{self.min_sigma:g}, {self.max_sigma:g}]) with the physical flux and Newton facets, and declines "
                "where the facet at which mᵀWm is least cannot be pushed or its levels do not settle to rtol; "
                "use 'graded' or 'adaptive'")

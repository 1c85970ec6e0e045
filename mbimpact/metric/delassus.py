"""The A-metric of the paper (2.1) seen from the contact point: the Delassus matrix.

For a contact point with world-aligned translational Jacobian ``J`` (d, n) the
A-metric normal of a facet with physical unit normal ``m`` is
N_m = A⁻¹ Jᵀ m / √(mᵀ W m) with the Delassus matrix W = J A⁻¹ Jᵀ, and its flux is
(N_m, v) = mᵀ u / √(mᵀ W m) with u = J v (:mod:`mbimpact.theory`, §3). Everything
the impact laws need is therefore one factorisation of A, ``A⁻¹ Jᵀ`` and ``W``. On a
mechanism, :meth:`ContactMetric.from_mechanism` computes the last two with the metric, in one
compiled call on Pinocchio's factor (:mod:`mbimpact.metric.kernels`); on arrays they are
computed on first use. (A single spatial impact of a mechanism builds no metric object: its
compiled route works on the factor directly, :meth:`mbimpact.ImpactLaw.apply_metric` on a
:class:`FactoredMetric`.)
"""

from __future__ import annotations

import functools
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Generic, TypeVar, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.compiled import KernelModule
from ..common.validation import FLOAT64, as_array
from ..errors import NonFiniteError, NotPositiveDefiniteError, ShapeError

if TYPE_CHECKING:
    from ..mechanism.mechanism import Mechanism

__all__ = ["ContactMetric", "FactoredMetric", "spread_bound", "eigen_ratio", "KERNELS"]

#: The compiled core of :meth:`ContactMetric.from_mechanism` (:mod:`mbimpact.metric.kernels`).
KERNELS = KernelModule("mbimpact.metric.kernels")

# Relative asymmetry of A tolerated before it is called non-symmetric.
_SYMMETRY_RTOL = 1e-9

# The largest float: a Delassus matrix, or a bound on it, beyond it has overflowed.
_FMAX = sys.float_info.max

_T = TypeVar("_T")


class _lazy(Generic[_T]):  # noqa: N801 — used as a decorator, like functools.cached_property
    """``functools.cached_property`` without its lock (Python 3.11 takes one on every first access,
    which costs a single impact more than the product it caches): computed on first access, then
    stored in the instance ``__dict__``, which shadows this non-data descriptor from then on.

    Frozen dataclasses may use it: it writes the instance ``__dict__`` directly, not through
    ``__setattr__``. A value the constructor already put in ``__dict__`` is never recomputed.
    """

    def __init__(self, fn: Callable[[Any], _T]) -> None:
        self.fn, self.name, self.__doc__ = fn, fn.__name__, fn.__doc__

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> _lazy[_T]: ...

    @overload
    def __get__(self, obj: object, owner: type | None = None) -> _T: ...

    def __get__(self, obj: object | None, owner: type | None = None) -> _lazy[_T] | _T:
        if obj is None:
            return self
        value = obj.__dict__[self.name] = self.fn(obj)
        return value


@dataclass(frozen=True, eq=False)
class ContactMetric:
    """Mass matrix, contact Jacobian and the Delassus quantities derived from them.

    Attributes
    ----------
    A : ndarray, shape (n, n)
        Symmetric positive definite mass matrix A(q).
    J : ndarray, shape (d, n)
        World-aligned translational contact Jacobian, d = 2 or 3.
    AinvJt : ndarray, shape (n, d)
        A⁻¹ Jᵀ (with the metric on a mechanism, else on first use): maps a contact impulse P to
        Δv = A⁻¹ Jᵀ P.
    W : ndarray, shape (d, d)
        Delassus matrix J A⁻¹ Jᵀ (likewise; exactly symmetric, positive semidefinite); a
        :class:`NonFiniteError` when it overflows.
    """

    A: NDArray[np.float64]
    J: NDArray[np.float64]
    solver: Callable[[NDArray[np.float64]], NDArray[np.float64]] = field(repr=False)

    #: A(q)'s factor (U, D) where a compiled single impact can read it at once (:class:`FactoredMetric`), else None.
    factor = None
    #: Whether the factor and J are the compiled front end's arrays, of the kernels' types (their dispatch is skipped).
    trusted = False

    def __init__(self, A: NDArray[np.float64], J: NDArray[np.float64],
                 solver: Callable[[NDArray[np.float64]], NDArray[np.float64]]) -> None:
        # written out: a frozen dataclass's generated __init__ sets fields through object.__setattr__
        self.__dict__.update(A=A, J=J, solver=solver)

    @classmethod
    def from_arrays(cls, A: ArrayLike, J: ArrayLike) -> ContactMetric:
        """Validate ``A`` and ``J`` and factorise ``A`` once (Cholesky).

        Raises
        ------
        ShapeError, NotPositiveDefiniteError
            Invalid arrays.
        NonFiniteError
            A NaN or infinite entry, or a Delassus matrix J A⁻¹ Jᵀ bound to overflow.
        """
        A = as_array("A", A, 2)
        n = A.shape[0]
        if A.shape != (n, n) or n == 0:
            raise ShapeError(f"A must be a non-empty square matrix, got shape {A.shape}")
        J = as_array("J", J, 2)
        if J.shape[0] not in (2, 3) or J.shape[1] != n:
            raise ShapeError(f"J must have shape (d, {n}) with d = 2 or 3, got {J.shape}")
        scale = float(np.max(np.abs(A)))
        if scale < 0.5 * _FMAX:
            asym = float(np.max(np.abs(A - A.T)))
        else:  # A - Aᵀ would overflow (a RuntimeWarning): in halves, which are exact
            asym = 2.0 * float(np.max(np.abs(0.5 * A - 0.5 * A.T)))
        if asym > _SYMMETRY_RTOL * scale:
            text = f"{asym:.3g}" if math.isfinite(asym) else f"beyond the largest float {_FMAX:.3g}"
            raise NotPositiveDefiniteError(
                f"A is not symmetric: max |A - Aᵀ| = {text} (max |A| = {scale:.3g})"
            )
        # W_ii = J_i A⁻¹ J_iᵀ ≥ |J_i|² / λ_max(A) ≥ max|J|² / (n max|A|): once that bound overflows, so
        # does W; named here, before a law's products of J and A⁻¹ (J Jᵀ, n⁰ᵀ J A⁻¹ Jᵀ n⁰) warn. In floats
        # (they never warn), on J's entries: cheaper than numpy's reductions on a small array
        flat = J.ravel().tolist()
        big = max(max(flat), -min(flat))
        if scale > 0.0 and not (r := big / math.sqrt(n * scale)) * r < _FMAX:
            raise NonFiniteError(
                f"J A⁻¹ Jᵀ overflows: max |J| = {big:.3g} with max |A| = {scale:.3g} (n = {n}) gives a Delassus "
                f"matrix beyond the largest float {_FMAX:.3g}; max |J|² / (n max |A|) must stay below it "
                "(rescale the units of J or A)"
            )
        return cls.from_symmetric(A, J, scale)

    @classmethod
    def from_symmetric(cls, A: NDArray[np.float64], J: NDArray[np.float64], scale: float | None = None
                       ) -> ContactMetric:
        """For a mass matrix known to be symmetric and finite: only positive definiteness is
        checked, by the Cholesky factorisation itself.

        ``scale`` is max |A| when the caller has it at hand (:meth:`from_arrays`); for a positive
        definite A it is the largest diagonal entry.

        Raises
        ------
        NotPositiveDefiniteError
            A is not positive definite (the message gives its smallest eigenvalue).
        """
        if scale is None:
            scale = float(np.max(np.abs(A))) if A.size else 1.0
        if not scale > 0.0:
            raise NotPositiveDefiniteError("A is not positive definite: all its entries are zero")
        # scaled first by 4ᵖ ≈ max|A| (a Cholesky of 1e300·I overflows and of 1e-300·I underflows), then
        # the factor by 2ᵖ: both exact, so the solves equal those by the unscaled factor, and no division
        # by the scale is left to overflow (a RuntimeWarning) where A⁻¹ b exceeds the float range
        p = (math.frexp(scale)[1] - 1) // 2  # max |A| / 4ᵖ in [1, 4); 4ᵖ ≤ 2¹⁰²² is a float
        unit = math.ldexp(1.0, 2 * p)
        try:
            L = np.linalg.cholesky(A / unit)
        except np.linalg.LinAlgError:
            # on A / 4ᵖ, whose entries are below 4: ½(A + Aᵀ) of a huge A overflows
            As = A / unit
            rel = float(np.linalg.eigvalsh(0.5 * (As + As.T))[0])
            lam = rel * unit  # in floats: beyond the float range it is ±inf, without a warning
            text = f"{lam:.6g}" if math.isfinite(lam) else f"{rel:.6g}·4^{p} (beyond the float range)"
            raise NotPositiveDefiniteError(
                f"A is not positive definite: smallest eigenvalue {text} (must be > 0)"
            ) from None
        if p:
            L *= math.ldexp(1.0, p)
        _freeze(A, J)

        def solve(b: NDArray[np.float64]) -> NDArray[np.float64]:
            # LAPACK's solve: an A⁻¹ b beyond the float range comes out as inf, without a warning. For the
            # float64 (n,) and (n, k) right-hand sides of the package, dpotrs itself: what
            # scipy.linalg.cho_solve calls after checks that cost a single impact more (~7 µs) than the solve
            if type(b) is np.ndarray and b.dtype is FLOAT64 and b.ndim in (1, 2) and len(b) == len(L):
                x, info = _cholesky_solver()(L, b, lower=1)
                if not info:
                    return x
            import scipy.linalg  # deferred: the import costs more than most impacts

            return scipy.linalg.cho_solve((L, True), b, check_finite=False)

        return cls(A, J, solve)

    @classmethod
    def from_mechanism(cls, mech: Mechanism, q: NDArray[np.float64], J: NDArray[np.float64]) -> ContactMetric:
        """A(q) by ``pin.crba`` with its sparse Cholesky factor (``pin.cholesky``, what
        ``pin.impulseDynamics`` uses); solves by that factor are backward stable, whereas a
        product with the explicit inverse errs by ~ε cond(A) in every entry.

        Raises
        ------
        NotPositiveDefiniteError
            A(q) is singular (massless links) or not positive definite.
        """
        A, factor = mech.factorise(q)
        if not factor.valid:
            lam = float(np.linalg.eigvalsh(A)[0]) if np.all(np.isfinite(A)) else math.nan
            raise NotPositiveDefiniteError(
                f"the mass matrix of {mech.name} at q is not positive definite (smallest eigenvalue "
                f"{lam:.6g}); its URDF may have massless links or joints without inertia"
            )
        A.setflags(write=False)
        J.setflags(write=False)
        metric = cls(A, J, factor.solve)
        # A⁻¹Jᵀ and W in one compiled call on Pinocchio's factor (what d + 2 Python-level calls cost
        # a single impact several times over); an overflow leaves them to the lazy route, which names it
        U, D = factor.arrays()
        Yt, W, finite = KERNELS.get().delassus(U, D, J)  # any layout: the kernel's signature takes it
        if finite:
            Yt.setflags(write=False)
            W.setflags(write=False)
            metric.__dict__.update(AinvJt=Yt.T, W=W)
        return metric

    def solve(self, b: NDArray[np.float64]) -> NDArray[np.float64]:
        """A⁻¹ b for b of shape (n,) or (n, k)."""
        return self.solver(b)

    @_lazy
    def AinvJt(self) -> NDArray[np.float64]:  # noqa: N802 — the paper's notation
        out = self.solver(self.J.T)  # Jᵀ as a view: its columns are the contiguous rows of J
        out.setflags(write=False)
        return out

    @_lazy
    def W(self) -> NDArray[np.float64]:  # noqa: N802
        # J A⁻¹ Jᵀ of a finite J and A overflows for a large J or a small (or ill-conditioned) A. In floats
        # (they never warn), |W_ij| ≤ n max|J| max|A⁻¹Jᵀ|: below _FMAX / 18 the product cannot overflow
        # and the sum of the |W_ij| stays below half the largest float (cheaper than numpy's errstate)
        Y = self.AinvJt
        bound = len(Y) * max(map(abs, self.J.ravel().tolist())) * max(map(abs, Y.T.ravel().tolist()))
        if bound < _FMAX / 18.0:
            W = self.J.dot(Y)
        else:  # computed without numpy's RuntimeWarning, then named
            with np.errstate(over="ignore", invalid="ignore"):
                W = self.J.dot(Y)
            # a NaN or inf entry makes the sum non-finite, and a sum of |W_ij| below half the largest float
            # bounds W_ij + W_ji below, and every entry of Rᵀ W R, n⁰ᵀ W n⁰ and tr W that the laws compute
            if not sum([abs(x) for x in W.ravel().tolist()]) < 0.5 * _FMAX:
                raise NonFiniteError(
                    f"the Delassus matrix W = J A⁻¹ Jᵀ overflows (max |J| = {float(np.max(np.abs(self.J))):.3g}, "
                    f"max |A| = {float(np.max(np.abs(self.A))):.3g}): the sum of its |W_ij| must stay below half "
                    f"the largest float, {0.5 * _FMAX:.3g} (rescale the units of J or A)"
                )
        # exact symmetry, ½(W + Wᵀ): rounding would otherwise leak into mᵀWm (in floats for d = 3)
        if len(W) == 3:
            (a, b, c), (d, e, f), (g, h, k) = W.tolist()
            b, c, f = 0.5 * (b + d), 0.5 * (c + g), 0.5 * (f + h)
            out = np.array([a, b, c, b, e, f, c, f, k]).reshape(3, 3)
        else:
            out = W + W.T
            out *= 0.5
        out.setflags(write=False)
        return out

    @_lazy
    def range_projector(self) -> NDArray[np.float64] | None:
        """Orthogonal projector onto range(W), or None when W has full rank."""
        W = self.W
        if spread_bound(W) > 1e-12:  # clearly full rank
            return None
        lam, vec = np.linalg.eigh(W)
        keep = lam > 1e-12 * lam[-1]
        return vec[:, keep] @ vec[:, keep].T

    @property
    def d(self) -> int:
        """Dimension of contact space (2 or 3)."""
        return int(self.J.shape[0])

    @property
    def n(self) -> int:
        """Number of generalised velocities."""
        return int(self.A.shape[0])


class FactoredMetric(ContactMetric):
    """The metric of a single impact of a mechanism whose factor A(q) = U D Uᵀ is at hand: a compiled single
    impact reads the factor at once (:meth:`mbimpact.ImpactLaw.apply_metric`); everything else (W, A⁻¹Jᵀ,
    solves, the range projector) comes from ``full()``, the metric made the usual way
    (:meth:`ContactMetric.from_mechanism`, which names a mass matrix that is not positive definite), on
    first access. ``U`` and ``D`` may be views of a workspace that the next impact overwrites: read them
    before it."""

    def __init__(self, A: NDArray[np.float64], J: NDArray[np.float64], U: NDArray[np.float64],
                 D: NDArray[np.float64], full: Callable[[], ContactMetric], trusted: bool = False) -> None:
        A.setflags(write=False)  # a result may keep it
        self.__dict__.update(A=A, J=J, factor=(U, D), trusted=trusted, _full=full)

    @_lazy
    def metric(self) -> ContactMetric:
        """The metric made the usual way."""
        full: ContactMetric = self.__dict__["_full"]()
        return full

    solver = property(lambda self: self.metric.solver)
    AinvJt = property(lambda self: self.metric.AinvJt)
    W = property(lambda self: self.metric.W)
    range_projector = property(lambda self: self.metric.range_projector)


@functools.cache
def _cholesky_solver() -> Callable[..., tuple[NDArray[np.float64], int]]:
    """LAPACK's dpotrs (scipy's), imported on first use: the import costs more than most impacts, and an
    import statement in the solve would cost each of them a few µs."""
    from scipy.linalg.lapack import dpotrs

    return dpotrs


def _freeze(*arrays: NDArray[np.float64]) -> None:
    for a in arrays:
        a.setflags(write=False)


def spread_bound(W: NDArray[np.float64] | list[list[float]]) -> float:
    """A lower bound det W / tr(W)^d of λ_min / λ_max for a positive semidefinite W (d ≤ 3).

    Computed in floats on W / tr W (no over- or underflow whatever the scale of W): for
    2 × 2 and 3 × 3 matrices this is far cheaper than LAPACK. ``W`` may also be given as
    nested lists of floats (``W.tolist()``, on hot paths that already hold them).
    """
    rows = W if isinstance(W, list) else W.tolist()
    if len(rows) == 2:
        (a, b), (c, d) = rows
        tr = 0.0 + a + d
        if not tr > 0.0:
            return 0.0
        return (a / tr) * (d / tr) - (b / tr) * (c / tr)
    (a, b, c), (d, e, f), (g, h, k) = rows
    tr = 0.0 + a + e + k
    if not tr > 0.0:
        return 0.0
    a, b, c, d, e, f, g, h, k = a / tr, b / tr, c / tr, d / tr, e / tr, f / tr, g / tr, h / tr, k / tr
    return a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g)


def eigen_ratio(W: NDArray[np.float64]) -> float:
    """λ_min / λ_max of a symmetric positive semidefinite 3 × 3 matrix, in closed form.

    Smith's trigonometric solution of the characteristic cubic in floats (a few µs
    instead of LAPACK's tens); λ_min carries an absolute error of order ε λ_max where
    the two smaller eigenvalues are apart, up to ~1e-8 λ_max where both are small (a
    nearly rank-1 W): enough to tell a well-conditioned W from a nearly singular one,
    not to tell the rank.
    """
    (a, b, c), (_, d, f), (_, _, g) = rows = W.tolist()
    tr = rows[0][0] + rows[1][1] + rows[2][2]
    if not tr > 0.0:
        return 0.0
    a, b, c, d, f, g = a / tr, b / tr, c / tr, d / tr, f / tr, g / tr  # unit trace: no over- or underflow
    q = (a + d + g) / 3.0
    off = b * b + c * c + f * f
    p = math.sqrt(((a - q) ** 2 + (d - q) ** 2 + (g - q) ** 2 + 2.0 * off) / 6.0)
    if p <= 1e-300 or q <= 0.0:
        return 1.0 if q > 0.0 else 0.0
    a, d, g = (a - q) / p, (d - q) / p, (g - q) / p
    b, c, f = b / p, c / p, f / p
    r = 0.5 * (a * (d * g - f * f) - b * (b * g - f * c) + c * (b * f - d * c))
    phi = math.acos(min(1.0, max(-1.0, r))) / 3.0
    largest = q + 2.0 * p * math.cos(phi)
    smallest = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    return max(smallest, 0.0) / largest

r"""Calibration: fit a law's parameters to an impact table by least squares.

The residual of a table cell is the law's prediction (:mod:`mbimpact.calibration.quantities`)
minus the datum, made dimensionless (ratios as they are, angles in radians, spins as
ωR/V) and multiplied by the column's weight; gaps are skipped. The free parameters
(:mod:`mbimpact.calibration.parameters`) are varied within their bounds by
``scipy.optimize.least_squares`` (trust-region reflective, finite-difference Jacobian),
from several starting points when the problem is not known to be convex — the
template's values and ``starts − 1`` points drawn uniformly in the bounds (seeded) —
and the best is kept.

The finite-difference Jacobian uses a relative step of :data:`DIFF_STEP` (1e-3), far
above the noise of the facet integrators. Standard errors come from the Jacobian J of
the weighted residuals at the optimum:
cov = s² (JᵀJ)⁺ with s² = 2·cost / (m − p) the residual variance (m residuals,
p free parameters). They assume independent errors of equal size in the dimensionless
residuals (the weights say otherwise) and a locally linear model; a parameter on its
bound has no meaningful error (``Fit.at_bound``).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import FitError, ImpactError, ImpactWarning
from ..laws.base import ImpactLaw
from ..laws.rough import RoughLaw
from .bodies import Body, PointMass, as_body
from .parameters import PARAMETERS, family, law_parameters, with_parameters
from .predict import predict
from .quantities import QUANTITIES, residual_scale
from .table import ImpactTable

__all__ = ["Fit", "fit"]

#: The residual given to every cell where the law cannot be evaluated (an error, or NaN).
PENALTY = 10.0
#: Relative step of the finite-difference Jacobian: well above the integrators' noise (≈ 1e-6).
DIFF_STEP = 1e-3
#: Upper bounds of ``starts`` and ``max_nfev``: they keep a typo from turning into days of fitting.
MAX_STARTS = 10_000
MAX_NFEV = 1_000_000
_EPS = float(np.finfo(float).eps)  # least_squares warns on tolerances below it
#: Parameters that make the problem non-convex (several starts by default).
_NONCONVEX = {"sigma", "alpha", "kt", "hc"}


@dataclass(frozen=True, eq=False)
class Fit:
    """The outcome of :func:`fit`.

    Attributes
    ----------
    law : ImpactLaw
        The fitted law.
    label : str
        The family name, or the template's repr.
    params : mapping of str to float
        Every parameter of the law (free and fixed) at the optimum.
    free : tuple of str
        The fitted ones.
    stderr : mapping of str to float
        Standard errors of the free parameters (NaN when the data cannot tell).
    rms : float
        RMS of the dimensionless weighted residuals.
    quantity_rms : mapping of str to float
        RMS of prediction − datum per column, in the column's unit.
    residuals : mapping of str to ndarray, shape (n,)
        prediction − datum per column and row, in the column's unit; NaN at gaps.
    table : ImpactTable
    body : Body
    speed : ndarray, shape (n,)
        The impact speeds the predictions used (m/s).
    at_bound : tuple of str
        Free parameters that ended on a bound.
    cost : float
        ½ Σ r² at the optimum.
    nfev : int
        Residual evaluations, over all starts.
    starts : int
        Starting points tried.
    success : bool
        Whether the best start converged (scipy's ``status > 0``).
    message : str
        scipy's message for the best start.
    warned : bool
        Whether mbimpact warned at the optimum (κ < 0: further micro-impacts; accuracy not reached).
    """

    law: ImpactLaw
    label: str
    params: Mapping[str, float]
    free: tuple[str, ...]
    stderr: Mapping[str, float]
    rms: float
    quantity_rms: Mapping[str, float]
    residuals: Mapping[str, NDArray[np.float64]]
    table: ImpactTable
    body: Body
    speed: NDArray[np.float64]
    at_bound: tuple[str, ...] = ()
    cost: float = 0.0
    nfev: int = 0
    starts: int = 1
    success: bool = True
    message: str = ""
    warned: bool = False
    quantities: tuple[str, ...] = field(default=())

    def predict(self, angles_deg: ArrayLike, speed: float | None = None) -> dict[str, NDArray[np.float64]]:
        """Predictions of the fitted law at incidences ``angles_deg`` (deg) for the fit's body, at ``speed``
        (default: the table's first speed), every column the body can give."""
        v = float(self.speed[0]) if speed is None else speed
        return predict(self.law, angles_deg, self.body, v, quiet=True)

    def summary(self) -> str:
        """Parameters ± errors, then the RMS per column, one line each."""
        lines = [f"{self.label}: rms = {self.rms:.4g} (dimensionless), {self.nfev} evaluations, "
                 f"{self.starts} start(s){'' if self.success else ', NOT CONVERGED: ' + self.message}"]
        for name, value in self.params.items():
            if name in self.free:
                flag = "  (on its bound)" if name in self.at_bound else ""
                lines.append(f"  {name:6s} = {value:.5g} ± {self.stderr[name]:.2g}{flag}")
            else:
                lines.append(f"  {name:6s} = {value:.5g} (fixed)")
        for q, r in self.quantity_rms.items():
            unit = QUANTITIES[q].unit
            lines.append(f"  rms {q} = {r:.4g}{' ' + unit if unit else ''}")
        return "\n".join(lines)


def fit(
    table: ImpactTable,
    law: str | ImpactLaw = "rough-coulomb",
    body: Body | object | None = None,
    free: str | tuple[str, ...] | None = None,
    *,
    fixed: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    quantities: str | tuple[str, ...] | None = None,
    weights: Mapping[str, float] | None = None,
    speed: float | None = None,
    starts: int | None = None,
    seed: int | None = 0,
    max_nfev: int = 50,
    tol: float = 1e-5,
    progress: Callable[[int, int], None] | None = None,
) -> Fit:
    """Fit the parameters of ``law`` to ``table`` by least squares.

    Parameters
    ----------
    table : ImpactTable
    law : str or ImpactLaw
        A family name of :data:`mbimpact.calibration.parameters.FAMILIES` (``"newton"``, ``"coulomb"``,
        ``"rough-newton"``, ``"rough-coulomb"``, ``"compliant"``, ``"rough-compliant"``,
        ``"rough-hunt-crossley"``) or a template law whose values are the first starting point.
    body : Body or Sphere, optional
        What strikes: a :class:`Ball`, a :class:`PointMass`, or an :class:`mbimpact.Sphere` with a
        ``mass`` (taken as a solid ball); default the table's ``body`` metadata, else the contact
        point (:class:`PointMass`).
    free : str or tuple of str, optional
        Parameters to fit (default: all of the law's, :func:`law_parameters`).
    fixed : mapping, optional
        Values for parameters that are not fitted (default: the template's).
    bounds : mapping of str to (lower, upper), optional
        Bounds replacing :data:`mbimpact.calibration.parameters.PARAMETERS`'.
    quantities : str or tuple of str, optional
        Columns to fit (default: all with data).
    weights : mapping of str to float, optional
        Weight of each column's dimensionless residuals (default 1).
    speed : float, optional
        Impact speed (m/s) when the table has no ``speed`` column; needed for ``spin`` and for
        speed-dependent laws.
    starts : int, optional
        Starting points, 1 … :data:`MAX_STARTS` (default: 1 for Newton's and Coulomb's laws, 4 when
        roughness, stiffness ratio or Hunt–Crossley damping is free).
    seed : int or None
        Seed of the random starting points: an integer ≥ 0, or None for fresh entropy.
    max_nfev : int
        Iterations (residual evaluations without the Jacobian's) per start, 1 … :data:`MAX_NFEV`.
    tol : float
        Relative change of the cost and of the parameters at which a start has converged
        (``ftol`` and ``xtol`` of ``least_squares``), in [machine epsilon, 1); the compliant facets'
        integration makes the residuals noisy (~1e-6 to 1e-5 of the predictions), so much tighter
        is pointless.
    progress : callable, optional
        Called as ``progress(done, starts)`` after each starting point has been optimised.

    Returns
    -------
    Fit

    Raises
    ------
    FitError
        Unknown parameters or columns, no data, a body that cannot give a column, no speed
        where one is needed, a ``starts``, ``seed``, ``max_nfev`` or ``tol`` out of its range.
    """
    if not isinstance(table, ImpactTable):
        raise FitError(f"table must be an ImpactTable (ImpactTable.from_csv(path)), got {type(table).__name__}")
    label = law if isinstance(law, str) else repr(law)
    template = family(law) if isinstance(law, str) else law
    if not isinstance(template, ImpactLaw):
        raise FitError(f"law must be a family name or an ImpactLaw, got {law!r}")
    values = law_parameters(template)
    # dict() and .items() of anything but a mapping fail with bare TypeErrors: name the argument instead
    for arg, given, example in (("fixed", fixed, "{'e': 0.8}"), ("bounds", bounds, "{'e': (0.5, 1.0)}"),
                                ("weights", weights, "{'kappa': 2.0}")):
        if given is not None and not isinstance(given, Mapping):
            raise FitError(f"{arg} must be a mapping such as {example}, got {type(given).__name__}")
    if fixed:
        template = with_parameters(template, dict(fixed))
        values = law_parameters(template)
    free = tuple(values) if free is None else _names("free", free)
    unknown = [p for p in free if p not in values]
    if unknown or not free:
        raise FitError(f"free parameters must be some of {', '.join(values)} (those of {template!r}); got {free!r}")
    if fixed and set(fixed) & set(free):
        raise FitError(f"parameters {sorted(set(fixed) & set(free))} are both free and fixed")
    lo, hi = _bounds(free, bounds)
    body = as_body(body) if body is not None else (table.body() or PointMass())
    cols = table.quantities if quantities is None else _names("quantities", quantities)
    missing = [q for q in cols if q not in table.quantities]
    if missing or not cols:
        raise FitError(f"columns {missing or cols} have no data in {table.name}; it has {', '.join(table.quantities)}")
    speeds = _speeds(table, template, cols, speed)
    weight = {q: 1.0 for q in cols} | dict(weights or {})
    if any(isinstance(w, bool) or not isinstance(w, (int, float, np.integer, np.floating))
           or not (w >= 0 and math.isfinite(w)) for w in weight.values()):
        raise FitError(f"weights must be finite numbers ≥ 0, got {dict(weights or {})}")
    # the cells that enter: data present, prediction defined (tangential ratios need θ > 0)
    obs = {q: table.values(q) for q in cols}
    use = {q: ~np.isnan(obs[q]) & ((table.theta_deg > 0) | (q not in ("et", "et_cp"))) for q in cols}
    scale = {q: residual_scale(q, body, speeds) * weight[q] for q in cols}
    m = int(sum(u.sum() for u in use.values()))
    if m == 0:
        raise FitError("no data cells to fit")
    count = [0]

    def build(x: NDArray[np.float64]) -> ImpactLaw:
        return with_parameters(template, dict(zip(free, map(float, x))))

    def residual(x: NDArray[np.float64]) -> NDArray[np.float64]:
        count[0] += 1
        try:
            pred = predict(build(x), table.theta_deg, body, speeds, cols, quiet=True)
        except ImpactError:
            return np.full(m, PENALTY)
        r = np.concatenate([((pred[q] - obs[q]) * scale[q])[use[q]] for q in cols])
        return np.where(np.isfinite(r), r, PENALTY)

    from scipy.optimize import least_squares  # deferred: scipy.optimize costs 0.1 s to import

    x0 = np.clip([values[p] for p in free], lo, hi)
    n_starts = starts if starts is not None else (4 if _NONCONVEX & set(free) else 1)
    n_starts = _count("starts", n_starts, MAX_STARTS)
    # scipy raises bare errors on max_nfev ≤ 0, loops without end on a fractional one, and warns on a tol < ε
    max_nfev = _count("max_nfev", max_nfev, MAX_NFEV)
    if isinstance(tol, bool) or not isinstance(tol, (int, float, np.integer, np.floating)) \
            or not _EPS <= tol < 1.0:
        raise FitError(f"tol must be a number in [{_EPS:.3g}, 1) (machine epsilon to 1), got {tol!r}")
    rng = np.random.default_rng(_seed(seed))
    points = [x0] + [rng.uniform(lo, hi) for _ in range(n_starts - 1)]
    best = None
    for k, point in enumerate(points, 1):
        res = least_squares(residual, point, bounds=(lo, hi), x_scale="jac", diff_step=DIFF_STEP, ftol=tol,
                            xtol=tol, gtol=1e-10, max_nfev=max_nfev)
        if best is None or res.cost < best.cost:
            best = res
        if progress is not None:
            progress(k, len(points))
    assert best is not None
    x = best.x
    fitted = build(x)
    p = len(free)
    J = np.asarray(best.jac, dtype=float)
    if m > p:
        s2 = 2.0 * float(best.cost) / (m - p)
        cov = s2 * np.linalg.pinv(J.T @ J)
        err = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        err = np.where(np.linalg.matrix_rank(J) < p, np.nan, err)
    else:
        err = np.full(p, np.nan)
    span = hi - lo
    at_bound = tuple(n for n, xi, a, b, s in zip(free, x, lo, hi, span) if min(xi - a, b - xi) <= 1e-6 * s)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImpactWarning)
        pred = predict(fitted, table.theta_deg, body, speeds, cols)
    resid = {q: np.where(use[q], pred[q] - obs[q], np.nan) for q in cols}
    q_rms = {q: float(np.sqrt(np.nanmean(resid[q] ** 2))) for q in cols}
    return Fit(
        law=fitted, label=label, params=MappingProxyType(law_parameters(fitted)), free=free,
        stderr=MappingProxyType(dict(zip(free, map(float, err)))), rms=float(np.sqrt(2.0 * best.cost / m)),
        quantity_rms=MappingProxyType(q_rms), residuals=MappingProxyType(resid), table=table, body=body,
        speed=speeds, at_bound=at_bound, cost=float(best.cost), nfev=count[0], starts=len(points),
        success=bool(best.status > 0), message=str(best.message), warned=bool(caught), quantities=cols,
    )


def _names(what: str, value: object) -> tuple[str, ...]:
    """``value`` as a tuple of names: one str is one name (``tuple("mu")`` would split it into letters)."""
    if isinstance(value, str):
        return (value,)
    names: tuple[object, ...] | None = tuple(value) if isinstance(value, Iterable) else None
    if names is None or not all(isinstance(n, str) for n in names):
        raise FitError(f"{what} must be a name or a tuple of names (str), got {value!r}")
    return tuple(str(n) for n in names)


def _count(name: str, value: object, hi: int) -> int:
    """``value`` checked to be an integer in [1, ``hi``] (a bool is not a count)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= hi:
        raise FitError(f"{name} must be an integer in [1, {hi}], got {value!r}")
    return int(value)


def _seed(seed: object) -> int | None:
    """``seed`` checked: numpy's ``default_rng`` raises bare ValueError/TypeError on a negative or non-integer one."""
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise FitError(f"seed must be an integer ≥ 0 (or None for a random one), got {seed!r}")
    return int(seed)


def _bounds(free: tuple[str, ...], given: Mapping[str, tuple[float, float]] | None
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    lo = np.array([PARAMETERS[p].lower for p in free])
    hi = np.array([PARAMETERS[p].upper for p in free])
    for name, pair in (given or {}).items():
        if name not in free:
            raise FitError(f"bounds given for {name!r}, which is not free ({', '.join(free)})")
        try:
            a, b = (float(v) for v in pair)
        except (TypeError, ValueError):
            raise FitError(f"bounds[{name!r}] must be (lower, upper), got {pair!r}") from None
        if not (a < b and math.isfinite(a) and math.isfinite(b)):  # random starts are drawn between them
            raise FitError(f"bounds[{name!r}] must be finite with lower < upper, got {pair!r}")
        i = free.index(name)
        lo[i], hi[i] = a, b
    return lo, hi


def _speeds(table: ImpactTable, law: ImpactLaw, cols: tuple[str, ...], speed: float | None) -> NDArray[np.float64]:
    """Impact speeds per row: the table's, else ``speed``, else 1 m/s where nothing depends on it."""
    if table.speed is not None:
        return table.speed
    if speed is not None:
        if isinstance(speed, bool) or not (isinstance(speed, (int, float)) and speed > 0 and math.isfinite(speed)):
            raise FitError(f"speed must be a positive number of m/s, got {speed!r}")
        return np.full(len(table), float(speed))
    needs = "spin" in cols or (isinstance(law, RoughLaw) and not law.facet.homogeneous)
    if needs:
        raise FitError(f"{table.name} has no speed column, and {'spin' if 'spin' in cols else repr(law)} depends on "
                       "the impact speed: give fit(..., speed=...)")
    return np.ones(len(table))

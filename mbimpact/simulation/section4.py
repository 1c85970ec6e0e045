"""Section 4: a point bouncing on a vibrating rough surface of revolution.

For an isotropic roughness the rough law, linearised about a normal impact,
reduces the tangential velocity by Δv_l = −λ v_l (4.1) and restitutes the
normal one with κ of (4.2) (corrected forms, :mod:`mbimpact.theory`, §8):

    λ = 2(1+e) E[sin²α cos α] / ((d−1) E[cos α]),   1 + κ = (1+e) E[cos³α] / E[cos α].

The periodic bouncing along the axis (period m surface periods) is stable for
0 < ρ⁻¹/B < 1, B = (2−λ)(1+κ) / (2π²m²(1+κ−λ)) (4.3), ρ in units of g/ω²: a cup when
B > 0, a dome when B < 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..common.validation import as_count, as_scalar
from ..errors import IntegrationError, RoughnessError
from ..roughness import Cone, IsotropicSlopes, Roughness

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["Stability", "isotropic_moments", "stability", "Orbit", "periodic_orbit", "orbit_scene", "deviation_run",
           "growth_rate", "stability_map"]


def isotropic_moments(roughness: Roughness) -> tuple[int, Callable[[Callable[[NDArray[np.float64]], NDArray[np.float64]]], float]]:
    """Tangent dimension d − 1 and E[f(α)] over the facet tilts of an isotropic measure.

    Section 4 linearises the law about a normal impact. That needs an isotropic measure:
    with facets (sin α · l, cos α) of weights p, the tangential moments Σ p sin α l and
    Σ p cos²α sin α l must vanish (a normal impact gives no horizontal kick, so the
    periodic motion along the axis exists) and Σ p cos α sin²α l lᵀ must be a multiple of
    the identity (the horizontal response (4.1) is a scalar λ). Cones, sawtooths and tilt
    densities are isotropic by construction; a finite set of facets (or a measured relief)
    is checked.

    Raises
    ------
    RoughnessError
        The measure is not isotropic.
    """
    if isinstance(roughness, Cone):
        a = np.array([roughness.alpha])
        return 2, lambda f: float(f(a)[0])
    if isinstance(roughness, IsotropicSlopes):
        return roughness.dim - 1, roughness.moment
    if not roughness.exact:
        raise RoughnessError(f"{roughness!r} has no known tilt moments for section 4")
    d = roughness.dim or 3
    normal = np.zeros((1, d))
    normal[0, -1] = -1.0
    m, p = roughness.rule_batch(normal, 1)  # at normal incidence no facet is shadowed
    m, p = (m[0], p[0]) if m.ndim == 3 else (m, np.broadcast_to(p, (len(m),)) if p.ndim == 1 else p[0])
    p = p / p.sum()
    t, c = m[:, :-1], m[:, -1]
    scale = float(p @ np.linalg.norm(t, axis=1)) or 1.0
    first = max(float(np.abs(p @ t).max()), float(np.abs((p * c * c) @ t).max()))
    second = (t * (p * c)[:, None]).T @ t
    spread = float(np.abs(second - np.trace(second) / (d - 1) * np.eye(d - 1)).max())
    if first > 1e-9 * scale or spread > 1e-9 * scale:
        raise RoughnessError(
            f"{roughness!r} is not isotropic (tangential moments {first:.3g}, anisotropy {spread:.3g}): "
            "the periodic motion along the axis of section 4 needs an isotropic measure (a cone, a sawtooth, "
            "a tilt density, or facets whose moments Σ p sin α l and Σ p cos²α sin α l vanish and whose "
            "Σ p cos α sin²α l lᵀ is a multiple of the identity)"
        )
    tilt = np.arccos(np.clip(c, -1.0, 1.0))
    return d - 1, lambda f: float(p @ f(tilt))


@dataclass(frozen=True)
class Stability:
    """λ of (4.1), κ of (4.2) and the bound B of (4.3) for the period-m motion along the axis.

    The horizontal deviation is stable iff 0 < λ < 2 and 0 < ρ⁻¹ / B < 1 (ρ in units of
    g/ω²): a cup (ρ > 0) with ρ⁻¹ < B when B > 0, a dome (ρ < 0) with B < ρ⁻¹ when B < 0
    (1 + κ < λ, planar roughness only).
    """

    lam: float
    kappa: float
    B: float

    @property
    def stabilisable(self) -> bool:
        """Some surface curvature (a cup or a dome) stabilises the motion."""
        return 0.0 < self.lam < 2.0 and math.isfinite(self.B) and self.B != 0.0

    @property
    def surface(self) -> str:
        """The shape that stabilises: ``"cup"`` (B > 0), ``"dome"`` (B < 0), or ``"none"``."""
        if not self.stabilisable:
            return "none"
        return "cup" if self.B > 0 else "dome"

    def stable(self, inv_rho: float) -> bool:
        """Whether the motion is stable on a surface of curvature ρ⁻¹ (units of ω²/g): 0 < ρ⁻¹/B < 1."""
        return self.stabilisable and 0.0 < inv_rho / self.B < 1.0

    def growth(self, inv_rho: float, m: int) -> float:
        """ln of the largest |eigenvalue| of the linear 2×2 map over one period of the motion
        (< 0: the deviation decays), for curvature ρ⁻¹ in units of ω²/g."""
        aT = (1.0 + self.kappa - self.lam) * 4.0 * math.pi**2 * m**2 * inv_rho / (1.0 + self.kappa)
        tr, det = 2.0 - self.lam - aT, 1.0 - self.lam
        eig = np.roots([1.0, -tr, det])
        return float(np.log(np.abs(eig).max()))


def stability(roughness: Roughness, e: float, m: int) -> Stability:
    """λ, κ and B for an isotropic roughness, facet restitution e, period ratio m (4.1)–(4.3).

    Raises
    ------
    RoughnessError
        The measure is not isotropic (:func:`isotropic_moments`).
    ParameterError
        e outside [0, 1], m not a positive integer.
    """
    e = as_scalar("e", e, 0.0, 1.0)
    m = as_count("m (period of the motion / period of the surface)", m, 1, 1000)
    dm1, E = isotropic_moments(roughness)
    ec = E(np.cos)
    lam = 2 * (1 + e) * E(lambda a: np.sin(a) ** 2 * np.cos(a)) / (dm1 * ec)
    one_k = (1 + e) * E(lambda a: np.cos(a) ** 3) / ec
    denom = 2 * math.pi**2 * m**2 * (one_k - lam)
    B = (2 - lam) * one_k / denom if denom != 0 else math.inf
    return Stability(lam, one_k - 1, B)


@dataclass(frozen=True)
class Orbit:
    """The vertical period-m bouncing orbit chosen for a simulation (SI units).

    The amplitude is put in the middle of the window where the orbit exists and is
    stable, Γ_min = mπ(1−κ)/(1+κ) < Γ = Aω²/g < sqrt(Γ_min² + (2(1+κ²)/(1+κ)²)²)
    (the bouncing ball on a vibrating table), and the phase is the one at which the
    surface rises and decelerates at impact.
    """

    amplitude: float
    phase: float
    takeoff_speed: float
    gamma: float


def periodic_orbit(kappa: float, m: int, frequency: float, g: float = 9.81) -> Orbit:
    """Amplitude and phase of a stable period-m vertical bouncing for restitution κ."""
    w = 2 * math.pi * frequency
    lo = m * math.pi * (1 - kappa) / (1 + kappa)
    hi = math.hypot(lo, 2 * (1 + kappa**2) / (1 + kappa) ** 2)
    gamma = 0.5 * (lo + hi)
    A = gamma * g / w**2
    V = g * m / frequency / 2
    adot = V * (1 - kappa) / (1 + kappa)
    return Orbit(A, math.acos(adot / (A * w)), V, gamma)


def orbit_scene(roughness: Roughness, e: float, m: int, inv_rho: float, periods: int, x0: float,
                frequency: float = 5.0, max_wall_time: float = 120.0) -> Scene:
    """The point on the vibrating rough surface of revolution, started on the vertical period-m orbit
    with a horizontal offset ``x0`` (m); ``inv_rho`` is ρ⁻¹ in units of ω²/g (< 0: a dome, 0: a plane)."""
    from ..laws.rough import RoughLaw
    from ..mechanism.mechanism import Mechanism
    from .scene import Scene
    from .scene_contacts import SceneContact
    from .surfaces import Surface

    st = stability(roughness, e, m)
    g = 9.81
    orbit = periodic_orbit(st.kappa, m, frequency, g)
    w = 2 * math.pi * frequency
    rho = (g / w**2) / inv_rho if inv_rho != 0 else math.inf  # ρ < 0: a dome
    surface = Surface("paraboloid" if math.isfinite(rho) else "plane", rho=rho, amplitude=orbit.amplitude,
                      frequency=frequency, phase=orbit.phase)
    q0 = np.array([x0, 0.0, 0.0])
    q0[2] = -surface.gap(q0, 0.0)  # on the surface, just after an impact of the orbit
    return Scene(Mechanism.from_model("point_mass_3d"), q0, np.array([0.0, 0.0, orbit.takeoff_speed]),
                 (SceneContact("mass", RoughLaw(roughness, e), surface),), duration=(periods + 0.5) * m / frequency,
                 rtol=1e-11, name="section4", max_wall_time=max_wall_time)


def deviation_run(roughness: Roughness, e: float, m: int, inv_rho: float, periods: int = 30,
                  x0: float = 1e-3, frequency: float = 5.0) -> NDArray[np.float64]:
    """Simulate the point on the vibrating surface of revolution (:func:`orbit_scene`): the
    horizontal offset x at each of the ``periods`` impacts (m).

    Raises
    ------
    IntegrationError
        The simulation did not complete (its status and message are given).
    """
    from .simulator import simulate

    tr = simulate(orbit_scene(roughness, e, m, inv_rho, periods, x0, frequency), samples=10)
    if not tr.completed:
        raise IntegrationError(f"section 4 run at rho^-1 = {inv_rho:g} ended with {tr.status}: {tr.message}")
    times = tr.impact_times()[:periods]
    return np.interp(times, tr.t, tr.q[:, 0])


def growth_rate(x: NDArray[np.float64], linear: float = 1000.0) -> float:
    """ln of the largest |eigenvalue| of the 2×2 map x_{k+1} = tr x_k − det x_{k−1} fitted to a
    sequence of offsets (per period of the motion): < 0 when the deviation decays. Only the
    offsets up to ``linear`` times the first are used (a growing deviation leaves the linear regime)."""
    x = np.asarray(x, dtype=float)
    small = np.flatnonzero(np.abs(x) > linear * abs(x[0]))
    x = x[: max(5, int(small[0])) if small.size else len(x)]
    x = x / float(np.abs(x).max())
    M = np.column_stack([x[1:-1], -x[:-2]])
    (tr, det), *_ = np.linalg.lstsq(M, x[2:], rcond=None)
    return float(np.log(np.abs(np.roots([1.0, -tr, det])).max()))


def _map_point(roughness: Roughness, e: float, m: int, ratio: float, periods: int, x0: float) -> tuple[float, str]:
    """One point of the stability map: the simulated growth rate at ρ⁻¹ = ratio · B, or NaN and why not."""
    from .simulator import simulate

    st = stability(roughness, e, m)
    tr = simulate(orbit_scene(roughness, e, m, ratio * st.B, periods, x0, max_wall_time=60.0), samples=10)
    if not tr.completed:
        return math.nan, f"{tr.status}: {tr.message}"
    x = np.interp(tr.impact_times()[:periods], tr.t, tr.q[:, 0])
    return growth_rate(x), "completed"


def stability_map(cases: list[tuple[Roughness, float, int]], ratios: NDArray[np.float64] | None = None,
                  periods: int = 24, x0: float = 1e-7, executor: object | None = None) -> list[dict[str, Any]]:
    """The stability boundary (4.3) against full simulations.

    For each case (roughness, e, m) and each ρ⁻¹ = ratio · B (ratios from −1.5 to 1.5 by
    default), the growth rate per period of a small horizontal offset, from a simulation of
    ``periods`` periods fitted by the 2×2 map (:func:`growth_rate`), beside the linear theory's
    (:meth:`Stability.growth`). Runs go through :func:`mbimpact.sweep` (``executor``: any
    concurrent.futures Executor); each is bounded in wall time, and one that does not complete
    is reported with its status instead of a rate.

    Returns
    -------
    list of dict
        Per case: ``label``, ``B``, ``ratio`` (n,), ``growth`` (n,) simulated (NaN where the run
        did not complete), ``theory`` (n,), ``status`` (n,) and ``boundary``: the simulated
        ρ⁻¹/B where the growth changes sign (interpolated; ≈ 1 when (4.3) holds, also ≈ 0).
    """
    from .sweep import sweep

    ratios = np.linspace(-1.5, 1.5, 13) if ratios is None else np.asarray(ratios, dtype=float)
    jobs = [(rough, e, m, float(r), periods, x0) for rough, e, m in cases for r in ratios]
    results = sweep(_map_point, jobs, executor)  # type: ignore[arg-type]
    out = []
    for k, (rough, e, m) in enumerate(cases):
        st = stability(rough, e, m)
        part = results[k * len(ratios):(k + 1) * len(ratios)]
        growth = np.array([g for g, _ in part])
        theory = np.array([st.growth(r * st.B, m) for r in ratios])
        signs = np.flatnonzero(np.diff(np.sign(growth)) != 0)
        crossings = [ratios[i] - growth[i] * (ratios[i + 1] - ratios[i]) / (growth[i + 1] - growth[i]) for i in signs
                     if np.isfinite(growth[i]) and np.isfinite(growth[i + 1])]
        out.append({"label": f"{rough!r}, e={e:g}, m={m}", "B": st.B, "ratio": ratios, "growth": growth,
                    "theory": theory, "status": [s for _, s in part], "boundary": np.array(crossings)})
    return out

"""Section 4: a point bouncing on a vibrating rough surface of revolution.

For an isotropic roughness the rough law, linearised about a normal impact,
reduces the tangential velocity by Δv_l = −λ v_l (4.1) and restitutes the
normal one with κ of (4.2) (corrected forms, THEORY §9):

    λ = 2(1+e) E[sin²α cos α] / ((d−1) E[cos α]),   1 + κ = (1+e) E[cos³α] / E[cos α].

The periodic bouncing along the axis (period m surface periods) is stable for
0 < ρ⁻¹ < B = (2−λ)(1+κ) / (2π²m²(1+κ−λ)) (4.3), ρ in units of g/ω².
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..common.validation import as_scalar
from ..errors import ParameterError, RoughnessError
from ..roughness import Cone, Facets, Roughness, Sawtooth, Smooth
from ..roughness.slopes import IsotropicSlopes

__all__ = ["Stability", "tilt_moments", "stability", "Orbit", "periodic_orbit", "deviation_run", "deviation_grows", "stability_map"]


def tilt_moments(roughness: Roughness) -> tuple[int, Callable[[Callable[[np.ndarray], np.ndarray]], float]]:
    """Tangent dimension d − 1 and E[·] over the facet tilts of an isotropic measure."""
    if isinstance(roughness, Smooth):
        return 2, lambda f: float(f(np.zeros(1))[0])
    if isinstance(roughness, (Cone, Sawtooth)):
        a = np.array([roughness.alpha])
        return (2 if isinstance(roughness, Cone) else 1), lambda f: float(f(a)[0])
    if isinstance(roughness, IsotropicSlopes):
        return roughness.dim - 1, roughness.moment
    if isinstance(roughness, Facets):
        m = roughness.normals
        tilt = np.arccos(np.clip(m[:, -1], -1.0, 1.0))
        w = roughness.weights
        return m.shape[1] - 1, lambda f: float(w @ f(tilt))
    raise RoughnessError(f"{roughness!r} is not an isotropic measure with known tilts")


@dataclass(frozen=True)
class Stability:
    """λ of (4.1), κ of (4.2) and the bound B of (4.3); ``stabilisable`` is B > 0."""

    lam: float
    kappa: float
    B: float

    @property
    def stabilisable(self) -> bool:
        """Some surface curvature stabilises the motion (false when 1 + κ < λ ≤ 2)."""
        return self.B > 0

    def stable(self, inv_rho: float) -> bool:
        """Whether 0 < ρ⁻¹ < B (ρ in units of g/ω²)."""
        return 0.0 < inv_rho < self.B


def stability(roughness: Roughness, e: float, m: int) -> Stability:
    """λ, κ and B for an isotropic roughness, facet restitution e, period ratio m."""
    e = as_scalar("e", e, 0.0, 1.0)
    if int(m) != m or m < 1:
        raise ParameterError(f"m (period of the motion / period of the surface) must be a positive integer, got {m}")
    dm1, E = tilt_moments(roughness)
    ec = E(np.cos)
    lam = 2 * (1 + e) * E(lambda a: np.sin(a) ** 2 * np.cos(a)) / (dm1 * ec)
    one_k = (1 + e) * E(lambda a: np.cos(a) ** 3) / ec
    denom = 2 * math.pi**2 * m**2 * (one_k - lam)
    B = (2 - lam) * one_k / denom if denom != 0 else -math.inf
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


def deviation_run(roughness: Roughness, e: float, m: int, inv_rho: float, periods: int = 30,
                  x0: float = 1e-3, frequency: float = 5.0) -> np.ndarray:
    """Simulate the point on the vibrating paraboloid; horizontal offset at each impact.

    ``inv_rho`` is ρ⁻¹ in units of ω²/g. Returns x at the successive impacts (m).
    """
    from ..mechanism.mechanism import Mechanism
    from ..laws.rough import RoughLaw
    from .scene import Scene, SceneContact, Surface
    from .simulator import simulate

    st = stability(roughness, e, m)
    g = 9.81
    orbit = periodic_orbit(st.kappa, m, frequency, g)
    w = 2 * math.pi * frequency
    rho = (g / w**2) / inv_rho if inv_rho > 0 else math.inf
    surface = Surface("paraboloid" if math.isfinite(rho) else "plane", rho=rho, amplitude=orbit.amplitude,
                      frequency=frequency, phase=orbit.phase)
    z0 = orbit.amplitude * math.sin(orbit.phase) + x0**2 / (2 * rho) + 1e-9
    scene = Scene(Mechanism.from_model("point_mass_3d"), np.array([x0, 0.0, z0]), np.array([0.0, 0.0, orbit.takeoff_speed]),
                  (SceneContact("mass", RoughLaw(roughness, e), surface),), duration=periods * m / frequency,
                  rtol=1e-10, name="vibro")
    tr = simulate(scene, samples=10)
    return np.array([tr.q[np.argmin(np.abs(tr.t - r.t)), 0] for r in tr.impacts])


def deviation_grows(roughness: Roughness, e: float, m: int, inv_rho: float, periods: int = 16,
                    x0: float = 1e-4) -> bool:
    """Simulated verdict: does a small horizontal offset grow (×10 within the run)?"""
    x = deviation_run(roughness, e, m, inv_rho, periods=periods, x0=x0)
    return bool(np.abs(x).max() > 10 * x0)


def stability_map(alphas: np.ndarray, e: float = 0.8, m: int = 1, factors: tuple[float, ...] = (0.5, 2.0),
                  executor: object | None = None) -> dict[str, np.ndarray]:
    """B(α) for a cone of facets, and simulated points at ρ⁻¹ = factor · B(α).

    Returns the analytic boundary on a fine α grid and, for every simulated point,
    α, ρ⁻¹ and whether the deviation grew. Simulations run through
    :func:`mbimpact.sweep.sweep` (``executor``: any concurrent.futures Executor).
    """
    from ..roughness import Cone
    from .sweep import sweep

    fine = np.linspace(float(np.min(alphas)), float(np.max(alphas)), 200)
    boundary = np.array([stability(Cone(a), e, m).B for a in fine])
    points = [(float(a), f * stability(Cone(a), e, m).B) for a in alphas for f in factors]
    grew = sweep(deviation_grows, [(Cone(a), e, m, r) for a, r in points], executor)  # type: ignore[arg-type]
    return {"alpha_fine": fine, "B": boundary, "alpha": np.array([p[0] for p in points]),
            "inv_rho": np.array([p[1] for p in points]), "grew": np.array(grew)}

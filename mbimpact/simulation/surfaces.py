"""Surfaces a scene's contacts strike: planes and paraboloids of revolution, fixed or vibrating.

A surface is given by a gap function f(p, t) of the world point p: f > 0 outside
(separated), f = 0 on the surface, f < 0 inside. For a plane through ``origin``
with unit normal n, f = n·(p − o) − a(t); for a paraboloid of revolution about the
axis (o, n) with radius of curvature ρ on the axis, f = n·(p − o) − |d_t|²/(2ρ) − a(t),
d_t the part of p − o across n (ρ > 0: a cup, ρ < 0: a dome). The whole surface moves
along n by a(t) = A sin(2π f t + φ).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_array, as_scalar
from ..errors import ImpactError, SceneError
from ..mechanism.contact import unit_vector

__all__ = ["Surface", "scene_errors"]

#: Surface kinds.
KINDS = ("plane", "paraboloid")

#: Smallest |rho| of a paraboloid [m]: a sharper tip is below any contact the simulator resolves, and
#: its curvature terms (|d_t|²/ρ, d_t/ρ) overflow for ordinary distances.
RHO_MIN = 1e-6


@contextmanager
def scene_errors(where: str = "") -> Iterator[None]:
    """Re-raise the shared validation helpers' errors (ParameterError, ShapeError, ...) as SceneError.

    A scene object built in Python then fails with the same class as one read from a file
    (:func:`mbimpact.load_scene`); the message is kept, prefixed by ``where``.

    Parameters
    ----------
    where : str
        Prefix of the message, e.g. ``"contacts[2] (foot): "``.
    """
    try:
        yield
    except SceneError:
        raise
    except ImpactError as exc:
        raise SceneError(f"{where}{exc}") from exc


@dataclass(frozen=True, eq=False)
class Surface:
    """A plane or a paraboloid of revolution, fixed or moving harmonically along its normal.

    Parameters
    ----------
    kind : {"plane", "paraboloid"}
    normal : array_like, shape (3,)
        Unit normal n (normalised here), pointing out of the surface.
    origin : array_like, shape (3,)
        A point of the surface (the vertex of a paraboloid) at a(t) = 0.
    rho : float
        Radius of curvature of a paraboloid on its axis, |rho| ≥ :data:`RHO_MIN` (< 0: a dome); ∞ for
        a plane.
    amplitude, frequency, phase : float
        Harmonic motion a(t) = amplitude · sin(2π frequency t + phase) along n; its peak velocity and
        acceleration must be finite floats.
    """

    kind: Literal["plane", "paraboloid"] = "plane"
    normal: NDArray[np.float64] = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    origin: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    rho: float = math.inf
    amplitude: float = 0.0
    frequency: float = 0.0
    phase: float = 0.0

    def __post_init__(self) -> None:
        with scene_errors():
            self._validate()

    def _validate(self) -> None:
        # a str first: `in` on an array compares elementwise, and its truth value is ambiguous
        if not isinstance(self.kind, str) or self.kind not in KINDS:
            raise SceneError(f"surface kind must be 'plane' or 'paraboloid', got {self.kind!r}")
        object.__setattr__(self, "normal", unit_vector("surface normal", self.normal))
        object.__setattr__(self, "origin", as_array("surface origin", self.origin, 1, (3,)))
        if self.kind == "paraboloid":
            rho = as_scalar("rho", self.rho, -math.inf, math.inf)
            if not abs(rho) >= RHO_MIN:
                raise SceneError(f"rho of a paraboloid must be ≥ {RHO_MIN:g} m in magnitude (> 0: a cup, < 0: a "
                                 f"dome), got {rho:g}")
            object.__setattr__(self, "rho", rho)
        else:
            object.__setattr__(self, "rho", math.inf)
        object.__setattr__(self, "amplitude", as_scalar("amplitude", self.amplitude, -math.inf, math.inf))
        object.__setattr__(self, "frequency", as_scalar("frequency", self.frequency, 0.0, math.inf))
        object.__setattr__(self, "phase", as_scalar("phase", self.phase, -math.inf, math.inf))
        w = 2.0 * math.pi * self.frequency
        if self.moving and not math.isfinite(abs(self.amplitude) * max(w, w * w)):
            # offset() would overflow (Python floats turn to inf silently, then sin(inf) raises)
            raise SceneError(f"a surface's motion must have a finite peak velocity and acceleration, amplitude·2π·"
                             f"frequency and amplitude·(2π·frequency)², below {np.finfo(float).max:.3g}; got "
                             f"amplitude = {self.amplitude:g}, frequency = {self.frequency:g}")

    @property
    def moving(self) -> bool:
        """Whether the surface moves (a nonzero amplitude at a nonzero frequency)."""
        return self.amplitude != 0.0 and self.frequency != 0.0

    @property
    def curved(self) -> bool:
        return self.kind == "paraboloid"

    def offset(self, t: float) -> tuple[float, float, float]:
        """a(t), ȧ(t), ä(t): displacement, velocity and acceleration along the normal."""
        if not self.moving:
            return 0.0, 0.0, 0.0
        w = 2.0 * math.pi * self.frequency
        s, c = math.sin(w * t + self.phase), math.cos(w * t + self.phase)
        return self.amplitude * s, self.amplitude * w * c, -self.amplitude * w * w * s

    def gap(self, p: ArrayLike, t: float = 0.0) -> float:
        """f(p, t): > 0 outside, 0 on the surface, < 0 inside."""
        d = np.asarray(p, dtype=float) - self.origin
        h = float(self.normal @ d)
        a = self.offset(t)[0]
        if not self.curved:
            return h - a
        lateral = d - h * self.normal
        return h - float(lateral @ lateral) / (2.0 * self.rho) - a

    def gradient(self, p: ArrayLike) -> NDArray[np.float64]:
        """∇f at p (not normalised): n − d_t / ρ."""
        if not self.curved:
            return self.normal
        d = np.asarray(p, dtype=float) - self.origin
        lateral = d - float(self.normal @ d) * self.normal
        return self.normal - lateral / self.rho

    def normal_at(self, p: ArrayLike) -> NDArray[np.float64]:
        """The unit normal of the surface through p (the direction of ∇f)."""
        g = self.gradient(p)
        return g / float(np.linalg.norm(g))

    def curvature_term(self, u: NDArray[np.float64]) -> float:
        """uᵀ (∇²f) u for a point velocity u (0 for a plane): the part of f̈ due to the curvature."""
        if not self.curved:
            return 0.0
        lateral = u - float(self.normal @ u) * self.normal
        return -float(lateral @ lateral) / self.rho

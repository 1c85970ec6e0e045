r"""Bodies for calibration: what strikes the surface in an impact experiment.

A body gives the arrays of Lagrange's impact equations (1.1) — the mass matrix A and
the contact Jacobian J — for a contact at the bottom of the body on a surface with
normal n⁰ = e_z, and reads the experiment's quantities from the generalised velocities.
The incidence plane is x–z: the body arrives with velocity V (sin θ, −cos θ) and no spin.

:class:`Ball` (radius R, mass m, inertia I = 2/5 m R² unless given) is a rigid body
with spin. Spatial (d = 3): q̇ = (v, ω) ∈ ℝ⁶, A = diag(m, m, m, I, I, I) and
J = [I₃, −[r]ₓ] with r = −R n⁰, so that u = v + ω × r. Planar (d = 2, motion in the
x–z plane): q̇ = (v_x, v_z, ω_y), A = diag(m, m, I) and J = [[1, 0, −R], [0, 1, 0]],
u_x = v_x − R ω_y (ω_y > 0 rolls forward, +x). For a sphere W = J A⁻¹ Jᵀ =
diag(1 + mR²/I, 1)/m: the ratio W_tt/W_nn = 7/2 of a solid sphere.

:class:`PointMass` is the contact point itself (A = I, J = I): the body for data that
only speak of the contact point.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..common.validation import as_scalar
from ..errors import FitError, ParameterError

__all__ = ["Body", "Ball", "PointMass", "Motion", "as_body"]


@dataclass(frozen=True, eq=False)
class Motion:
    """In-plane velocities of a body before or after impacts, shape (B,) each.

    Attributes
    ----------
    vt, vn : ndarray
        Centre-of-mass velocity along the surface (x) and along the normal (z).
    ut, un : ndarray
        Contact-point velocity along x and z.
    spin : ndarray
        Angular velocity ω_y (rad/s; positive rolls forward along +x); 0 for a point.
    """

    vt: NDArray[np.float64]
    vn: NDArray[np.float64]
    ut: NDArray[np.float64]
    un: NDArray[np.float64]
    spin: NDArray[np.float64]


class Body(ABC):
    """A body striking a plane with normal e_z, incidence in the x–z plane."""

    @abstractmethod
    def arrays(self, d: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """A (n, n) and J (d, n) for a contact space of dimension d (2: planar, 3: spatial)."""

    @abstractmethod
    def velocities(self, theta: NDArray[np.float64], speed: NDArray[np.float64], d: int) -> NDArray[np.float64]:
        """Pre-impact generalised velocities (B, n): COM velocity speed·(sin θ, −cos θ), no spin."""

    @abstractmethod
    def motion(self, V: NDArray[np.float64], d: int) -> Motion:
        """The in-plane motion of generalised velocities V (B, n)."""

    @property
    def has_spin(self) -> bool:
        """Whether the body rotates (its spin can be compared with data)."""
        return False

    def spin_scale(self, speed: NDArray[np.float64]) -> NDArray[np.float64]:
        """The natural size of the rebound spin at an impact speed: V / R (rad/s); a fit measures spin
        residuals in it (dimensionless ωR/V)."""
        raise FitError(f"{self!r} does not rotate: a spin column needs a body with spin (mbimpact.Ball)")


@dataclass(frozen=True)
class Ball(Body):
    """A rigid sphere with spin; see the module notes for A and J.

    Parameters
    ----------
    radius : float
        R > 0 (m).
    mass : float
        m > 0 (kg).
    inertia : float, optional
        Moment of inertia about a diameter (kg m²); default 2/5 m R² (solid sphere).
    """

    radius: float
    mass: float
    inertia: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", as_scalar("radius", self.radius, 0.0, math.inf, lo_open=True))
        object.__setattr__(self, "mass", as_scalar("mass", self.mass, 0.0, math.inf, lo_open=True))
        if self.inertia is None:
            # products, not radius**2: a float power raises a bare OverflowError where a product gives inf
            inertia = 0.4 * self.mass * self.radius * self.radius
            if not 0.0 < inertia < math.inf:  # A = diag(m, I) would be singular or infinite
                raise ParameterError(f"the solid-sphere inertia 2/5 m R² of mass {self.mass:g} and radius "
                                     f"{self.radius:g} is {inertia:g}; it must be finite and > 0: change units "
                                     "or give inertia=...")
            object.__setattr__(self, "inertia", inertia)
        else:
            object.__setattr__(self, "inertia", as_scalar("inertia", self.inertia, 0.0, math.inf, lo_open=True))

    @property
    def has_spin(self) -> bool:
        return True

    def spin_scale(self, speed: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(speed, dtype=float) / self.radius

    @property
    def moment(self) -> float:
        """The moment of inertia I (kg m²)."""
        assert self.inertia is not None
        return float(self.inertia)

    def arrays(self, d: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        m, I, R = self.mass, self.moment, self.radius
        if d == 2:
            return np.diag([m, m, I]), np.array([[1.0, 0.0, -R], [0.0, 1.0, 0.0]])
        if d == 3:
            r = np.array([0.0, 0.0, -R])
            cross = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
            return np.diag([m, m, m, I, I, I]), np.hstack([np.eye(3), -cross])
        raise FitError(f"a sphere strikes in a planar (d = 2) or spatial (d = 3) contact space, got d = {d}")

    def velocities(self, theta: NDArray[np.float64], speed: NDArray[np.float64], d: int) -> NDArray[np.float64]:
        B = len(theta)
        V = np.zeros((B, 3 if d == 2 else 6))
        V[:, 0] = speed * np.sin(theta)
        V[:, 1 if d == 2 else 2] = -speed * np.cos(theta)
        return V

    def motion(self, V: NDArray[np.float64], d: int) -> Motion:
        R = self.radius
        if d == 2:
            vt, vn, w = V[:, 0], V[:, 1], V[:, 2]
        else:
            vt, vn, w = V[:, 0], V[:, 2], V[:, 4]
        return Motion(vt=vt, vn=vn, ut=vt - R * w, un=vn, spin=w)


@dataclass(frozen=True)
class PointMass(Body):
    """The contact point itself, unit mass: A = I, J = I (W = I)."""

    def arrays(self, d: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if d not in (2, 3):
            raise FitError(f"a point strikes in a planar (d = 2) or spatial (d = 3) contact space, got d = {d}")
        return np.eye(d), np.eye(d)

    def velocities(self, theta: NDArray[np.float64], speed: NDArray[np.float64], d: int) -> NDArray[np.float64]:
        V = np.zeros((len(theta), d))
        V[:, 0] = speed * np.sin(theta)
        V[:, -1] = -speed * np.cos(theta)
        return V

    def motion(self, V: NDArray[np.float64], d: int) -> Motion:
        return Motion(vt=V[:, 0], vn=V[:, -1], ut=V[:, 0], un=V[:, -1], spin=np.zeros(len(V)))


def as_body(body: object) -> Body:
    """``body`` as a :class:`Body`: a Body as it is, a collision :class:`mbimpact.Sphere` with a
    ``mass`` as the solid :class:`Ball` of its radius and mass.

    Raises
    ------
    FitError
        Anything else, or a sphere without a mass.
    """
    if isinstance(body, Body):
        return body
    if getattr(body, "kind", None) == "sphere":  # mbimpact.Sphere (not imported: coal is not needed here)
        mass = getattr(body, "mass", None)
        if mass is None:
            raise FitError("a Sphere is a body only with its mass: Sphere(radius, mass=...)")
        return Ball(float(body.radius), float(mass))  # type: ignore[attr-defined]
    raise FitError(f"body must be a Ball, a PointMass or a Sphere with a mass, got {type(body).__name__}")

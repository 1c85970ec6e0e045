"""One contact point at one instant: what the impact and persistent-contact solvers see."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

__all__ = ["ContactState", "slowest"]


@dataclass(frozen=True, eq=False)
class ContactState:
    """One contact point of a scene's contact at one state.

    A frame contact has one point; a collision pair has one per witness point (the corners
    of a face lying on the ground), all with the same ``index``.

    Attributes
    ----------
    index : int
        The contact's index in the scene.
    gap : float
        f at this point [m].
    normal : ndarray, shape (3,)
        Unit normal, from the surface (or obstacle) towards the body.
    frame : ndarray, shape (3, 3)
        Local frame: columns t₁, t₂, n.
    J : ndarray, shape (3, nv)
        World-aligned translational Jacobian of the point (relative to the other body's
        witness point for a self-collision pair).
    u : ndarray, shape (3,)
        Velocity of the point relative to the surface, J v − (surface velocity).
    surface_velocity : ndarray, shape (3,)
        Velocity of the surface at the point.
    point : ndarray, shape (3,)
        The point, world frame.
    key : tuple of int
        (index, number of the point among the contact's points at this state).
    """

    index: int
    gap: float
    normal: NDArray[np.float64]
    frame: NDArray[np.float64]
    J: NDArray[np.float64]
    u: NDArray[np.float64]
    surface_velocity: NDArray[np.float64]
    point: NDArray[np.float64]
    key: tuple[int, int] = (0, 0)

    @property
    def un(self) -> float:
        """Relative normal velocity (< 0: approaching)."""
        return float(self.normal @ self.u)

    @property
    def ut(self) -> float:
        """Relative tangential speed."""
        return float(np.linalg.norm(self.u - self.un * self.normal))

    def at(self, v: NDArray[np.float64]) -> ContactState:
        """The same point at the same configuration with generalised velocity v (J is velocity-free)."""
        return replace(self, u=self.J @ v - self.surface_velocity)


def slowest(states: list[ContactState]) -> ContactState:
    """The most approaching point (smallest u_n) of a contact's points."""
    return min(states, key=lambda s: s.un)

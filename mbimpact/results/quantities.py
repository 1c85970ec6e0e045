"""The contact quantities every result reports, written once: κ, μ, energy loss, separation.

All functions take contact-space vectors along the last axis, shape (d,) or (B, d),
and return a float or an array of shape (B,). ``n0`` is the unit base normal, shape
(d,) or (B, d).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..common.geometry import scaled_norm

__all__ = ["SEPARATION_RTOL", "normal_part", "restitution", "friction_ratio", "energy_loss", "separates"]

#: A contact separates when n⁰·u₊ ≥ −SEPARATION_RTOL |u₋|: a plastic impact (e = 0) leaves
#: n⁰·u₊ at rounding level, which must not count as still approaching.
SEPARATION_RTOL = 1e-9


def _out(x: NDArray[np.float64]) -> Any:
    return float(x) if x.ndim == 0 else x


def normal_part(n0: NDArray[np.float64], x: NDArray[np.float64]) -> Any:
    """n⁰·x."""
    return _out(np.einsum("...d,...d->...", n0, x))


def restitution(n0: NDArray[np.float64], u_minus: NDArray[np.float64], u_plus: NDArray[np.float64]) -> Any:
    """Newton's restitution κ = −(n⁰·u₊)/(n⁰·u₋), (1.2); may exceed 1 (property 4°) or be < 0."""
    return _out(-np.einsum("...d,...d->...", n0, u_plus) / np.einsum("...d,...d->...", n0, u_minus))


def friction_ratio(n0: NDArray[np.float64], P: NDArray[np.float64]) -> Any:
    """μ = |P_t| / P_n of a contact impulse, (3.1); 0 where P_n ≤ 0.

    For a point mass this is the paper's (3.1) exactly. For a mechanism, splitting the
    generalised impulse I = Jᵀ P into normal and tangential parts is not coordinate-free;
    reading μ from the contact impulse P is a choice, and the one made here.
    """
    pn = np.einsum("...d,...d->...", n0, P)
    pt = np.asarray(scaled_norm(P - pn[..., None] * n0))
    return _out(np.divide(pt, pn, out=np.zeros_like(pn), where=pn > 0))


def energy_loss(P: NDArray[np.float64], u_minus: NDArray[np.float64], u_plus: NDArray[np.float64]) -> Any:
    """T₋ − T₊ = −Pᵀ(u₋ + u₊)/2: the kinetic energy lost, computed in contact space without
    the cancellation of two large energies (exact for any impulse: ΔT = Pᵀ(u₋ + u₊)/2). Energies
    beyond the float range (velocities above ~1e154) are ±inf."""
    with np.errstate(over="ignore"):
        return _out(-0.5 * np.einsum("...d,...d->...", P, u_minus + u_plus))


def separates(n0: NDArray[np.float64], u_minus: NDArray[np.float64], u_plus: NDArray[np.float64]) -> Any:
    """Whether the contact point leaves the surface, n⁰·u₊ ≥ −:data:`SEPARATION_RTOL` |u₋|."""
    un = np.einsum("...d,...d->...", n0, u_plus)
    ok = un >= -SEPARATION_RTOL * scaled_norm(u_minus)
    return bool(ok) if ok.ndim == 0 else ok

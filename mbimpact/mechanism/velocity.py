"""The joint velocity that gives a contact point a desired velocity.

Of all v with J v = u, the one of least kinetic energy ½ vᵀ A v is v = A⁻¹ Jᵀ W⁻¹ u with the
Delassus matrix W = J A⁻¹ Jᵀ (W⁻¹ a least-squares solve where W is singular). At a singular
posture, or with fewer joints than contact directions, J v spans only part of the contact
velocities: a u outside it is refused, rather than replaced by the nearest one that the mechanism
can produce.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_array, as_scalar
from ..errors import NotPositiveDefiniteError, ShapeError, UnreachableVelocityError

__all__ = ["joint_velocity", "REACH_RTOL"]

#: Default relative residual |J v − u| / |u| above which a contact velocity counts as unreachable.
REACH_RTOL = 1e-6


def joint_velocity(A: ArrayLike, J: ArrayLike, u: ArrayLike, rtol: float = REACH_RTOL) -> NDArray[np.float64]:
    """The least-kinetic-energy joint velocity whose contact velocity is ``u``: v = A⁻¹ Jᵀ W⁻¹ u.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Mass matrix A(q), symmetric positive definite.
    J : array_like, shape (d, n)
        Contact Jacobian (world-aligned, translational), d = 2 or 3.
    u : array_like, shape (d,) or (B, d)
        Desired contact velocity, or one per row.
    rtol : float
        Largest relative residual |J v − u| / |u| accepted, in [0, 1).

    Returns
    -------
    ndarray, shape (n,) or (B, n)
        v, with J v = u to within ``rtol``.

    Raises
    ------
    UnreachableVelocityError
        The posture cannot produce ``u`` (a singular posture, too few joints): the message gives the
        velocity asked, the nearest one achievable and the relative residual.
    NotPositiveDefiniteError
        A is not symmetric positive definite (massless links, joints without inertia).
    ShapeError, NonFiniteError, ParameterError
        Arrays of the wrong shape or not finite; ``rtol`` out of range.
    """
    A = as_array("A", A, 2)
    n = A.shape[0]
    if A.shape != (n, n) or n == 0:
        raise ShapeError(f"A must be a non-empty square matrix, got shape {A.shape}")
    J = as_array("J", J, 2)
    d = J.shape[0]
    if d not in (2, 3) or J.shape[1] != n:
        raise ShapeError(f"J must have shape (d, {n}) with d = 2 or 3, got {J.shape}")
    U = np.asarray(u)
    single = U.ndim == 1
    U = as_array("u", U, 1, (d,)) if single else as_array("u", U, 2, (None, d))
    rtol = as_scalar("rtol", rtol, 0.0, 1.0, hi_open=True)
    try:
        np.linalg.cholesky(0.5 * (A + A.T))
    except np.linalg.LinAlgError:
        raise NotPositiveDefiniteError("A is not positive definite (massless links or joints without inertia?): "
                                       "the joint velocity of least kinetic energy needs A⁻¹") from None
    AinvJt = np.linalg.solve(A, J.T)
    W = J @ AinvJt
    W = 0.5 * (W + W.T)
    rows = U.reshape(-1, d)
    V = (AinvJt @ np.linalg.lstsq(W, rows.T, rcond=None)[0]).T
    achieved = V @ J.T
    scale = np.linalg.norm(rows, axis=1)
    residual = np.linalg.norm(achieved - rows, axis=1) / np.where(scale > 0.0, scale, 1.0)
    worst = int(np.argmax(residual))
    if residual[worst] > rtol:
        def fmt(x: NDArray[np.float64]) -> str:
            return "(" + ", ".join(f"{c:.4g}" for c in (x + 0.0).tolist()) + ")"  # + 0.0: no "-0"

        which = f" (row {worst})" if not single else ""
        raise UnreachableVelocityError(
            f"the posture cannot produce the contact velocity u = {fmt(rows[worst])}{which}: the nearest velocity "
            f"its joints give is J v = {fmt(achieved[worst])}, a relative residual |J v − u| / |u| = "
            f"{residual[worst]:.3g} > {rtol:.3g} (a singular posture, or fewer joints than contact directions); "
            "choose a posture or a direction the contact can move in")
    return V[0] if single else V

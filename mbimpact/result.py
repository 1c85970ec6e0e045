"""The outcome of one impact, able to check itself."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["ImpactResult", "BatchResult", "SEPARATION_RTOL"]

#: A contact separates when n⁰·u₊ ≥ −SEPARATION_RTOL |u₋|: a plastic impact (e = 0) leaves
#: n⁰·u₊ at rounding level, which must not count as still approaching.
SEPARATION_RTOL = 1e-9


@dataclass(frozen=True, eq=False)
class ImpactResult:
    """Velocities and impulses of one impact, Lagrange's equations (1.1).

    Attributes
    ----------
    v_minus, v_plus : ndarray, shape (n,)
        Generalised velocity before and after the impact.
    dv : ndarray, shape (n,)
        Velocity jump Δv = A⁻¹ Jᵀ P (kept separately: v₊ − v₋ would lose digits
        when the jump is small beside the velocity).
    P : ndarray, shape (d,)
        Contact impulse in world-aligned contact coordinates; I = Jᵀ P. When J is
        rank-deficient, P is defined up to the null space of Jᵀ and the
        minimum-norm impulse is reported.
    u_minus, u_plus : ndarray, shape (d,)
        Contact-point velocity J v before and after.
    n0 : ndarray, shape (d,)
        Unit base normal.
    A : ndarray, shape (n, n)
        The mass matrix the impact was computed with.
    J : ndarray, shape (d, n)
        The contact Jacobian.
    law : ImpactLaw
        The law that produced the result.
    error_estimate : float
        Estimated relative error of ``P`` from the averaging quadrature
        (0 for laws and roughness measures that are integrated exactly).
    nodes : int
        Number of facet nodes in the final quadrature (1 for Newton's law).
    """

    v_minus: NDArray[np.float64]
    v_plus: NDArray[np.float64]
    dv: NDArray[np.float64]
    P: NDArray[np.float64]
    u_minus: NDArray[np.float64]
    u_plus: NDArray[np.float64]
    n0: NDArray[np.float64]
    A: NDArray[np.float64]
    J: NDArray[np.float64]
    law: Any
    error_estimate: float = 0.0
    nodes: int = 1

    def __post_init__(self) -> None:
        for a in (self.v_minus, self.v_plus, self.dv, self.P, self.u_minus, self.u_plus, self.n0):
            a.setflags(write=False)

    @property
    def I(self) -> NDArray[np.float64]:  # noqa: E743 — the paper's name
        """Generalised impulse I = A Δv = Jᵀ P, shape (n,), (1.1)."""
        return self.J.T @ self.P

    @property
    def P_n(self) -> float:
        """Normal contact impulse n⁰·P (≥ 0)."""
        return float(self.n0 @ self.P)

    @property
    def P_t(self) -> NDArray[np.float64]:
        """Tangential contact impulse P − (n⁰·P) n⁰, shape (d,)."""
        return self.P - self.P_n * self.n0

    @property
    def mu(self) -> float:
        """Impact friction ratio |P_t| / P_n, read in contact space (3.1)."""
        pn = self.P_n
        return float(np.linalg.norm(self.P_t)) / pn if pn > 0 else 0.0

    @property
    def kappa(self) -> float:
        """Newton's restitution −(n⁰·u₊)/(n⁰·u₋), (1.2); may exceed 1 (4°)."""
        return -float(self.n0 @ self.u_plus) / float(self.n0 @ self.u_minus)

    @property
    def separates(self) -> bool:
        """Whether the contact point leaves the surface, n⁰·u₊ ≥ 0 (up to :data:`SEPARATION_RTOL`).

        False when the averaged outcome (2.8) still approaches (κ < 0): further
        micro-impacts follow (``RoughLaw(..., repeat=True)`` applies them).
        """
        return float(self.n0 @ self.u_plus) >= -SEPARATION_RTOL * float(np.linalg.norm(self.u_minus))

    @property
    def energy_loss(self) -> float:
        """Kinetic energy lost, T₋ − T₊ (≥ 0 for every law here).

        Computed in contact space as −Pᵀ(u₋ + u₊)/2, which equals
        ½ v₋ᵀAv₋ − ½ v₊ᵀAv₊ without the cancellation of two large energies.
        """
        return -0.5 * float(self.P @ (self.u_minus + self.u_plus))

    @property
    def T_minus(self) -> float:
        """Kinetic energy before the impact, ½ v₋ᵀ A v₋."""
        return 0.5 * float(self.v_minus @ self.A @ self.v_minus)

    @property
    def T_plus(self) -> float:
        """Kinetic energy after the impact, ½ v₊ᵀ A v₊."""
        return 0.5 * float(self.v_plus @ self.A @ self.v_plus)

    @property
    def residual(self) -> float:
        """Relative residual of (1.1), |A Δv − Jᵀ P| / |Jᵀ P|."""
        impulse = self.I
        scale = float(np.linalg.norm(impulse)) or 1.0
        return float(np.linalg.norm(self.A @ self.dv - impulse)) / scale

    def summary(self) -> str:
        """One line with κ, μ, the energy loss and the post-impact contact velocity."""
        return (
            f"{self.law!r}: kappa={self.kappa:.6g} mu={self.mu:.6g} "
            f"energy_loss={self.energy_loss:.6g} u_plus={np.array2string(self.u_plus, precision=6)}"
        )


@dataclass(frozen=True, eq=False)
class BatchResult:
    """Results of many impacts evaluated together (rows), see :class:`ImpactResult`.

    ``A`` and ``J`` are shared, shapes (n, n) and (d, n), for a batch at one
    configuration, or per row, shapes (B, n, n) and (B, d, n).
    """

    V_minus: NDArray[np.float64]
    V_plus: NDArray[np.float64]
    dV: NDArray[np.float64]
    P: NDArray[np.float64]
    U_minus: NDArray[np.float64]
    U_plus: NDArray[np.float64]
    n0: NDArray[np.float64]
    A: NDArray[np.float64]
    J: NDArray[np.float64]
    law: Any
    error_estimate: NDArray[np.float64]
    nodes: int = 1

    def __len__(self) -> int:
        return self.V_minus.shape[0]

    def __getitem__(self, i: int) -> ImpactResult:
        """The i-th impact as an :class:`ImpactResult`."""
        A = self.A[i] if self.A.ndim == 3 else self.A
        J = self.J[i] if self.J.ndim == 3 else self.J
        n0 = self.n0[i] if self.n0.ndim == 2 else self.n0
        return ImpactResult(
            v_minus=self.V_minus[i].copy(), v_plus=self.V_plus[i].copy(), dv=self.dV[i].copy(),
            P=self.P[i].copy(), u_minus=self.U_minus[i].copy(), u_plus=self.U_plus[i].copy(),
            n0=n0.copy(), A=A, J=J, law=self.law, error_estimate=float(self.error_estimate[i]), nodes=self.nodes,
        )

    @property
    def P_n(self) -> NDArray[np.float64]:
        """Normal contact impulses, shape (B,)."""
        return np.einsum("bd,...d->b", self.P, self.n0) if self.n0.ndim == 2 else self.P @ self.n0

    @property
    def mu(self) -> NDArray[np.float64]:
        """Friction ratios |P_t| / P_n, shape (B,)."""
        pn = self.P_n
        n0 = self.n0 if self.n0.ndim == 2 else self.n0[None, :]
        pt = np.linalg.norm(self.P - pn[:, None] * n0, axis=1)
        return np.divide(pt, pn, out=np.zeros_like(pn), where=pn > 0)

    @property
    def kappa(self) -> NDArray[np.float64]:
        """Newton restitutions −(n⁰·u₊)/(n⁰·u₋), shape (B,)."""
        n0 = self.n0 if self.n0.ndim == 2 else self.n0[None, :]
        return -np.sum(self.U_plus * n0, axis=1) / np.sum(self.U_minus * n0, axis=1)

    @property
    def separates(self) -> NDArray[np.bool_]:
        """Whether each contact leaves the surface (see :attr:`ImpactResult.separates`), shape (B,)."""
        n0 = self.n0 if self.n0.ndim == 2 else self.n0[None, :]
        un = np.sum(self.U_plus * n0, axis=1)
        return un >= -SEPARATION_RTOL * np.linalg.norm(self.U_minus, axis=1)

    @property
    def energy_loss(self) -> NDArray[np.float64]:
        """T₋ − T₊ per row, −Pᵀ(u₋ + u₊)/2, shape (B,)."""
        return -0.5 * np.sum(self.P * (self.U_minus + self.U_plus), axis=1)

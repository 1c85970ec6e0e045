"""The outcome of an impact, able to check itself: I = A Δv = Jᵀ P by (1.1), shared by every stage."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..common.threads import single_blas_thread
from . import quantities

__all__ = ["ContactImpulses", "ImpactResult", "BatchResult"]


@dataclass(frozen=True, eq=False)
class ContactImpulses:
    """What a law's core returns: contact impulses for a batch of contact velocities.

    Attributes
    ----------
    P : ndarray, shape (B, d)
        Contact impulses.
    error : ndarray, shape (B,)
        Relative error estimates of ``P`` (0 when exact).
    nodes : int
        Facet nodes, samples or series terms of the final evaluation (what they count
        depends on ``method``; 1 for closed forms).
    method : str
        How the impulse was computed: an averaging method of (2.8) (``"ring"``,
        ``"adaptive"``, …; :data:`mbimpact.averaging.METHODS`), ``"closed-form"``
        (Newton's law), ``"impulse-space"`` (Coulomb's law).
    """

    P: NDArray[np.float64]
    error: NDArray[np.float64]
    nodes: int = 1
    method: str = "closed-form"


# where ImpactResult.from_buffer's vectors lie: (a, b, length) starts one at a·n + b·d, n or d long
_IN_BUFFER = {"v_minus": (0, 0, "n"), "v_plus": (1, 0, "n"), "dv": (2, 0, "n"), "P": (3, 0, "d"),
              "u_minus": (3, 1, "d"), "u_plus": (3, 2, "d"), "n0": (3, 3, "d")}


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
        minimum-norm impulse is reported (Newton's law: its normal impulse P_n n⁰).
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
        Estimated relative error of ``P`` (0 for laws and measures integrated exactly).
    nodes : int
        Facet nodes (or samples, or series terms) of the final evaluation.
    method : str
        How ``P`` was computed (see :class:`ContactImpulses`).
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
    method: str = "closed-form"

    def __post_init__(self) -> None:
        for a in (self.v_minus, self.v_plus, self.dv, self.P, self.u_minus, self.u_plus, self.n0):
            a.setflags(write=False)  # frozen to the values too: a result checks itself against them

    @classmethod
    def from_buffer(cls, buffer: NDArray[np.float64], A: NDArray[np.float64], J: NDArray[np.float64], law: Any,
                    error_estimate: float = 0.0, nodes: int = 1, method: str = "closed-form") -> ImpactResult:
        """The result whose vectors lie in one buffer, in the order of the attributes: ``v_minus``,
        ``v_plus``, ``dv`` (n each), ``P``, ``u_minus``, ``u_plus``, ``n0`` (d each), with (d, n) the
        shape of ``J``; anything after them is ignored.

        The buffer, ``A`` and ``J`` become the result's own, and nothing is done for them before
        they are read (the compiled single-impact routes fill such a buffer,
        :mod:`mbimpact.metric.kernels`, and a caller pays only for what it reads). Each vector is a
        view of the buffer taken on first access (the buffer is made read-only before the first);
        ``A`` and ``J`` are made read-only when first read.

        Parameters
        ----------
        buffer : ndarray, shape (3n + 4d + k,), k ≥ 0
        A : ndarray, shape (n, n)
        J : ndarray, shape (d, n)
        law, error_estimate, nodes, method
            As for the constructor.
        """
        self = cls.__new__(cls)
        state = self.__dict__
        state["_buffer"], state["_A"], state["_J"], state["_dims"], state["law"] = buffer, A, J, J.shape, law
        if error_estimate or nodes != 1 or method != "closed-form":  # else the class defaults stand
            # (item by item: update() with keywords builds a dict first, a third of this method's cost)
            state["error_estimate"], state["nodes"], state["method"] = error_estimate, nodes, method
        return self

    @classmethod
    def from_packed(cls, buffer: NDArray[np.float64], n: int, d: int, law: Any) -> ImpactResult:
        """:meth:`from_buffer` of a closed-form impact whose ``A`` and ``J`` lie in the buffer too.

        Parameters
        ----------
        buffer : ndarray, shape (3n + 4d + n² + dn,)
            The vectors as :meth:`from_buffer` reads them, then A (n, n) and J (d, n), row-major
            (what the compiled front end fills, :mod:`mbimpact.mechanism.front`). It becomes the
            result's own; each array is a read-only view of it, taken on first access.
        n, d : int
            Velocities and contact-space dimension.
        law
            As for the constructor.
        """
        self = cls.__new__(cls)
        state = self.__dict__
        state["_buffer"], state["_A"], state["_J"], state["_dims"], state["law"] = buffer, None, None, (d, n), law
        return self

    def __getattr__(self, name: str) -> Any:
        # only reached for what the instance __dict__ lacks: what from_buffer left to its first access
        state = self.__dict__
        buffer = state.get("_buffer")
        if buffer is not None:
            d, n = state["_dims"]
            if name == "A" or name == "J":
                array = state["_" + name]
                if array is None:  # packed after the vectors (from_packed)
                    buffer.setflags(write=False)
                    start = 3 * n + 4 * d + (0 if name == "A" else n * n)
                    array = buffer[start:start + (n * n if name == "A" else d * n)].reshape(-1, n)
                array.setflags(write=False)
                return state.setdefault(name, array)
            place = _IN_BUFFER.get(name)
            if place is not None:
                buffer.setflags(write=False)  # before any view: the views of a read-only buffer are read-only
                a, b, length = place
                start = a * n + b * d
                return state.setdefault(name, buffer[start:start + (n if length == "n" else d)])
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def I(self) -> NDArray[np.float64]:  # noqa: E743, N802 — the paper's name
        """Generalised impulse I = A Δv = Jᵀ P, shape (n,), (1.1)."""
        return self.J.T @ self.P

    @property
    def P_n(self) -> float:  # noqa: N802
        """Normal contact impulse n⁰·P (≥ 0)."""
        return float(self.n0 @ self.P)

    @property
    def P_t(self) -> NDArray[np.float64]:  # noqa: N802
        """Tangential contact impulse P − (n⁰·P) n⁰, shape (d,)."""
        return self.P - self.P_n * self.n0

    @property
    def mu(self) -> float:
        """Impact friction ratio |P_t| / P_n, read in contact space (3.1)
        (:func:`mbimpact.results.quantities.friction_ratio`)."""
        return float(quantities.friction_ratio(self.n0, self.P))

    @property
    def kappa(self) -> float:
        """Newton's restitution −(n⁰·u₊)/(n⁰·u₋), (1.2); may exceed 1 (4°), or be < 0 (see
        :attr:`separates`)."""
        return float(quantities.restitution(self.n0, self.u_minus, self.u_plus))

    @property
    def separates(self) -> bool:
        """Whether the contact point leaves the surface, n⁰·u₊ ≥ 0 (up to rounding).

        False when the averaged outcome (2.8) still approaches (κ < 0): further
        micro-impacts follow (``RoughLaw(..., repeat=True)`` applies them).
        """
        return bool(quantities.separates(self.n0, self.u_minus, self.u_plus))

    @property
    def energy_loss(self) -> float:
        """Kinetic energy lost, T₋ − T₊ (≥ 0 for every law here), −Pᵀ(u₋ + u₊)/2."""
        return float(quantities.energy_loss(self.P, self.u_minus, self.u_plus))

    @property
    def T_minus(self) -> float:  # noqa: N802
        """Kinetic energy before the impact, ½ v₋ᵀ A v₋."""
        return 0.5 * float(self.v_minus @ self.A @ self.v_minus)

    @property
    def T_plus(self) -> float:  # noqa: N802
        """Kinetic energy after the impact, ½ v₊ᵀ A v₊."""
        return 0.5 * float(self.v_plus @ self.A @ self.v_plus)

    @property
    def residual(self) -> float:
        """Relative residual of (1.1), |A Δv − Jᵀ P| / |Jᵀ P|."""
        impulse = self.I
        scale = float(np.linalg.norm(impulse)) or 1.0
        return float(np.linalg.norm(self.A @ self.dv - impulse)) / scale

    def summary(self) -> str:
        """One line with κ, μ, the energy loss, the post-impact contact velocity and the method."""
        return (
            f"{self.law!r}: kappa={self.kappa:.6g} mu={self.mu:.6g} "
            f"energy_loss={self.energy_loss:.6g} u_plus={np.array2string(self.u_plus, precision=6)} "
            f"({self.method}, {self.nodes} nodes)"
        )


# the fields BatchResult.along_normal forms on first access
_ALONG_NORMAL = frozenset({"dV", "V_plus", "U_minus", "U_plus", "P", "error_estimate"})


@dataclass(frozen=True, eq=False)
class BatchResult:
    """Results of many impacts evaluated together (rows), see :class:`ImpactResult`.

    ``A`` and ``J`` are shared, shapes (n, n) and (d, n), for a batch at one
    configuration, or per row, shapes (B, n, n) and (B, d, n); ``n0`` is (d,) or (B, d).
    A batch of Newton's law at one configuration forms its fields on first access
    (:meth:`along_normal`).
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
    method: str = "closed-form"

    @classmethod
    def along_normal(cls, V: NDArray[np.float64], Pn: NDArray[np.float64], y: NDArray[np.float64],
                     Jy: NDArray[np.float64], n0: NDArray[np.float64], A: NDArray[np.float64],
                     J: NDArray[np.float64], law: Any) -> BatchResult:
        """A batch at one configuration whose impulses all lie along n⁰, P = P_n n⁰ (Newton's law),
        with Δv = P_n y for one direction y = A⁻¹ Jᵀ n⁰ (1.1).

        Only ``V_minus`` (the caller's own copy) and the normal impulses are stored; each other
        field is formed from them on first access and then kept, with the arithmetic of an eager
        batch (outer products as matrix products): a batch pays only for what it reads, one
        allocation a field at most. Every array of such a batch is read-only (what the fields are
        formed of is made so here).

        Parameters
        ----------
        V : ndarray, shape (B, n)
            Pre-impact velocities; kept as ``V_minus``.
        Pn : ndarray, shape (B,)
            Normal impulses.
        y : ndarray, shape (n,)
            A⁻¹ Jᵀ n⁰.
        Jy : ndarray, shape (d,)
            J y, the change of contact velocity per unit normal impulse.
        n0 : ndarray, shape (d,)
        A, J, law
            As for the constructor (one configuration).
        """
        for a in (V, Pn, y, Jy, n0):  # what the fields are formed of must not change before they are
            a.setflags(write=False)
        self = cls.__new__(cls)
        self.__dict__.update(V_minus=V, n0=n0, A=A, J=J, law=law, _normal=(Pn, y, Jy))
        return self

    def __getattr__(self, name: str) -> Any:
        # only reached for what the instance __dict__ lacks: a field along_normal forms on first access
        state = self.__dict__
        normal = state.get("_normal")
        if normal is None or name not in _ALONG_NORMAL:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        Pn, y, Jy = normal
        column = Pn[:, None]
        with single_blas_thread(len(Pn)):  # thin products, as in the batch itself
            if name == "dV":
                value = column.dot(y[None, :])
            elif name == "V_plus":  # V₋ + Δv, without keeping Δv: one array formed, not two
                value = column.dot(y[None, :])
                value += self.V_minus
            elif name == "U_minus":
                value = self.V_minus.dot(self.J.T)
            elif name == "U_plus":
                value = column.dot(Jy[None, :])
                value += self.U_minus
            elif name == "P":
                value = column.dot(self.n0[None, :])
            else:  # error_estimate: a closed form
                value = np.zeros(len(Pn))
        value.setflags(write=False)
        return state.setdefault(name, value)  # one array a field, even if threads race to form it

    @classmethod
    def stack(cls, results: list[ImpactResult]) -> BatchResult:
        """Rows of single results (one configuration each)."""
        def stack(name: str) -> NDArray[np.float64]:
            return np.stack([getattr(r, name) for r in results])

        methods = sorted({r.method for r in results})
        return cls(
            V_minus=stack("v_minus"), V_plus=stack("v_plus"), dV=stack("dv"), P=stack("P"),
            U_minus=stack("u_minus"), U_plus=stack("u_plus"), n0=stack("n0"), A=stack("A"), J=stack("J"),
            law=results[0].law, error_estimate=np.array([r.error_estimate for r in results]),
            nodes=max(r.nodes for r in results), method="+".join(methods),
        )

    def __len__(self) -> int:
        return int(self.V_minus.shape[0])

    def __getitem__(self, i: int) -> ImpactResult:
        """The i-th impact as an :class:`ImpactResult`."""
        A = self.A[i] if self.A.ndim == 3 else self.A
        J = self.J[i] if self.J.ndim == 3 else self.J
        n0 = self.n0[i] if self.n0.ndim == 2 else self.n0
        return ImpactResult(
            v_minus=self.V_minus[i].copy(), v_plus=self.V_plus[i].copy(), dv=self.dV[i].copy(),
            P=self.P[i].copy(), u_minus=self.U_minus[i].copy(), u_plus=self.U_plus[i].copy(),
            n0=n0.copy(), A=A, J=J, law=self.law, error_estimate=float(self.error_estimate[i]), nodes=self.nodes,
            method=self.method,
        )

    @property
    def I(self) -> NDArray[np.float64]:  # noqa: E743, N802
        """Generalised impulses Jᵀ P per row, shape (B, n)."""
        if self.J.ndim == 3:
            return np.einsum("bdn,bd->bn", self.J, self.P)
        return self.P @ self.J

    @property
    def P_n(self) -> NDArray[np.float64]:  # noqa: N802
        """Normal contact impulses, shape (B,)."""
        return quantities.normal_part(self.n0, self.P)

    @property
    def mu(self) -> NDArray[np.float64]:
        """Friction ratios |P_t| / P_n, shape (B,)."""
        return quantities.friction_ratio(self.n0, self.P)

    @property
    def kappa(self) -> NDArray[np.float64]:
        """Newton restitutions −(n⁰·u₊)/(n⁰·u₋), shape (B,)."""
        return quantities.restitution(self.n0, self.U_minus, self.U_plus)

    @property
    def separates(self) -> NDArray[np.bool_]:
        """Whether each contact leaves the surface (see :attr:`ImpactResult.separates`), shape (B,)."""
        return quantities.separates(self.n0, self.U_minus, self.U_plus)

    @property
    def energy_loss(self) -> NDArray[np.float64]:
        """T₋ − T₊ per row, −Pᵀ(u₋ + u₊)/2, shape (B,)."""
        return quantities.energy_loss(self.P, self.U_minus, self.U_plus)

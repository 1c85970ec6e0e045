"""The sparse Cholesky factor of A(q) that a mechanism's workspace holds (``pin.cholesky``)."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

if TYPE_CHECKING:
    from .mechanism import Mechanism

__all__ = ["MassFactor", "new_token", "pivots_valid"]


#: A token for a new factorisation in a workspace, unique in this process: a factor knows whether its
#: thread's workspace still holds it. (The counter's own ``__next__``: it is taken on every impact.)
new_token = itertools.count(1).__next__


def _restored_factor(mechanism: Mechanism, q: NDArray[np.float64], valid: bool) -> MassFactor:
    """An unpickled :class:`MassFactor`, with a token of this process (its first solve re-factorises)."""
    return MassFactor(mechanism, q, new_token(), valid)


def pivots_valid(data: Any) -> bool:
    """Every pivot of the workspace's factor finite and > 0 (A positive definite), in floats: min and
    max may step over a NaN, their sum never does."""
    D = data.D.tolist()
    return min(D) > 0.0 and max(D) < math.inf and not math.isnan(sum(D))


@dataclass(frozen=True, eq=False)
class MassFactor:
    """The sparse Cholesky factor of A(q) held in a thread's Pinocchio workspace.

    :meth:`solve` re-factorises at ``q`` first if the workspace has been used for
    another configuration since (or the factor is used from another thread).

    Attributes
    ----------
    valid : bool
        A(q) is positive definite (every pivot of the factor finite and > 0).
    """

    mechanism: Mechanism
    q: NDArray[np.float64]
    token: int
    valid: bool

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        # a new token when unpickled (in the loading process): its counter may have issued this one already
        return (_restored_factor, (self.mechanism, self.q, self.valid))

    def _data(self) -> Any:
        """This thread's workspace, holding this factor (re-factorised at ``q`` if it was reused)."""
        mech = self.mechanism
        local = mech.workspace()
        if getattr(local, "token", None) != self.token:
            pin.crba(mech.model, local.data, self.q)
            pin.cholesky.decompose(mech.model, local.data)
            local.token = self.token
        return local.data

    def arrays(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The factor A(q) = U D Uᵀ: U (nv, nv) unit upper triangular and the pivots D (nv,).

        Views of the workspace's memory, valid until the next call on this mechanism in this
        thread: read them at once (:func:`mbimpact.metric.kernels.delassus` does).
        """
        data = self._data()
        return data.U, data.D

    def solve(self, b: NDArray[np.float64]) -> NDArray[np.float64]:
        """A⁻¹ b for b of shape (nv,) or (nv, k)."""
        model, data, solve = self.mechanism.model, self._data(), pin.cholesky.solve
        if b.ndim == 1:
            return solve(model, data, b)
        if not b.shape[1]:
            return np.zeros(b.shape)
        # one solve per column, assembled in one copy and returned as its transposed view (Fortran order:
        # every consumer multiplies it, which BLAS does in either order, and a C copy costs more than that)
        return np.array([solve(model, data, col) for col in b.T]).T

"""The family of averaging methods: how the two integrals of (2.8) are computed.

Every method turns a roughness measure, the Delassus matrix W and a batch of unit
contact velocities U (local frame) into contact impulses. They differ in cost and
in what they can do: exact sums over finite facet sets, quadrature refined until
``rtol`` (plain or graded towards the peaks of a nearly singular W), closed-form
expansions for batches at one W (ring series, tilt tables), a two-level shortcut
for a single velocity on a cone, and Monte Carlo. :data:`mbimpact.averaging.METHODS`
names them; ``RoughLaw(method=...)`` picks one, or ``"auto"`` tries
:data:`mbimpact.averaging.AUTO_ORDER` and takes the first that accepts the case.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..results.impact import ContactImpulses
from .kernels import AveragingSpec

__all__ = ["Averaging"]


class Averaging(ABC):
    """Base class of the averaging methods of (2.8).

    Attributes
    ----------
    name : str
        Registry name (:data:`mbimpact.averaging.METHODS`); a measure lists the names it
        supports in :attr:`mbimpact.Roughness.methods`.
    """

    name: ClassVar[str]
    #: The method whose ``"auto"`` screen (:meth:`worthwhile`) this one repeats for the single velocities
    #: it treats (one row of a 3-D W, no fixed node count): ``"auto"`` then reuses the decision instead of
    #: screening the same W twice (the compiled twins of ``"graded"``).
    shares_screen_with: ClassVar[str | None] = None

    def supports(self, spec: AveragingSpec) -> bool:
        """Whether the method can average this measure at all (by default: the measure says so)."""
        return self.name in spec.roughness.methods

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        """Whether ``"auto"`` should try the method on this case (its cost pays off); the
        thresholds are documented attributes of each method. Not consulted when a user
        picks the method by name."""
        return True

    @abstractmethod
    def average(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses | None:
        """Contact impulses of (2.8) for unit local-frame velocities.

        Parameters
        ----------
        spec : AveragingSpec
        W : ndarray, shape (d, d)
            Delassus matrix in the local frame.
        U : ndarray, shape (B, d)
            Unit contact velocities, local frame, ``U[:, -1] < 0``.

        Returns
        -------
        ContactImpulses or None
            None when the method declines this case at run time (a series that does not
            converge, a shortcut that is not conclusive); ``"auto"`` then tries the next.
        """

    def reason(self, spec: AveragingSpec) -> str:
        """Why :meth:`average` declined, for the error a user gets after picking it by name."""
        return f"the '{self.name}' averaging cannot treat this case"

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

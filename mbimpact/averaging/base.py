"""The contract of an averaging rule: how the two integrals of (2.8) are computed.

Every rule turns a roughness measure, the Delassus matrix W and a batch of unit contact velocities U
(local frame) into contact impulses. A subclass says, as scipy's ``OdeSolver`` does:

========================== ======================================================================
``name``                   its registry name (:data:`mbimpact.averaging.METHODS`)
``average(spec, W, U)``    **required**: the contact impulses, or None where it declines this case
``supports(spec)``         whether it can average the measure at all (default: the measure lists it)
``worthwhile(spec, W, U)`` whether ``"auto"`` should try it here (default: always)
``reason(spec)``           why it declined, for a user who named it
``any_facet``              whether it averages any facet law (:mod:`mbimpact.facets`), or Newton's only
``cone_step(spec)``        its step in a compiled single impact on a cone, if any
========================== ======================================================================

A compiled kernel is a backend a rule picks for itself (one velocity, Newton facets), and the result
says so: ``result.method == "adaptive[compiled]"``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..results.impact import ContactImpulses
from .compiled.codes import SKIP
from .integrand import AveragingSpec

__all__ = ["Averaging", "SKIP", "compiled_label"]


def compiled_label(name: str) -> str:
    """The ``method`` of a result that a rule's compiled backend computed: ``"adaptive[compiled]"``."""
    return f"{name}[compiled]"


class Averaging(ABC):
    """Base class of the averaging rules of (2.8) (see the module docstring for the contract).

    Attributes
    ----------
    name : str
        Registry name (:data:`mbimpact.averaging.METHODS`); a measure lists the names it
        supports in :attr:`mbimpact.Roughness.methods`.
    any_facet : bool
        True for the quadratures that evaluate any facet law (:mod:`mbimpact.facets`) at their nodes;
        False for those that integrate Newton facets in closed form or compiled.
    """

    name: ClassVar[str]
    any_facet: ClassVar[bool] = False

    def supports(self, spec: AveragingSpec) -> bool:
        """Whether the rule can average this measure at all (by default: the measure says so)."""
        return self.name in spec.roughness.methods

    def worthwhile(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]) -> bool:
        """Whether ``"auto"`` should try the rule on this case (its cost pays off); the thresholds
        are documented attributes of each rule. Not consulted when a user names the rule."""
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
            None when the rule declines this case at run time (a series that does not converge, a
            closed form that does not apply); ``"auto"`` then tries the next.
        """

    def reason(self, spec: AveragingSpec) -> str:
        """Why :meth:`average` declined, for the error a user gets after naming the rule."""
        return f"the '{self.name}' averaging cannot treat this case"

    def cone_step(self, spec: AveragingSpec) -> int | None:
        """This rule's step in a compiled single impact on a :class:`~mbimpact.Cone` of ``spec``
        (one velocity, no fixed node count): a step code of :mod:`~mbimpact.averaging.compiled.codes`,
        :data:`SKIP` where ``"auto"`` never runs the rule for one velocity, or None where it has no
        compiled step (a single impact then cannot run whole compiled). None here."""
        return None

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

"""Newton's facet (2.5)–(2.6): the paper's facet law, a Kelvin–Voigt impact along the facet normal."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..common.validation import as_scalar
from .base import FacetLaw

__all__ = ["NewtonFacet"]


@dataclass(frozen=True)
class NewtonFacet(FacetLaw):
    """Newton's frictionless impact on the facet, (2.6): P = −(1+e) (mᵀu / mᵀWm) m.

    The Kelvin–Voigt force (2.3) along the facet normal gives it in the limit M → ∞,
    with e = exp(−kπ/√(1−k²)) (:func:`mbimpact.e_from_k`). ``RoughLaw(roughness, e)`` is
    ``RoughLaw(roughness, facet=NewtonFacet(e))``, and only this facet law has the
    closed-form averages (``ring``, ``tilt-table``, ``laplace``, ``poles``) and the compiled backends of
    the refinable rules (``adaptive[compiled]``, ``graded[compiled]``).

    Parameters
    ----------
    e : float
        Facet restitution in [0, 1].
    """

    e: float
    name: ClassVar[str] = "newton"

    def __post_init__(self) -> None:
        object.__setattr__(self, "e", as_scalar("e", self.e, 0.0, 1.0))

    def __repr__(self) -> str:
        return f"NewtonFacet(e={self.e:g})"

    @property
    def newton_restitution(self) -> float | None:
        return self.e

    def impulse(self, m: NDArray[np.float64], W: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        s = np.einsum("nd,nd->n", m, u)
        q = np.einsum("nd,nd->n", m @ W, m)
        return (-(1.0 + self.e) * s / q)[:, None] * m

    def facet_impulse(self, W: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        P = np.zeros_like(u)
        P[:, -1] = -(1.0 + self.e) * u[:, -1] / W[:, -1, -1]
        return P

"""Facet laws by name, for users (and the command line) who pick them by name."""

from __future__ import annotations

from typing import Any

from ..errors import ParameterError
from .base import FacetLaw, method_label, split_method
from .compliant import CompliantFacet
from .coulomb import CoulombFacet
from .hunt_crossley import HuntCrossleyFacet
from .newton import NewtonFacet

__all__ = ["FACETS", "facet_law", "method_label", "split_method"]

#: The facet laws by name.
FACETS: dict[str, type[FacetLaw]] = {
    cls.name: cls for cls in (NewtonFacet, CoulombFacet, CompliantFacet, HuntCrossleyFacet)
}


def facet_law(name: str, **params: Any) -> FacetLaw:
    """The facet law registered as ``name`` with its parameters, e.g. ``facet_law("coulomb", e=0.5, mu=0.3)``.

    Raises
    ------
    ParameterError
        An unknown name, or parameters the law does not take.
    """
    if not isinstance(name, str) or name not in FACETS:
        raise ParameterError(f"unknown facet law {name!r}; valid: {', '.join(repr(n) for n in FACETS)}")
    try:
        return FACETS[name](**params)
    except TypeError as exc:
        raise ParameterError(f"facet law {name!r}: {exc}") from None

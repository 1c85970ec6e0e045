"""The parameters of impact laws, by name: read them from a law, build a law with new values.

A fit varies named parameters of a *template* law (:func:`law_parameters`,
:func:`with_parameters`):

========== ======================================= =====================================
name       meaning                                 in
========== ======================================= =====================================
``e``      restitution (of the law or the facets)  NewtonLaw, CoulombLaw, Newton/Coulomb/
                                                   compliant facets
``mu``     Coulomb friction coefficient            CoulombLaw, Coulomb/compliant facets
``kt``     tangential/normal stiffness ratio κ_t   compliant facets
``hc``     Hunt–Crossley damping α (s/m)           Hunt–Crossley facets
``sigma``  RMS slope of Gaussian roughness         RoughLaw(GaussianSlopes)
``alpha``  facet tilt (rad)                        RoughLaw(Sawtooth or Cone)
========== ======================================= =====================================

:data:`FAMILIES` names the templates the ``mbimpact fit`` command compares.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..errors import FitError, ImpactError
from ..facets.compliant import CompliantFacet
from ..facets.coulomb import CoulombFacet
from ..facets.hunt_crossley import HuntCrossleyFacet
from ..facets.newton import NewtonFacet
from ..laws.base import ImpactLaw
from ..laws.coulomb import CoulombLaw
from ..laws.newton import NewtonLaw
from ..laws.rough import RoughLaw
from ..roughness.cone import Cone
from ..roughness.finite import Sawtooth, Smooth
from ..roughness.slopes import GaussianSlopes

__all__ = ["Parameter", "PARAMETERS", "FAMILIES", "law_parameters", "with_parameters", "family"]


@dataclass(frozen=True)
class Parameter:
    """A fit parameter: its bounds and meaning."""

    name: str
    lower: float
    upper: float
    description: str


PARAMETERS: dict[str, Parameter] = {p.name: p for p in (
    Parameter("e", 0.001, 1.0, "restitution"),
    Parameter("mu", 0.0, 2.0, "Coulomb friction coefficient"),
    Parameter("kt", 0.02, 20.0, "tangential/normal stiffness ratio"),
    Parameter("hc", 0.0, 100.0, "Hunt-Crossley damping alpha (s/m)"),
    Parameter("sigma", 0.005, 1.5, "RMS slope of Gaussian roughness"),
    Parameter("alpha", 0.0, 1.4, "facet tilt (rad)"),
)}

# the facet fields behind each parameter name, and the parameters of each facet law
_FACET_FIELDS = {"e": "e", "mu": "mu", "kt": "stiffness_ratio", "hc": "alpha"}
_FACET_PARAMETERS: dict[type, tuple[str, ...]] = {
    NewtonFacet: ("e",), CoulombFacet: ("e", "mu"), CompliantFacet: ("e", "mu", "kt"), HuntCrossleyFacet: ("hc",),
}


def law_parameters(law: ImpactLaw) -> dict[str, float]:
    """The named parameters of ``law`` and their values (see the module's table).

    Raises
    ------
    FitError
        A law (or facet law, or roughness) whose parameters are not known here.
    """
    if isinstance(law, NewtonLaw):
        return {"e": law.e}
    if isinstance(law, CoulombLaw):
        return {"e": law.e, "mu": law.mu}
    if isinstance(law, RoughLaw):
        out: dict[str, float] = {}
        rough = law.roughness
        if isinstance(rough, GaussianSlopes):
            out["sigma"] = rough.sigma
        elif isinstance(rough, (Sawtooth, Cone)):
            out["alpha"] = rough.alpha
        elif not isinstance(rough, Smooth):
            raise FitError(f"cannot vary the roughness {rough!r}; fit GaussianSlopes (sigma), Sawtooth or Cone "
                           "(alpha), or keep Smooth")
        facet = law.facet
        names = _FACET_PARAMETERS.get(type(facet))
        if names is None:
            raise FitError(f"cannot vary the facet law {facet!r}; known: "
                           + ", ".join(cls.__name__ for cls in _FACET_PARAMETERS))
        out.update({name: float(getattr(facet, _FACET_FIELDS[name])) for name in names})
        return out
    raise FitError(f"cannot fit {law!r}: fit NewtonLaw, CoulombLaw or RoughLaw")


def with_parameters(law: ImpactLaw, values: dict[str, float]) -> ImpactLaw:
    """``law`` with some named parameters changed (the others kept).

    Raises
    ------
    FitError
        A name the law does not have; an invalid value (the law's own error, re-raised).
    """
    have = law_parameters(law)
    if not isinstance(values, Mapping):  # set() of it below would fail with a bare TypeError, or split a str
        raise FitError(f"values must be a mapping of parameter name to value ({', '.join(have)}), "
                       f"got {type(values).__name__}")
    unknown = set(values) - set(have)
    if unknown:
        raise FitError(f"{law!r} has no parameter(s) {sorted(unknown)}; it has {', '.join(have)}")
    v = {**have, **values}
    try:
        if isinstance(law, NewtonLaw):
            return NewtonLaw(v["e"])
        if isinstance(law, CoulombLaw):
            return CoulombLaw(v["e"], v["mu"], law.restitution, rtol=law.rtol)
        assert isinstance(law, RoughLaw)
        rough = law.roughness
        if isinstance(rough, GaussianSlopes):
            rough = GaussianSlopes(v["sigma"], dim=rough.dim)
        elif isinstance(rough, Sawtooth):
            rough = Sawtooth(v["alpha"])
        elif isinstance(rough, Cone):
            rough = Cone(v["alpha"])
        changes = {fld: v[name] for name, fld in _FACET_FIELDS.items() if name in have}
        facet = dataclasses.replace(law.facet, **changes)  # type: ignore[type-var]
        return law.replace(roughness=rough, facet=facet)
    except ImpactError as exc:
        raise FitError(f"cannot build {type(law).__name__} with {v}: {exc}") from exc


def _rough(facet: Any) -> RoughLaw:
    """A planar Gaussian roughness (σ = 0.1) with these facets, fixed nodes (smooth in the parameters)."""
    return RoughLaw(GaussianSlopes(0.1, dim=2), facet=facet, method="fixed", nodes=12, repeat=True)


#: Template laws by name, with their starting values (``mbimpact fit --law``).
FAMILIES: dict[str, Any] = {
    "newton": lambda: NewtonLaw(0.9),
    "coulomb": lambda: CoulombLaw(0.9, 0.1),
    "rough-newton": lambda: _rough(NewtonFacet(0.9)),
    "rough-coulomb": lambda: _rough(CoulombFacet(0.9, 0.1)),
    "compliant": lambda: RoughLaw(Smooth(), facet=CompliantFacet(0.9, 0.1, 0.8)),
    "rough-compliant": lambda: _rough(CompliantFacet(0.9, 0.1, 0.8)),
    "rough-hunt-crossley": lambda: _rough(HuntCrossleyFacet(0.01)),
}


def family(name: str) -> ImpactLaw:
    """The template law of a family name (:data:`FAMILIES`)."""
    if not isinstance(name, str) or name not in FAMILIES:  # a list is unhashable: no bare TypeError
        raise FitError(f"unknown law family {name!r}; valid: {', '.join(FAMILIES)}")
    law: ImpactLaw = FAMILIES[name]()
    return law

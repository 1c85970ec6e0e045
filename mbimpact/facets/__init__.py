"""Facet laws: the impact on one facet of the microrelief that the rough law (2.8) averages.

=================== ======================================================= ==============================
name                the facet impact                                        averaging methods
=================== ======================================================= ==============================
``newton``          Newton's, (2.6) (the paper's; ``RoughLaw(rough, e)``)    all, closed forms included
``coulomb``         axiomatic Coulomb impact (closed form in 2-D)            exact, fixed, adaptive, graded,
``compliant``       Kelvin–Voigt + tangential spring + Coulomb slip, in time monte-carlo (quadrature methods)
``hunt-crossley``   Newton's with the speed-dependent e(v) of Hunt–Crossley
=================== ======================================================= ==============================

``mbi.RoughLaw(roughness, facet=mbi.CoulombFacet(e, mu))``. The flux weights (2.7) are
the same for every facet law; only the facet impulse changes.
"""

from .base import FacetLaw, facet_frames, to_facet_frame
from .compliant import CompliantFacet, CompliantHistory, compliant_impulses
from .coulomb import CoulombFacet, planar_coulomb, spatial_coulomb
from .hunt_crossley import HuntCrossleyFacet, hunt_crossley_restitution
from .newton import NewtonFacet
from .registry import FACETS, facet_law, method_label, split_method
from .restitution import e_from_k, impact_duration, k_from_e, restitution_from

__all__ = [
    "FacetLaw",
    "NewtonFacet",
    "CoulombFacet",
    "CompliantFacet",
    "CompliantHistory",
    "HuntCrossleyFacet",
    "FACETS",
    "facet_law",
    "method_label",
    "split_method",
    "facet_frames",
    "to_facet_frame",
    "planar_coulomb",
    "spatial_coulomb",
    "compliant_impulses",
    "hunt_crossley_restitution",
    "e_from_k",
    "k_from_e",
    "impact_duration",
    "restitution_from",
]

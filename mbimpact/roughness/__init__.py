"""Stage 3 of the pipeline: roughness measures (G, P), the facets and their measure.

A measure gives the distribution of facet normals at the contact point (fractions of
true physical surface area) and a quadrature rule for it that follows the facing set
G* of (2.7) exactly. Families: finite facet sets (:class:`Smooth`,
:class:`Sawtooth`, :class:`Facets`), isotropic rings and tilt densities
(:class:`Cone`, :class:`IsotropicSlopes`, :class:`GaussianSlopes`) and measured
relief with exact shadowing (:class:`Profile`, :class:`HeightMap`).
"""

from .base import FiniteRoughness, Roughness, Rule, check_normals, check_weights
from .cone import Cone
from .finite import Facets, Sawtooth, Smooth
from .relief import HeightMap, Profile
from .slopes import GaussianSlopes, IsotropicSlopes

__all__ = [
    "Roughness",
    "FiniteRoughness",
    "Rule",
    "Smooth",
    "Sawtooth",
    "Cone",
    "Facets",
    "IsotropicSlopes",
    "GaussianSlopes",
    "Profile",
    "HeightMap",
    "check_normals",
    "check_weights",
]

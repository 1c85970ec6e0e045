"""Stage 4 of the pipeline: averaging methods, the rules that turn a roughness measure, the
Delassus matrix W and the contact velocities into the two integrals of (2.8).

====================== ============================================================== ===================
name                   what it does                                                   ``"auto"`` uses it
====================== ============================================================== ===================
``exact``              finite sum over a finite facet set                             finite measures
``ring``               Fourier series of a cone's kernels at fixed W (exact)          cones, ≥ 32 rows
``tilt-table``         Chebyshev tables of a tilt density in the incidence (exact)    tilt densities, ≥ 1024 rows
``laplace``            Gaussian slopes: 1/mᵀWm as ∫ e^{−τ mᵀWm} dτ, the facets in      Gaussian slopes (3-D), physical flux
                       closed form, one compiled τ-integral left
``graded-slope-pass``  ``graded`` for one velocity on a tilt density, in one call     one velocity (3-D), a peak < 0.15
``pole-pass``          a cone's peaks as poles in closed form, the rest plain, compiled one velocity, a peak < 0.15
``graded-pass``        ``graded`` for one velocity on a cone, in one compiled call    one velocity, a peak < 0.15
``graded``             quadrature graded towards the peaks of a nearly singular W     a peak narrower than 0.15
``cone-pair``          a cone's first adaptive pass (32 + 64 nodes), one compiled call one velocity on a cone
``cone-pass``          a cone's whole adaptive rule in one compiled call              one velocity on a cone
``slope-pass``         a tilt density's adaptive rule in one compiled call            one velocity on a tilt density
``fixed``              the measure's rule with ``nodes`` nodes                        ``nodes`` given
``adaptive``           the measure's rule doubled until ``rtol``                      otherwise
``monte-carlo``        ``samples`` facets drawn from P, with a standard error         never (a baseline)
====================== ============================================================== ===================

``RoughLaw(..., method="auto" | name | Averaging subclass or instance)``. With
``"auto"`` the methods are tried in :data:`AUTO_ORDER`; the first that supports the
measure, finds the case worthwhile and does not decline it at run time is used. The
result records which method ran (``result.method``) and with how many nodes.
"""

from __future__ import annotations

from .base import Averaging
from .cone_pair import ConePair
from .cone_pass import ConePass
from .exact import Exact, MonteCarlo
from .graded_pass import GradedPass
from .graded_slope_pass import GradedSlopePass
from .laplace import Laplace
from .pole_pass import PolePass
from .kernels import FLUXES, AveragingSpec, Flux
from .refinement import Adaptive, Fixed, Graded
from .ring import Ring
from .slope_pass import SlopePass
from .tilt_table import TiltTableMethod

__all__ = [
    "Averaging",
    "AveragingSpec",
    "Flux",
    "FLUXES",
    "METHODS",
    "AUTO_ORDER",
    "Exact",
    "Ring",
    "TiltTableMethod",
    "Laplace",
    "Graded",
    "PolePass",
    "GradedPass",
    "GradedSlopePass",
    "ConePair",
    "ConePass",
    "SlopePass",
    "Fixed",
    "Adaptive",
    "MonteCarlo",
]

#: The averaging methods by name.
METHODS: dict[str, type[Averaging]] = {
    cls.name: cls
    for cls in (Exact, Ring, TiltTableMethod, Laplace, GradedSlopePass, PolePass, GradedPass, Graded, ConePair, ConePass,
                SlopePass,
                Fixed, Adaptive, MonteCarlo)
}

#: The order in which ``method="auto"`` tries them.
AUTO_ORDER: tuple[str, ...] = ("exact", "ring", "tilt-table", "laplace", "graded-slope-pass", "pole-pass", "graded-pass",
                               "graded", "cone-pair", "cone-pass", "slope-pass", "fixed", "adaptive")

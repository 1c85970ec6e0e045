"""Stage 4 of the pipeline: the averaging rules, which turn a roughness measure, the Delassus matrix W
and the contact velocities into the two integrals of (2.8).

============== =================================================================== =================================
name           what it computes                                                    ``"auto"`` uses it
============== =================================================================== =================================
``exact``      the finite sum over a finite facet set (shadowing exact)            finite measures
``ring``       a cone at fixed W by the Fourier series of its kernels              cones, ≥ 32 rows
``tilt-table`` a tilt density at fixed W by Chebyshev tables in the incidence      tilt densities, large batches
``laplace``    Gaussian slopes: 1/mᵀWm = ∫ e^{−τ mᵀWm} dτ, facets in closed form   Gaussian slopes, physical flux
``poles``      a cone's peaked kernels with their poles taken out in closed form   one velocity, a narrow peak
``graded``     the measure's rule graded towards the peaks of a nearly singular W  a peak narrower than 0.15
``fixed``      the measure's rule with ``nodes`` nodes                             ``nodes`` given
``adaptive``   the measure's rule doubled until ``rtol``                           otherwise
``monte-carlo`` ``samples`` facets drawn from P, with a standard error             never (a baseline)
============== =================================================================== =================================

``RoughLaw(..., method="auto" | name | Averaging subclass or instance)``. With ``"auto"`` the rules are
tried in :data:`AUTO_ORDER`; the first that supports the measure, finds the case worthwhile and does
not decline it at run time is used. The result records which ran (``result.method``) and with how many
nodes.

Compiled backends. For one velocity with Newton facets, ``adaptive`` and ``graded`` run their levels in
one compiled call (numba, :mod:`mbimpact.averaging.compiled`), with the same nodes, error estimate and
stopping rule as their numpy form; the result then says ``"adaptive[compiled]"``. ``poles`` and
``laplace`` are compiled only.

Error estimates. A refinable rule reports the relative difference of its last two levels, measured by
the velocity change W P they make (P is defined only up to null(Jᵀ) for a rank-deficient J, W P always).
Near a singular posture two more bounds enter, which no level reduces and which the estimate therefore
states even where they exceed ``rtol``: the rounding of q = mᵀWm at the kernels' peaks (an ulp of W's
entries moves q by up to ε Σ |W_ik| |m_i| |m_k| there, and the peak's integral by a power of that
relative to q_min: :func:`mbimpact.quadrature.graded.minima_sensitivity`), and the rounding of P itself
where W nearly annihilates it (ε tr W |P| / |W P|: :func:`mbimpact.averaging.refinement.rounding_floor`).
"""

from __future__ import annotations

from .base import SKIP, Averaging, compiled_label
from .exact import Exact, MonteCarlo
from .integrand import FLUXES, AveragingSpec, Flux
from .laplace import Laplace
from .poles import Poles
from .refinement import Adaptive, Fixed, Graded
from .ring import Ring
from .tilt_table import TiltTableMethod

__all__ = [
    "Averaging",
    "AveragingSpec",
    "Flux",
    "FLUXES",
    "METHODS",
    "AUTO_ORDER",
    "SKIP",
    "compiled_label",
    "Exact",
    "Ring",
    "TiltTableMethod",
    "Laplace",
    "Poles",
    "Graded",
    "Fixed",
    "Adaptive",
    "MonteCarlo",
]

#: The averaging rules by name.
METHODS: dict[str, type[Averaging]] = {
    cls.name: cls for cls in (Exact, Ring, TiltTableMethod, Laplace, Poles, Graded, Fixed, Adaptive, MonteCarlo)
}

#: The order in which ``method="auto"`` tries them.
AUTO_ORDER: tuple[str, ...] = ("exact", "ring", "tilt-table", "laplace", "poles", "graded", "fixed", "adaptive")

"""The compliant route: the constructive model resolved in time (Kelvin–Voigt contacts (2.3)).

:func:`resolve` integrates one or several compliant contacts on the full dynamics;
:func:`resolve_rough` samples facets with the flux weights (2.7) and averages the
resolved impacts; :func:`compare_simultaneous` flags simultaneous impacts where a
single-contact law applied contact by contact disagrees with the resolution.
"""

from .resolve import Resolved, resolve
from .sampled import RoughResolved, resolve_rough
from .simultaneous import SimultaneousReport, compare_simultaneous

__all__ = ["resolve", "Resolved", "resolve_rough", "RoughResolved", "compare_simultaneous", "SimultaneousReport"]

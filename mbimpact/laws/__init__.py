"""Stage 5 of the pipeline: impact laws (Newton's, the rough law (2.8), Coulomb's).

All share :class:`ImpactLaw`'s pipeline (metric → contact impulse → result by (1.1)).
"""

from .base import ImpactLaw
from .coulomb import CoulombLaw
from .newton import NewtonLaw
from .rough import RoughLaw

__all__ = ["ImpactLaw", "NewtonLaw", "RoughLaw", "CoulombLaw"]

"""Results that check themselves (κ, μ, energy, separation, method): the value objects every stage shares."""

from .impact import BatchResult, ContactImpulses, ImpactResult
from .quantities import SEPARATION_RTOL, energy_loss, friction_ratio, restitution, separates

__all__ = [
    "ImpactResult",
    "BatchResult",
    "ContactImpulses",
    "SEPARATION_RTOL",
    "restitution",
    "friction_ratio",
    "energy_loss",
    "separates",
]

"""The exception tree of mbimpact.

Every error the library raises on bad input derives from :class:`ImpactError`,
itself a :class:`ValueError`, so ``except ValueError`` keeps working for callers
that do not care about the details. Messages say what was wrong and what would
have been valid.
"""

from __future__ import annotations

__all__ = [
    "ImpactError",
    "ShapeError",
    "NonFiniteError",
    "NotPositiveDefiniteError",
    "ParameterError",
    "RoughnessError",
    "NameNotFoundError",
    "RobotNotFoundError",
    "FrameNotFoundError",
    "NoImpactError",
    "NoFacingFacetError",
    "IntegrationError",
]


class ImpactError(ValueError):
    """Root of every error raised by mbimpact on invalid input or state."""


class ShapeError(ImpactError):
    """An array has the wrong number of dimensions or the wrong length."""


class NonFiniteError(ImpactError):
    """An input contains NaN or infinity."""


class NotPositiveDefiniteError(ImpactError):
    """The mass matrix A is not symmetric positive definite."""


class ParameterError(ImpactError):
    """A scalar parameter (e, k, alpha, ...) is outside its valid range."""


class RoughnessError(ImpactError):
    """A roughness measure is ill-formed (weights, facet normals, dimension)."""


class NameNotFoundError(ImpactError):
    """A name (robot, frame) does not exist; the message lists close matches."""


class RobotNotFoundError(NameNotFoundError):
    """No example-robot-data robot or URDF file of that name."""


class FrameNotFoundError(NameNotFoundError):
    """The mechanism has no frame of that name."""


class NoImpactError(ImpactError):
    """The velocity does not approach the base surface: (N0, v) >= 0."""


class NoFacingFacetError(ImpactError):
    """No facet of the roughness faces the velocity: the set G* of (2.7) is empty."""


class IntegrationError(ImpactError):
    """The time integration of a compliant impact gave up (the message gives the time reached)."""

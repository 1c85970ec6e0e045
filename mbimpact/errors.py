"""The exception tree of mbimpact, warnings included.

Every error the library raises on bad input derives from :class:`ImpactError`,
itself a :class:`ValueError`, so ``except ValueError`` keeps working for callers
that do not care about the details. Messages say what was wrong and what would
have been valid. The warnings derive from :class:`ImpactWarning`, which is both an
:class:`ImpactError` and a :class:`UserWarning`: ``except mbi.ImpactError`` also
catches them when they are turned into errors.
"""

from __future__ import annotations

import functools
import os
import sys
import warnings
from types import FrameType

__all__ = [
    "ImpactError",
    "ShapeError",
    "NonFiniteError",
    "NotPositiveDefiniteError",
    "ParameterError",
    "UnreachableVelocityError",
    "RoughnessError",
    "NameNotFoundError",
    "RobotNotFoundError",
    "URDFError",
    "FrameNotFoundError",
    "CollisionNotFoundError",
    "GeometryError",
    "NoImpactError",
    "NoFacingFacetError",
    "IntegrationError",
    "SceneError",
    "TableError",
    "FitError",
    "ImpactWarning",
    "AccuracyWarning",
    "NoSeparationWarning",
    "ignored",
    "warn",
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


class UnreachableVelocityError(ParameterError):
    """A contact velocity the mechanism cannot produce at its posture: no joint velocity v gives J v = u
    (a singular posture, too few joints); the message gives the asked and the nearest achievable velocity."""


class RoughnessError(ImpactError):
    """A roughness measure is ill-formed (weights, facet normals, dimension)."""


class NameNotFoundError(ImpactError):
    """A name (robot, frame) does not exist; the message lists close matches."""


class RobotNotFoundError(NameNotFoundError):
    """No example-robot-data robot or URDF file of that name."""


class URDFError(RobotNotFoundError):
    """A URDF (or MJCF) file exists but cannot be parsed; the message gives its path and the
    parser's complaint. (A :class:`RobotNotFoundError`: ``except RobotNotFoundError`` catches every
    robot that could not be loaded.)"""


class FrameNotFoundError(NameNotFoundError):
    """The mechanism has no frame of that name."""


class CollisionNotFoundError(NameNotFoundError):
    """The mechanism (or a gap model) has no collision object of that name; the message lists close matches."""


class GeometryError(ImpactError):
    """Collision geometry is missing or unusable: a mechanism without ``<collision>`` elements, a mesh
    file that cannot be found or read, a convex hull that cannot be built, a duplicate name."""


class NoImpactError(ImpactError):
    """The velocity does not approach the base surface: (N0, v) >= 0."""


class NoFacingFacetError(ImpactError):
    """No facet of the roughness faces the velocity: the set G* of (2.7) is empty."""


class IntegrationError(ImpactError):
    """A time integration gave up (the message gives the time reached)."""


class SceneError(ImpactError):
    """A scene file or object is invalid; the message names the key (and line)."""


class TableError(ImpactError):
    """A data table is ill-formed: a missing or unknown column, a bad value, an unreadable file."""


class FitError(ImpactError):
    """A fit cannot be set up: a parameter the law does not have, nothing to fit, too few data."""


class ImpactWarning(ImpactError, UserWarning):
    """Root of mbimpact's warnings: a result was computed but is not what was asked for."""


class AccuracyWarning(ImpactWarning):
    """The averaging quadrature stopped before reaching the requested ``rtol``."""


class NoSeparationWarning(ImpactWarning):
    """The averaged outcome (2.8) still approaches the surface: κ < 0.

    The law assumes one micro-impact per facet. A mean contact velocity that still
    moves into the base surface afterwards means further micro-impacts follow
    (steep facets at normal incidence, or an oblique impact on an anisotropic W);
    ``RoughLaw(..., repeat=True)`` applies the law again until the contact separates.
    Its text is the same for every impact of a law (κ itself is on the result), so that
    Python's default filter shows it once per line of a loop of impacts.
    """


_PACKAGE = os.path.dirname(os.path.abspath(__file__))


def ignored(category: type[Warning]) -> bool:
    """Whether Python's warning filters drop every warning of ``category``, whatever its text and origin:
    the first filter that matches it by category says "ignore" and asks nothing of text, module or line
    (``warnings.simplefilter("ignore", category)`` or one for a parent class). A filter on the text or
    the origin before it leaves the decision to :func:`warnings.warn_explicit`."""
    for action, message, kind, module, lineno in warnings.filters:
        if not issubclass(category, kind):
            continue
        return action == "ignore" and message is None and module is None and not lineno
    return False  # no filter applies: Python's default action shows it


def warn(category: type[ImpactWarning], message: str) -> None:
    """Issue an mbimpact warning attributed to the first caller outside the package.

    impact, apply, apply_batch and the simulator reach the place that warns at
    different depths; naming the user's line makes Python's default filter show a
    warning once per call site. A category that the filters drop whatever its origin
    (:func:`ignored`) costs no walk of the stack, so a loop of impacts that silences it
    pays almost nothing for it.
    """
    if ignored(category):  # what warn_explicit would decide for any frame; for "ignore" it records nothing
        return
    frame: FrameType | None = sys._getframe(1)
    level = 2  # stacklevel 2 is the caller of this function
    while frame is not None and _inside(frame.f_code.co_filename):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)


def _inside(filename: str) -> bool:
    """Whether a code object's file belongs to the package. A relative name depends on the working
    directory, so it is resolved each time; ``<string>``, ``<stdin>`` are never the package's."""
    if filename.startswith("<"):
        return False
    if not os.path.isabs(filename):
        return os.path.abspath(filename).startswith(_PACKAGE + os.sep)
    return _inside_absolute(filename)


@functools.lru_cache(maxsize=1024)
def _inside_absolute(filename: str) -> bool:
    return os.path.normpath(filename).startswith(_PACKAGE + os.sep)

"""Quadrature rules on the sphere of facet normals, used by the roughness measures.

Plain rules (:mod:`.rules`: Gauss–Legendre, the exact facing arc of a ring, tilt
segments split where rings start to be cut) and rules graded towards the peaks of
the kernels of (2.8) for a nearly singular Delassus matrix (:mod:`.graded`).
"""

from .graded import (graded_azimuth_rule, graded_tilt_rule, peak_tilts, peak_width_bound, ring_minima, ring_minima_many,
                     ring_width_bound)
from .rules import azimuth_rule, gauss_legendre, tilt_segments

__all__ = [
    "gauss_legendre",
    "azimuth_rule",
    "tilt_segments",
    "graded_azimuth_rule",
    "graded_tilt_rule",
    "peak_tilts",
    "peak_width_bound",
    "ring_minima",
    "ring_minima_many",
    "ring_width_bound",
]

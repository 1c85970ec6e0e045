"""The compiled backends of the averaging rules: numba kernels for one velocity (and Gaussian slopes
by their Laplace reduction for any number), loaded on first use.

A kernel is a backend of the rule it computes, not a rule of its own: :class:`~mbimpact.averaging.Adaptive`
runs :mod:`~mbimpact.averaging.compiled.cone` or :mod:`~mbimpact.averaging.compiled.slopes` for one
velocity, :class:`~mbimpact.averaging.Graded` :mod:`~mbimpact.averaging.compiled.graded_cone` or
:mod:`~mbimpact.averaging.compiled.graded_slopes`, and each result says so (``"adaptive[compiled]"``).
The rules :class:`~mbimpact.averaging.Poles` and :class:`~mbimpact.averaging.Laplace` exist compiled
only (:mod:`~mbimpact.averaging.compiled.poles`, :mod:`~mbimpact.averaging.compiled.laplace`). A backend
computes the nodes, error estimate and stopping rule of its rule and agrees with the numpy reference
to rounding; what it does not settle (a facet the mechanism cannot push, rounding or ``max_nodes``
short of rtol) the numpy rule then treats, and warns of.

Importing numba costs ~0.3 s, more than ``import mbimpact`` may take: each module below is imported by
its :class:`~mbimpact.common.compiled.KernelModule` on first use (:func:`mbimpact.compile_kernels` does
it ahead of time). The status codes the kernels return are in :mod:`~mbimpact.averaging.compiled.codes`,
which needs no numba; their shared numerics in :mod:`~mbimpact.averaging.compiled.primitives`.
"""

from __future__ import annotations

from ...common.compiled import KernelModule

__all__ = ["CONE", "GRADED_CONE", "POLES", "SLOPES", "GRADED_SLOPES", "LAPLACE"]

#: The adaptive rule on a cone, one velocity (:mod:`~mbimpact.averaging.compiled.cone`).
CONE = KernelModule("mbimpact.averaging.compiled.cone")
#: The graded rule on a cone, one velocity (:mod:`~mbimpact.averaging.compiled.graded_cone`).
GRADED_CONE = KernelModule("mbimpact.averaging.compiled.graded_cone")
#: The pole rule on a cone, one velocity (:mod:`~mbimpact.averaging.compiled.poles`).
POLES = KernelModule("mbimpact.averaging.compiled.poles")
#: The adaptive rule on a tilt density, one velocity (:mod:`~mbimpact.averaging.compiled.slopes`).
SLOPES = KernelModule("mbimpact.averaging.compiled.slopes")
#: The graded rule on a spatial tilt density, one velocity (:mod:`~mbimpact.averaging.compiled.graded_slopes`).
GRADED_SLOPES = KernelModule("mbimpact.averaging.compiled.graded_slopes")
#: Gaussian slopes by the Laplace reduction, any number of velocities (:mod:`~mbimpact.averaging.compiled.laplace`).
LAPLACE = KernelModule("mbimpact.averaging.compiled.laplace")

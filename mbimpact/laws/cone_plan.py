"""The compiled single impact of a rough law on a cone: the plan of the compiled steps that ``"auto"``
runs, in order, with their node tables (:mod:`mbimpact.laws.compiled_cone` executes it)."""

from __future__ import annotations

import functools

import numpy as np

from ..averaging import Averaging, Graded
from ..averaging.backends import level_plan
from ..averaging.compiled import CONE, GRADED_CONE
from ..averaging.compiled.codes import SKIP
from ..averaging.integrand import AveragingSpec
from ..averaging.poles import pole_plan
from ..common.compiled import KernelModule
from ..roughness.cone import Cone
from .compiled import CompiledImpact

__all__ = ["cone_impact", "KERNELS"]

#: The compiled single impact on a cone (:mod:`mbimpact.laws.compiled_cone`), loaded on first use.
KERNELS = KernelModule("mbimpact.laws.compiled_cone")

# levels of the compiled call's node tables (32, 64, 128 nodes for a cone: the anisotropic W of a foot
# on the ground needs the third); a velocity that needs more goes on in Python with every level
_CONE_LEVELS = 3


def cone_impact(spec: AveragingSpec, methods: tuple[Averaging, ...]) -> CompiledImpact | None:
    """The compiled single impact on a cone that runs the compiled steps of ``methods`` (those of "auto", in
    order), or None where one that "auto" may run for one velocity has none, or the levels fall short of the
    first pair."""
    steps = []
    for method in methods:
        step = method.cone_step(spec)
        if step is None:
            return None
        if step != SKIP:
            steps.append(step)
    n, levels = level_plan(spec)
    if levels < 2 or 2 * spec.roughness.initial_nodes > spec.max_nodes or not steps:
        return None
    return _cone_plan(spec, tuple(steps), n, min(levels, _CONE_LEVELS), Graded.peaked)


@functools.lru_cache(maxsize=64)
def _cone_plan(spec: AveragingSpec, steps: tuple[int, ...], n: int, levels: int, peaked: float) -> CompiledImpact:
    graded, cone = GRADED_CONE.get(), CONE.get()
    pole_n, pole_levels = pole_plan(spec)
    codes = np.array(steps, dtype=np.int64)
    codes.flags.writeable = False
    cone_ = spec.roughness
    assert isinstance(cone_, Cone)
    args = (cone_.alpha, codes, graded.rule_table(n, levels), levels, peaked, cone.rule_table(n, levels),
            levels, cone.rule_table(pole_n, pole_levels), pole_levels, spec.flux == "configuration", spec.e, spec.rtol)
    names = tuple(f"{name}[compiled]" if name != "poles" else name
                  for name in (_STEP_NAMES[step] for step in steps))
    # the single impact without the pole and graded rules until a velocity needs them
    return CompiledImpact(KERNELS, "cone_unpeaked", "cone_batch", args, names, whole="cone_impact")


# the rules of the compiled steps (mbimpact.averaging.compiled.codes), as results name them
_STEP_NAMES = {0: "poles", 1: "graded", 2: "adaptive"}

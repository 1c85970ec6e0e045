"""The codes the compiled averaging backends speak in, importable without numba.

Status codes (what a kernel returns for a velocity) and the steps of a compiled single impact on a
cone (:meth:`mbimpact.averaging.Averaging.cone_step`), with what makes a step hand the velocity on to
the next rule rather than to its own numpy reference (:data:`PASSES_ON`).
"""

from __future__ import annotations

__all__ = ["SETTLED", "DEGENERATE_FACET", "NOT_FACING", "NOT_SETTLED", "STALLED", "CAPPED", "NOT_PEAKED",
           "UNRESOLVED", "NEED_TABLE", "STATUS_NAMES", "POLES_STEP", "GRADED_STEP", "ADAPTIVE_STEP", "SKIP",
           "PASSES_ON"]

#: The velocity is settled to rtol, or why not: a node on a facet the mechanism cannot push; no facing
#: facet (total weight 0); the levels disagree (refine on); rounding amplified by an ill-conditioned W
#: stops the levels above rtol; the last level of the table was reached; the kernels have no peak narrow
#: enough to grade (graded and pole rules); a zero of q was not found (pole rule); the node table ends
#: before the next level (the caller extends it and calls again).
SETTLED, DEGENERATE_FACET, NOT_FACING, NOT_SETTLED, STALLED, CAPPED, NOT_PEAKED, UNRESOLVED, NEED_TABLE = range(9)

#: The status codes by name, in order.
STATUS_NAMES = ("settled", "degenerate facet", "not facing", "not settled", "stalled", "capped", "not peaked",
                "unresolved", "need table")

#: Steps of a compiled single impact on a cone: the pole rule, the graded rule, the adaptive rule.
POLES_STEP, GRADED_STEP, ADAPTIVE_STEP = range(3)

#: A rule that ``"auto"`` never runs for one velocity of the spec (a series for batches, fixed nodes).
SKIP = -1

#: The statuses on which a step hands the velocity on to the next rule of ``"auto"`` (the rule declines);
#: any other status short of SETTLED sends it to the rule's numpy reference instead, which treats it and
#: warns where it must. The pole rule declines whatever stops it; the graded rule where the kernels have
#: no narrow peak; the adaptive rule never.
PASSES_ON: dict[int, frozenset[int]] = {
    POLES_STEP: frozenset(range(1, 9)),
    GRADED_STEP: frozenset({NOT_PEAKED}),
    ADAPTIVE_STEP: frozenset(),
}

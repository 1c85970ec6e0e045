"""Repeated micro-impacts of a rough law: (2.8) applied again while the contact still approaches.

The model assumes one micro-impact per facet. Where the averaged outcome still approaches the surface
(κ < 0: steep facets at normal incidence, or an oblique impact on an anisotropic W), further
micro-impacts follow; ``RoughLaw(repeat=True)`` applies them (:func:`repeated`), with the work bounded by
the law's class attributes (``max_repeats``, ``repeat_budget``, ``exact_budget``, ``coarse_facets``,
``coarse_rtol``, ``settled``, ``contraction``: :class:`mbimpact.RoughLaw`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import warnings
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..averaging import Adaptive, Fixed, Graded
from ..averaging.integrand import AveragingSpec
from ..errors import AccuracyWarning, warn
from ..results.impact import ContactImpulses
from ..results.quantities import SEPARATION_RTOL

if TYPE_CHECKING:
    from .rough import RoughLaw

__all__ = ["repeated", "coarse_spec"]

# the rules whose ``nodes`` count a quadrature rule's nodes a piece (Roughness.rule_size gives its facets)
_REFINED = (Fixed, Adaptive, Graded)


def coarse_spec(law: RoughLaw, graded: bool) -> AveragingSpec:
    """The averaging spec of the micro-impacts beyond ``exact_budget`` (see the class attributes):
    ``coarse_rtol`` and the most nodes a piece (doublings of the measure's ``initial_nodes``, at
    least one) whose rule (``graded`` or not) has at most ``coarse_facets`` facets; this law's
    own spec for a fixed node count, or when that relaxes nothing."""
    spec = law.spec
    if spec.nodes is not None:
        return spec
    rough = spec.roughness
    limit = 2 * max(1, rough.initial_nodes)
    while limit < spec.max_nodes and rough.rule_size(2 * limit, graded) <= law.coarse_facets:
        limit *= 2
    coarse = dataclasses.replace(spec, rtol=max(spec.rtol, law.coarse_rtol), max_nodes=min(spec.max_nodes, limit))
    return spec if (coarse.rtol, coarse.max_nodes) == (spec.rtol, spec.max_nodes) else coarse

def repeated(law: RoughLaw, W: NDArray[np.float64], U: NDArray[np.float64], first: ContactImpulses,
             physical: NDArray[np.float64] | None = None) -> ContactImpulses:
    """Apply (2.8) again to the rows whose contact still approaches, until it separates.

    (2.8) is positively homogeneous of degree 1, so the micro-impacts either throw the
    contact off after finitely many of them, or their directions settle into a fixed
    direction or a two-cycle (bouncing between the walls of a valley) along which
    u_{k+p} = ρ u_k with ρ < 1: the velocities then shrink geometrically to u = 0, and
    the limit of the impulses is the one that stops the contact point, P = −W⁺ u₋.
    (For a speed-dependent facet law, ``physical`` holds the rows' physical speeds.)

    The work is bounded as the class attributes say: once the micro-impacts averaged to rtol
    have cost ``exact_budget``, the rest are coarse (:func:`coarse_spec`); a row whose coarse
    path may have drifted by a tenth of its distance to the tangent plane falls back to its
    last micro-impact averaged to rtol; all stop at ``repeat_budget`` or ``max_repeats``."""
    total, err, nodes = first.P.copy(), first.error.copy(), first.nodes
    coarse: AveragingSpec | None = None  # made once a pass has shown whether the rule is graded
    rough = law.spec.roughness
    B, d = U.shape
    u = U + total @ W  # W is symmetric
    dirs = np.full((2, B, d), np.nan)  # the last two directions of each row, oldest first
    speeds = np.ones((2, B))
    steps = np.full((2, B), np.nan)  # the last two changes of direction |d_k − d_{k−1}|
    # the state after the last micro-impact averaged to rtol, and how far the coarse ones since
    # may have led u astray: Σ |W δP_k| ≤ Σ error_k |W P_k|
    kept_total, kept_u, kept_err, kept_count = total.copy(), u.copy(), err.copy(), np.zeros(B, dtype=int)
    astray = np.zeros(B)
    coarsened = np.zeros(B, dtype=bool)  # rows followed by coarse micro-impacts
    lost = np.zeros(B, dtype=bool)  # rows the coarse micro-impacts could not follow
    work = 0  # facets averaged (passes of rules refined in nodes a piece)
    graded = False  # whether they were graded
    count = 0  # passes made
    todo = np.flatnonzero(u[:, -1] < -SEPARATION_RTOL)  # U is unit
    while todo.size and count < law.max_repeats and work < law.repeat_budget:
        speed = np.linalg.norm(u[todo], axis=1)
        direction = u[todo] / speed[:, None]
        # a coarse path that may have moved u by a tenth of its way to the tangent plane cannot tell
        # whether the contact separates: back to the last micro-impact averaged to rtol
        adrift = coarsened[todo] & ~(astray[todo] <= 0.1 * speed * -direction[:, -1])
        if adrift.any():
            rows = todo[adrift]
            total[rows], u[rows], err[rows], lost[rows] = kept_total[rows], kept_u[rows], kept_err[rows], True
            todo, speed, direction = todo[~adrift], speed[~adrift], direction[~adrift]
            if not todo.size:
                break
        stuck = np.zeros(len(todo), dtype=bool)
        for period in (1, 2):
            rho = speed / speeds[2 - period, todo]
            stuck |= (np.einsum("bd,bd->b", direction, dirs[2 - period, todo]) > 1.0 - law.settled) & (rho < 1.0)
        # a direction converging geometrically (to a fixed point or a two-cycle): its changes shrink
        # by r < 1, so it moves at most step·r/(1 − r) more; if that cannot bring it to the tangent
        # plane and the speed keeps shrinking, the contact is being stopped: settle now
        step = np.linalg.norm(direction - dirs[1, todo], axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = np.maximum(step / steps[1, todo], steps[1, todo] / steps[0, todo])
            drift = step * r / (1.0 - r)
        shrinking = (speed < speeds[1, todo]) & (speeds[1, todo] < speeds[0, todo])
        stuck |= (r < law.contraction) & shrinking & (drift < 0.1 * -direction[:, -1])
        steps[0, todo], steps[1, todo] = steps[1, todo], step
        if stuck.any():
            rows = todo[stuck]
            total[rows] = -np.linalg.lstsq(W, U[rows].T, rcond=1e-12)[0].T  # u₋ + W P = 0
            u[rows] = 0.0
            err[rows], coarsened[rows] = kept_err[rows], False  # coarse micro-impacts only told it stops
            todo, speed, direction = todo[~stuck], speed[~stuck], direction[~stuck]
            if not todo.size:
                break
        if work >= law.exact_budget and coarse is None:
            coarse = coarse_spec(law, graded)
        spec = law.spec if coarse is None else coarse
        # a coarse rule stopped short is expected: its error is kept below (entering catch_warnings resets
        # the once-per-call-site registries, so only coarse passes do)
        with warnings.catch_warnings() if spec is not law.spec else contextlib.nullcontext():
            if spec is not law.spec:
                warnings.simplefilter("ignore", AccuracyWarning)
            if physical is None:
                more, method = law.average_to(spec, W, direction)
                Pk = more.P * speed[:, None]
            else:
                more, method = law.average_to(spec, W, direction * (speed * physical[todo])[:, None])
                Pk = more.P / physical[todo][:, None]
        count += 1
        if isinstance(method, _REFINED):  # the other methods cost little, or what the user asked for
            graded = isinstance(method, Graded)
            work += rough.rule_size(more.nodes, graded)
        nodes = max(nodes, more.nodes)
        err[todo] = np.maximum(err[todo], more.error)
        total[todo] += Pk
        dU = Pk @ W
        u[todo] += dU
        if spec is law.spec:
            kept_total[todo], kept_u[todo], kept_err[todo], kept_count[todo] = total[todo], u[todo], err[todo], count
        else:
            coarsened[todo] = True
            astray[todo] += more.error * np.linalg.norm(dU, axis=1)
        dirs[0, todo], dirs[1, todo] = dirs[1, todo], direction
        speeds[0, todo], speeds[1, todo] = speeds[1, todo], speed
        todo = todo[u[todo, -1] < -SEPARATION_RTOL]
    if todo.size:
        warn(AccuracyWarning, f"{law!r}: the contact still approaches after {_impacts(count)} "
                              f"(n0·u = {u[todo[0], -1]:.3g} for a unit approach), at the limit of "
                              f"RoughLaw.max_repeats = {law.max_repeats} or RoughLaw.repeat_budget = "
                              f"{law.repeat_budget:g} facets")
    if lost.any():
        assert coarse is not None
        i = int(np.flatnonzero(lost)[0])
        warn(AccuracyWarning, f"{law!r}: the contact still approaches after {_impacts(int(kept_count[i]))} "
                              f"(n0·u = {u[i, -1]:.3g} for a unit approach): later ones, averaged to "
                              f"rtol={coarse.rtol:g} with at most {coarse.max_nodes} nodes to bound the work "
                              "(RoughLaw.exact_budget), are too inaccurate on this W to tell whether it separates")
    loose = np.flatnonzero(coarsened & ~lost & (err > law.spec.rtol))
    if loose.size:
        assert coarse is not None
        warn(AccuracyWarning, f"{law!r}: the contact separated after repeated impacts of which the later ones "
                              f"were averaged to rtol={coarse.rtol:g} with at most {coarse.max_nodes} nodes to "
                              f"bound the work (RoughLaw.exact_budget): estimated relative error "
                              f"{err[loose].max():.3g} > rtol={law.spec.rtol:g}")
    return ContactImpulses(total, err, nodes, first.method)


def _impacts(count: int) -> str:
    """"1 repeated impact", "3 repeated impacts"."""
    return f"{count} repeated impact" + ("" if count == 1 else "s")

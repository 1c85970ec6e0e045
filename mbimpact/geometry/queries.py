"""One-call queries: the gaps and contact points of a mechanism against obstacles at one configuration.

Both build (once, then reuse from :mod:`mbimpact.geometry.cache`) the :class:`GapModel` of the
mechanism, obstacles and pairs given, then evaluate it at q. In a loop over configurations,
keeping the :class:`GapModel` yourself saves the cache lookup (~2 µs).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from numpy.typing import ArrayLike

from ..errors import ParameterError
from .cache import remember
from .gap import Gap
from .gap_model import GapModel
from .pairs import Pair
from .shapes import Shape

if TYPE_CHECKING:
    from ..mechanism.mechanism import Mechanism

__all__ = ["gap_model", "gaps", "contact_points"]


def gap_model(mech: Mechanism, obstacles: Sequence[Shape] | Shape = (), *, bodies: Sequence[str] | None = None,
              self_pairs: Sequence[Pair] | str | None = None, srdf: str | Path | None = None) -> GapModel:
    """The (cached) :class:`GapModel` of these obstacles and pairs on ``mech``; arguments as for it."""
    from ..mechanism.mechanism import Mechanism

    if not isinstance(mech, Mechanism):
        raise ParameterError(f"mech must be an mbimpact.Mechanism, got {type(mech).__name__}")
    obs = (obstacles,) if isinstance(obstacles, Shape) else tuple(obstacles)
    try:
        key = (obs, None if bodies is None else tuple(bodies),
               self_pairs if self_pairs is None or isinstance(self_pairs, str) else tuple(map(tuple, self_pairs)),
               None if srdf is None else str(srdf), mech.collision_model().version)
        hash(key)
    except TypeError:  # unhashable arguments: let GapModel say what is wrong with them
        return GapModel(mech, obs, bodies=bodies, self_pairs=self_pairs, srdf=srdf)
    return remember(mech, key, lambda: GapModel(mech, obs, bodies=bodies, self_pairs=self_pairs, srdf=srdf))


def gaps(mech: Mechanism, q: ArrayLike, obstacles: Sequence[Shape] | Shape = (), *,
         bodies: Sequence[str] | None = None, self_pairs: Sequence[Pair] | str | None = None,
         cutoff: float | None = None) -> list[Gap]:
    """One :class:`Gap` per (collision object, obstacle) pair, then per self-collision pair.

    Parameters
    ----------
    mech : Mechanism
    q : array_like, shape (nq,)
    obstacles : sequence of Shape
        World obstacles.
    bodies : sequence of str, optional
        Collision objects paired with each obstacle (default: every moving one).
    self_pairs : sequence of (str, str), or "all", optional
        Pairs of the mechanism's own collision objects.
    cutoff : float, optional
        Keep only the gaps with distance ≤ cutoff.

    Returns
    -------
    list of Gap
        Body-major: for each body, one gap per obstacle in the order given.
    """
    return gap_model(mech, obstacles, bodies=bodies, self_pairs=self_pairs).gaps(q, cutoff)


def contact_points(mech: Mechanism, q: ArrayLike, obstacles: Sequence[Shape] | Shape = (), margin: float = 1e-3, *,
                   bodies: Sequence[str] | None = None, self_pairs: Sequence[Pair] | str | None = None,
                   patch_tolerance: float = 1e-3) -> list[Gap]:
    """Every witness point (whole contact patches) of the pairs closer than ``margin``.

    A box lying flat gives its 4 corners, a box on an edge the 2 ends of the edge; see
    :meth:`GapModel.contact_points`.

    Returns
    -------
    list of Gap
        One per contact point, each with its normal, signed distance and Jacobian.
    """
    return gap_model(mech, obstacles, bodies=bodies, self_pairs=self_pairs).contact_points(q, margin, patch_tolerance)

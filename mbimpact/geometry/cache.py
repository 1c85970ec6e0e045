"""What the geometry layer remembers about a mechanism: its collision model and recent gap models.

The store lives on the mechanism object itself (an attribute the dataclass does not declare), so
it goes with the mechanism: collected with it, dropped when it is pickled (``Mechanism.__reduce__``
rebuilds from the model file, and the geometry is reloaded on first use). Gap models are kept per
key (obstacles by identity, bodies, pairs, the collision model's version) in a small LRU so that
:func:`mbimpact.geometry.gaps` and :class:`mbimpact.geometry.GeometryContact` called in a loop
build their ``pinocchio.GeometryModel`` once.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..mechanism.mechanism import Mechanism

__all__ = ["mechanism_cache", "GAP_MODELS_KEPT", "remember"]

#: Gap models kept per mechanism (least recently used dropped first).
GAP_MODELS_KEPT = 32

_ATTR = "_mbimpact_geometry"
_LOCK = threading.RLock()


def mechanism_cache(mech: Mechanism) -> dict[str, Any]:
    """The geometry store of ``mech`` (created empty on first use)."""
    store = mech.__dict__.get(_ATTR)
    if store is None:
        with _LOCK:
            store = mech.__dict__.get(_ATTR)
            if store is None:
                store = {"lock": threading.RLock(), "gap_models": OrderedDict()}
                object.__setattr__(mech, _ATTR, store)
    return store


def remember(mech: Mechanism, key: tuple[Any, ...], build: Any) -> Any:
    """The gap model stored under ``key``, or ``build()`` stored there (LRU of :data:`GAP_MODELS_KEPT`)."""
    store = mechanism_cache(mech)
    models: OrderedDict[tuple[Any, ...], Any] = store["gap_models"]
    with store["lock"]:
        found = models.get(key)
        if found is not None:
            models.move_to_end(key)
            return found
    value = build()
    with store["lock"]:
        models[key] = value
        while len(models) > GAP_MODELS_KEPT:
            models.popitem(last=False)
    return value

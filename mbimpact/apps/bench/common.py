"""What every part of the bench shares: the row of a measurement, the timer, the machine."""

from __future__ import annotations

import math
import os
import platform
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ...mechanism import Mechanism

__all__ = ["BenchRow", "machine_summary", "per_call", "per_call_together", "moving_frame"]


@dataclass(frozen=True)
class BenchRow:
    """One measurement: ``part`` is accuracy, overhead or batch."""

    part: str
    case: str
    method: str
    param: float
    error: float
    seconds: float
    ratio: float = math.nan


def machine_summary() -> str:
    """Processor, Python, numpy and Pinocchio versions, and whether the compiled front end ran
    (:func:`mbimpact.mechanism.front.status`), for the report."""
    from ...mechanism import front

    return (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, {platform.system()}, "
        f"Python {platform.python_version()}, numpy {np.__version__}, pinocchio {pin.__version__}; "
        f"compiled front end {front.status()}"
    )


def per_call(fn: Callable[[], object], min_time: float) -> float:
    """Best of 3 mean wall times of ``fn()``, each over at least ``min_time`` seconds."""
    return per_call_together({"fn": fn}, min_time, rounds=3)["fn"]


# The timing loop as a user's own code: compiled under a file name outside the package. A warning raised in
# the timed call is attributed to the first frame outside the package, and mbimpact.errors.warn walks the
# stack up to it; from a loop inside the package it would walk on through the bench's own frames, a cost no
# user pays.
_USER_CODE: dict[str, Callable[..., float]] = {}
exec(compile("""
def mean_time(fn, min_time, clock):
    count, start = 0, clock()
    while True:
        fn()
        count += 1
        elapsed = clock() - start
        if elapsed >= min_time:
            return elapsed / count
""", "<the caller's loop>", "exec"), _USER_CODE)


def per_call_together(fns: dict[str, Callable[[], object]], min_time: float, rounds: int = 7) -> dict[str, float]:
    """Mean wall times of several ``fn()`` measured in turn, round after round: each one's best round.

    A busy machine slows down for stretches of a fraction of a second. Timed one after the other,
    a function caught in such a stretch, the reference of a ratio above all, skews every ratio
    formed with it; timed in alternation over ``rounds`` rounds of at least ``min_time`` seconds
    each, every function has rounds outside the stretch, and their best is compared. Each is called
    from a loop that stands where a user's loop would (outside the package).
    """
    best = dict.fromkeys(fns, math.inf)
    mean_time = _USER_CODE["mean_time"]
    for fn in fns.values():
        mean_time(fn, 0.0, time.perf_counter)  # one call: warm caches
    for _ in range(rounds):
        for label, fn in fns.items():
            best[label] = min(best[label], mean_time(fn, min_time, time.perf_counter))
    return best


def moving_frame(mech: Mechanism, q: np.ndarray) -> str:
    """The last-declared frame whose translational Jacobian at q is not zero."""
    for name in reversed(mech.frame_names):
        if np.linalg.norm(mech.point_jacobian(q, name)) > 1e-6:
            return name
    raise ValueError(f"no frame of {mech.name} moves")  # pragma: no cover



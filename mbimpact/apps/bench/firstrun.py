"""Bench of a new user's first command: ``mbimpact demo`` in a fresh interpreter.

Two rows, each the wall time of the whole command as a user runs it (interpreter start-up, import,
Pinocchio, the demo's impacts and its printout):

* ``empty kernel cache`` — ``NUMBA_CACHE_DIR`` points at an empty directory, as on a fresh install:
  every kernel the demo reaches is compiled; this is what the first hour's goal reads;
* ``kernels cached`` — the same command again on the cache it has just written.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time

from ..progress import Progress
from .common import BenchRow

__all__ = ["first_run", "FIRST_DEMO"]

#: The case of the row the first-run goal reads.
FIRST_DEMO = "first mbimpact demo"


def _demo_seconds(env: dict[str, str]) -> float:
    """Wall time of ``python -m mbimpact demo`` in a fresh interpreter with ``env``."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "mbimpact", "demo"], check=True, capture_output=True, env=env)
    return time.perf_counter() - start


def first_run(progress: Progress) -> list[BenchRow]:
    """``mbimpact demo`` on an empty kernel cache, then on the cache it wrote: two rows (``seconds``)."""
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("empty kernel cache", "kernels cached"):
            rows.append(BenchRow("first-run", FIRST_DEMO, label, 0, 0.0, _demo_seconds(env), math.nan))
    progress.step("first run")
    return rows

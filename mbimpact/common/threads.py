"""BLAS threads during a batch: one, whatever the process's setting.

A batch of impacts multiplies tall, thin matrices ((B, 3) by (3, 3), (B, 3) by (3, n)):
products too small along their inner axis for BLAS threads to pay. With OpenBLAS's
default threads on a busy machine they cost more than they save (the rough law's batch
ran 3.2× slower on 2 cores with 2 threads than with 1, measured 2026-11-22). Batches
therefore run with one BLAS thread, set through ``threadpoolctl`` for the duration of
the call and restored after, so the user's own setting is untouched. The BLAS libraries
are those of numpy and scipy (found once, on the first batch).
"""

from __future__ import annotations

import contextlib
import functools
from contextlib import AbstractContextManager
from typing import Any

__all__ = ["SINGLE_THREAD_ROWS", "single_blas_thread"]

# Below this many rows a batch's products are too short for threads to matter, and the
# limit's own cost (~10 µs) would show.
SINGLE_THREAD_ROWS = 256


@functools.cache
def _controller() -> Any:
    """threadpoolctl's controller, made once, on the first batch (it scans the libraries loaded then:
    scipy.linalg is imported first, so that it sees scipy's BLAS beside numpy's)."""
    import scipy.linalg  # noqa: F401
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def single_blas_thread(rows: int) -> AbstractContextManager[Any]:
    """A context in which BLAS runs on one thread, for a batch of ``rows`` rows.

    A no-op below :data:`SINGLE_THREAD_ROWS` rows, and when the process already runs BLAS
    on one thread.
    """
    if rows < SINGLE_THREAD_ROWS:
        return contextlib.nullcontext()
    controller = _controller()
    if all(lib.num_threads == 1 for lib in controller.lib_controllers if lib.user_api == "blas"):
        return contextlib.nullcontext()
    return controller.limit(limits=1, user_api="blas")

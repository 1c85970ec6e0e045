"""Threads during a batch: one for BLAS, whatever the process's setting; several for the
compiled kernels that treat independent rows.

A batch of impacts multiplies tall, thin matrices ((B, 3) by (3, 3), (B, 3) by (3, n)):
products too small along their inner axis for BLAS threads to pay. With OpenBLAS's
default threads on a busy machine they cost more than they save (the rough law's batch
ran 3.2× slower on 2 cores with 2 threads than with 1, measured 2026-11-22). Batches
therefore run with one BLAS thread, set through ``threadpoolctl`` for the duration of
the call and restored after, so the user's own setting is untouched. The BLAS libraries
are those of numpy and scipy (found once, on the first batch).

The compiled kernels of :func:`mbimpact.impact_batch` treat each row on its own and release
the GIL: :func:`over_rows` hands blocks of rows to a pool of threads as the calling thread
gathers them (Pinocchio's work, which holds the GIL). Every row is computed by the same
arithmetic on whichever thread, so results do not depend on the thread count:
:func:`set_kernel_threads`'s setting, else ``MBIMPACT_NUM_THREADS``, else the CPUs the process
may run on (:func:`kernel_threads`).
"""

from __future__ import annotations

import contextlib
import functools
import os
import queue
import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING, Any

from ..errors import ParameterError

if TYPE_CHECKING:  # concurrent.futures is imported on the first threaded batch (it costs ~7 ms)
    from concurrent.futures import Future, ThreadPoolExecutor

__all__ = ["SINGLE_THREAD_ROWS", "ROWS_PER_THREAD", "BLOCK_ROWS", "single_blas_thread", "kernel_threads",
           "set_kernel_threads", "over_rows"]

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


#: Fewest rows a kernel's thread is given: below, handing rows to a thread (~20 µs) costs more
#: than the thread saves.
ROWS_PER_THREAD = 128

_THREADS: list[int | None] = [None]  # set_kernel_threads's setting; None: from the environment


def _available_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def kernel_threads() -> int:
    """How many threads :func:`over_rows` uses: :func:`set_kernel_threads`'s setting, else
    ``MBIMPACT_NUM_THREADS``, else the CPUs the process may run on."""
    n = _THREADS[0]
    if n is None:
        text = os.environ.get("MBIMPACT_NUM_THREADS", "").strip()
        try:
            n = int(text) if text else _available_cpus()
        except ValueError:
            raise ParameterError(f"MBIMPACT_NUM_THREADS must be a positive integer, got {text!r}") from None
        if n < 1:
            raise ParameterError(f"MBIMPACT_NUM_THREADS must be a positive integer, got {text!r}")
    return n


def set_kernel_threads(n: int | None) -> int | None:
    """Set how many threads the batches' compiled kernels use (1: the calling thread only; None: back
    to the default, see :func:`kernel_threads`). Results do not depend on it.

    Returns
    -------
    int or None
        The previous setting: ``set_kernel_threads(previous)`` restores it.

    Raises
    ------
    ParameterError
        ``n`` is not a positive integer or None.
    """
    if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
        raise ParameterError(f"the kernel thread count must be a positive integer or None, got {n!r}")
    previous = _THREADS[0]
    _THREADS[0] = n
    return previous


#: Rows of a block handed from :func:`over_rows`'s producer to its kernel threads: a few hundred
#: microseconds of work each, so that the hand-over (the GIL passed from the producer, which holds it
#: while it fills, to a helper and back) is small beside it.
BLOCK_ROWS = 256


_POOL_LOCK = threading.Lock()
_POOL: list[Any] = [None, 0, 0]  # the executor, its worker count and the process that made it


def _pool(workers: int) -> ThreadPoolExecutor:
    """The process's pool of kernel threads, with at least ``workers`` threads (started as needed).

    One pool per process: made on first use, made again in a forked child (whose copy has no threads)
    and when more threads are asked for (the smaller pool is shut down once its work ends)."""
    from concurrent.futures import ThreadPoolExecutor

    with _POOL_LOCK:
        pool, size, pid = _POOL
        if pool is None or pid != os.getpid() or size < workers:
            if pool is not None and pid == os.getpid():
                pool.shutdown(wait=False)
            pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="mbimpact-kernel")
            _POOL[:] = [pool, workers, os.getpid()]
        return pool


def over_rows(call: Callable[[int, int], None], rows: int,
              fill: Callable[[int, int], None] | None = None) -> None:
    """``call(start, stop)`` over the rows ``[0, rows)``, in contiguous blocks run side by side.

    ``call`` must release the GIL (a numba kernel compiled with ``nogil=True``) and treat each row on
    its own, writing only that row's outputs. At most :func:`kernel_threads` threads, each with at least
    :data:`ROWS_PER_THREAD` rows; the calling thread is one of them, and takes every block the others
    have not started (so a call never waits for threads busy elsewhere: another batch, an enclosing
    one, or a pool that can no longer start threads at interpreter exit).

    Parameters
    ----------
    call : callable
        ``call(start, stop)`` treats rows ``start`` to ``stop``.
    rows : int
    fill : callable, optional
        ``fill(start, stop)`` makes the inputs of those rows (Pinocchio's work, which holds the GIL). If
        given, the calling thread fills block after block of :data:`BLOCK_ROWS` rows while the other
        threads ``call`` each block filled, then joins them: the two kinds of work overlap.

    An exception of ``fill`` or of any block is raised once every block handed to a thread has
    finished; after an exception of ``fill``, the blocks no thread has started yet are dropped.
    """
    available = kernel_threads()
    threads = max(1, min(available, rows // ROWS_PER_THREAD))
    if threads == 1:
        if fill is not None:
            fill(0, rows)
        call(0, rows)
        return
    size = BLOCK_ROWS if fill is not None else -(-rows // threads)
    ready: queue.SimpleQueue[tuple[int, int] | None] = queue.SimpleQueue()

    def work() -> None:
        while (block := ready.get()) is not None:
            call(*block)

    helpers: list[Future[None]] = []
    filled = False
    try:
        pool = _pool(available - 1)
        for _ in range(threads - 1):
            helpers.append(pool.submit(work))
    except RuntimeError:  # no new threads (interpreter exit): the calling thread does it all
        pass
    try:
        for start in range(0, rows, size):
            stop = min(start + size, rows)
            if fill is not None:
                fill(start, stop)
            ready.put((start, stop))
            time.sleep(0)  # lets a waiting helper take the GIL to start the block
        filled = True
    finally:
        for _ in helpers:  # each helper stops at its sentinel, after the blocks queued before it
            ready.put(None)
        try:
            while (block := ready.get_nowait()) is not None:
                if filled:  # else the caller gets fill's exception: the blocks left are dropped
                    call(*block)
            ready.put(None)  # a helper's sentinel, given back (every block was queued before it)
        except queue.Empty:  # the helpers took everything
            pass
        finally:
            # a helper that has not started has nothing left to do: cancelled, and not waited for (wait()
            # would wait until the pool's thread, busy elsewhere, took it off its queue)
            _wait([helper for helper in helpers if not helper.cancel()])
    for helper in helpers:
        if not helper.cancelled():
            helper.result()


def _forget_in_child() -> None:
    """After a fork: the child has none of the parent's threads, nor the batches they ran."""
    global _POOL_LOCK
    _POOL_LOCK = threading.Lock()
    _POOL[:] = [None, 0, 0]


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_in_child)


def _wait(futures: list[Future[None]]) -> None:
    from concurrent.futures import wait

    wait(futures)

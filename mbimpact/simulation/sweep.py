"""Parameter sweeps through any ``concurrent.futures.Executor``.

A local process pool by default; for a cluster pass ``client.get_executor()`` of a
``dask.distributed.Client`` (optional extra ``mbimpact[cluster]``), or any other
Executor. The function and its arguments must be picklable (module-level).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from concurrent.futures import Executor, ProcessPoolExecutor
from typing import Any, TypeVar

__all__ = ["sweep"]

T = TypeVar("T")


def sweep(func: Callable[..., T], params: Iterable[tuple[Any, ...]], executor: Executor | None = None,
          max_workers: int | None = None) -> list[T]:
    """``[func(*p) for p in params]``, evaluated in parallel, results in input order.

    Parameters
    ----------
    executor : Executor, optional
        Where to run; default a ``ProcessPoolExecutor(max_workers)`` created and
        shut down here.
    """
    params = list(params)
    if executor is not None:
        return [f.result() for f in [executor.submit(func, *p) for p in params]]
    with ProcessPoolExecutor(max_workers=max_workers) as pool:
        return [f.result() for f in [pool.submit(func, *p) for p in params]]

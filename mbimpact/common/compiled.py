"""Compiled kernels (numba), loaded on first use, and the registry that makes them all ready at once.

Some laws and averaging methods run their inner loops in modules compiled by numba
(``@njit(cache=True)``). Importing numba costs ~0.3 s, more than ``import mbimpact`` may take, so
each such module is imported by its :class:`KernelModule` on first use; numba then loads the
machine code from its on-disk cache, or compiles it once after an install. :func:`compile_kernels`
does this ahead of time for every kernel module of the package and says what each cost.
"""

from __future__ import annotations

import contextlib
import importlib
import time
from collections.abc import Iterator
from types import ModuleType

__all__ = ["KernelModule", "KERNELS", "compile_kernels"]


class KernelModule:
    """A module of compiled kernels, imported and made callable on first use.

    Parameters
    ----------
    name : str
        Full module name. The module defines ``jit_seconds() -> float``: it calls each of its
        kernels once (numba then loads or compiles them) and returns the wall time that took.

    Registered in :data:`KERNELS` under ``name``.
    """

    def __init__(self, name: str) -> None:
        self.name = name
        self._module: ModuleType | None = None
        KERNELS[name] = self

    def __repr__(self) -> str:
        return f"KernelModule({self.name!r}, ready={self.ready})"

    @property
    def ready(self) -> bool:
        """Whether the kernels are loaded in this process."""
        return self._module is not None

    @property
    def module(self) -> ModuleType | None:
        """The kernel module if it is loaded in this process, else None (nothing is loaded here)."""
        return self._module

    @contextlib.contextmanager
    def unloaded(self) -> Iterator[None]:
        """A context in which the kernels count as not loaded, as in a fresh process (code that runs
        without them until they are needed can be tested so); the loaded module is restored on exit."""
        saved, self._module = self._module, None
        try:
            yield
        finally:
            self._module = saved

    def get(self) -> ModuleType:
        """The kernel module, made ready first if needed (:meth:`compile`)."""
        module = self._module
        if module is None:
            self.compile()
            module = self._module
            assert module is not None
        return module

    def compile(self) -> tuple[float, float]:
        """Import the module and make its kernels callable; time both.

        Returns
        -------
        (import_seconds, jit_seconds) : tuple of float
            Wall times of the import (numba's, mostly, in a fresh process) and of loading the
            kernels' machine code from numba's cache, or compiling it when the cache is missing or
            stale (set ``NUMBA_CACHE_DIR`` to an empty directory to time a cold compilation). Their
            sum is what the first call of a process pays; both are ~0 once done.
        """
        start = time.perf_counter()
        module = importlib.import_module(self.name)
        imported = time.perf_counter() - start
        jitted = float(module.jit_seconds())
        self._module = module
        return imported, jitted


# The packages whose modules register kernels (imported by compile_kernels, so that all are registered).
_OWNERS = ("mbimpact.metric", "mbimpact.averaging", "mbimpact.laws")

#: Every kernel module of the package, by module name (filled as the modules that use them are imported).
KERNELS: dict[str, KernelModule] = {}


def compile_kernels() -> dict[str, tuple[float, float]]:
    """Make every compiled kernel of the package ready (after an install: compile them once).

    Imports the modules that use kernels, so that all of them are registered, then
    :meth:`KernelModule.compile` for each.

    Returns
    -------
    dict
        ``{module name: (import_seconds, jit_seconds)}``; the first entry's import includes numba's.
    """
    for owner in _OWNERS:  # their modules register their kernels
        importlib.import_module(owner)
    return {name: kernels.compile() for name, kernels in sorted(KERNELS.items())}

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
from collections.abc import Callable, Iterator
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["KernelModule", "KERNELS", "compile_kernels", "kernel_array"]


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
        self._entries: dict[str, Callable[..., Any]] = {}
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
        entries, self._entries = self._entries, {}
        try:
            yield
        finally:
            self._module, self._entries = saved, entries

    def get(self) -> ModuleType:
        """The kernel module, made ready first if needed (:meth:`compile`)."""
        module = self._module
        if module is None:
            self.compile()
            module = self._module
            assert module is not None
        return module

    def unchecked(self, name: str) -> Callable[..., Any]:
        """Kernel ``name``'s machine code, called without numba's dispatch.

        numba's dispatcher resolves the type of every argument before each call (~30 ns an
        argument: 0.6 µs of a single impact's ~10 µs for the 19 arguments of
        :func:`mbimpact.laws.compiled_cone.cone_impact`). A kernel compiled for one explicit
        signature needs none of it: its entry point converts the arguments as that signature says.
        It checks nothing: an array of another dtype or number of dimensions is read as if it had
        the signature's (wrong values, or memory out of bounds). Only for arguments the package
        made itself, of the signature's types. Run interpreted (``NUMBA_DISABLE_JIT=1``), the plain
        function.
        """
        entry = self._entries.get(name)
        if entry is None:
            kernel = getattr(self.get(), name)
            signatures = getattr(kernel, "signatures", None)
            if signatures is None:  # interpreted: the function itself
                entry = kernel
            else:  # a kernel of the package, compiled for its one explicit signature
                assert len(signatures) == 1, f"{self.name}.{name}: {len(signatures)} signatures"
                entry = kernel.overloads[signatures[0]].entry_point
            self._entries[name] = entry
        return entry

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


def kernel_array(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """``a`` as the kernels are compiled for it (C-contiguous, writeable float64), copied only if need be:
    any other layout, dtype or a read-only array would make numba compile another specialisation, for
    seconds."""
    flags = a.flags
    if a.dtype == np.float64 and flags.c_contiguous and flags.writeable:
        return a
    return np.array(a, dtype=np.float64, order="C")


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

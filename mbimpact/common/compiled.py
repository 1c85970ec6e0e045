"""Compiled kernels (numba), loaded on first use, and the registry that makes them all ready at once.

Some laws and averaging methods run their inner loops in modules compiled by numba
(``@njit(cache=True)``). Importing numba costs ~0.3 s, more than ``import mbimpact`` may take, so
each such module is imported by its :class:`KernelModule` on first use. Its entry points are declared
with :func:`kernel`: one explicit signature each, compiled on the first call that reaches the entry
point (numba loads the machine code from its on-disk cache, or compiles it once after an install), so
that a command compiles what it runs and nothing else. Where that compilation takes a while, one line
on stderr says so, once per process (:func:`compile_notice`). :func:`compile_kernels` makes every
kernel of the package ready ahead of time and says what each module cost.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import os
import sys
import threading
import time
from collections.abc import Callable, Iterator
from types import ModuleType
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

__all__ = ["KernelModule", "KERNELS", "compile_kernels", "kernel_array", "kernel", "compile_notice",
           "NOTICE_SECONDS"]

_F = TypeVar("_F", bound=Callable[..., Any])


class KernelModule:
    """A module of compiled kernels, imported and made callable on first use.

    Parameters
    ----------
    name : str
        Full module name. The module defines ``jit_seconds() -> float``: it calls each of its
        entry points once (numba then loads or compiles them) and returns the wall time that took.

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
        """Whether the module is imported in this process (its entry points compile on first call)."""
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
        """The kernel module, imported first if needed; each entry point compiles (or loads from numba's
        cache) on its first call, for its one signature (:func:`kernel`)."""
        module = self._module
        if module is None:
            module = self._module = importlib.import_module(self.name)
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
            function = getattr(self.get(), name)
            if not hasattr(function, "signatures"):  # interpreted: the function itself
                entry = function
            else:  # a kernel of the package, compiled for its one explicit signature
                getattr(function, "ensure_compiled", lambda: None)()
                signatures = function.signatures
                assert len(signatures) == 1, f"{self.name}.{name}: {len(signatures)} signatures"
                entry = function.overloads[signatures[0]].entry_point
            self._entries[name] = entry
        return entry

    def compile(self) -> tuple[float, float]:
        """Import the module and make every entry point of it callable; time both.

        Returns
        -------
        (import_seconds, jit_seconds) : tuple of float
            Wall times of the import (numba's, mostly, in a fresh process) and of loading the
            kernels' machine code from numba's cache, or compiling it when the cache is missing or
            stale (set ``NUMBA_CACHE_DIR`` to an empty directory to time a cold compilation). Their
            sum is what the first calls of a process pay if they reach every entry point; both are
            ~0 once done.
        """
        start = time.perf_counter()
        module = importlib.import_module(self.name)
        imported = time.perf_counter() - start
        with compile_notice(self.name):
            jitted = float(module.jit_seconds())
        self._module = module
        return imported, jitted


#: Seconds of compiling after which :func:`compile_notice` says, on stderr, what is being compiled.
NOTICE_SECONDS = 1.5

# whether the notice was printed in this process, and how deep compile_notice contexts are nested
_notice = {"printed": False, "depth": 0}
_notice_lock = threading.Lock()


def _cache_dir(module: str) -> str:
    """Where numba keeps the machine code of ``module``'s kernels: ``NUMBA_CACHE_DIR``, else the
    ``__pycache__`` next to the module's source (numba's choice where that is writable)."""
    configured = os.environ.get("NUMBA_CACHE_DIR", "")
    if configured:
        return configured
    source = getattr(sys.modules.get(module), "__file__", None)
    return os.path.join(os.path.dirname(source), "__pycache__") if source else "numba's cache directory"


def _print_notice(what: str, where: str) -> None:
    with _notice_lock:
        if _notice["printed"]:
            return
        _notice["printed"] = True
    print(f"mbimpact: compiling numba kernels for {what} (once; cached on disk in {where}) …", file=sys.stderr,
          flush=True)


@contextlib.contextmanager
def compile_notice(what: str, module: str | None = None) -> Iterator[None]:
    """A context that compiles kernels: if it lasts longer than :data:`NOTICE_SECONDS`, one line on
    stderr says what is being compiled and where numba caches it, once per process (a fresh install
    compiles for seconds, silently otherwise). Quick compilations and loads from the cache print
    nothing; nested contexts count as the outermost.

    Parameters
    ----------
    what : str
        What is compiled (a kernel or a kernel module).
    module : str, optional
        The module whose cache directory the line names; ``what`` if not given.
    """
    with _notice_lock:
        outermost = _notice["depth"] == 0 and not _notice["printed"]
        _notice["depth"] += 1
    timer = None
    if outermost:
        timer = threading.Timer(NOTICE_SECONDS, _print_notice, (what, _cache_dir(module or what)))
        timer.daemon = True
        timer.start()
    try:
        yield
    finally:
        if timer is not None:
            timer.cancel()
        with _notice_lock:
            _notice["depth"] -= 1


@functools.cache
def _lazy_dispatcher() -> type:
    """The numba dispatcher class of :func:`kernel` (numba imported on first use)."""
    from numba.core import typeinfer
    from numba.core.compiler_lock import global_compiler_lock
    from numba.core.registry import CPUDispatcher

    base: Any = CPUDispatcher  # numba's private hooks below are not in its annotations

    class LazyKernel(base):
        """A numba dispatcher for one explicit signature, compiled when first reached: by a call from
        Python, or by the compilation of a kernel that calls it."""

        _signature: Any = None

        def ensure_compiled(self) -> None:
            """Compile (or load from numba's cache) the signature, and no other, if not done yet."""
            with global_compiler_lock:  # a batch's first calls may come from several threads at once
                if self._can_compile and self._signature is not None:
                    f = self.py_func
                    with compile_notice(f"{f.__module__}.{f.__qualname__}", f.__module__), \
                            typeinfer.register_dispatcher(self):
                        self.compile(self._signature)
                    self.disable_compile()

        def get_call_template(self, args: Any, kws: Any) -> Any:  # typing a call from compiled code
            self.ensure_compiled()
            return super().get_call_template(args, kws)

        def _compile_for_args(self, *args: Any, **kws: Any) -> Any:  # a call from Python: the code to call
            if not self._can_compile or self._signature is None:
                return super()._compile_for_args(*args, **kws)
            self.ensure_compiled()
            # the signature's machine code where the arguments convert to it (as numba's dispatch picks
            # it from now on), else numba's TypeError
            if not kws and self._search_new_conversions(*args):
                return self.overloads[self.signatures[0]].entry_point
            return self._explain_matching_error(*args)

    return LazyKernel


def kernel(signature: Any, **options: Any) -> Callable[[_F], _F]:
    """``numba.njit(signature, cache=True, **options)``, compiled when first reached rather than on import.

    A kernel module's entry points have one explicit signature each: a call with arrays of other
    layouts or flags is converted to it rather than compiled again. numba compiles explicit signatures
    when the decorator runs; this one waits for the first call from Python, or for the compilation of a
    kernel that calls it, so that importing the module compiles nothing and a command compiles the
    entry points it reaches (:func:`compile_notice` says so where that takes a while). With
    ``NUMBA_DISABLE_JIT=1``, the function itself.

    Parameters
    ----------
    signature : numba signature
        The one signature of the entry point.
    **options
        numba's options (``error_model``, ``nogil``, ``fastmath``, …).
    """
    def wrap(function: _F) -> _F:
        from numba.core import config

        if getattr(config, "DISABLE_JIT", False):
            return function
        dispatcher = _lazy_dispatcher()(py_func=function, locals={},
                                        targetoptions={"nopython": True, "boundscheck": None, **options})
        dispatcher._signature = signature
        dispatcher.enable_caching()
        return dispatcher

    return wrap


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

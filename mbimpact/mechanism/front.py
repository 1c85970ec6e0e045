"""The compiled front end of a single impact: Pinocchio's stage of the pipeline in one C++ call.

A single impact is a few microseconds of Pinocchio's work (the frame Jacobian, ``crba``, the
Cholesky factor of A(q)) and, around it, Python's calls, checks and conversions, which cost more
than the work itself. The extension :mod:`mbimpact.mechanism.native` (``native.cpp``) does the
whole front of it in one call on the live ``pinocchio.Model``, with the same machine code as
Pinocchio's Python bindings run: it checks q and v, computes J(q), A(q) and the factor into
buffers the caller owns, and, for Newton's law, the impact (1.2) itself: the same algorithm as the
Python route, with the same results to rounding. What it does not handle (inputs that need a named
error, degenerate impacts) it hands back to the Python route, which treats or names it.

The extension is compiled at ``pip install`` against the headers of the ``pin`` wheel present then
(:mod:`mbimpact.mechanism.native_build`). It is used only where it was built and that Pinocchio is
the one running (a C++ module on a different Pinocchio would read its objects wrongly);
:func:`status` says which. ``MBIMPACT_NATIVE=0`` in the environment, or :func:`disabled`, turns
it off: every impact then takes the Python route.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from types import ModuleType

import pinocchio as pin

__all__ = ["NATIVE", "available", "status", "disabled"]


def _load() -> tuple[ModuleType | None, str]:
    if os.environ.get("MBIMPACT_NATIVE", "").strip() == "0":
        return None, "off: MBIMPACT_NATIVE=0"
    try:
        from . import native
    except ImportError as exc:
        return None, f"not built at install (no C++ compiler or headers then?): {exc}"
    if native.PINOCCHIO_VERSION != pin.__version__:
        return None, (f"off: built for Pinocchio {native.PINOCCHIO_VERSION}, running {pin.__version__} "
                      "(reinstall mbimpact to rebuild it)")
    return native, f"on: built for Pinocchio {native.PINOCCHIO_VERSION}"


_LOADED, _STATUS = _load()
NATIVE: ModuleType | None = _LOADED
"""The extension module where it is in use, else None (read at each call: :func:`disabled` sets it)."""


def available() -> bool:
    """Whether single impacts run through the compiled front end in this process."""
    return NATIVE is not None


def status() -> str:
    """Whether the front end is in use, and if not, why (``"on: built for Pinocchio 4.1.0"``, ...)."""
    return _STATUS if NATIVE is _LOADED else "off: disabled()"


@contextlib.contextmanager
def disabled() -> Iterator[None]:
    """A context in which every impact takes the Python route (to compare the two, or to time it)."""
    global NATIVE
    saved, NATIVE = NATIVE, None
    try:
        yield
    finally:
        NATIVE = saved

"""Hypothesis profiles and fixtures shared by every test (helpers are in :mod:`tests.helpers`).

Profiles: ``ci`` (default, fast, derandomised) and ``nightly``
(``--hypothesis-profile=nightly``, 10⁴ examples per property).
"""

from __future__ import annotations

import numpy as np
import pytest

import mbimpact as mbi
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", max_examples=60, deadline=None, derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "nightly", max_examples=10_000, deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("ci")


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels() -> None:
    """Every compiled kernel of the package, loaded (or compiled, ~40 s on a fresh install) once before
    any test, so that no test's time limit pays for the JIT."""
    mbi.compile_kernels()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


@pytest.fixture
def small_blocks(monkeypatch):
    """Kernel-thread blocks of a few rows, so that short row counts are split between threads and blocks;
    the kernel thread setting restored after."""
    from mbimpact.common import threads

    monkeypatch.setattr(threads, "ROWS_PER_THREAD", 2)
    monkeypatch.setattr(threads, "BLOCK_ROWS", 3)
    previous = mbi.set_kernel_threads(None)
    yield
    mbi.set_kernel_threads(previous)

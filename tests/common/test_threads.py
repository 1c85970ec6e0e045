"""Batches run BLAS on one thread, whatever the process's setting, and restore it after; the compiled
kernels' rows are shared between threads without changing a bit."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import mbimpact as mbi
from mbimpact.common import SINGLE_THREAD_ROWS
from mbimpact.common import threads
from tests.helpers import mechanism


def blas_threads() -> list[int]:
    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


class Recording(mbi.NewtonLaw):
    """Newton's law through the general batch route, recording the BLAS threads it ran with."""

    seen: list[list[int]]

    def contact_impulses(self, W, U):
        self.seen.append(blas_threads())
        return super().contact_impulses(W, U)

    def apply_batch(self, A, J, V, frame):  # the base class's route (NewtonLaw's closed form bypasses contact_impulses)
        return mbi.ImpactLaw.apply_batch(self, A, J, V, frame)


@pytest.fixture
def ur5_batch():
    mech = mechanism("ur5")
    rng = np.random.default_rng(5)
    q = mech.random_configuration(rng)
    J, A = mech.point_jacobian(q, "tool0"), mech.mass_matrix(q)
    V = rng.normal(size=(2 * SINGLE_THREAD_ROWS, mech.nv))
    V[V @ J[2] > 0] *= -1
    return A, J, V


@pytest.mark.parametrize("rows, inside", [(2 * SINGLE_THREAD_ROWS, 1), (SINGLE_THREAD_ROWS // 2, 2)])
def test_a_batch_runs_blas_on_one_thread_and_restores_the_setting(ur5_batch, rows, inside):
    if not blas_threads():
        pytest.skip("numpy links no BLAS that threadpoolctl can see")
    A, J, V = ur5_batch
    law = Recording(0.5)
    law.seen = []
    with threadpool_limits(limits=2, user_api="blas"):
        res = law.apply_batch(A, J, V[:rows], [0.0, 0.0, 1.0])
        assert set(blas_threads()) == {2}  # restored
    assert law.seen and all(set(s) == {inside} for s in law.seen)
    # the same impacts as the closed form
    np.testing.assert_allclose(res.V_plus, mbi.NewtonLaw(0.5).apply_batch(A, J, V[:rows], [0.0, 0.0, 1.0]).V_plus,
                               rtol=1e-12, atol=1e-12)


# ---------------------------------------------------------------- the compiled kernels' threads
@pytest.mark.parametrize("count", [1, 2, 4])
@pytest.mark.parametrize("rows", [0, 1, 5, 40])
@pytest.mark.parametrize("with_fill", [False, True])
def test_over_rows_treats_every_row_once_after_its_fill(small_blocks, count, rows, with_fill):
    """Every row is called exactly once, on at most ``count`` threads, and only after fill made it; the
    threads other than the caller's take part when the work is slow enough to share."""
    mbi.set_kernel_threads(count)
    made, seen, names = np.zeros(rows, int), np.zeros(rows, int), set()
    lock = threading.Lock()

    def fill(a, b):
        made[a:b] += 1
        time.sleep(0.001)  # the caller's filling takes time too: the workers have blocks to take meanwhile

    def call(a, b):
        assert not with_fill or np.all(made[a:b] == 1)
        time.sleep(0.002)  # slow work, released GIL: the other threads pick up blocks meanwhile
        with lock:
            seen[a:b] += 1
            names.add(threading.current_thread().name)

    threads.over_rows(call, rows, fill if with_fill else None)
    assert np.all(seen == 1) and (not with_fill or np.all(made == 1))
    assert len(names) <= count
    if count > 1 and rows >= 40:
        assert any(name.startswith("mbimpact-kernel") for name in names)


@pytest.mark.parametrize("with_fill", [False, True])
def test_over_rows_raises_a_blocks_error_after_every_block_ends(small_blocks, with_fill):
    """A block that raises: the error reaches the caller, once the other threads' blocks have ended
    (they write into the caller's arrays)."""
    mbi.set_kernel_threads(2)
    done = []

    def call(a, b):
        if a == 0:
            raise RuntimeError("block 0 failed")
        time.sleep(0.002)
        done.append((a, b))

    with pytest.raises(RuntimeError, match="block 0 failed"):
        threads.over_rows(call, 30, (lambda a, b: None) if with_fill else None)
    count = len(done)
    time.sleep(0.05)
    assert len(done) == count  # nothing still running once over_rows has returned


def test_over_rows_raises_fills_error_and_drops_the_blocks_not_started(small_blocks):
    """fill raises at a later block: that error reaches the caller, no row past the failed block is
    called, and nothing runs after over_rows returns."""
    mbi.set_kernel_threads(2)
    called = []

    def fill(a, b):
        if a >= 12:
            raise KeyError("row 12")

    def call(a, b):
        time.sleep(0.001)
        called.append((a, b))

    with pytest.raises(KeyError, match="row 12"):
        threads.over_rows(call, 30, fill)
    count = len(called)
    time.sleep(0.05)
    assert len(called) == count and all(b <= 12 for _, b in called)


def test_kernel_threads_setting_and_its_errors(monkeypatch):
    """set_kernel_threads returns the previous setting (which restores it); the environment sets the
    default; a count that is not a positive integer is named."""
    previous = mbi.set_kernel_threads(None)
    try:
        monkeypatch.setenv("MBIMPACT_NUM_THREADS", "3")
        assert mbi.kernel_threads() == 3
        assert mbi.set_kernel_threads(1) is None and mbi.kernel_threads() == 1
        assert mbi.set_kernel_threads(None) == 1 and mbi.kernel_threads() == 3
        monkeypatch.delenv("MBIMPACT_NUM_THREADS")
        assert mbi.kernel_threads() >= 1
        for bad in (0, -2, 1.5, True, "2"):
            with pytest.raises(mbi.ParameterError, match="positive integer or None"):
                mbi.set_kernel_threads(bad)
        for text in ("0", "two", "-1"):
            monkeypatch.setenv("MBIMPACT_NUM_THREADS", text)
            with pytest.raises(mbi.ParameterError, match="MBIMPACT_NUM_THREADS must be a positive integer"):
                mbi.kernel_threads()
    finally:
        mbi.set_kernel_threads(previous)


def test_impact_batch_is_the_same_on_any_number_of_threads(small_blocks):
    """The compiled rows of a batch are the same to the bit on one thread or several, for the rough cone
    and the Coulomb law (each row is the same arithmetic on whichever thread)."""
    mech = mechanism("ur5")
    rng = np.random.default_rng(11)
    contact = mbi.PointContact("tool0")
    Q = np.stack([mech.random_configuration(rng) for _ in range(50)])
    V = rng.normal(size=(50, mech.nv))
    for i, q in enumerate(Q):
        jz = mech.point_jacobian(q, "tool0")[2]
        V[i] -= (1.0 + max(jz @ V[i], 0.0)) * jz / float(jz @ jz)
    for law in (mbi.RoughLaw(mbi.Cone(0.4), 0.5), mbi.CoulombLaw(0.5, 0.3)):
        mbi.set_kernel_threads(1)
        one = mbi.impact_batch(mech, Q, V, contact, law)
        mbi.set_kernel_threads(2)
        two = mbi.impact_batch(mech, Q, V, contact, law)
        for name in ("V_plus", "P", "U_plus", "A", "J", "error_estimate"):
            assert np.array_equal(getattr(one, name), getattr(two, name)), name


def _run_in_thread(target, timeout=60.0):
    """target() on a daemon thread; True if it returned within ``timeout`` seconds."""
    worker = threading.Thread(target=target, daemon=True)
    worker.start()
    worker.join(timeout)
    return not worker.is_alive()


def test_over_rows_nested_in_a_fill_does_not_wait_for_busy_threads(small_blocks):
    """A batch started inside another's fill (a contact whose jacobian runs a batch) finds the pool's
    threads busy with the outer batch: it does its blocks itself and returns."""
    mbi.set_kernel_threads(2)
    inner_seen, outer_seen = np.zeros(40, int), np.zeros(60, int)

    def inner(a, b):
        inner_seen[a:b] += 1

    def outer_fill(a, b):
        if a == 9:
            threads.over_rows(inner, 40, lambda a, b: None)

    def outer(a, b):
        time.sleep(0.001)
        outer_seen[a:b] += 1

    assert _run_in_thread(lambda: threads.over_rows(outer, 60, outer_fill))
    assert np.all(inner_seen == 1) and np.all(outer_seen == 1)


def test_over_rows_in_a_forked_child(small_blocks):
    """A child forked after the parent's threads ran gets threads of its own (its copy of the pool has
    none), and its batches complete."""
    import multiprocessing

    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork on this platform")
    mbi.set_kernel_threads(2)
    threads.over_rows(lambda a, b: time.sleep(0.001), 40, lambda a, b: None)  # the parent's pool at work
    context = multiprocessing.get_context("fork")
    child = context.Process(target=threads.over_rows, args=(_slow_rows, 40, _no_fill))
    child.start()
    child.join(60)
    alive = child.is_alive()
    if alive:
        child.kill()
    assert not alive and child.exitcode == 0


def _slow_rows(a, b):
    time.sleep(0.001)


def _no_fill(a, b):
    pass


def test_over_rows_at_interpreter_exit():
    """From an atexit handler (the pool can no longer start threads) the calling thread does the rows."""
    import subprocess
    import sys

    code = ("import atexit, numpy as np, mbimpact as mbi\n"
            "from mbimpact.common import threads\n"
            "threads.ROWS_PER_THREAD, threads.BLOCK_ROWS = 2, 3\n"
            "mbi.set_kernel_threads(2)\n"
            "seen = np.zeros(30, int)\n"
            "def call(a, b): seen[a:b] += 1\n"
            "@atexit.register\n"
            "def at_exit():\n"
            "    threads.over_rows(call, 30, lambda a, b: None)\n"
            "    print('rows', int(seen.sum()), 'once', bool(np.all(seen == 1)))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "rows 30 once True", out.stderr


def test_kernel_threads_are_one_pool(small_blocks):
    """Batches of every size share the process's pool: at most kernel_threads() − 1 threads are kept."""
    mbi.set_kernel_threads(4)
    for rows in range(4, 12):  # 2, 3 and 4 threads a call (ROWS_PER_THREAD = 2)
        threads.over_rows(lambda a, b: None, rows, lambda a, b: None)
    kept = [t for t in threading.enumerate() if t.name.startswith("mbimpact-kernel")]
    assert len(kept) <= 3

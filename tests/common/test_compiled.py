"""Compiled kernels on first use (mbimpact.common.compiled): the entry point called without numba's
dispatch is the same machine code, and it is forgotten with the module."""

import numpy as np

from mbimpact.common.compiled import KernelModule
from mbimpact.laws.cone_plan import KERNELS as ROUGH_KERNELS
from mbimpact.metric.delassus import KERNELS as METRIC_KERNELS

from tests.helpers import mechanism


def _state(seed):
    mech = mechanism("ur5")
    rng = np.random.default_rng(seed)
    q = mech.random_configuration(rng)
    _A, U, D = mech.factor_arrays(q)
    J = mech.point_jacobian(q, "tool0")
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    v = -J.T @ R[:, 2] + 0.1 * rng.normal(size=mech.nv)
    return U, D, J, v, R


def test_the_unchecked_entry_computes_what_the_dispatcher_does():
    for seed in range(5):
        U, D, J, v, R = _state(seed)
        kernels = METRIC_KERNELS.get()
        got, want = np.full(6 * 6 + 33, 7.0), np.full(6 * 6 + 33, 7.0)  # (parts stay unwritten)
        a = METRIC_KERNELS.unchecked("prepare_factor")(U, D, J, v, R, 1e-14, 1e-12, got)
        b = kernels.prepare_factor(U, D, J, v, R, 1e-14, 1e-12, want)
        assert a == b and a[0] == kernels.READY
        assert np.array_equal(got, want)


def test_it_is_kept_with_the_module_and_forgotten_with_it():
    entry = ROUGH_KERNELS.unchecked("cone_impact")
    assert ROUGH_KERNELS.unchecked("cone_impact") is entry
    with ROUGH_KERNELS.unloaded():
        assert not ROUGH_KERNELS.ready
        ROUGH_KERNELS.unchecked("cone_impact")  # loads the module again
        assert ROUGH_KERNELS.ready
    assert ROUGH_KERNELS.unchecked("cone_impact") is entry


def test_an_interpreted_kernel_is_its_own_entry(tmp_path, monkeypatch):
    # NUMBA_DISABLE_JIT=1 leaves plain functions: no signatures, nothing to skip
    (tmp_path / "plain_kernels.py").write_text("def add(a, b):\n    return a + b\n\n"
                                               "def jit_seconds():\n    return 0.0\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    module = KernelModule("plain_kernels")
    try:
        assert module.unchecked("add")(2, 3) == 5
    finally:
        from mbimpact.common.compiled import KERNELS

        KERNELS.pop("plain_kernels", None)


# A kernel module of two entry points, the second calling the first (compiled first, for its own signature).
_TINY = '''
import time

import numpy as np
from numba import types

from mbimpact.common.compiled import kernel

_IN1 = types.Array(types.float64, 1, "A", readonly=True)


@kernel(types.float64(_IN1), error_model="numpy")
def total(x):
    s = 0.0
    for k in range(x.shape[0]):
        s += x[k]
    return s


@kernel(types.float64(_IN1, types.float64), error_model="numpy")
def scaled_total(x, a):
    return a * total(x)


def jit_seconds():
    start = time.perf_counter()
    scaled_total(np.ones(2), 1.0)
    return time.perf_counter() - start
'''

# Runs the tiny module's kernels in a fresh interpreter, numba's compiler made slow (0.6 s a compilation, on a
# cache miss only) and the notice's delay short: what a user's first command sees after an install.
_SLOW_FIRST_CALL = '''
import time

import numba
import numba.core.dispatcher as dispatcher
import numpy as np

from mbimpact.common import compiled

numba.njit(lambda: 0)()  # numba's own set-up, once a process, outside the timed part
compiled.NOTICE_SECONDS = 0.3
compile_ = dispatcher._FunctionCompiler.compile


def slow(self, args, return_type):
    time.sleep(0.6)
    return compile_(self, args, return_type)


dispatcher._FunctionCompiler.compile = slow
kernels = compiled.KernelModule("tiny_kernels").get()
assert kernels.total.signatures == [] and kernels.scaled_total.signatures == []  # nothing compiled on import
print(kernels.scaled_total(np.arange(4.0), 2.0), kernels.total(np.arange(3.0)))
print(len(kernels.total.signatures), len(kernels.scaled_total.signatures))
print(sum(kernels.total.stats.cache_hits.values()) + sum(kernels.scaled_total.stats.cache_hits.values()))
'''


def _tiny_module(tmp_path):
    (tmp_path / "tiny_kernels.py").write_text(_TINY)
    (tmp_path / "first_call.py").write_text(_SLOW_FIRST_CALL)


def test_a_slow_compilation_says_so_once_and_a_cached_one_says_nothing(tmp_path):
    import os
    import subprocess
    import sys

    _tiny_module(tmp_path)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(tmp_path))

    def run():
        done = subprocess.run([sys.executable, str(tmp_path / "first_call.py")], capture_output=True, text=True,
                              env=env, timeout=120, check=False)
        assert done.returncode == 0, done.stderr
        return done.stdout.split(), done.stderr

    out, err = run()  # an empty cache: both kernels compiled, each for its one signature
    assert out == ["12.0", "3.0", "1", "1", "0"]
    notices = [line for line in err.splitlines() if line.startswith("mbimpact: compiling numba kernels")]
    want = f"mbimpact: compiling numba kernels for tiny_kernels.scaled_total (once; cached on disk in {tmp_path}"
    assert notices == [want + "/cache) …"]
    out, err = run()  # both loaded from the cache: quick, silent
    assert out == ["12.0", "3.0", "1", "1", "2"]
    assert "mbimpact: compiling" not in err


def test_the_notice_waits_for_a_slow_compilation(monkeypatch, capsys):
    import time

    from mbimpact.common import compiled

    monkeypatch.setattr(compiled, "_notice", {"printed": False, "depth": 0})
    monkeypatch.setattr(compiled, "NOTICE_SECONDS", 0.1)
    with compiled.compile_notice("quick kernels"):
        pass
    time.sleep(0.3)
    assert capsys.readouterr().err == ""  # done before the delay: nothing to say
    # nested (the kernels a kernel calls): counted in the outermost
    with compiled.compile_notice("slow kernels"), compiled.compile_notice("the kernels they call"):
        time.sleep(0.3)
    with compiled.compile_notice("more slow kernels"):  # once per process
        time.sleep(0.3)
    err = capsys.readouterr().err
    assert err.startswith("mbimpact: compiling numba kernels for slow kernels (once; cached on disk in ")
    assert err.count("\n") == 1


def test_a_kernel_converts_other_arrays_to_its_signature_and_refuses_other_types(tmp_path, monkeypatch):
    import numpy as np
    import pytest

    _tiny_module(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    module = KernelModule("tiny_kernels")
    try:
        kernels = module.get()
        x = np.arange(6.0)[::2]  # strided and writeable: the signature's read-only "A" array takes it
        assert kernels.total(x) == 6.0 and kernels.total(np.ones(3)) == 3.0
        assert len(kernels.total.signatures) == 1
        with pytest.raises(TypeError, match="No matching definition"):
            kernels.total(np.ones((2, 2)))
        assert len(kernels.total.signatures) == 1
        assert module.unchecked("scaled_total")(np.ones(2), 3.0) == 6.0
    finally:
        from mbimpact.common.compiled import KERNELS

        KERNELS.pop("tiny_kernels", None)

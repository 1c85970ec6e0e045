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

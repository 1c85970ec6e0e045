"""Sweeps run through any concurrent.futures Executor: process pool, threads, dask."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.simulation import sweep


def kappa_at(alpha: float, tan_beta: float) -> float:
    return mbi.RoughLaw(mbi.Cone(alpha), 0.8).apply(np.eye(3), np.eye(3), [tan_beta, 0.0, -1.0], [0, 0, 1]).kappa


PARAMS = [(a, t) for a in (0.1, 0.3) for t in (0.0, 1.0, 3.0)]


def test_default_process_pool_keeps_input_order():
    assert sweep(kappa_at, PARAMS, max_workers=2) == [kappa_at(*p) for p in PARAMS]


def test_any_executor():
    with ThreadPoolExecutor(2) as pool:
        assert sweep(kappa_at, PARAMS, pool) == [kappa_at(*p) for p in PARAMS]


def test_dask_local_cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            assert sweep(kappa_at, PARAMS, client.get_executor()) == [kappa_at(*p) for p in PARAMS]


def test_stability_map_runs_through_an_executor():
    with ThreadPoolExecutor(2) as pool:
        (row,) = mbi.section4.stability_map([(mbi.Cone(0.3), 0.8, 1)], np.array([-0.5, 0.5, 1.5]), periods=12,
                                            executor=pool)
    assert row["status"] == ["completed"] * 3
    np.testing.assert_array_equal(row["growth"] > 0, [True, False, True])


def test_threads_sharing_one_mechanism_get_the_same_impacts():
    """Each thread has its own Pinocchio workspace: crba → Cholesky → solve cannot interleave."""
    import sys

    mech = mbi.Mechanism.from_robot("ur5")
    contact = mbi.PointContact("tool0")
    rng = np.random.default_rng(2)
    cases = []
    for _ in range(40):
        q = mech.random_configuration(rng)
        v = -mech.point_jacobian(q, "tool0")[2] + 0.05 * rng.normal(size=6)
        cases.append((q, v if mech.point_jacobian(q, "tool0")[2] @ v < 0 else -v))
    law = mbi.NewtonLaw(0.5)
    expected = [mbi.impact(mech, q, v, contact, law).v_plus for q, v in cases]
    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # switch threads as often as possible
    try:
        with ThreadPoolExecutor(4) as pool:
            for _ in range(5):
                got = list(pool.map(lambda c: mbi.impact(mech, c[0], c[1], contact, law).v_plus, cases))
                for a, b in zip(got, expected):
                    np.testing.assert_array_equal(a, b)
    finally:
        sys.setswitchinterval(old)

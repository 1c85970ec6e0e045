"""Sweeps run through any concurrent.futures Executor: process pool, threads, dask."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.sweep import sweep


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


def test_stability_map_points_fall_on_the_right_side_of_B():
    with ThreadPoolExecutor(2) as pool:
        sm = mbi.vibro.stability_map(np.array([0.2, 0.5]), executor=pool)
    B = np.interp(sm["alpha"], sm["alpha_fine"], sm["B"])
    np.testing.assert_array_equal(sm["grew"], sm["inv_rho"] > B)

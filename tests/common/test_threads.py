"""Batches run BLAS on one thread, whatever the process's setting, and restore it after."""

from __future__ import annotations

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import mbimpact as mbi
from mbimpact.common import SINGLE_THREAD_ROWS
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

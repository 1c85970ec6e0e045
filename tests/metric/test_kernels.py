"""The compiled core of the contact metric and of the single impact (mbimpact.metric.kernels), and the
registry of compiled kernels (mbimpact.compile_kernels)."""

import os
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.metric.delassus import KERNELS, ContactMetric

from tests.helpers import ROBOTS, last_frame, mechanism, seeds


@given(st.sampled_from(ROBOTS), seeds)
def test_delassus_on_pinocchios_factor_equals_the_dense_solve(name, seed):
    """A⁻¹Jᵀ and W from data.U, data.D equal a dense LAPACK solve to the accuracy the conditioning
    allows; W is exactly symmetric."""
    mech = mechanism(name)
    rng = np.random.default_rng(seed)
    q = mech.random_configuration(rng)
    J = mech.point_jacobian(q, last_frame(mech))
    A, factor = mech.factorise(q)
    U, D = factor.arrays()
    Yt, W, finite = KERNELS.get().delassus(U, D, J)
    assert finite
    Y = np.linalg.solve(A, J.T)
    cond = np.linalg.cond(A)
    np.testing.assert_allclose(Yt.T, Y, rtol=0, atol=1e-14 * cond * np.abs(Y).max())
    np.testing.assert_allclose(W, J @ Y, rtol=0, atol=1e-14 * cond * np.abs(W).max())
    assert np.array_equal(W, W.T)


def test_the_metric_of_a_mechanism_is_filled_by_the_kernel_and_agrees_with_the_lazy_route():
    mech = mechanism("panda")
    q = mech.random_configuration(np.random.default_rng(4))
    J = mech.point_jacobian(q, last_frame(mech))
    metric = ContactMetric.from_mechanism(mech, q, J)
    assert {"W", "AinvJt"} <= set(vars(metric))  # computed with the metric, not on first access
    lazy = ContactMetric.from_arrays(mech.mass_matrix(q), J)
    np.testing.assert_allclose(metric.W, lazy.W, rtol=1e-12, atol=1e-15 * np.abs(lazy.W).max())
    np.testing.assert_allclose(metric.AinvJt, lazy.AinvJt, rtol=1e-11, atol=1e-14 * np.abs(lazy.AinvJt).max())
    assert not metric.W.flags.writeable and not metric.AinvJt.flags.writeable


def test_an_overflowing_delassus_matrix_is_named():
    """J of 1e200 on a unit mass: W ~ 1e400. The kernel reports it; the metric names it."""
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "x")
    model.appendBodyToJoint(joint, pin.Inertia(1.0, np.zeros(3), np.eye(3)), pin.SE3.Identity())
    mech = mbi.Mechanism(model, "slider")
    q = np.zeros(1)
    A, factor = mech.factorise(q)
    J = np.array([[1e200], [0.0], [0.0]])
    assert not KERNELS.get().delassus(*factor.arrays(), J)[2]
    metric = ContactMetric.from_mechanism(mech, q, J)
    with pytest.raises(mbi.NonFiniteError, match="Delassus matrix"):
        metric.W


def test_single_impact_errors_from_the_compiled_route_are_named():
    """A finite velocity whose J v overflows: NonFiniteError naming the contact velocity, as the
    general route does; a large finite one gives the scaled impulse (homogeneity of degree 1, 1°)."""
    mech = mechanism("ur5")
    q = mech.neutral() + 0.3
    contact = mbi.PointContact("tool0", point=[1e3, 0.0, 0.0])  # J of order 1e3
    J, _ = contact.jacobian(mech, q, 3)
    law = mbi.RoughLaw(mbi.Cone(0.4), 0.5)
    v = np.linalg.lstsq(J, [0.0, 0.0, -1.0], rcond=None)[0]
    huge = v * (1e308 / np.abs(v).max())  # finite, but J v beyond the float range
    with np.errstate(all="ignore"):
        assert np.all(np.isfinite(huge)) and not np.all(np.isfinite(J @ huge))
    with pytest.raises(mbi.NonFiniteError, match="contact velocity"):
        mbi.impact(mech, q, huge, contact, law)
    finite = mbi.impact(mech, q, v, contact, law)
    big = mbi.impact(mech, q, v * 1e150, contact, law)
    np.testing.assert_allclose(big.P / 1e150, finite.P, rtol=1e-12)


def test_compile_kernels_makes_every_registered_module_ready():
    """mbi.compile_kernels() loads every kernel module of the package and times each; in a fresh
    interpreter, `import mbimpact` imports no numba, nor does Newton's law on arrays (a closed form in
    numpy), nor Newton's impact of a mechanism where the compiled front end runs it whole; the first
    rough impact of a mechanism does (its route is compiled), and so does Newton's without the front end."""
    out = mbi.compile_kernels()
    assert {"mbimpact.metric.kernels", "mbimpact.averaging.compiled.cone", "mbimpact.laws.coulomb_kernels",
            "mbimpact.averaging.compiled.slopes", "mbimpact.laws.newton_kernels", "mbimpact.laws.compiled_cone"} <= set(out)
    assert all(t >= 0.0 for pair in out.values() for t in pair)
    code = ("import sys, numpy as np, mbimpact as mbi; assert 'numba' not in sys.modules; "
            "m = mbi.Mechanism.from_robot('ur5'); q = m.neutral() + 0.3; J = m.point_jacobian(q, 'tool0'); "
            "v = np.linalg.lstsq(J, [0.0, 0.0, -1.0], rcond=None)[0]; "
            "mbi.NewtonLaw(0.5).apply(m.mass_matrix(q), J, v, [0.0, 0.0, 1.0]); assert 'numba' not in sys.modules; "
            "from mbimpact.mechanism import front; "
            "mbi.impact(m, q, v, mbi.PointContact('tool0'), mbi.NewtonLaw(0.5)); "
            "assert ('numba' in sys.modules) != front.available(), front.status(); "
            "mbi.impact(m, q, v, mbi.PointContact('tool0'), mbi.RoughLaw(mbi.Cone(alpha=0.3), e=0.5)); "
            "assert 'numba' in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)
    subprocess.run([sys.executable, "-c", code], check=True, env={**os.environ, "MBIMPACT_NATIVE": "0"})


@given(seeds, st.floats(-16.0, 0.0), st.floats(0.0, 1.0), st.sampled_from([0, 1, 2]))
def test_the_compiled_rank_screen_keeps_w_exactly_where_the_range_projector_keeps_it_whole(seed, log_ratio, mid,
                                                                                           zeros):
    """prepare_factor screens W by its determinant, then by a Cholesky test of W − τ I: it declines
    (NEAR_SINGULAR, the general route then projects on range W) exactly where det W / (tr W)³ ≤ 1e-12 and
    λ_min ≤ FULL_RANK_RATIO tr W (LAPACK's λ_min); where it goes on, the general route's range projector
    keeps W whole (None or the identity). W = Q diag(λ) Qᵀ with λ_min / λ_max over 16 decades, λ_mid
    anywhere between (two small eigenvalues: a nearly rank-1 W, where the closed-form eigen_ratio errs by
    ~1e-8), or exact zeros (a rank-deficient contact); A = I and J = W^½, so that W is the contact's
    Delassus matrix."""
    rng = np.random.default_rng(seed)
    Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    lam = np.array([1.0, 10.0 ** (mid * log_ratio), 10.0**log_ratio])
    lam[3 - zeros:] = 0.0
    root = (Q * np.sqrt(lam)) @ Q.T
    v = np.linalg.lstsq(root, [0.3, 0.1, -1.0], rcond=None)[0]
    kernels = KERNELS.get()
    buffer = np.empty(6 * 3 + 33)
    status = kernels.prepare_factor(np.eye(3), np.ones(3), root, v, np.eye(3), 1e-14, 1e-12, buffer)[0]
    if status == kernels.DECLINED:  # no approach, or n⁰ out of reach: not the screen's business
        return
    W = kernels.world_delassus(buffer, 3).copy()
    tr = np.trace(W)
    screened = np.linalg.det(W / tr) <= 1e-12
    ratio = np.linalg.eigvalsh(W)[0] / tr
    if abs(np.linalg.det(W / tr) - 1e-12) > 1e-14 and abs(ratio / kernels.FULL_RANK_RATIO - 1.0) > 1e-3:  # off the edges
        assert (status == kernels.NEAR_SINGULAR) == (screened and ratio <= kernels.FULL_RANK_RATIO)
    if status != kernels.NEAR_SINGULAR:
        assert status == kernels.READY
        projector = ContactMetric.from_arrays(np.eye(3), root).range_projector
        assert projector is None or np.allclose(projector, np.eye(3), rtol=0, atol=1e-12)

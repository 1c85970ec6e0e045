"""One velocity on a Cone with a nearly singular W: the kernels' poles taken out and integrated in closed form."""

import cmath
import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import mbimpact as mbi
from mbimpact.averaging import AUTO_ORDER, Graded, Poles
from mbimpact.averaging.compiled.poles import ring_zero
from mbimpact.averaging.refinement import rounding_floor

from tests.helpers import (UPRIGHT_UR5, anisotropic_delassus, mechanism, relative_du, rounding_bound, seeds, spd,
                           unit_velocities, upright_ur5_delassus, upright_ur5_velocity)


def _q(alpha, W, z):
    """q(z) = m(z)ᵀ W m(z) on the complexified ring, m(z) = (s (z + 1/z)/2, s (z − 1/z)/2i, c)."""
    s, c = math.sin(alpha), math.cos(alpha)
    m = np.array([s * (z + 1 / z) / 2, s * (z - 1 / z) / 2j, c])
    return m @ W @ m


@given(seeds, st.floats(0.05, 1.5), st.floats(3.0, 7.0), st.booleans())
def test_it_agrees_with_the_graded_rule(seed, alpha, log_cond, ur5):
    """On W with cond 1e3 … 1e7 (random, or the UR5's near-singular posture turned about the normal), across
    both regimes of incidence: worthwhile exactly where the graded rule is, and where it settles, the velocity
    change W P of the numpy graded rule within their error estimates (or rtol, which both promise). Where it
    settles, it needs at most 128 nodes, against 6 × (32 + 64) graded ones."""
    rng = np.random.default_rng(seed)
    W = anisotropic_delassus(rng, log_cond, ur5)
    law = mbi.RoughLaw(mbi.Cone(alpha), 0.5)
    for u in unit_velocities(rng, 7):
        U = u[None]
        assert Poles().worthwhile(law.spec, W, U) == Graded().worthwhile(law.spec, W, U)
        fast = Poles().average(law.spec, W, U)
        if fast is None:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mbi.AccuracyWarning)  # where numpy stalls, its error says by how much
            slow = Graded().reference(law.spec, W, U)
        assert slow is not None and fast.method == "poles" and fast.nodes <= 128
        bound = 10 * max(law.rtol, fast.error[0], slow.error[0])
        assert relative_du(fast.P, slow.P, W)[0] <= bound
        assert fast.error[0] <= max(law.rtol, 100 * np.finfo(float).eps * math.sqrt(fast.nodes),
                                    rounding_bound(law.spec, W, fast.P))


@given(seeds, st.floats(0.05, 1.5), st.floats(2.0, 7.0))
def test_the_zeros_are_those_of_q_inside_the_disk(seed, alpha, log_cond):
    """ring_zero finds, from a minimum of q on the ring and its width, a zero of q(z) = m(z)ᵀWm(z) inside the
    unit disk (their pairs a, 1/ā), within the width of the peak from the circle, at the minimum's azimuth."""
    rng = np.random.default_rng(seed)
    W = anisotropic_delassus(rng, log_cond, False)
    s, c = math.sin(alpha), math.cos(alpha)
    phi = np.linspace(0.0, 2 * math.pi, 4097)[:-1]
    m = np.stack([s * np.cos(phi), s * np.sin(phi), np.full(phi.size, c)])
    q = np.einsum("ik,ij,jk->k", m, W, m)
    i = int(np.argmin(q))
    d2 = (q[i - 1] - 2 * q[i] + q[(i + 1) % q.size]) / (phi[1] - phi[0]) ** 2
    width = math.sqrt(2 * q[i] / d2)
    a = ring_zero(s, c, W, phi[i], width)
    assert a != 0 and abs(a) < 1
    scale = np.abs(W).sum()
    assert abs(_q(alpha, W, a)) <= 1e-13 * scale
    assert abs(_q(alpha, W, 1 / a.conjugate())) <= 1e-12 * scale
    if width < 0.05:  # a narrow peak: the zero is where the quadratic model of q puts it
        assert abs(a - cmath.exp(complex(-width, phi[i]))) <= 0.2 * width + 2 * (phi[1] - phi[0])


def test_a_near_singular_arm_takes_out_the_poles():
    """The UR5 upright with the elbow straight (W's eigenvalues 1e7 apart): "auto" takes the poles out, in one
    compiled call, with 16 + 32 nodes; its impulse is the numpy graded rule's (6 × 64 nodes a piece) to rtol,
    and a reference of 1024 graded nodes a piece agrees with both."""
    mech = mechanism("ur5")
    v = upright_ur5_velocity()
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    contact = mbi.PointContact("tool0")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)  # further micro-impacts follow: not the point here
        res = mbi.impact(mech, UPRIGHT_UR5, v, contact, law)
        graded = mbi.impact(mech, UPRIGHT_UR5, v, contact, law.replace(method="graded"))
        fine = mbi.impact(mech, UPRIGHT_UR5, v, contact, law.replace(nodes=1024))
    assert res.method == "poles" and res.nodes == 32 and graded.method == "graded[compiled]"
    W = res.J @ np.linalg.solve(res.A, res.J.T)
    for ref in (graded, fine):
        assert relative_du(res.P[None], ref.P[None], W)[0] <= 1e-12
    # its estimate: the level difference within rtol, and P's own rounding where W nearly annihilates it
    floor = rounding_floor(res.P[None], W)[0]  # (W and P in the world frame here: the same to rounding)
    assert floor * (1 - 1e-9) <= res.error_estimate <= max(1e-12, floor) * (1 + 1e-9)
    assert AUTO_ORDER.index("poles") + 1 == AUTO_ORDER.index("graded")
    # several velocities or a fixed node count: not worthwhile, and it declines
    W, u = upright_ur5_delassus(), np.array([[0.3, 0.1, -1.0]]) / math.sqrt(1.1)
    assert Poles().worthwhile(law.spec, W, u)
    for spec, U in ((law.spec, np.vstack([u, u])), (law.replace(nodes=32).spec, u)):
        assert not Poles().worthwhile(spec, W, U) and Poles().average(spec, W, U) is None


def test_the_compiled_impact_and_the_python_method_agree():
    """mbimpact.impact's compiled cone route and the averaging rule Poles make the same decision, at
    the same node count, and the same impulse up to the rounding of the W and u rebuilt here."""
    mech = mechanism("ur5")
    v = upright_ur5_velocity()
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        whole = mbi.impact(mech, UPRIGHT_UR5, v, mbi.PointContact("tool0"), law)
    W = whole.J @ np.linalg.solve(whole.A, whole.J.T)
    R = mbi.PointContact("tool0").basis()
    out = law.replace(method="poles").contact_impulses(R.T @ W @ R, (R.T @ whole.u_minus)[None])
    assert out.method == whole.method == "poles" and out.nodes == whole.nodes
    np.testing.assert_allclose(R @ out.P[0], whole.P, rtol=1e-13)


def test_where_it_does_not_apply_or_cannot_reach_rtol_the_graded_rule_runs():
    """The configuration flux has branch points, not poles: not worthwhile (naming it fails with the reason). No
    narrow peak (W = I): not worthwhile, and naming it fails. A peak too narrow for a plain rule of 128 nodes
    to reach rtol: it declines and "auto" grades the rule."""
    W = upright_ur5_delassus()
    u = np.array([[math.sin(0.5), 0.0, -math.cos(0.5)]])
    configuration = mbi.RoughLaw(mbi.Cone(0.3), 0.5, flux="configuration")
    assert not Poles().worthwhile(configuration.spec, W, u) and Poles().average(configuration.spec, W, u) is None
    assert configuration.contact_impulses(W, u).method == "graded[compiled]"
    with pytest.raises(mbi.ParameterError, match="physical flux"):
        configuration.replace(method="poles").contact_impulses(W, u)
    law = mbi.RoughLaw(mbi.Cone(0.3), 0.5)
    assert not Poles().worthwhile(law.spec, np.eye(3), u)
    with pytest.raises(mbi.ParameterError, match="narrow peak"):
        law.replace(method="poles").contact_impulses(np.eye(3), u)
    # cond W = 1e8: where a peak is too narrow for 128 plain nodes, it declines and the graded rule settles
    rng, declined = np.random.default_rng(1), 0
    for _ in range(30):
        W = spd(rng, 3, 1e8)
        for v in unit_velocities(rng, 3):
            if Poles().worthwhile(law.spec, W, v[None]) and Poles().average(law.spec, W, v[None]) is None:
                declined += 1
                with warnings.catch_warnings():  # where the graded rule stops short of rtol, it says by how much
                    warnings.simplefilter("ignore", mbi.AccuracyWarning)
                    assert law.contact_impulses(W, v[None]).method in ("graded[compiled]", "graded")
    assert declined > 0


def test_where_an_ulp_of_w_moves_the_answer_by_more_than_rtol_it_declines():
    """Two cases of an independent check against a 36-digit reference (ring through W's null direction, cond
    1e8 and 1e6): the level differences say 1e-13 and 5e-13, but an ulp of W moves q at the narrowest minimum
    by up to ε Σ|W_ik||m_i||m_k| / q_min = 7e-10 and 5e-11 of itself (the answer by half that), and the rule
    was off by 1.25e-11 and 5.7e-12. It declines, and "auto" grades the rule; on the UR5 stretched out the bound
    is 6e-15 and it settles, reporting the larger of it and the level difference."""
    cases = [
        (1.218528392189509, 0.0,
         [[0.31673248861830783, -0.34966763825775626, 0.6777290971885757],
          [-0.34966763825775626, 0.6682155730113494, -0.6120507458273096],
          [0.6777290971885757, -0.6120507458273096, 1.5158636362691456]],
         [0.598680689532276, -0.7660333777006161, -0.2340390912427744]),
        (0.9360861984231083, 0.5,
         [[0.07093006100372927, 0.01502363630256826, 0.09799979273761858],
          [0.01502363630256826, 0.06704069729018981, 0.04198085937253557],
          [0.09799979273761858, 0.04198085937253557, 0.14245477802388087]],
         [0.703560389273315, 0.5475829139142239, -0.4529412004165543]),
    ]
    for alpha, e, W, u in cases:
        law, W, U = mbi.RoughLaw(mbi.Cone(alpha), e), np.array(W), np.array([u])
        assert Poles().worthwhile(law.spec, W, U) and Poles().average(law.spec, W, U) is None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mbi.AccuracyWarning)
            assert law.contact_impulses(W, U).method in ("graded[compiled]", "graded")
    law, W = mbi.RoughLaw(mbi.Cone(0.3), 0.5), upright_ur5_delassus()
    U = np.array([[0.3, 0.1, -1.0]]) / math.sqrt(1.1)
    out = Poles().average(law.spec, W, U)
    # settled: its level difference within rtol; its estimate holds P's rounding where W nearly annihilates it
    floor = rounding_floor(out.P, W)[0] if out is not None else math.nan
    assert out is not None and floor * (1 - 1e-9) <= out.error[0] <= max(law.rtol, floor) * (1 + 1e-9)


def test_compile_kernels_covers_the_pole_kernels():
    out = mbi.compile_kernels()
    assert "mbimpact.averaging.compiled.poles" in out
    assert all(t >= 0.0 for t in out["mbimpact.averaging.compiled.poles"])

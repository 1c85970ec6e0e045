"""Fuzzing impacts of every example-robot-data robot: a finite, dissipative answer or a named error.

Every robot of :func:`mbimpact.robot_names` must load (all of them do; keep it so). Each example
takes a few robots and, for each, a random configuration (Pinocchio's within the joint limits, or
the neutral one plus noise clipped to them), a random velocity (scale 1e-3…1e3), a random frame,
offset and base normal, and applies Newton's law, the rough law on a cone and Coulomb's law through
:func:`mbimpact.impact` with a :class:`~mbimpact.PointContact`. Asserted:

* every call returns within :data:`LIMIT`, with an :class:`mbimpact.ImpactError` (a singular mass
  matrix, a frame that cannot move along the normal) or a finite result;
* the kinetic energy never grows beyond the rounding bound of :func:`tests.helpers.energy_bound`
  (Coulomb's law with Newton's kinematic restitution excepted: it may create energy);
* Newton's law equals ``pin.impulseDynamics`` with the normal row of the contact Jacobian, to
  rounding amplified by the conditioning of A.

The default run takes a small derandomised sample; ``pytest -m slow`` runs 10⁴ examples.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mbimpact as mbi
from tests.helpers import energy_bound, mechanism, time_limit

LIMIT = 20.0  # seconds per impact
ROBOTS = mbi.robot_names()
EPS = float(np.finfo(float).eps)


def configuration(mech: mbi.Mechanism, rng: np.random.Generator, noisy: bool) -> np.ndarray:
    """Pinocchio's random configuration within the limits (unbounded joints: ±π, free-flyer
    positions: ±1 m), or the neutral one plus noise clipped to the limits."""
    model = mech.model
    lo = np.maximum(np.nan_to_num(model.lowerPositionLimit, neginf=-np.pi), -np.pi)
    hi = np.minimum(np.nan_to_num(model.upperPositionLimit, posinf=np.pi), np.pi)
    hi = np.maximum(lo, hi)
    if noisy:
        q = mech.neutral() + rng.normal(scale=0.3, size=mech.nq)
        q = np.clip(q, lo, hi)
    else:
        pin.seed(int(rng.integers(2**31)))  # pin.randomConfiguration draws from Pinocchio's own generator
        q = pin.randomConfiguration(model, lo, hi)
    return pin.normalize(model, q)


def condition(A: np.ndarray) -> float:
    lam = np.linalg.eigvalsh(0.5 * (A + A.T))
    return float(lam[-1] / max(lam[0], lam[-1] * EPS * EPS))


def impact_checked(mech: mbi.Mechanism, q: np.ndarray, v: np.ndarray, contact: mbi.PointContact,
                   law: mbi.ImpactLaw) -> mbi.ImpactResult | None:
    """mbi.impact under the time limit: a named error (None) or a finite result that creates no energy."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.ImpactWarning)  # honest warnings are allowed
        warnings.simplefilter("error", RuntimeWarning)  # no numpy overflow leaks out
        try:
            with time_limit(LIMIT):
                res = mbi.impact(mech, q, v, contact, law)
        except mbi.ImpactError:
            return None
    assert np.all(np.isfinite(res.v_plus)) and np.all(np.isfinite(res.P)), (mech.name, law)
    assert np.isfinite(res.energy_loss)
    if not (isinstance(law, mbi.CoulombLaw) and law.restitution == "newton"):
        W = res.J @ np.linalg.solve(res.A, res.J.T)
        assert res.energy_loss >= -energy_bound(res, condition(W))[0], (mech.name, law, res.energy_loss)
    return res


def check_robot(name: str, seed: int, noisy: bool, e: float, alpha: float, mu: float, restitution: str) -> None:
    mech = mechanism(name)
    rng = np.random.default_rng(seed)
    q = configuration(mech, rng, noisy)
    v = rng.normal(size=mech.nv) * 10.0 ** rng.uniform(-3, 3)
    frame = mech.frame_names[int(rng.integers(len(mech.frame_names)))]
    point = rng.normal(scale=0.05, size=3) if rng.random() < 0.5 else np.zeros(3)
    n0 = rng.normal(size=3)
    n0 /= np.linalg.norm(n0)
    contact = mbi.PointContact(frame, normal=n0, point=point)
    J = mech.point_jacobian(q, frame, point)
    if n0 @ J @ v > 0:
        v = -v
    newton = impact_checked(mech, q, v, contact, mbi.NewtonLaw(e))
    impact_checked(mech, q, v, contact, mbi.RoughLaw(mbi.Cone(alpha), e))
    impact_checked(mech, q, v, contact, mbi.CoulombLaw(e, mu, restitution))
    if newton is None:
        return
    expected = pin.impulseDynamics(mech.model, mech.model.createData(), q, v, (n0 @ J)[None, :], e, 0.0)
    scale = np.abs(expected).max() + np.abs(v).max()
    tol = 1e-12 * scale * max(1.0, 10 * EPS * condition(newton.A) / 1e-12)
    np.testing.assert_allclose(newton.v_plus, expected, rtol=0, atol=tol)


@pytest.mark.parametrize("name", ROBOTS)
def test_every_robot_loads_and_strikes(name):
    """All of them, once each, at a posture and frame of their own (a few ms each)."""
    mech = mechanism(name)
    assert mech.nv >= 1 and mech.mass_matrix(mech.neutral()).shape == (mech.nv, mech.nv)
    check_robot(name, ROBOTS.index(name), noisy=False, e=0.5, alpha=0.3, mu=0.4, restitution="energetic")


robot_cases = st.tuples(st.sampled_from(ROBOTS), st.integers(0, 2**32 - 1), st.booleans(), st.floats(0.0, 1.0),
                        st.floats(0.0, 1.4), st.floats(0.0, 3.0), st.sampled_from(["newton", "poisson", "energetic"]))


@settings(max_examples=300, deadline=None)
@given(st.lists(robot_cases, min_size=1, max_size=3))
def test_random_robot_impacts(cases):
    for case in cases:
        check_robot(*case)


# ---------------------------------------------------------------- nightly size: pytest -m slow

@pytest.mark.slow
@settings(max_examples=10_000, deadline=None)
@given(st.lists(robot_cases, min_size=1, max_size=3))
def test_random_robot_impacts_nightly(cases):
    test_random_robot_impacts.hypothesis.inner_test(cases)

"""Helpers shared by the tests: robots, random matrices and velocities, error measures."""

from __future__ import annotations

import contextlib
import functools
import math
from collections.abc import Iterator

import numpy as np
from hypothesis import strategies as st

import mbimpact as mbi

#: example-robot-data robots used in property tests (arms, legged, humanoid, floating).
ROBOTS = ["ur5", "panda", "solo12", "talos", "go1", "kinova", "double_pendulum", "xarm7", "anymal", "z1", "bolt", "iris"]


@functools.lru_cache(maxsize=None)
def mechanism(name: str) -> mbi.Mechanism:
    """Robots are loaded once per session (frames and data are reused read-only)."""
    return mbi.Mechanism.from_robot(name)


def last_frame(mech: mbi.Mechanism) -> str:
    """A frame at the end of the kinematic tree (the last one declared)."""
    return mech.frame_names[-1]


def spd(rng: np.random.Generator, n: int, cond: float = 1e3) -> np.ndarray:
    """Random symmetric positive definite matrix with condition number ``cond``."""
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return (Q * np.geomspace(1.0, cond, n)) @ Q.T / np.sqrt(cond)


def approaching(J: np.ndarray, v: np.ndarray, n0: np.ndarray) -> np.ndarray:
    """``v`` or ``-v``, whichever makes the contact point approach the surface."""
    return v if n0 @ J @ v < 0 else -v


def random_facets(rng: np.random.Generator, d: int, k: int, max_tilt: float = 1.2) -> mbi.Facets:
    """K facets with tilts below ``max_tilt`` and random positive weights."""
    tilt = rng.uniform(0.0, max_tilt, k)
    if d == 2:
        side = rng.choice([-1.0, 1.0], k)
        m = np.column_stack([side * np.sin(tilt), np.cos(tilt)])
    else:
        az = rng.uniform(0, 2 * np.pi, k)
        m = np.column_stack([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)])
    return mbi.Facets(m, rng.uniform(0.1, 1.0, k))


seeds = st.integers(min_value=0, max_value=2**32 - 1)


def unit_velocities(rng: np.random.Generator, count: int, beta_max: float = math.pi / 2 - 1e-9) -> np.ndarray:
    """Local-frame unit velocities with incidence β spread over [0, beta_max] (both regimes), random azimuth."""
    beta = np.linspace(0.0, beta_max, count)
    psi = rng.uniform(0.0, 2 * math.pi, count)
    return np.column_stack([np.sin(beta) * np.cos(psi), np.sin(beta) * np.sin(psi), -np.cos(beta)])


def relative_du(P: np.ndarray, ref: np.ndarray, W: np.ndarray) -> np.ndarray:
    """Row-wise relative difference of contact impulses, measured by Δu = W P."""
    return np.linalg.norm((P - ref) @ W, axis=1) / np.linalg.norm(ref @ W, axis=1)


#: UR5 upright with the elbow straight: the contact Jacobian nearly loses rank (W spans 1e7).
UPRIGHT_UR5 = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])


def upright_ur5_delassus() -> np.ndarray:
    """The (symmetrised) Delassus matrix of the UR5's tool0 at :data:`UPRIGHT_UR5`."""
    mech = mechanism("ur5")
    J = mech.point_jacobian(UPRIGHT_UR5, "tool0")
    W = J @ np.linalg.solve(mech.mass_matrix(UPRIGHT_UR5), J.T)
    return 0.5 * (W + W.T)


def upright_ur5_velocity() -> np.ndarray:
    """A velocity of the UR5 at :data:`UPRIGHT_UR5` whose tool0 moves along (0.3, 0.1, −1): an oblique
    approach at the near-singular posture."""
    J = mechanism("ur5").point_jacobian(UPRIGHT_UR5, "tool0")
    return np.linalg.lstsq(J, [0.3, 0.1, -1.0], rcond=None)[0]


def impulses(law: mbi.ImpactLaw, W: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """A law's core, :meth:`~mbimpact.ImpactLaw.contact_impulses`, as (P, error estimates, nodes)."""
    out = law.contact_impulses(W, U)
    return out.P, out.error, out.nodes


class CallTimeout(AssertionError):
    """A call under :func:`time_limit` ran too long: the test fails instead of hanging."""


@contextlib.contextmanager
def time_limit(seconds: float) -> Iterator[None]:
    """Fail the test (raise :class:`CallTimeout`) if the block runs longer than ``seconds`` of wall time.

    Uses SIGALRM, so it works in the main thread (where pytest runs tests); elsewhere it only
    checks afterwards.
    """
    import signal
    import threading
    import time

    if threading.current_thread() is not threading.main_thread():
        start = time.monotonic()
        yield
        if time.monotonic() - start > seconds:
            raise CallTimeout(f"the call took more than {seconds:g} s")
        return

    def expire(signum: int, frame: object) -> None:
        raise CallTimeout(f"the call took more than {seconds:g} s (a hang)")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def energy_bound(result: mbi.ImpactResult | mbi.BatchResult, W_cond: float) -> np.ndarray:
    """The kinetic energy a result may gain by rounding and quadrature alone.

    The energy change is computed as −Pᵀ(u₋ + u₊)/2; an impulse P off by a relative δ changes it by
    at most δ |P| (|u₋| + |u₊|)/2. δ is the law's own error estimate plus rounding, ε amplified by
    the conditioning of the contact (cond W ≈ |W||W⁻¹|, through the solves that give P and u₊),
    with a safety factor 100: gain ≤ (err + 100 ε cond W) |P| (|u₋| + |u₊|) / 2.
    """
    P = np.atleast_2d(result.P)
    um = np.atleast_2d(result.u_minus if isinstance(result, mbi.ImpactResult) else result.U_minus)
    up = np.atleast_2d(result.u_plus if isinstance(result, mbi.ImpactResult) else result.U_plus)
    err = np.atleast_1d(result.error_estimate)
    delta = err + 100 * np.finfo(float).eps * max(W_cond, 1.0)
    return delta * np.linalg.norm(P, axis=1) * (np.linalg.norm(um, axis=1) + np.linalg.norm(up, axis=1)) / 2


def graded_facets(spec, W: np.ndarray, u: np.ndarray, nodes: int) -> int:
    """The facet count of the numpy graded rule (mbimpact.averaging.Graded) at ``nodes`` a piece for one
    velocity ``u`` (3,): the K of its rounding floor 100 ε √K."""
    from mbimpact.averaging import Graded
    from mbimpact.averaging.refinement import peaked_rule

    return int(peaked_rule(spec, W, Graded.peaked, screen=False)(u[None], nodes)[1].shape[-1])


def at_rounding(out, spec, W: np.ndarray, u: np.ndarray) -> bool:
    """Whether a graded result's last difference of levels is within the rounding that the stall test of
    the adaptive rule allows, 100 ε √K amplified by tr(W) |P| / |W P|: there, whether to stop is rounding's
    decision."""
    P = out.P[0]
    amplification = np.trace(W) * np.linalg.norm(P) / np.linalg.norm(P @ W)
    return bool(out.error[0] <= 100 * np.finfo(float).eps * math.sqrt(graded_facets(spec, W, u, out.nodes))
                * amplification)


def rounding_bound(spec, W: np.ndarray, P: np.ndarray) -> float:
    """What the error estimate of a cone's graded rule holds besides its level difference: the rounding of q at
    its minima on the ring (minima_sensitivity) and that of P where W nearly annihilates it (rounding_floor);
    0 for other measures. To rounding: the compiled rules compute it in their own order."""
    from mbimpact.averaging.refinement import rounding_floor
    from mbimpact.quadrature.graded import minima_sensitivity, ring_minima

    if not isinstance(spec.roughness, mbi.Cone):
        return 0.0
    alpha = spec.roughness.alpha
    power = 1.0 if spec.flux == "configuration" else 0.5
    bound = max(minima_sensitivity(alpha, W, ring_minima(alpha, W)[0], power), float(rounding_floor(P, W).max()))
    return bound * (1 + 1e-9)


def compiled_graded(spec, W: np.ndarray, U: np.ndarray):
    """The graded rule's compiled backend for one velocity: its impulses where it settles, else None."""
    from mbimpact.averaging import Graded, backends

    return backends.graded(spec, W, U, Graded.peaked)[1]


def check_against_graded(fast_rule, law, W: np.ndarray, u: np.ndarray, cond: float, same_error: bool = True,
                         name: str = "graded[compiled]") -> None:
    """A compiled graded rule (``fast_rule(spec, W, U)``: impulses, or None where it does not settle) against
    the numpy graded rule (Graded.reference) for one velocity ``u`` (3,): None where it has no graded rule,
    and otherwise the same result to rounding at the same node count; a different decision (not settled, one
    level apart, or settled below the level where numpy stalled) only where the numpy rule warned or a
    difference sat at the stopping bound or at rounding."""
    import warnings

    from mbimpact.averaging import Graded

    eps = np.finfo(float).eps
    fast = fast_rule(law.spec, W, u[None])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        slow = Graded().reference(law.spec, W, u[None])
    if slow is None:  # no graded rule for this W: no narrow peak of the kernels
        assert fast is None
        return
    warned = any(issubclass(w.category, mbi.AccuracyWarning) for w in caught)
    stop = max(law.rtol, 100 * eps * math.sqrt(graded_facets(law.spec, W, u, slow.nodes)))  # the stopping bound
    if fast is None:  # numpy warned, or its last difference was at the bound or rounding itself
        assert warned or slow.error[0] > 0.1 * stop or at_rounding(slow, law.spec, W, u)
        return
    assert fast.method == name
    assert fast.error[0] <= max(law.rtol, 100 * eps * math.sqrt(graded_facets(law.spec, W, u, fast.nodes)),
                                rounding_bound(law.spec, W, fast.P))
    if warned:  # numpy stopped at rounding where the compensated sums fell below rtol
        assert at_rounding(slow, law.spec, W, u)
    if fast.nodes == slow.nodes:  # the same sums in another order
        assert relative_du(fast.P, slow.P, W)[0] < 1e-14 * cond
        if same_error:
            assert abs(fast.error[0] - slow.error[0]) < 1e-13 * cond
    elif warned and fast.nodes < slow.nodes:  # numpy stalled at rounding beyond the level the compiled rule settled
        assert relative_du(fast.P, slow.P, W)[0] < 10 * max(stop, fast.error[0], slow.error[0]) + 1e-14 * cond
    else:  # a difference at the bound, decided otherwise by rounding: one level apart, both converged; the
        # rule that settled first did so on a difference at the bound (the other found it just above)
        assert fast.nodes in (2 * slow.nodes, slow.nodes // 2)
        first = fast if fast.nodes < slow.nodes else slow
        assert first.error[0] > 0.1 * stop or at_rounding(slow, law.spec, W, u)
        assert relative_du(fast.P, slow.P, W)[0] < 10 * max(stop, fast.error[0], slow.error[0]) + 1e-14 * cond


def anisotropic_delassus(rng: np.random.Generator, log_cond: float, ur5: bool) -> np.ndarray:
    """A strongly anisotropic local-frame W (3, 3): the UR5's at its near-singular posture turned by a
    random angle about the normal, or a random one with condition number 10**log_cond."""
    if not ur5:
        return spd(rng, 3, 10**log_cond)
    turn = rng.uniform(0.0, 2 * math.pi)
    R = np.array([[math.cos(turn), -math.sin(turn), 0.0], [math.sin(turn), math.cos(turn), 0.0], [0.0, 0.0, 1.0]])
    return R @ upright_ur5_delassus() @ R.T

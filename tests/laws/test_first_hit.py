"""The rough law on a measured profile against a plain-geometry first-hit computation.

The reference here shares no code with the library's averaging, shadowing
(:meth:`Profile.lit_fraction`) or quadrature. It is the experiment behind (2.7)
done literally: the contact point approaches a periodic piecewise-linear profile
along straight lines parallel to its velocity ``u = J v``, starting above the relief
at horizontal offsets spread uniformly over one period; each line is intersected
exactly with every segment of a few periods, and the segment it crosses first is
the facet it strikes. The ray receives that facet's Newton impulse
``P_m = −(1+e) (mᵀu / mᵀWm) m`` (W the Delassus matrix of the mechanism) and the
reference is the plain mean over rays.

Uniform offsets are a uniform flux of contact-point trajectories through a
horizontal line, so a facet is struck by a share of rays proportional to the part
of it that is reached first, times its length, times ``−mᵀu``: the *physical*
weight of THEORY §5 ("Which weight is physical"), with shadowing, and nothing
weighted by hand. The configuration-space weight ``−mᵀu / sqrt(mᵀWm)`` of the
paper's literal (2.7) differs from it whenever W is not a multiple of the
identity and at least two facets are struck; the mechanism cases check that the
default law (``flux="physical"``) matches the geometry and that
``flux="configuration"`` does not.

The rays sample a piecewise-constant function of the offset at midpoints, so the
reference converges like 1/N in the number N of rays: its error is at most the
total variation of the per-ray impulse over one period divided by N; twice that
is the tolerance used (2e-5 to 8e-5 relative for N = 2e5 here, while the
configuration weight errs by percents). The library result on a
:class:`mbimpact.Profile` is exact to rounding.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

import mbimpact as mbi

RAYS = 200_000
E = 0.5
SPEED = 1.3  # |u|: the law is positively homogeneous, any speed will do
ROUNDING = 1e-12  # relative rounding allowance on top of the ray bound (0 when a single facet is struck)

# Asymmetric sawtooth of period 1: rises at 30° over 3/4 of the period, falls at 60°
# over the last quarter. On the grid dx = 1/4 the rise is three collinear segments.
_RISE = 0.75 * math.tan(math.radians(30.0))
SAWTOOTH = (np.array([0.0, _RISE / 3, 2 * _RISE / 3, _RISE, 0.0]), 0.25)
# A few random segments of period 1 (slopes between −46° and +50°), closed periodically.
_RANDOM = np.random.default_rng(3).uniform(0.0, 0.3, 7)
RANDOM = (np.append(_RANDOM, _RANDOM[0]), 1.0 / 7)
PROFILES = {"sawtooth": SAWTOOTH, "random": RANDOM}


def _facets(heights: NDArray[np.float64], dx: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Upward unit normals (K, 2) and true lengths (K,) of the segments of a profile."""
    slope = np.diff(heights) / dx
    sec = np.hypot(slope, 1.0)
    return np.column_stack([-slope, np.ones_like(slope)]) / sec[:, None], dx * sec


def first_hit(
    heights: NDArray[np.float64], dx: float, u: NDArray[np.float64], W: NDArray[np.float64], e: float,
    rays: int = RAYS,
) -> tuple[NDArray[np.float64], float, NDArray[np.int64]]:
    """Mean Newton impulse over straight approaches along ``u`` of a periodic profile.

    Parameters
    ----------
    heights : ndarray, shape (K + 1,)
        Profile heights at x = 0, dx, ..., K dx, with ``heights[K] == heights[0]``
        (period K dx).
    dx : float
        Spacing of the heights.
    u : ndarray, shape (2,)
        Contact-point velocity (tangential, normal), ``u[1] < 0``.
    W : ndarray, shape (2, 2)
        Delassus matrix in the same (tangential, normal) coordinates.
    e : float
        Facet restitution.
    rays : int
        Number of rays, at offsets (i + ½) K dx / rays.

    Returns
    -------
    P : ndarray, shape (2,)
        Mean over rays of the Newton impulse of the segment each ray hits first.
    bound : float
        Bound on the discretisation error |P − P_exact|: total variation of the
        per-ray impulse over one period, divided by ``rays``.
    hit : ndarray, shape (rays,)
        Index of the segment (within the period) each ray hits first.
    """
    K = heights.size - 1
    period = K * dx
    xa, ha = dx * np.arange(K), heights[:-1]
    ex, ez = np.full(K, dx), np.diff(heights)  # segment k: (xa, ha) + t (ex, ez), 0 ≤ t ≤ 1
    m, _ = _facets(heights, dx)
    # rays start above the relief and sink by at most its depth before they hit it
    z0 = heights.max() + 0.1 * period
    reach = (z0 - heights.min()) * abs(u[0]) / -u[1]
    shifts = np.arange(math.ceil(reach / period) + 1) * (1.0 if u[0] >= 0.0 else -1.0)
    seg = np.tile(np.arange(K), shifts.size)
    sx = (xa[None, :] + period * shifts[:, None]).ravel()
    x0 = (np.arange(rays) + 0.5) * (period / rays)
    # x0 + s u = (sx, ha) + t (ex, ez): Cramer's rule for (s, t), all rays × all segments
    rx, rz = sx[None, :] - x0[:, None], (ha[seg] - z0)[None, :]
    dex, dez = ex[seg][None, :], ez[seg][None, :]
    det = dex * u[1] - u[0] * dez
    s = (dex * rz - dez * rx) / det
    t = (u[0] * rz - u[1] * rx) / det
    s = np.where((t >= 0.0) & (t <= 1.0) & (s > 0.0), s, np.inf)
    first = np.argmin(s, axis=1)
    assert np.isfinite(s[np.arange(rays), first]).all(), "a ray missed the profile"
    hit = seg[first]
    mtu = m @ u
    assert (mtu[np.unique(hit)] < 0.0).all(), "a ray struck a facet from behind"
    Pm = -(1.0 + e) * (mtu / np.einsum("kd,de,ke->k", m, W, m))[:, None] * m
    # the mean over rays, summed per facet (a running sum over 2e5 rays would err by ~1e-11)
    P = np.bincount(hit, minlength=K) @ Pm / rays
    # the per-ray impulse jumps where the struck facet changes (cyclically: ray N is ray 0 shifted by a period)
    bound = float(np.linalg.norm(Pm[hit] - Pm[np.roll(hit, 1)], axis=1).sum()) / rays
    return P, bound, hit


def incidence(beta_deg: float, direction: int) -> NDArray[np.float64]:
    """Contact velocity of speed SPEED at angle β from the inward normal, moving along ±t."""
    beta = math.radians(beta_deg)
    return SPEED * np.array([direction * math.sin(beta), -math.cos(beta)])


# (profile, β in degrees, direction of the tangential velocity, every facet reached, ≥ 2 facets struck)
REGIMES = [
    # β < 30°: both sawtooth facets face u and are fully reached
    pytest.param("sawtooth", 20.0, +1, True, True, id="sawtooth-lit"),
    # β > 30°: the 60° facet faces away, wholly in the shadow of the peak, which also shades
    # the foot of the 30° rise; only the 30° facet is struck, so every weighting gives its
    # impulse (the two fluxes coincide)
    pytest.param("sawtooth", 50.0, +1, False, False, id="sawtooth-shadowed"),
    # β < 40°: every random segment faces u, none is shadowed
    pytest.param("random", 25.0, -1, True, True, id="random-lit"),
    # grazing: the steepest segments face away, others are partly or wholly shadowed by higher relief
    pytest.param("random", 70.0, +1, False, True, id="random-shadowed+"),
    pytest.param("random", 70.0, -1, False, True, id="random-shadowed-"),
]
ARGS = ("profile", "beta", "direction", "lit", "several")

# (model, contact frame, q): contact point of a mechanism striking the floor z = const
MECHANISMS = {
    # rod end, rod tilted by 0.7 rad: cond W = 4, principal axes at ~50° from the floor
    "rod": ("planar_rod", "end_a", np.array([0.0, 0.0, math.cos(0.7), math.sin(0.7)])),
    # pendulum tip: cond W ≈ 7.3, principal axes at ~−75° from the floor
    "pendulum": ("double_pendulum", "tip", np.array([0.5, 0.7])),
}


@pytest.mark.parametrize(ARGS, REGIMES)
def test_regime(profile: str, beta: float, direction: int, lit: bool, several: bool) -> None:
    """The rays split in proportion to the physical weight p_m (−mᵀu) where nothing is
    shadowed, and below it where something is (which is what the regimes claim)."""
    heights, dx = PROFILES[profile]
    u = incidence(beta, direction)
    _, _, hit = first_hit(heights, dx, u, np.eye(2), E)
    m, length = _facets(heights, dx)
    share = np.bincount(hit, minlength=length.size) / hit.size
    # a facet reached everywhere takes the flux across its projection, of the flux L |u_n|
    unshadowed = length * np.maximum(-(m @ u), 0.0) / (dx * length.size * -u[1])
    assert (share <= unshadowed + 2.0 / hit.size).all()
    if lit:
        assert (m @ u < 0.0).all()
        np.testing.assert_allclose(share, unshadowed, atol=2.0 / hit.size)
    else:  # some facet facing u is partly shadowed
        assert ((share > 0.01) & (share < unshadowed - 0.01)).any()
    struck = np.unique(np.round(m[np.unique(hit)], 12), axis=0)  # collinear segments are one facet
    assert (len(struck) > 1) == several


@pytest.mark.parametrize(ARGS, REGIMES)
def test_point_mass(profile: str, beta: float, direction: int, lit: bool, several: bool) -> None:
    """W = I: both weights coincide with the geometry."""
    heights, dx = PROFILES[profile]
    rough = mbi.Profile(heights, dx, shadowing=True, periodic=True)
    u = incidence(beta, direction)
    ref, bound, _ = first_hit(heights, dx, u, np.eye(2), E)
    tol = 2.0 * bound + ROUNDING * np.linalg.norm(ref)
    for law in (mbi.RoughLaw(rough, E), mbi.RoughLaw(rough, E, flux="configuration")):
        res = law.apply(np.eye(2), np.eye(2), u, [0.0, 1.0])
        assert np.linalg.norm(res.P - ref) <= tol


@pytest.mark.parametrize(ARGS, REGIMES)
@pytest.mark.parametrize("mechanism", sorted(MECHANISMS))
def test_mechanism(mechanism: str, profile: str, beta: float, direction: int, lit: bool, several: bool) -> None:
    """Anisotropic W: the default (physical) weight matches the geometry, the configuration weight does not."""
    model, frame, q = MECHANISMS[mechanism]
    mech = mbi.Mechanism.from_model(model)
    contact = mbi.PointContact(frame, normal=np.array([0.0, 0.0, 1.0]), tangent=np.array([1.0, 0.0, 0.0]))
    J, _ = contact.jacobian(mech, q, 2)  # rows: tangent (world x), normal (world z), as res.P
    W = J @ np.linalg.solve(mech.mass_matrix(q), J.T)
    assert np.linalg.cond(W) > 3.9
    u = incidence(beta, direction)
    v = np.linalg.pinv(J) @ u  # least-norm generalised velocity with J v = u

    heights, dx = PROFILES[profile]
    rough = mbi.Profile(heights, dx, shadowing=True, periodic=True)
    ref, bound, _ = first_hit(heights, dx, u, W, E)
    assert 2.0 * bound < 1e-4 * np.linalg.norm(ref)  # the rays resolve the weights finely enough
    tol = 2.0 * bound + ROUNDING * np.linalg.norm(ref)

    res = mbi.impact(mech, q, v, contact, mbi.RoughLaw(rough, E))
    np.testing.assert_allclose(res.u_minus, u, atol=1e-12)
    assert np.linalg.norm(res.P - ref) <= tol
    # κ = −(u + W P)_n / u_n and μ = |P_t| / P_n of the reference, with their error bounds
    kappa = -(u[1] + (W @ ref)[1]) / u[1]
    mu = abs(ref[0]) / ref[1]
    assert res.kappa == pytest.approx(kappa, abs=np.linalg.norm(W, 2) * tol / -u[1])
    assert res.mu == pytest.approx(mu, abs=(1.0 + mu) * tol / (ref[1] - tol))

    config = mbi.impact(mech, q, v, contact, mbi.RoughLaw(rough, E, flux="configuration"))
    if several:
        assert np.linalg.norm(config.P - ref) > 10.0 * tol
    else:  # a single facet struck: every weighting gives its impulse
        assert np.linalg.norm(config.P - ref) <= tol

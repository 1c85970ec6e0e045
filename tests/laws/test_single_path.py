"""The single-impact paths (the compiled route of ImpactLaw.apply_metric, NewtonLaw's closed form) against the batch pipeline.

A single impact skips the array machinery of :meth:`ImpactLaw.impulses` (checks, scalings and the
outcome in two compiled calls); for the contact velocity it reports, its impulse must be the batch
pipeline's to rounding, with the same rule and nodes, and its result the same checked object.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.metric.delassus import ContactMetric

from ..helpers import mechanism

LAWS = [
    mbi.NewtonLaw(0.5),
    mbi.RoughLaw(mbi.Cone(0.4), e=0.5),
    mbi.RoughLaw(mbi.Cone(0.6), 0.2, repeat=True),
    mbi.RoughLaw(mbi.GaussianSlopes(0.3), 0.5),
    mbi.RoughLaw(mbi.Sawtooth(0.3), 0.5),
]


def _case(name: str, rng: np.random.Generator, normal: tuple[float, ...]):
    mech = mechanism(name)
    q = mech.random_configuration(rng)
    frame = mech.frame_names[-1]
    contact = mbi.PointContact(frame=frame, normal=normal)
    J, R = contact.jacobian(mech, q, 3)
    n0 = R[:, -1]
    v = -J.T @ n0 / np.linalg.norm(J.T @ n0) + 0.3 * rng.normal(size=mech.nv)
    if (J @ v) @ n0 >= 0:
        v = -J.T @ n0
    return mech, q, v, contact


@pytest.mark.parametrize("law", LAWS, ids=repr)
@pytest.mark.parametrize("normal", [(0.0, 0.0, 1.0), (0.2, -0.1, 1.0)], ids=["world frame", "tilted"])
@pytest.mark.parametrize("name", ["ur5", "solo12"])
def test_single_impact_equals_the_batch_pipeline(law, normal, name, rng):
    for _ in range(3):
        mech, q, v, contact = _case(name, rng, normal)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = mbi.impact(mech, q, v, contact, law)
            J, R = contact.jacobian(mech, q, law.dim or 3)
            if isinstance(law, mbi.RoughLaw) and law.dim == 2:
                continue
            metric = ContactMetric.from_mechanism(mech, q, J)
            u = r.u_minus  # J v summed in the compiled order; numpy's may differ in the last bit
            np.testing.assert_allclose(u, J @ v, rtol=0, atol=1e-14 * np.abs(u).max())
            out = law.impulses(metric, u[None, :], R)  # the batch pipeline, one row
        if isinstance(law, mbi.NewtonLaw):  # Newton's own single path solves along one direction only
            np.testing.assert_allclose(r.P, out.P[0], rtol=1e-12, atol=1e-12 * np.abs(out.P).max())
        else:
            # the single route's W, its rotation and the law's sums are compiled apart from the batch
            # pipeline's: the same arithmetic, which a compiler may order otherwise
            np.testing.assert_allclose(r.P, out.P[0], rtol=0, atol=1e-13 * np.abs(out.P).max())
            assert abs(r.error_estimate - float(out.error[0])) <= 1e-13
            assert r.nodes == out.nodes and r.method == out.method
        assert np.array_equal(r.v_minus, v)
        for a in (r.v_minus, r.v_plus, r.dv, r.P, r.u_minus, r.u_plus, r.n0):
            assert not a.flags.writeable
        assert r.separates == bool(mbi.results.quantities.separates(r.n0, r.u_minus, r.u_plus))


def test_result_is_frozen_and_replaceable():
    import dataclasses

    r = mbi.NewtonLaw(0.5).apply(np.eye(3), np.eye(3), [0.1, 0.0, -1.0], [0, 0, 1])
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.nodes = 2  # type: ignore[misc]
    r2 = dataclasses.replace(r, nodes=3)
    assert r2.nodes == 3 and np.array_equal(r2.P, r.P) and not r2.v_plus.flags.writeable
    assert [f.name for f in dataclasses.fields(r)][:3] == ["v_minus", "v_plus", "dv"]

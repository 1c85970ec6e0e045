"""NewtonFacet is today's law exactly; facet laws plug into RoughLaw without changing the weights."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.facets import (CompliantFacet, CoulombFacet, FacetLaw, HuntCrossleyFacet, NewtonFacet, facet_frames,
                             facet_law, split_method, to_facet_frame)
from tests.helpers import unit_velocities


def spd(rng: np.random.Generator, d: int) -> np.ndarray:
    A = rng.normal(size=(d, d))
    return A @ A.T + 0.2 * np.eye(d)


@pytest.mark.parametrize("rough,methods", [
    (mbi.Sawtooth(0.4), ("exact",)),
    (mbi.Cone(0.3), ("ring", "adaptive", "fixed", "monte-carlo")),
    (mbi.GaussianSlopes(0.25), ("tilt-table", "adaptive")),
    (mbi.GaussianSlopes(0.25, dim=2), ("adaptive", "fixed")),
])
def test_newton_facet_is_todays_law_bit_for_bit(rough: mbi.Roughness, methods: tuple[str, ...],
                                               rng: np.random.Generator) -> None:
    d = rough.dim or 3
    W = spd(rng, d)
    U = unit_velocities(rng, 40, 1.4) if d == 3 else np.column_stack([np.sin(b := np.linspace(0, 1.4, 40)), -np.cos(b)])
    for method in methods:
        kw: dict[str, Any] = {"nodes": 32} if method == "fixed" else {}
        old = mbi.RoughLaw(rough, 0.6, method=method, **kw).contact_impulses(W, U)
        new = mbi.RoughLaw(rough, facet=NewtonFacet(0.6), method=method, **kw).contact_impulses(W, U)
        positional = mbi.RoughLaw(rough, NewtonFacet(0.6), method=method, **kw).contact_impulses(W, U)
        assert np.array_equal(old.P, new.P) and np.array_equal(old.P, positional.P)
        assert old.method == new.method == method  # Newton facets keep the bare averaging name
    one = U[7:8]  # single velocities: "auto" takes the adaptive rule's compiled backend on a cone
    old = mbi.RoughLaw(rough, 0.6).contact_impulses(W, one)
    new = mbi.RoughLaw(rough, facet=NewtonFacet(0.6)).contact_impulses(W, one)
    assert np.array_equal(old.P, new.P) and old.method == new.method


def test_auto_keeps_the_fast_paths_for_newton_facets(rng: np.random.Generator) -> None:
    W = spd(rng, 3)
    U = unit_velocities(rng, 64, 1.3)
    assert mbi.RoughLaw(mbi.Cone(0.3), facet=NewtonFacet(0.5)).contact_impulses(W, U).method == "ring"
    coarse = CoulombFacet(0.5, 0.2, steps=10)  # the label is the point here, not the accuracy
    assert mbi.RoughLaw(mbi.Cone(0.3), facet=coarse).contact_impulses(W, U[:8]).method == "adaptive[coulomb]"


def test_newton_impulse_equals_the_facet_frame_route(rng: np.random.Generator) -> None:
    """NewtonFacet.impulse's closed form equals the generic route through the facet frames (2.4)."""
    for d in (2, 3):
        W = spd(rng, d)
        m = rng.normal(size=(50, d))
        m[:, -1] = np.abs(m[:, -1]) + 0.1
        m /= np.linalg.norm(m, axis=1)[:, None]
        u = -m * rng.uniform(0.1, 1, (50, 1)) + 0.3 * rng.normal(size=(50, d))
        u = np.where((np.einsum("nd,nd->n", m, u) < 0)[:, None], u, -u)
        law = NewtonFacet(0.7)
        generic = FacetLaw.impulse(law, m, W, u)
        assert np.allclose(law.impulse(m, W, u), generic, rtol=1e-12, atol=1e-14)


def test_facet_frames_are_rotations_onto_the_facet_normal(rng: np.random.Generator) -> None:
    for d in (2, 3):
        m = rng.normal(size=(200, d))
        m[:, -1] = np.abs(m[:, -1]) + 1e-3
        m /= np.linalg.norm(m, axis=1)[:, None]
        R = facet_frames(m)
        assert np.allclose(np.swapaxes(R, 1, 2) @ R, np.eye(d), atol=1e-13)
        assert np.allclose(np.linalg.det(R), 1.0)
        assert np.allclose(R[:, :, -1], m)
        W = spd(rng, d)
        Wf, uf = to_facet_frame(R, W, m)  # the normal itself lands on the last axis
        assert np.allclose(uf, np.eye(d)[-1], atol=1e-13)
        assert np.allclose(Wf[:, -1, -1], np.einsum("nd,de,ne->n", m, W, m))


def test_non_newton_facets_refuse_the_closed_form_averages() -> None:
    for facet in (CoulombFacet(0.5, 0.3), CompliantFacet(0.5, 0.3, 0.8), HuntCrossleyFacet(0.1)):
        for method in ("ring", "poles"):
            with pytest.raises(mbi.ParameterError, match=f"'{method}' averaging integrates Newton facets"):
                mbi.RoughLaw(mbi.Cone(0.3), facet=facet, method=method)
        with pytest.raises(mbi.ParameterError, match="tilt-table"):
            mbi.RoughLaw(mbi.GaussianSlopes(0.3), facet=facet, method="tilt-table")


def test_construction_errors_and_replace() -> None:
    with pytest.raises(mbi.ParameterError, match="either e/k"):
        mbi.RoughLaw(mbi.Cone(0.3), 0.5, facet=CoulombFacet(0.5, 0.1))
    with pytest.raises(mbi.ParameterError, match="facet must be a facet law"):
        mbi.RoughLaw(mbi.Cone(0.3), facet="coulomb")  # type: ignore[arg-type]
    with pytest.raises(mbi.ParameterError, match="exactly one"):
        mbi.RoughLaw(mbi.Cone(0.3))
    law = mbi.RoughLaw(mbi.Cone(0.3), facet=CompliantFacet(0.5, 0.2, 0.8))
    assert law.rtol == 1e-3 and law.e == 0.5  # spatial compliant facets: the integrator's accuracy
    assert "facet=CompliantFacet" in repr(law)
    again = law.replace(repeat=True)
    assert again.facet == law.facet and again.repeat
    newton = law.replace(facet=NewtonFacet(0.5))
    assert newton.rtol == 1e-12  # the default accuracy goes with the facet law
    assert newton.replace(e=0.3).facet == NewtonFacet(0.3)
    with pytest.raises(mbi.ParameterError, match="give facet="):
        law.replace(e=0.3)
    assert facet_law("coulomb", e=0.5, mu=0.3) == CoulombFacet(0.5, 0.3)
    with pytest.raises(mbi.ParameterError, match="unknown facet law"):
        facet_law("stronge")
    with pytest.raises(mbi.ParameterError, match="facet law 'coulomb'"):
        facet_law("coulomb", e=0.5, friction=0.3)
    for bad in (lambda: CoulombFacet(1.5, 0.1), lambda: CoulombFacet(0.5, -1.0), lambda: CompliantFacet(0.5, 0.1, 0.0),
                lambda: HuntCrossleyFacet(-1.0), lambda: CoulombFacet(0.5, 0.1, "kinetic")):  # type: ignore[arg-type]
        with pytest.raises(mbi.ParameterError):
            bad()
    assert split_method("adaptive[compliant]") == ("adaptive", "compliant")
    assert split_method("ring") == ("ring", "newton")

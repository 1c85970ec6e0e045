"""κ < 0: outcomes of (2.8) that still approach the surface, and the repeated-impact limit."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import mbimpact as mbi

I3 = np.eye(3)
N0 = [0.0, 0.0, 1.0]


def test_steep_facets_at_normal_incidence_do_not_separate_and_say_so():
    """(4.2): 1 + κ = (1+e) cos²α for a cone, so κ < 0 once (1+e) cos²α < 1."""
    alpha, e = 1.2, 0.1
    law = mbi.RoughLaw(mbi.Cone(alpha), e)
    with pytest.warns(mbi.NoSeparationWarning, match="repeat=True") as caught:
        res = law.apply(I3, I3, [0.0, 0.0, -1.0], N0)
    assert caught[0].filename == __file__  # attributed to the caller's line
    assert res.kappa == pytest.approx((1 + e) * math.cos(alpha) ** 2 - 1, rel=1e-12)
    assert res.kappa < 0 and not res.separates
    # a shallow cone separates: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", mbi.NoSeparationWarning)
        assert mbi.RoughLaw(mbi.Cone(0.3), e).apply(I3, I3, [0.0, 0.0, -1.0], N0).separates


def test_a_loop_of_impacts_that_do_not_separate_warns_once_per_line():
    """Python's default filter shows a warning once per line of the caller for each text: the text does
    not carry κ (each impact's own value is on its result), so a loop of impacts warns once, whichever
    route runs them (compiled on a mechanism, the general route from arrays)."""
    mech = mbi.Mechanism.from_robot("solo12")
    q = mech.neutral()
    q[2] = 0.336  # a foot on the ground: oblique impacts on its anisotropic W keep approaching
    contact = mbi.PointContact("FL_FOOT")
    steep = mbi.RoughLaw(mbi.Cone(1.2), 0.1)
    for run in (lambda v: mbi.impact(mech, q, v, contact, mbi.RoughLaw(mbi.Cone(0.3), 0.5)),
                lambda v: steep.apply(I3, I3, [v[0], 0.0, -1.0], N0)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")
            kappas = set()
            for vx in np.linspace(0.1, 0.5, 5):
                v = np.zeros(mech.nv)
                v[[0, 2]] = vx, -1.0
                kappas.add(round(run(v).kappa, 12))
        assert len(kappas) == 5 and max(kappas) < 0.0  # five impacts, five outcomes, none separates
        assert len(caught) == 1 and caught[0].category is mbi.NoSeparationWarning
        assert "kappa < 0" in str(caught[0].message)


def test_the_warning_advises_what_the_law_can_do():
    """Only a rough law has ``repeat``: it is advised where it was off; where the repetition ran out of
    budget the warning says so instead; other laws point to the rough law."""
    law = mbi.RoughLaw(mbi.Cone(1.2), 0.1)
    assert law.separation_advice().endswith("use repeat=True to apply them")
    assert "stopped before the contact separated" in mbi.RoughLaw(mbi.Cone(1.2), 0.1, repeat=True).separation_advice()
    for other in (mbi.CoulombLaw(0.5, 0.3), mbi.NewtonLaw(0.5)):
        assert "a RoughLaw with repeat=True" in other.separation_advice()


def test_an_oblique_impact_on_an_anisotropic_delassus_matrix_can_still_approach():
    W = np.diag([1.0, 0.05, 2.0])
    law = mbi.RoughLaw(mbi.Cone(0.4), 0.0)
    with pytest.warns(mbi.NoSeparationWarning):
        res = law.apply(np.linalg.inv(W), I3, [0.5, 0.3, -1.0], N0)
    assert res.kappa < 0 and not res.separates
    assert res.energy_loss > 0


def test_the_warning_is_shown_once_per_call_site():
    law = mbi.RoughLaw(mbi.Cone(1.2), 0.1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default", mbi.NoSeparationWarning)
        for _ in range(5):
            law.apply(I3, I3, [0.0, 0.0, -1.0], N0)
    assert len(caught) == 1


def test_a_batch_warns_once_and_reports_each_row():
    law = mbi.RoughLaw(mbi.Cone(1.2), 0.1)
    V = np.array([[0.0, 0.0, -1.0], [0.2, 0.0, -1.0], [20.0, 0.0, -1.0]])  # grazing: thrown off the teeth
    with pytest.warns(mbi.NoSeparationWarning, match="2 of 3") as caught:
        res = law.apply_batch(I3, I3, V, N0)
    assert len(caught) == 1
    assert res.separates.tolist() == [False, False, True]


def test_plastic_impacts_separate_despite_rounding():
    """e = 0 leaves n⁰·u₊ at rounding level: that is a separation, not an approach."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        A = np.diag(rng.uniform(0.1, 10, 3))
        v = rng.normal(size=3)
        v[2] = -abs(v[2])
        with warnings.catch_warnings():
            warnings.simplefilter("error", mbi.NoSeparationWarning)
            res = mbi.NewtonLaw(0.0).apply(A, I3, v, N0)
        assert res.separates and abs(res.kappa) < 1e-12


def test_repeated_limit_at_normal_incidence_is_the_plastic_newton_impact():
    """Isotropic, normal incidence: u_n shrinks by −κ per impact, Σ (1+κ)(−κ)^k = 1: the limit of
    the micro-impacts is the plastic impact along n⁰, whatever e and α."""
    rng = np.random.default_rng(5)
    A = np.diag([2.0, 3.0, 0.5])
    for alpha, e in [(1.2, 0.1), (1.0, 0.0), (0.9, 0.2)]:
        law = mbi.RoughLaw(mbi.Cone(alpha), e, repeat=True)
        with warnings.catch_warnings():
            warnings.simplefilter("error", mbi.NoSeparationWarning)
            res = law.apply(A, I3, [0.0, 0.0, -rng.uniform(0.5, 2.0)], N0)
        plastic = mbi.NewtonLaw(0.0).apply(A, I3, res.v_minus, N0)
        np.testing.assert_allclose(res.P, plastic.P, rtol=1e-12, atol=1e-14)
        assert res.separates


def test_repeated_limit_equals_applying_the_law_by_hand():
    """Where the contact separates after a few micro-impacts, repeat=True is the plain loop."""
    W = np.diag([1.0, 0.05, 2.0])
    A = np.linalg.inv(W)
    once = mbi.RoughLaw(mbi.Cone(0.4), 0.0)
    v = np.array([0.5, 0.3, -1.0])
    total = np.zeros(3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        for count in range(1, 50):
            res = once.apply(A, I3, v, N0)
            total += res.P
            v = res.v_plus
            if res.separates:
                break
    assert count > 1
    rep = mbi.RoughLaw(mbi.Cone(0.4), 0.0, repeat=True).apply(A, I3, [0.5, 0.3, -1.0], N0)
    np.testing.assert_allclose(rep.P, total, rtol=1e-12)
    assert rep.separates and rep.energy_loss > 0


@pytest.mark.parametrize("seed", range(12))
def test_repeated_limit_never_gains_energy_and_always_separates(seed):
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    W = (Q * np.geomspace(1.0, 10 ** rng.uniform(0, 3), 3)) @ Q.T
    law = mbi.RoughLaw(mbi.Cone(rng.uniform(0.3, 1.3)), rng.uniform(0, 1), repeat=True)
    v = rng.normal(size=3)
    v[2] = -abs(v[2])
    with warnings.catch_warnings():
        warnings.simplefilter("error", mbi.NoSeparationWarning)
        res = law.apply(np.linalg.inv(W), I3, v, N0)
    assert res.separates
    assert res.energy_loss >= -1e-12 * res.T_minus


def test_micro_impacts_trapped_in_a_valley_stop_the_contact_point():
    """Directions that settle into a two-cycle (the contact point bouncing between two walls of a
    valley) shrink geometrically: the limit stops the contact point, P = −W⁻¹u₋. The plain loop of
    single impacts converges to the same impulse, slowly."""
    rng = np.random.default_rng(10)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    W = (Q * np.geomspace(1.0, 10 ** rng.uniform(0, 3), 3)) @ Q.T
    rough, e = mbi.Cone(rng.uniform(0.3, 1.3)), rng.uniform(0, 1)
    v0 = rng.normal(size=3)
    v0[2] = -abs(v0[2])
    A = np.linalg.inv(W)
    rep = mbi.RoughLaw(rough, e, repeat=True).apply(A, I3, v0, N0)
    np.testing.assert_allclose(rep.u_plus, 0.0, atol=1e-13)
    np.testing.assert_allclose(rep.P, -np.linalg.solve(W, v0), rtol=1e-12)
    once, v, total = mbi.RoughLaw(rough, e), v0.copy(), np.zeros(3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mbi.NoSeparationWarning)
        for _ in range(3000):
            res = once.apply(A, I3, v, N0)
            total, v = total + res.P, res.v_plus
            assert not res.separates and res.kappa < 0
    np.testing.assert_allclose(total, rep.P, rtol=1e-9)


def test_warnings_name_the_callers_file_whatever_its_path(tmp_path, monkeypatch):
    """A warning is attributed to the first frame outside the package: code compiled from a string is
    outside it, and a relative file name is resolved against the working directory of each warning
    (not of the first one)."""
    import os

    law, env = mbi.RoughLaw(mbi.Cone(1.2), 0.1), {"I3": I3, "N0": N0}
    env["law"] = law
    with pytest.warns(mbi.NoSeparationWarning) as caught:
        exec(compile("law.apply(I3, I3, [0.0, 0.0, -1.0], N0)", "<user code>", "exec"), env)
    assert caught[0].filename == "<user code>"
    relative = compile("law.apply(I3, I3, [0.0, 0.0, -1.0], N0)", "zz_user.py", "exec")
    monkeypatch.chdir(os.path.dirname(mbi.__file__))  # "zz_user.py" would be a file of the package here
    with pytest.warns(mbi.NoSeparationWarning) as caught:
        exec(relative, env)
    assert caught[0].filename == __file__
    monkeypatch.chdir(tmp_path)  # and the user's own file here
    with pytest.warns(mbi.NoSeparationWarning) as caught:
        exec(relative, env)
    assert caught[0].filename == "zz_user.py"

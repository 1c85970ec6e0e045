"""Gaps: closed forms for primitives, signs and normals, and ∇f against finite differences on the manifold."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import mbimpact as mbi
from mbimpact import geometry as G

from tests.geometry.helpers import floating_q, model, two_balls, unit

R_SPHERE = 0.05  # models/sphere.urdf
HALF_BOX = np.array([0.1, 0.1, 0.05])  # models/box.urdf


def random_halfspace(rng: np.random.Generator) -> G.HalfSpace:
    n = rng.normal(size=3)
    n[2] = abs(n[2]) + 1.0  # a slope, not a wall
    return G.HalfSpace(n, rng.uniform(-0.05, 0.05))


def fd_check(gm: G.GapModel, q: np.ndarray, rng: np.random.Generator, directions: int = 4,
             eps: float = 1e-5, rtol: float = 1e-6) -> None:
    """∇f·δv equals the central difference of f along q ⊕ ε δv (pin.integrate) for every pair."""
    mech = gm.mech
    for k in range(len(gm)):
        g = gm.gap(q, k)
        for _ in range(directions):
            dv = rng.normal(size=mech.nv)
            fp = gm.distances(pin.integrate(mech.model, q, eps * dv))[k]
            fm = gm.distances(pin.integrate(mech.model, q, -eps * dv))[k]
            fd = (fp - fm) / (2 * eps)
            assert g.gradient @ dv == pytest.approx(fd, abs=rtol * (1.0 + abs(fd))), (gm.pairs[k], g.distance)


# ---------------------------------------------------------------- closed forms
@pytest.mark.parametrize("seed", range(5))
def test_sphere_over_a_plane(seed):
    """Touches at the centre minus R times the normal; distance n·c − d − R; ∇f = nᵀJ(point)."""
    rng = np.random.default_rng(seed)
    mech = model("sphere")
    hs = random_halfspace(rng)
    q = floating_q(mech, rng, height=rng.uniform(-0.02, 0.3))
    (g,) = G.gaps(mech, q, [hs])
    c = q[:3]
    n = hs.normal
    assert (g.body, g.other) == ("sphere_0", "halfspace")
    assert g.distance == pytest.approx(n @ c - hs.offset - R_SPHERE, abs=1e-12)
    np.testing.assert_allclose(g.normal, n, atol=1e-12)
    np.testing.assert_allclose(g.point, c - R_SPHERE * n, atol=1e-12)
    np.testing.assert_allclose(g.point - g.other_point, g.distance * g.normal, atol=1e-12)
    np.testing.assert_allclose(g.jacobian, mech.point_jacobian(q, "sphere", pin.SE3(
        pin.Quaternion(q[3:7]).matrix(), c).actInv(g.point)), atol=1e-12)
    np.testing.assert_allclose(g.gradient, n @ g.jacobian, atol=1e-15)


@pytest.mark.parametrize("seed", range(5))
def test_tilted_box_touches_at_its_lowest_corner(seed):
    rng = np.random.default_rng(10 + seed)
    mech = model("box")
    q = floating_q(mech, rng, height=rng.uniform(-0.02, 0.3))
    R = pin.Quaternion(q[3:7]).matrix()
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * HALF_BOX
    world = q[:3] + corners @ R.T
    low = int(np.argmin(world[:, 2]))
    (g,) = G.gaps(mech, q, [G.HalfSpace()])
    # coal's GJK stops at GJK_TOLERANCE (1e-9) and starts from the last query's guess, so the
    # distance agrees to ~1e-11 and its last digits depend on which queries ran before
    assert g.distance == pytest.approx(world[low, 2], abs=1e-10)
    np.testing.assert_allclose(g.point, world[low], atol=1e-9)
    np.testing.assert_allclose(g.normal, [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(g.jacobian, mech.point_jacobian(q, "box", corners[low]), atol=1e-9)


def test_penetration_is_negative_and_the_normal_keeps_pointing_out():
    mech = model("sphere")
    q = mech.neutral()
    q[2] = 0.02  # 3 cm deep
    (g,) = G.gaps(mech, q, [G.HalfSpace()])
    assert g.penetrating and g.distance == pytest.approx(-0.03)
    np.testing.assert_allclose(g.normal, [0, 0, 1])
    np.testing.assert_allclose(g.point, [0, 0, -0.03], atol=1e-12)  # the deepest point
    np.testing.assert_allclose(g.other_point, [0, 0, 0], atol=1e-12)


def test_sphere_obstacle_normal_points_from_obstacle_to_body():
    mech = model("sphere")
    q = mech.neutral()
    q[:3] = [0.3, 0.4, 0.0]
    (g,) = G.gaps(mech, q, [G.Sphere(0.1, position=(0, 0, 0))])
    assert g.distance == pytest.approx(0.5 - 0.1 - R_SPHERE)
    np.testing.assert_allclose(g.normal, [0.6, 0.8, 0.0], atol=1e-9)
    np.testing.assert_allclose(g.other_point, [0.06, 0.08, 0.0], atol=1e-9)


def test_capsule_lowest_point(tiny_mjcf):
    """The MJCF capsule (fromto 0 0 0 → 0 0 −0.2, radius 0.02) hinged at the arm: lowest point closed form."""
    mech = mbi.Mechanism.from_mjcf(tiny_mjcf)
    q = mech.model.referenceConfigurations["qpos0"].copy()
    q[7] = 0.4  # hinge about y
    gm = G.GapModel(mech, [G.HalfSpace()], bodies=["stick"])
    g = gm.gap(q, 0)
    hinge = np.array([0.3, 0.0, 0.5])
    tip = hinge + pin.utils.rotate("y", 0.4) @ np.array([0, 0, -0.2])
    assert g.distance == pytest.approx(tip[2] - 0.02, abs=1e-12)
    np.testing.assert_allclose(g.point, tip - [0, 0, 0.02], atol=1e-9)


# ---------------------------------------------------------------- ∇f on the manifold
@pytest.mark.parametrize("name", ["sphere", "box"])
@pytest.mark.parametrize("seed", range(4))
def test_gradient_primitives_vs_halfspace_and_box(name, seed):
    rng = np.random.default_rng(100 + seed)
    mech = model(name)
    gm = G.GapModel(mech, [random_halfspace(rng), G.Box((0.3, 0.2, 0.1), position=(0.2, 0.1, -0.1),
                                                          rotation=pin.utils.rotate("z", 0.4))])
    fd_check(gm, floating_q(mech, rng), rng)


@pytest.mark.parametrize("seed", range(4))
def test_gradient_capsule(tiny_mjcf, seed):
    rng = np.random.default_rng(200 + seed)
    mech = mbi.Mechanism.from_mjcf(tiny_mjcf)
    gm = G.GapModel(mech, [random_halfspace(rng), G.Capsule(0.05, 0.4, position=(0.3, 0.0, 0.1),
                                                             rotation=pin.utils.rotate("x", 1.2))],
                    bodies=["stick", "ball_geom"])
    q = floating_q(mech, rng, height=0.4)
    fd_check(gm, q, rng)


@pytest.mark.parametrize("seed", range(3))
def test_gradient_convex_mesh_solo12_feet(seed):
    rng = np.random.default_rng(300 + seed)
    mech = model("solo12")
    gm = G.GapModel(mech, [random_halfspace(rng), G.Sphere(0.1, position=(0.2, 0.15, 0.0))],
                    bodies=["FL_FOOT_0", "HR_LOWER_LEG_0"])
    fd_check(gm, floating_q(mech, rng, height=0.25), rng)


@pytest.mark.parametrize("seed", range(3))
def test_gradient_convex_mesh_ur5_links(seed):
    """A fixed-base arm: hull links against a half-space, a box and a mesh obstacle (hull vs hull)."""
    rng = np.random.default_rng(400 + seed)
    mech = model("ur5")
    from mbimpact.mechanism.robots import robots_dir

    foot = G.Mesh(robots_dir() / "solo_description/meshes/stl/with_foot/solo_foot.stl", scale=3.0,
                  position=(0.4, 0.2, 0.3))
    gm = G.GapModel(mech, [G.HalfSpace((0, 0, 1), -0.2), G.Box((0.2, 0.2, 0.2), position=(0.5, 0.0, 0.2)), foot],
                    bodies=["forearm_link_0", "wrist_3_link_0", "ee_link_0"])
    fd_check(gm, mech.random_configuration(rng), rng)


@pytest.mark.parametrize("seed", range(3))
def test_gradient_self_collision_pairs(seed):
    """The relative Jacobian of two witness points gives ∇f of a pair of moving hulls."""
    rng = np.random.default_rng(500 + seed)
    mech = model("solo12")
    gm = G.GapModel(mech, self_pairs=[("FL_FOOT_0", "HL_FOOT_0"), ("FL_LOWER_LEG_0", "base_link_0"),
                                      ("FR_FOOT_0", "HR_LOWER_LEG_0")])
    fd_check(gm, floating_q(mech, rng), rng)


def test_two_balls_closed_form_and_relative_jacobian():
    mech = two_balls(0.1, 0.2)
    q = mech.neutral()
    q[:3] = [0.0, 0.0, 1.0]
    q[7:10] = [0.3, 0.4, 1.0]
    gm = G.GapModel(mech, self_pairs=[("ball_a", "ball_b")])
    g = gm.gap(q)
    assert g.distance == pytest.approx(0.5 - 0.3)
    n = np.array([-0.6, -0.8, 0.0])  # from b towards a
    np.testing.assert_allclose(g.normal, n, atol=1e-12)
    np.testing.assert_allclose(g.point, [0, 0, 1] + 0.1 * -n, atol=1e-12)
    np.testing.assert_allclose(g.other_point, [0.3, 0.4, 1] + 0.2 * n, atol=1e-12)
    # a moves with v_a, b with v_b: J v is the relative velocity of the witness points
    v = np.zeros(12)
    v[:3] = [1.0, 0, 0]
    v[6:9] = [0, 2.0, 0]
    np.testing.assert_allclose(g.velocity(v), [1.0, -2.0, 0.0], atol=1e-12)
    assert g.normal_velocity(v) == pytest.approx(n @ [1.0, -2.0, 0.0])
    fd_check(gm, q, np.random.default_rng(7))


# ---------------------------------------------------------------- many pairs, cutoffs, the broad phase
def test_pairs_order_and_names():
    mech = model("solo12")
    g1, g2 = G.HalfSpace(), G.HalfSpace((0, 0, 1), -1.0)
    gm = G.GapModel(mech, [g1, g2], bodies=["FL_FOOT_0", "FR_FOOT_0"], self_pairs=[("FL_FOOT_0", "FR_FOOT_0")])
    assert gm.pairs == (("FL_FOOT_0", "halfspace"), ("FL_FOOT_0", "halfspace_1"), ("FR_FOOT_0", "halfspace"),
                        ("FR_FOOT_0", "halfspace_1"), ("FL_FOOT_0", "FR_FOOT_0"))
    gaps = gm.gaps(floating_q(mech, np.random.default_rng(1)))
    assert [(g.body, g.other) for g in gaps] == list(gm.pairs)
    assert [g.pair for g in gaps] == list(range(5))
    assert gaps[1].distance == pytest.approx(gaps[0].distance + 1.0)
    assert gm.pair_index("FR_FOOT_0", "halfspace_1") == 3
    with pytest.raises(G.CollisionNotFoundError, match="pairs of 'FR_FOOT_0'"):
        gm.pair_index("FR_FOOT_0", "wall")


@pytest.mark.parametrize("seed", range(3))
def test_broad_phase_is_exact_below_the_cutoff(seed):
    rng = np.random.default_rng(600 + seed)
    mech = model("solo12")
    gm = G.GapModel(mech, [G.HalfSpace(), G.Sphere(0.1, position=(0.2, 0.0, 0.0))], self_pairs="all")
    assert gm.broad_phase and len(gm) > G.BROAD_PHASE_MIN_PAIRS
    q = floating_q(mech, rng, height=0.2)
    exact = gm.distances(q)
    lb = gm._spheres.lower_bounds(gm._workspace().gdata)
    assert np.all(lb <= exact + 1e-9)
    cut = 0.05
    approx = gm.distances(q, cutoff=cut)
    near = exact <= cut
    # GJK between hulls is warm-started: repeated queries agree to its tolerance (1e-9), not to the last bit
    np.testing.assert_allclose(approx[near], exact[near], rtol=0, atol=1e-9)
    assert np.all(approx[~near] > cut) and np.all(approx[~near] <= exact[~near] + 1e-9)
    kept = gm.gaps(q, cutoff=cut)
    assert [g.pair for g in kept] == np.flatnonzero(near).tolist()


def test_self_pairs_all_skips_adjacent_links_and_srdf():
    from mbimpact.mechanism.robots import robots_dir

    mech = model("solo12")
    gm = G.GapModel(mech, self_pairs="all")
    names = {frozenset(p) for p in gm.pairs}
    assert frozenset(("FL_LOWER_LEG_0", "FL_FOOT_0")) not in names  # same joint
    assert frozenset(("FL_UPPER_LEG_0", "FL_LOWER_LEG_0")) not in names  # parent and child
    assert frozenset(("FL_FOOT_0", "HL_FOOT_0")) in names
    srdf = robots_dir() / "solo_description/srdf/solo.srdf"
    filtered = G.GapModel(mech, self_pairs="all", srdf=srdf)
    assert set(filtered.pairs) <= set(gm.pairs)


# ---------------------------------------------------------------- bad input
def test_bad_queries_are_named_errors():
    mech = model("box")
    gm = G.GapModel(mech, [G.HalfSpace()])
    with pytest.raises(mbi.ShapeError, match="q"):
        gm.gaps(np.zeros(3))
    q = mech.neutral()
    q[0] = math.nan
    with pytest.raises(mbi.NonFiniteError, match="q"):
        gm.distances(q)
    q = mech.neutral()
    q[3:7] = [1, 1, 0, 0]
    with pytest.raises(mbi.ParameterError, match="normalised"):
        gm.gaps(q)
    with pytest.raises(mbi.NonFiniteError, match="cutoff"):
        gm.distances(mech.neutral(), cutoff=math.nan)
    with pytest.raises(mbi.ParameterError, match="margin"):
        gm.contact_points(mech.neutral(), margin=-1.0)
    with pytest.raises(mbi.ParameterError, match=r"pair index 5"):
        gm.gap(mech.neutral(), 5)
    with pytest.raises(mbi.ParameterError, match=r"obstacles\[1\]"):
        G.GapModel(mech, [G.HalfSpace(), "ground"])  # type: ignore[list-item]
    with pytest.raises(mbi.ParameterError, match="one string"):
        G.GapModel(mech, [G.HalfSpace()], bodies="box_0")
    with pytest.raises(mbi.ParameterError, match="itself"):
        G.GapModel(mech, self_pairs=[("box_0", "box_0")])
    with pytest.raises(mbi.ParameterError, match="twice"):
        G.GapModel(mech, [G.HalfSpace()], bodies=["box_0", "box_0"])
    with pytest.raises(G.GeometryError, match="no pair"):
        G.GapModel(mech)
    with pytest.raises(mbi.ParameterError, match="Mechanism"):
        G.GapModel("box", [G.HalfSpace()])  # type: ignore[arg-type]


def test_gaps_are_immutable():
    mech = model("sphere")
    (g,) = G.gaps(mech, mech.neutral(), [G.HalfSpace()])
    for a in (g.normal, g.point, g.other_point, g.jacobian, g.gradient):
        with pytest.raises(ValueError):
            a[0] = 1.0
    np.testing.assert_allclose(g.frame()[:, 2], g.normal)
    R = g.frame(tangent=(1, 1, 0))
    np.testing.assert_allclose(R[:, 0], unit(np.array([1.0, 1.0, 0.0])))
    with pytest.raises(mbi.ShapeError, match="parallel"):
        g.frame(tangent=(0, 0, 1))


def test_gap_constructor_checks_shapes():
    g = G.Gap("a", "b", 0.1, [0, 0, 1], [0, 0, 0], [0, 0, -0.1], np.zeros((3, 2)), np.zeros(2))
    assert isinstance(g.normal, np.ndarray) and not g.normal.flags.writeable
    with pytest.raises(mbi.ShapeError, match=r"\(3, nv\)"):
        G.Gap("a", "b", 0.1, [0, 0, 1], [0, 0, 0], [0, 0, 0], np.zeros((2, 2)), np.zeros(2))


def test_one_call_queries_reuse_their_gap_model():
    from mbimpact.geometry import cache

    mech = mbi.Mechanism.from_model("box")
    ground = G.HalfSpace()
    assert G.gap_model(mech, [ground]) is G.gap_model(mech, [ground])
    assert G.gap_model(mech, [ground]) is not G.gap_model(mech, [G.HalfSpace()])  # obstacles by identity
    for _ in range(cache.GAP_MODELS_KEPT + 3):
        G.gap_model(mech, [G.HalfSpace()])
    assert len(cache.mechanism_cache(mech)["gap_models"]) == cache.GAP_MODELS_KEPT


@pytest.mark.parametrize("seed", range(3))
def test_stacked_evaluation_equals_the_gaps(seed):
    rng = np.random.default_rng(700 + seed)
    mech = model("solo12")
    gm = G.GapModel(mech, [G.HalfSpace(), random_halfspace(rng)], self_pairs=[("FL_FOOT_0", "HL_FOOT_0"),
                                                                            ("FR_LOWER_LEG_0", "base_link_0")])
    q = floating_q(mech, rng, height=0.25)
    arrays = gm.evaluate(q)
    gaps = gm.gaps(q)
    assert len(arrays) == len(gaps) == len(gm)
    for k, g in enumerate(gaps):
        assert arrays.pairs[k] == g.pair
        assert arrays.distance[k] == pytest.approx(g.distance, abs=1e-9)
        np.testing.assert_allclose(arrays.normal[k], g.normal, atol=1e-9)
        np.testing.assert_allclose(arrays.point[k], g.point, atol=1e-9)
        np.testing.assert_allclose(arrays.jacobian[k], g.jacobian, atol=1e-9)
        np.testing.assert_allclose(arrays.gradient[k], g.gradient, atol=1e-9)
    ds = np.sort(arrays.distance)
    cut = float(ds[len(ds) // 2 - 1] + ds[len(ds) // 2]) / 2  # between two distances, far from both
    some = gm.evaluate(q, cutoff=cut)
    assert some.pairs.tolist() == [k for k in range(len(gm)) if arrays.distance[k] <= cut]
    assert not some.jacobian.flags.writeable
    none = gm.evaluate(q, cutoff=-10.0)
    assert len(none) == 0 and none.jacobian.shape == (0, 3, mech.nv)


@pytest.mark.parametrize("seed", range(20))
def test_contact_frame_follows_local_basis(seed):
    from mbimpact.geometry.gap import contact_frame

    n = unit(np.random.default_rng(seed).normal(size=3))
    np.testing.assert_allclose(contact_frame(n), mbi.local_basis(n, 3), atol=1e-14)


# ---------------------------------------------------------------- rates and chosen pairs
@pytest.mark.parametrize("seed", range(3))
def test_rates_are_the_gradient_along_v_without_jacobians(seed):
    """GapModel.rates gives ḟ = ∇f·v from one forward pass with v: obstacles and self pairs."""
    rng = np.random.default_rng(600 + seed)
    mech = model("solo12")
    q = floating_q(mech, rng, height=0.25)
    v = rng.normal(size=mech.nv)
    for gm in (G.GapModel(mech, [random_halfspace(rng), G.Box((0.3, 0.2, 0.1), position=(0.2, 0.1, -0.1))],
                          bodies=["FL_FOOT_0", "base_link_0"]),
               G.GapModel(mech, self_pairs=[("FL_FOOT_0", "HL_FOOT_0"), ("FR_LOWER_LEG_0", "base_link_0")])):
        f, rate = gm.rates(q, v)
        np.testing.assert_allclose(f, gm.distances(q), rtol=0, atol=1e-12)
        np.testing.assert_allclose(rate, [g.gradient @ v for g in gm.gaps(q)], rtol=1e-9, atol=1e-12)
    with pytest.raises(mbi.ParameterError, match="v must have shape"):
        gm.rates(q, v[:3])


def test_contact_points_of_chosen_pairs():
    mech = model("box")
    q = mech.neutral()
    q[2] = 0.05  # lying flat on z = 0, and 0.05 above z = -0.05
    gm = G.GapModel(mech, [G.HalfSpace(), G.HalfSpace(offset=-0.05)])
    both = gm.contact_points(q, margin=1e-3, patch_tolerance=1e-6)
    assert [g.pair for g in both] == [0] * 4
    assert gm.contact_points(q, margin=1e-3, patch_tolerance=1e-6, pairs=[1]) == []
    wide = gm.contact_points(q, margin=0.06, patch_tolerance=1e-6, pairs=[1])
    assert len(wide) == 4 and all(g.pair == 1 and g.distance == pytest.approx(0.05) for g in wide)
    with pytest.raises(mbi.ParameterError, match="pair indices"):
        gm.contact_points(q, pairs=[2])

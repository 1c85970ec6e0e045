"""Collision contacts in scenes and scene files: validation, expansion of "all", errors naming key and line."""

from __future__ import annotations

import pytest

import mbimpact as mbi

SPHERE = """name = "s"
[mechanism]
model = "sphere"
floating = true
[initial]
q = [0.0, 0.0, 0.3, 0.0, 0.0, 0.0, 1.0]
{obstacles}
[[contacts]]
{contact}
e = 0.5
"""
GROUND = '[[obstacles]]\nname = "ground"\nshape = "halfspace"'


def load(tmp_path, contact, obstacles=GROUND):
    path = tmp_path / "s.toml"
    path.write_text(SPHERE.format(contact=contact, obstacles=obstacles))
    return mbi.load_scene(path)


def test_a_collision_contact_from_a_file(tmp_path):
    scene = load(tmp_path, 'body = "sphere_0"\nobstacle = "ground"\nfriction = 0.2')
    (c,) = scene.contacts
    assert isinstance(c, mbi.SceneCollision) and c.label == "sphere_0 | ground" and c.friction == 0.2
    assert isinstance(c.obstacle, mbi.HalfSpace)
    box = '[[obstacles]]\nname = "step"\nshape = "box"\nsize = [1.0, 1.0, 0.1]\nposition = [0.0, 0.0, -0.05]\nrpy = [0.0, 0.1, 0.0]'
    (c,) = load(tmp_path, 'body = ["sphere_0"]\nobstacle = "step"', box).contacts
    assert isinstance(c.obstacle, mbi.Box) and c.obstacle.rotation[0, 2] == pytest.approx(0.0998334, rel=1e-6)


@pytest.mark.parametrize("contact, obstacles, match", [
    ('frame = "bottom"\nbody = "sphere_0"\nobstacle = "ground"', GROUND,
     r"contacts\[0\] \(line 10\): a contact needs exactly one of frame .* or body"),
    ('body = "sphere_0"', GROUND, r"contacts\[0\]\.body \(line 11\): a collision contact needs exactly one of obstacle"),
    ('body = "sphere_0"\nobstacle = "groun"', GROUND,
     r"contacts\[0\]\.obstacle \(line 12\): no obstacle 'groun' \(did you mean 'ground'\?\)"),
    ('body = "sphere_0"\nobstacle = "ground"', "", r"no obstacle 'ground'; declare it in an \[\[obstacles\]\] table"),
    ('body = "sphere_1"\nobstacle = "ground"', GROUND, r"contacts\[0\]\.body \(line 11\).*no collision object 'sphere_1'.*sphere_0"),
    ('body = "sphere_0"\nobstacle = "ground"\nsurface = "plane"', GROUND,
     r"contacts\[0\]\.surface \(line 13\): applies to frame contacts"),
    ('frame = "bottom"\nobstacle = "ground"', GROUND, r"contacts\[0\]\.obstacle \(line 12\): applies to collision contacts"),
    ('body = "sphere_0"\nobstacle = "ground"', '[[obstacles]]\nname = "ground"\nshape = "box"',
     r"obstacles\[0\]\.shape \(line 9\): a box needs size"),
    ('body = "sphere_0"\nobstacle = "ground"', '[[obstacles]]\nname = "ground"\nshape = "halfspace"\nradius = 1.0',
     r"obstacles\[0\]\.radius \(line 10\): does not apply to shape = 'halfspace'"),
    ('body = "sphere_0"\nobstacle = "ground"', '[[obstacles]]\nname = "ground"\nshape = "cone"',
     r"obstacles\[0\]\.shape \(line 9\): must be one of 'halfspace'"),
    ('body = "sphere_0"\nobstacle = "ground"', GROUND + "\n" + GROUND,
     r"obstacles\[1\]\.name \(line 11\): obstacle 'ground' is declared twice"),
    ('body = "sphere_0"\nobstacle = "ground"', '[[obstacles]]\nname = "ground"\nshape = "mesh"\npath = "none.stl"',
     r"obstacles\[0\] \(line 7\): mesh file .*none\.stl' not found"),
    ('body = "sphere_0"\nobstacle = "ground"', '[[obstacles]]\nname = "ground"\nshape = "halfspace"\noffset = 0.3',
     r"contacts\[0\].*starts 0\.05 m inside what it strikes"),
])
def test_collision_mistakes_name_key_and_line(tmp_path, contact, obstacles, match):
    with pytest.raises(mbi.SceneError, match=match):
        load(tmp_path, contact, obstacles)


def test_all_expands_to_one_contact_per_pair():
    solo = mbi.Mechanism.from_robot("solo12")
    law = mbi.NewtonLaw(0.2)
    ground = mbi.HalfSpace()
    q = solo.neutral()
    q[2] = 1.0
    scene = mbi.Scene(solo, q, [0.0] * solo.nv,
                      (mbi.SceneCollision("all", law, obstacle=ground),))
    assert len(scene.contacts) == len(solo.collision_model().moving) == 17
    assert all(c.concrete and c.obstacle is ground for c in scene.contacts)
    feet = mbi.SceneCollision(["FL_FOOT_0", "FR_FOOT_0"], law, obstacle=ground)
    assert [c.body for c in feet.pairs(solo)] == ["FL_FOOT_0", "FR_FOOT_0"]
    self_pairs = mbi.SceneCollision("all", law, other="all").pairs(solo)
    assert len(self_pairs) == len(mbi.gap_model(solo, self_pairs="all").pairs)
    assert all(c.other is not None and c.other != c.body for c in self_pairs)
    base = mbi.SceneCollision("base_link_0", law, other="all").pairs(solo)
    assert base and all("base_link_0" in (c.body, c.other) for c in base)


def test_collision_contacts_are_validated():
    sphere = mbi.Mechanism.from_model("sphere", floating=True)
    law = mbi.NewtonLaw(0.5)
    ground = mbi.HalfSpace()
    q = sphere.neutral()
    q[2] = 0.3
    v = [0.0] * 6
    for kwargs, match in [({}, "exactly one of obstacle"), ({"obstacle": ground, "other": "x"}, "exactly one"),
                          ({"obstacle": "ground"}, "must be a shape"), ({"obstacle": ground, "friction": -1.0}, "friction"),
                          ({"other": "sphere_0"}, "does not strike itself")]:
        with pytest.raises(mbi.ImpactError, match=match):
            mbi.SceneCollision("sphere_0", law, **kwargs)
    with pytest.raises(mbi.SceneError, match="body"):
        mbi.SceneCollision(3, law, obstacle=ground)  # type: ignore[arg-type]
    with pytest.raises(mbi.SceneError, match="law"):
        mbi.SceneCollision("sphere_0", "newton", obstacle=ground)  # type: ignore[arg-type]
    twice = mbi.SceneCollision("sphere_0", law, obstacle=ground)
    with pytest.raises(mbi.SceneError, match="declared twice"):
        mbi.Scene(sphere, q, v, (twice, twice))
    with pytest.raises(mbi.SceneError, match=r"contacts\[0\].*no collision object 'ball'"):
        mbi.Scene(sphere, q, v, (mbi.SceneCollision("ball", law, obstacle=ground),))
    with pytest.raises(mbi.SceneError, match="no pair"):
        mbi.Scene(sphere, q, v, (mbi.SceneCollision("all", law, other="all"),))  # one object: no self pair
    q[2] = 0.01
    with pytest.raises(mbi.SceneError, match=r"starts 0\.04 m inside what it strikes"):
        mbi.Scene(sphere, q, v, (mbi.SceneCollision("sphere_0", law, obstacle=ground),))
    with pytest.raises(mbi.ImpactError, match="patch_tolerance"):
        mbi.Scene(sphere, [0, 0, 1, 0, 0, 0, 1], v, (mbi.SceneCollision("sphere_0", law, obstacle=ground),),
                  patch_tolerance=0.0)

"""The scene file format: every mistake is a SceneError naming the key and its line."""

from __future__ import annotations

import re

import pytest

import mbimpact as mbi
from mbimpact.apps.cli import main

BASE = """name = "s"
[mechanism]
model = "point_mass_3d"
[initial]
q = [0.0, 0.0, 0.3]
[[contacts]]
frame = "mass"
e = 0.5
{contact}
{tables}
"""


def load(tmp_path, contact="", tables=""):
    path = tmp_path / "s.toml"
    path.write_text(BASE.format(contact=contact, tables=tables))
    return mbi.load_scene(path)


def line_of(text, needle):
    return 1 + text.splitlines().index(needle)


@pytest.mark.parametrize("contact, tables, match", [
    ("", "[simulation]\nduraton = 2.0", r"simulation\.duraton \(line 11\): unknown key 'duraton' \(did you mean 'duration'\?\)"),
    ("", "[forces]\ngravty = true", r"forces\.gravty \(line 11\): unknown key 'gravty' \(did you mean 'gravity'\?\)"),
    ("motion = { freq = 5.0 }", "", r"contacts\[0\]\.motion\.freq \(line 9\): unknown key 'freq' \(did you mean 'frequency'\?\)"),
    ("", "[forces]\ngravity = \"no\"", r"forces\.gravity \(line 11\): must be of type boolean, got 'no'"),
    ("law = \"rough\"", "", r"contacts\[0\]\.law \(line 9\): law = 'rough' needs a roughness table"),
    ("law = \"newton\"\nroughness = { kind = \"cone\", alpha = 0.2 }", "",
     r"contacts\[0\]\.roughness \(line 10\): does not apply to law = 'newton'"),
    ("mu = 0.3", "", r"contacts\[0\]\.mu \(line 9\): does not apply to law = 'newton'"),
    ("k = 0.1", "", r"contacts\[0\]\.e \(line 8\): give exactly one of e"),
    ("normal = [0.0, nan, 1.0]", "", r"contacts\[0\]\.normal\[1\].*not a finite number"),
    ("normal = [0.0, 1.0]", "", r"contacts\[0\]\.normal.*too short"),
    ("surface = \"sphere\"", "", r"contacts\[0\]\.surface \(line 9\): must be one of 'plane', 'paraboloid', got 'sphere'"),
    ("surface = \"paraboloid\"", "", r"contacts\[0\]\.surface \(line 9\): a paraboloid needs rho"),
    ("rho = 0.3", "", r"contacts\[0\]\.rho \(line 9\): rho applies to surface = 'paraboloid' only"),
    ("roughness = { kind = \"cone\", alpha = 2.0 }", "", r"contacts\[0\]\.roughness.*0 ≤ alpha < π/2 rad"),
    ("roughness = { kind = \"cone\", sigma = 0.2 }", "", r"contacts\[0\]\.roughness\.sigma.*does not apply to a cone"),
    ("e = 0.3", "", r"TOML"),
    ("", "[simulation]\nduration = -1.0", r"simulation\.duration \(line 11\).*minimum"),
    ("", "[simulation]\nsimultaneous = \"magic\"", r"simulation\.simultaneous.*'newton'"),
    ("", "[record]\nstates = [\"x3\"]", r"record\.states\[0\].*does not match"),
    ("", "[forces]\ntorque = [1.0]", r"forces\.torque \(line 11\): must have 3 entries"),
    ("", "[forcez]\ngravity = true", r"forcez \(line 10\): unknown key 'forcez' \(did you mean 'forces'\?\)"),
    ("roughness = { kind = \"cone\", alpha = 0.2 }\nfacet = { kind = \"coulomb\" }", "",
     r"contacts\[0\]\.facet \(line 10\): a coulomb facet needs mu"),
    ("roughness = { kind = \"cone\", alpha = 0.2 }\nfacet = { kind = \"coulomb\", mu = 0.2, alpha = 1.0 }", "",
     r"contacts\[0\]\.facet\.alpha \(line 10\): does not apply to a coulomb facet"),
    ("law = \"newton\"\nfacet = { kind = \"coulomb\", mu = 0.2 }", "",
     r"contacts\[0\]\.facet \(line 10\): does not apply to law = 'newton'"),
    ("roughness = { kind = \"cone\", alpha = 0.2 }\nfacet = { kind = \"hunt-crossley\", alpha = 0.1 }", "",
     r"contacts\[0\]\.e \(line 8\): a hunt-crossley facet has no e or k"),
    ("roughness = { kind = \"cone\", alpha = 0.2 }\nfacet = { kind = \"stronge\" }", "",
     r"contacts\[0\]\.facet\.kind.*must be one of 'newton', 'coulomb'"),
])
def test_mistakes_are_errors_naming_key_and_line(tmp_path, contact, tables, match):
    with pytest.raises(mbi.SceneError, match=match):
        load(tmp_path, contact, tables)


def test_contradictory_mechanism_and_state(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[mechanism]\nrobot = "ur5"\nmodel = "point_mass_3d"\n[[contacts]]\nframe = "tool0"\ne = 0.5\n')
    with pytest.raises(mbi.SceneError, match=r"mechanism\.model \(line 3\): give exactly one of robot, model or urdf"):
        mbi.load_scene(path)
    path.write_text('[mechanism]\nmodel = "point_mass_3d"\n[initial]\nq = [0.0, 0.0, 1.0]\nposture = "neutral"\n'
                    '[[contacts]]\nframe = "mass"\ne = 0.5\n')
    with pytest.raises(mbi.SceneError, match=r"initial\.posture \(line 5\): give q or posture, not both"):
        mbi.load_scene(path)
    path.write_text('[mechanism]\nmodel = "point_mass_3d"\n[[contacts]]\nframe = "massx"\ne = 0.5\n')
    with pytest.raises(mbi.SceneError, match=r"contacts\[0\].*frame 'massx' not found.*mass"):
        mbi.load_scene(path)
    with pytest.raises(mbi.SceneError, match="shipped scenes"):
        mbi.load_scene("no_such_scene")


def test_a_start_inside_a_surface_is_an_error(tmp_path):
    path = tmp_path / "s.toml"
    text = BASE.format(contact="origin = [0.0, 0.0, 0.5]", tables="")
    path.write_text(text)
    with pytest.raises(mbi.SceneError, match=r"contacts\[0\] \(line 6\).*starts 0\.2 m inside its surface"):
        mbi.load_scene(path)
    with pytest.raises(mbi.SceneError, match="inside its surface"):
        mbi.Scene(mbi.Mechanism.from_model("point_mass_3d"), [0.0, 0.0, -1e-6], [0.0, 0.0, 0.0],
                  (mbi.SceneContact("mass", mbi.NewtonLaw(0.5)),))


def test_scene_objects_are_validated():
    mech = mbi.Mechanism.from_model("point_mass_3d")
    c = mbi.SceneContact("mass", mbi.NewtonLaw(0.5))
    for kwargs, match in [({"duration": float("nan")}, "finite"), ({"contact_step": 0.0}, "contact_step"),
                          ({"simultaneous": "x"}, "simultaneous"), ({"record": ("q9",)}, "record"),
                          ({"gravity": "no"}, "gravity"), ({"max_impacts": 0}, "max_impacts")]:
        with pytest.raises(mbi.ImpactError, match=match):
            mbi.Scene(mech, [0.0, 0.0, 1.0], [0.0, 0.0, 0.0], (c,), **kwargs)
    with pytest.raises(mbi.ImpactError, match="law must be an impact law"):
        mbi.SceneContact("mass", 3)  # type: ignore[arg-type]
    with pytest.raises(mbi.SceneError, match="give exactly one of e"):  # a law by name, as in a file, needs e
        mbi.SceneContact("mass", "newton")  # type: ignore[arg-type]
    with pytest.raises(mbi.ImpactError, match="friction"):
        mbi.SceneContact("mass", mbi.NewtonLaw(0.5), friction=-1.0)
    with pytest.raises(mbi.ImpactError, match="rho"):
        mbi.Surface("paraboloid", rho=0.0)
    with pytest.raises(mbi.ImpactError, match="Scene"):
        mbi.simulate("ball_drop")  # type: ignore[arg-type]


def test_the_reference_lists_every_key_and_the_cli_prints_it(capsys):
    text = mbi.simulation.reference()
    schema = mbi.simulation.schema.SCHEMA
    for table, sub in schema["properties"].items():
        assert table in text
        props = sub.get("properties") or sub.get("items", {}).get("properties", {})
        for key in props:
            assert re.search(rf"\b{key}\b", text), (table, key)
    with pytest.raises(SystemExit):
        main(["scene", "--help"])
    out = capsys.readouterr().out
    assert "[[contacts]]" in out and "rest_velocity" in out and "chatter_time" in out


def test_scene_command_checks_a_file(capsys, tmp_path):
    assert main(["scene", "ball_drop"]) == 0
    assert "ball_drop" in capsys.readouterr().out
    path = tmp_path / "s.toml"
    path.write_text(BASE.format(contact="", tables="[simulation]\nduraton = 2.0"))
    assert main(["scene", str(path)]) == 2
    assert "duraton" in capsys.readouterr().err


def test_facet_laws_in_scene_files(tmp_path):
    scene = load(tmp_path, "roughness = { kind = \"cone\", alpha = 0.2 }\nfacet = { kind = \"coulomb\", mu = 0.2 }")
    law = scene.contacts[0].law
    assert isinstance(law, mbi.RoughLaw) and law.facet == mbi.CoulombFacet(0.5, 0.2) and law.repeat
    tr = mbi.simulate(scene)
    hit = next(e for e in tr.events if e.kind == "impact")
    assert tr.status == "completed" and "CoulombFacet" in hit.rule and hit.kappa > 0

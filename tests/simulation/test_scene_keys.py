"""Scenes in Python take the scene file's keys; scene files are found by path whatever their suffix."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.apps.cli import main
from mbimpact.simulation.schema import SCHEMA

CONTACT_KEYS = SCHEMA["properties"]["contacts"]["items"]["properties"]

# a value for each key of a [[contacts]] table that is valid alone (with frame or body and a law)
CONTACT_VALUES = {
    "frame": "mass", "point": [0.0, 0.0, 0.0], "surface": "plane", "normal": [0.0, 0.0, 1.0],
    "origin": [0.0, 0.0, -0.1], "tangent": [1.0, 0.0, 0.0], "law": "newton", "e": 0.5, "friction": 0.3,
    "stiffness": 1e4, "motion": {"amplitude": 0.01, "frequency": 2.0, "phase": 0.0},
}


def _frame_contact(key: str) -> dict:
    """The keyword arguments of a frame contact that uses ``key``."""
    kw = {"frame": "mass", "law": "newton", "e": 0.5}
    extra = {"k": {"k": 0.2}, "roughness": {"law": "rough", "roughness": {"kind": "cone", "alpha": 0.2}},
             "flux": {"law": "rough", "roughness": {"kind": "cone", "alpha": 0.2}, "flux": "configuration"},
             "facet": {"law": "rough", "roughness": {"kind": "cone", "alpha": 0.2}, "facet": {"kind": "coulomb", "mu": 0.2}},
             "mu": {"law": "coulomb", "mu": 0.4}, "restitution": {"law": "coulomb", "mu": 0.4, "restitution": "poisson"},
             "rho": {"surface": "paraboloid", "rho": 2.0}}
    if key == "k":
        del kw["e"]
    if key in extra:
        kw.update(extra[key])
    elif key in CONTACT_VALUES:
        kw[key] = CONTACT_VALUES[key]
    return kw


@pytest.mark.parametrize("key", sorted(CONTACT_KEYS))
def test_every_contact_key_of_the_file_is_a_python_key(key):
    """SceneContact (frame keys) or SceneCollision (body keys) takes every key of a [[contacts]] table."""
    if key in ("body", "obstacle", "other"):
        kw = {"body": "all", "law": "newton", "e": 0.5}
        kw.update({"obstacle": mbi.HalfSpace()} if key in ("body", "obstacle") else {"other": "all"})
        contact = mbi.SceneCollision(**kw)
        assert contact.law == mbi.NewtonLaw(0.5) or repr(contact.law) == "NewtonLaw(e=0.5)"
        return
    contact = mbi.SceneContact(**_frame_contact(key))
    law, surface = contact.law, contact.surface
    checks = {
        "e": lambda: repr(law) == "NewtonLaw(e=0.5)", "k": lambda: isinstance(law, mbi.NewtonLaw) and law.e == pytest.approx(mbi.e_from_k(0.2)),
        "roughness": lambda: isinstance(law, mbi.RoughLaw) and law.roughness == mbi.Cone(0.2),
        "flux": lambda: law.flux == "configuration", "facet": lambda: isinstance(law.facet, mbi.CoulombFacet),
        "mu": lambda: isinstance(law, mbi.CoulombLaw) and law.mu == 0.4,
        "restitution": lambda: law.restitution == "poisson",
        "rho": lambda: surface.kind == "paraboloid" and surface.rho == 2.0,
        "origin": lambda: np.allclose(surface.origin, [0.0, 0.0, -0.1]),
        "normal": lambda: np.allclose(surface.normal, [0.0, 0.0, 1.0]),
        "motion": lambda: surface.amplitude == 0.01 and surface.frequency == 2.0,
        "friction": lambda: contact.friction == 0.3, "stiffness": lambda: contact.stiffness == 1e4,
        "tangent": lambda: np.allclose(contact.tangent, [1.0, 0.0, 0.0]),
        "surface": lambda: surface.kind == "plane", "frame": lambda: contact.frame == "mass",
        "point": lambda: np.allclose(contact.point, 0.0), "law": lambda: isinstance(law, mbi.NewtonLaw),
    }
    assert checks[key](), (key, contact)


@pytest.mark.parametrize("table", ["initial", "forces", "simulation", "record", "mechanism", "top"])
def test_every_scene_key_of_the_file_is_a_python_key(table):
    """Scene takes each key of the file's tables one by one, and the tables whole."""
    mech = mbi.Mechanism.from_model("point_mass_3d")
    base = {"mechanism": mech, "q": [0.0, 0.0, 1.0], "contacts": [mbi.SceneContact(frame="mass", law="newton", e=0.8)]}
    values = {"q": [0.0, 0.0, 0.5], "posture": "neutral", "v": [0.1, 0.0, 0.0], "gravity": False, "damping": 0.1,
              "torque": [0.0, 0.0, 1.0], "pd": {"kp": 1.0, "kd": 0.1, "q": "neutral"}, "duration": 0.3,
              "rest_velocity": 2e-3, "contact_step": 2e-3, "chatter_time": 0.05, "rtol": 1e-9, "tolerance": 1e-7,
              "patch_tolerance": 1e-5, "simultaneous": "newton", "samples": 64, "max_impacts": 10,
              "max_events_per_second": 1e4, "max_wall_time": 60.0, "states": ["q2"]}
    if table == "top":
        keys = set(SCHEMA["properties"])
        for key in keys:
            kw = dict(base)
            kw[key] = {"name": "drop", "mechanism": {"model": "point_mass_3d"}, "initial": {"q": [0.0, 0.0, 0.5]},
                       "obstacles": [mbi.HalfSpace(name="floor")],
                       "contacts": [{"frame": "mass", "law": "newton", "e": 0.8}],
                       "forces": {"damping": 0.1}, "simulation": {"duration": 0.3}, "record": {"states": ["v2"]}}[key]
            if key == "initial":
                del kw["q"]
            scene = mbi.Scene(**kw)
            assert isinstance(scene, mbi.Scene), key
        return
    keys = set(SCHEMA["properties"][table]["properties"])
    for key in keys:
        kw = dict(base)
        if table == "mechanism":
            tables = {"robot": {"robot": "ur5"}, "model": {"model": "point_mass_3d"},
                      "urdf": {"urdf": str(mbi.model_path("point_mass_3d"))},
                      "floating": {"model": "point_mass_3d", "floating": False}}
            kw = {"mechanism": tables[key], "contacts": [{"frame": "mass", "law": "newton", "e": 0.8,
                                                          "origin": [0.0, 0.0, -1.0]}]}
            if key == "robot":
                kw["contacts"] = [{"frame": "tool0", "law": "newton", "e": 0.5, "origin": [0.0, 0.0, -5.0]}]
            scene = mbi.Scene(**kw)
            assert scene.mechanism.name == ("ur5" if key == "robot" else "point_mass_3d"), key
            continue
        value = values["states"] if key == "states" else values[key]
        kw.pop(key, None)
        if key == "posture":
            del kw["q"]
            kw["contacts"] = [mbi.SceneContact(frame="mass", law="newton", e=0.8, origin=[0, 0, -1.0])]
        one = mbi.Scene(**kw, **{key: value})
        whole = mbi.Scene(**kw, **{table: {key: value}})
        for scene in (one, whole):
            field = {"q": "q0", "v": "v0", "states": "record"}.get(key)
            if field:
                assert np.allclose(getattr(scene, field), value) if field != "record" else scene.record == ("q2",)
            elif key == "pd":
                assert np.allclose(scene.pd.q_ref, mech.neutral()) and scene.pd.kp == 1.0
            elif key == "posture":
                assert np.allclose(scene.q0, mech.neutral())
            elif key == "torque":
                assert np.allclose(scene.torque, value)
            else:
                assert getattr(scene, key) == value, key


def test_unknown_keys_are_named_with_the_valid_ones():
    with pytest.raises(mbi.SceneError, match=r"SceneContact: unknown key 'frction' \(did you mean 'friction'\?\); "
                                             r"valid keys: .*friction.*"):
        mbi.SceneContact(frame="mass", law="newton", e=0.5, frction=0.3)
    with pytest.raises(mbi.SceneError, match=r"Scene: unknown key 'duraton' \(did you mean 'duration'\?\)"):
        mbi.Scene(mechanism=mbi.Mechanism.from_model("point_mass_3d"),
                  contacts=[mbi.SceneContact(frame="mass", law="newton", e=0.5)], duraton=1.0)
    with pytest.raises(mbi.SceneError, match="the law object NewtonLaw"):
        mbi.SceneContact(frame="mass", law=mbi.NewtonLaw(0.5), e=0.5)
    with pytest.raises(mbi.SceneError, match="applies to collision contacts"):
        mbi.SceneContact(frame="mass", law="newton", e=0.5, body="all")
    with pytest.raises(mbi.SceneError, match="give exactly one of e"):
        mbi.SceneContact(frame="mass", law="newton")
    # the objects stay accepted
    law = mbi.RoughLaw(mbi.Cone(0.2), 0.5)
    assert mbi.SceneContact(frame="mass", law=law).law is law


def test_a_scene_built_in_python_simulates_as_the_same_scene_from_its_file():
    """The README's ball drop: the shipped ball_drop.toml, written in Python with the file's keys."""
    scene = mbi.Scene(
        mechanism=mbi.Mechanism.from_model("point_mass_3d"),
        q=[0.0, 0.0, 1.0],
        contacts=[mbi.SceneContact(frame="mass", law="newton", e=0.8)],
        duration=5.0,
        states=["q2", "v2"],
        name="ball_drop",
    )
    loaded = mbi.load_scene("ball_drop")
    for f in dataclasses.fields(mbi.Scene):
        a, b = getattr(scene, f.name), getattr(loaded, f.name)
        if f.name == "mechanism":
            assert a.name == b.name and a.nq == b.nq
        elif f.name == "contacts":
            assert [(c.frame, repr(c.law), c.friction) for c in a] == [(c.frame, repr(c.law), c.friction) for c in b]
        elif isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)
        else:
            assert a == b, f.name
    mine, theirs = mbi.simulate(scene), mbi.simulate(loaded)
    assert len(mine.impact_times()) > 5
    np.testing.assert_allclose(mine.impact_times(), theirs.impact_times(), rtol=1e-9)
    # each impact keeps 0.8 of the approach speed: the law from the keys acts
    first = [e for e in mine.events if e.kind == "impact"][0]
    assert first.kappa == pytest.approx(0.8)


# ---------------------------------------------------------------- finding the scene file


def test_a_scene_file_with_another_suffix_is_read(tmp_path, capsys):
    path = tmp_path / "my_scene.txt"
    shutil.copy(mbi.simulation.scene_path("ball_drop"), path)
    scene = mbi.load_scene(path)
    assert scene.name == "ball_drop" and scene.mechanism.name == "point_mass_3d"
    assert main(["scene", str(path)]) == 0
    assert "ball_drop: valid" in capsys.readouterr().out
    not_toml = tmp_path / "notes.txt"
    not_toml.write_text("this is = = not toml\n")
    with pytest.raises(mbi.SceneError, match="notes.txt: not a valid TOML scene file"):
        mbi.load_scene(not_toml)
    assert main(["run", str(not_toml), "--no-progress"]) == 2
    assert "not a valid TOML scene file" in capsys.readouterr().err


def test_a_mistyped_shipped_name_gets_suggestions(capsys):
    with pytest.raises(mbi.SceneError, match=r"scene 'ball_drp' not found.*did you mean 'ball_drop'\?"):
        mbi.load_scene("ball_drp")
    for command in ("run", "scene"):
        assert main([command, "ball_drp"] + (["--no-progress"] if command == "run" else [])) == 2
        assert "did you mean 'ball_drop'?" in capsys.readouterr().err
    with pytest.raises(mbi.SceneError) as info:
        mbi.load_scene("zzzz_qqqq")
    assert "did you mean" not in str(info.value) and "shipped scenes: ball_drop" in str(info.value)

"""Loading mechanisms: malformed robot files, a user's own Pinocchio model, a short repr."""

from __future__ import annotations

import pinocchio as pin
import pytest

import mbimpact as mbi

MALFORMED = '<robot name="bad"><link name="a"/><joint name="j" type="revolute"><parent link="a"/></joint>\n'


def test_a_malformed_urdf_is_a_named_parse_error_with_the_parsers_complaint(tmp_path, capfd):
    path = tmp_path / "bad.urdf"
    path.write_text(MALFORMED)
    with pytest.raises(mbi.URDFError) as info:
        mbi.Mechanism.from_urdf(path)
    text = str(info.value)
    assert str(path) in text and "could not parse URDF file" in text
    assert "XML_ERROR_PARSING" in text  # urdfdom's complaint, which it writes to stderr from C++
    assert "XML_ERROR" not in capfd.readouterr().err  # ... in the error, not printed before it
    assert isinstance(info.value, mbi.RobotNotFoundError) and isinstance(info.value, mbi.ImpactError)
    missing = tmp_path / "missing.urdf"
    with pytest.raises(mbi.RobotNotFoundError, match="not found") as info:
        mbi.Mechanism.from_urdf(missing)
    assert not isinstance(info.value, mbi.URDFError)


def test_a_malformed_urdf_on_the_command_line(tmp_path, capsys):
    from mbimpact.apps.cli import main

    path = tmp_path / "bad.urdf"
    path.write_text(MALFORMED)
    assert main(["compare", "--urdf", str(path), "--frame", "a"]) == 2
    err = capsys.readouterr().err
    assert "could not parse URDF file" in err and "XML_ERROR_PARSING" in err


def test_repr_is_short():
    ur5 = mbi.Mechanism.from_robot("ur5")
    text = repr(ur5)
    assert text == f"Mechanism('ur5', nq=6, nv=6, floating=False, frames={len(ur5.model.frames)})"
    assert "\n" not in text
    assert "floating=True" in repr(mbi.Mechanism.from_model("box"))


def test_a_users_own_pinocchio_model_is_wrapped():
    """mbi.Mechanism(model, name=...) takes any pinocchio.Model and computes impacts with it."""
    model = pin.buildModelFromUrdf(str(mbi.model_path("point_mass_3d")))
    mech = mbi.Mechanism(model, name="my_point_mass")
    assert mech.nq == 3 and repr(mech).startswith("Mechanism('my_point_mass'")
    res = mbi.impact(mech, [0.0, 0.0, 0.0], [0.0, 0.0, -1.0], mbi.PointContact("mass"), mbi.NewtonLaw(0.5))
    assert res.kappa == pytest.approx(0.5)
    with pytest.raises(mbi.ParameterError, match="pinocchio.Model"):
        mbi.Mechanism("ur5")  # type: ignore[arg-type]

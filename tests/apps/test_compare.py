"""``mbimpact compare``: approach velocities the posture can produce, its table and its figure."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.apps import compare
from mbimpact.apps.cli import main

# a planar 2-link arm in the x-z plane (hinges about y), each link 1 m; at q = 0 it lies stretched out
# along x, so its tip can only move vertically
ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="link1"><inertial><origin xyz="0.5 0 0"/><mass value="1.0"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.0833" iyz="0" izz="0.0833"/></inertial></link>
  <link name="link2"><inertial><origin xyz="0.5 0 0"/><mass value="1.0"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.0833" iyz="0" izz="0.0833"/></inertial></link>
  <link name="tip"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="link1"/>
    <axis xyz="0 1 0"/><limit lower="-3.14" upper="3.14" effort="0" velocity="10"/></joint>
  <joint name="elbow" type="revolute"><parent link="link1"/><child link="link2"/><origin xyz="1 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-3.14" upper="3.14" effort="0" velocity="10"/></joint>
  <joint name="tip_joint" type="fixed"><parent link="link2"/><child link="tip"/><origin xyz="1 0 0"/></joint>
</robot>
"""

CONTACT = mbi.PointContact("tip", normal=np.array([0.0, 0.0, 1.0]), tangent=np.array([1.0, 0.0, 0.0]))


@pytest.fixture()
def arm_urdf(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(ARM)
    return path


def test_the_stretched_arm_cannot_approach_obliquely(arm_urdf):
    """Straight down is reachable (and its contact velocity is the one asked); any oblique incidence is
    refused with the asked and the achievable velocity, instead of a row for an impact that never happens."""
    arm = mbi.Mechanism.from_urdf(arm_urdf)
    q = arm.neutral()
    v = compare.approach_velocity(arm, q, CONTACT, 0.0, 2.0)
    np.testing.assert_allclose(arm.point_jacobian(q, "tip") @ v, [0.0, 0.0, -2.0], atol=1e-12)
    with pytest.raises(mbi.UnreachableVelocityError, match=r"cannot produce the contact velocity.*relative residual"):
        compare.approach_velocity(arm, q, CONTACT, math.radians(30.0))
    with pytest.raises(mbi.ParameterError):  # a ParameterError: callers catching those keep working
        compare.compare_laws(arm, q, CONTACT, {"Newton": mbi.NewtonLaw(0.5)}, [0.0, 10.0])
    # bent, the same arm reaches every direction of its plane
    bent = np.array([0.3, 1.2])
    v = compare.approach_velocity(arm, bent, CONTACT, math.radians(60.0))
    u = arm.point_jacobian(bent, "tip") @ v
    np.testing.assert_allclose(u, [math.sin(math.radians(60.0)), 0.0, -math.cos(math.radians(60.0))], atol=1e-10)


def test_the_command_refuses_the_stretched_arm(arm_urdf, capsys):
    code = main(["compare", "--urdf", str(arm_urdf), "--frame", "tip", "--steps", "4"])
    captured = capsys.readouterr()
    assert code == 2
    assert "cannot produce the contact velocity" in captured.err and "Traceback" not in captured.err
    assert "| Newton" not in captured.out  # no rows for approaches that never happened


def test_joint_velocity_is_the_least_kinetic_energy_one():
    """Of all v with J v = u, joint_velocity returns the one of least ½ vᵀ A v (a redundant arm)."""
    rng = np.random.default_rng(3)
    B = rng.normal(size=(5, 5))
    A = B @ B.T + 5 * np.eye(5)
    J = rng.normal(size=(3, 5))
    u = np.array([0.3, -0.2, -1.0])
    v = mbi.joint_velocity(A, J, u)
    np.testing.assert_allclose(J @ v, u, atol=1e-12)
    null = np.linalg.svd(J)[2][3:]  # directions that leave J v unchanged
    for d in null:
        for step in (1e-3, -1e-3):
            w = v + step * d
            assert w @ A @ w > v @ A @ v
    V = mbi.joint_velocity(A, J, np.array([u, 2 * u]))  # one per row
    np.testing.assert_allclose(V, [v, 2 * v], rtol=1e-12)
    with pytest.raises(mbi.UnreachableVelocityError, match="row 1"):
        mbi.joint_velocity(A, np.vstack([J[:2], J[0]]), np.array([[1.0, 0.0, 1.0], [0.0, 0.0, 1.0]]))


def test_the_table_has_no_negative_zeros(arm_urdf):
    """A quantity that is zero is printed 0.0000, whatever the sign of its rounding error."""
    rows = [compare.CompareRow("Newton", 0.0, -1e-17, 0.8, 0.8, -0.0, 1e-9)]
    table = compare.format_table(rows)
    assert "-0.0" not in table
    assert "| Newton | 0 | 0.0000 | 0.8000 | 0.8000 | 0.0000 | 0.00000 |" in table
    assert "-0.5000" in compare.format_table([compare.CompareRow("x", 5.0, -0.5, 0.1, 0.1, 0.0, 0.0)])
    # and on the command line: the 1-DOF-per-direction point mass has many exact zeros
    code = main(["compare", "--urdf", str(mbi.model_path("point_mass_3d")), "--frame", "mass", "--steps", "5"])
    assert code == 0


def test_the_command_table_prints_no_negative_zero(capsys):
    assert main(["compare", "--steps", "6"]) == 0
    assert "-0.0000" not in capsys.readouterr().out


def test_the_figure_names_its_parameters_and_coinciding_laws(tmp_path, monkeypatch):
    """compare.png: the title carries the approach speed and the laws' labels (with e, α, μ), the legend
    panel names laws that coincide, and κ's axis is not flattened by its runaway near grazing."""
    import matplotlib.figure

    saved = {}

    def keep(fig, path, **kwargs):  # record the figure instead of (also) reading the PNG back
        saved["fig"] = fig
        return original(fig, path, **kwargs)

    original = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    mech = mbi.Mechanism.from_robot("ur5")
    contact = mbi.PointContact("tool0", normal=np.array([0.0, 0.0, 1.0]), tangent=np.array([1.0, 0.0, 0.0]))
    laws = {"Newton e=0.8": mbi.NewtonLaw(0.8), "rough Cone alpha=0.3": mbi.RoughLaw(mbi.Cone(0.3), 0.8),
            "Coulomb mu=0.3 (energetic)": mbi.CoulombLaw(0.8, 0.3)}
    from mbimpact.apps.demo import UR5_POSTURE

    rows = compare.compare_laws(mech, UR5_POSTURE, contact, laws, np.linspace(0.0, 85.0, 18), 1.5)
    path = compare.plot(rows, tmp_path / "compare.png", "ur5 tool0")
    assert path.stat().st_size > 10_000
    fig = saved["fig"]
    title = fig._suptitle.get_text()
    assert "ur5 tool0" in title and "1.5 m/s" in title and "e=0.8" in title and "alpha=0.3" in title and "mu=0.3" in title
    axes = fig.axes
    texts = " ".join(" ".join(t.get_text() for t in axes[5].texts).split())  # unwrapped
    assert "Newton e=0.8 and Coulomb mu=0.3 (energetic) coincide" in texts  # κ = e for both
    legend = axes[5].get_legend()
    assert [t.get_text() for t in legend.get_texts()] == list(laws)
    assert all(ax.get_legend() is None for ax in axes[:5])  # one shared legend, over no data
    styles = {line.get_linestyle() for line in axes[1].get_lines()}
    assert len(styles) == 3  # Newton and Coulomb stay apart by their style where they coincide
    kappa = [r.kappa for r in rows]
    assert max(kappa) > 3 * min(kappa) > 0  # the rough law's κ runs away near grazing incidence
    assert axes[2].get_yscale() == "log" and "κ on a log axis" in texts  # nothing hidden, nothing flattened
    low, high = axes[2].get_ylim()
    assert low <= min(kappa) and high >= max(kappa)
    assert axes[1].get_yscale() == "linear"
    assert all("[" in ax.get_title() for ax in axes[:5])  # units

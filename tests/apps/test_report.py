"""``mbimpact run``'s summary and plots: what came to rest is named and true; units from the joint types."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest

import mbimpact as mbi
from mbimpact.apps import report
from mbimpact.mechanism import state_units


@pytest.fixture(scope="module")
def strikes():
    """The UR5 striking the table for 1.2 s: the tool comes to rest on the table while the arm still turns."""
    from dataclasses import replace

    scene = replace(mbi.load_scene("ur5_strikes_table"), duration=1.2)
    return scene, mbi.simulate(scene)


def test_the_rest_line_names_the_contact_and_is_true(strikes):
    scene, tr = strikes
    text = report.summary(scene, tr)
    assert "came to rest at t =" not in text  # the bare claim that something unnamed came to rest
    line = next(ln for ln in text.splitlines() if "came to rest" in ln)
    found = re.search(r"contact 0 \(tool0\) came to rest on its surface .* at t = ([0-9.e+-]+) s and stayed on it "
                      r"to the end; the mechanism then: fastest joint coordinate \|v(\d+)\| = ([0-9.e+-]+) rad/s", line)
    assert found, line
    t_rest, j, speed = float(found[1]), int(found[2]), float(found[3])
    after = tr.t > t_rest
    assert after.any() and tr.active[after, 0].all()  # persistent from then on
    assert np.abs(tr.gaps[after, 0]).max() <= scene.tolerance  # on the table
    before = (tr.t < t_rest) & (tr.t > 0.1)
    bounces = np.abs(tr.gap_rates[before, 0]).max()
    assert bounces > 0.1 and np.abs(tr.gap_rates[after, 0]).max() < 0.02 * bounces  # no more bouncing
    k = int(np.searchsorted(tr.t, t_rest, side="right")) - 1
    assert abs(tr.v[k, j]) == pytest.approx(speed, rel=1e-2)
    assert speed > 1.0  # the arm is far from at rest then: the line says so rather than "came to rest"
    assert speed == pytest.approx(np.abs(tr.v[k]).max(), rel=1e-2)


def test_units_come_from_the_joint_types():
    """Prismatic joints (JointModelPX/PZ) are in m and m/s, the unbounded revolute's (cos, sin) unitless, a
    free flyer's translation in m, its quaternion unitless, its angular velocity in rad/s."""
    rod = mbi.Mechanism.from_model("planar_rod")
    assert [j.shortname() for j in rod.model.joints[1:]] == ["JointModelPX", "JointModelPZ", "JointModelRUBY"]
    assert state_units(rod.model) == (["m", "m", "1", "1"], ["m/s", "m/s", "rad/s"])
    box = mbi.Mechanism.from_model("box")
    assert state_units(box.model) == (["m"] * 3 + ["1"] * 4, ["m/s"] * 3 + ["rad/s"] * 3)
    ur5 = mbi.Mechanism.from_robot("ur5")
    assert state_units(ur5.model) == (["rad"] * 6, ["rad/s"] * 6)
    solo = mbi.Mechanism.from_robot("solo12")
    q_units, v_units = state_units(solo.model)
    assert q_units[:7] == ["m"] * 3 + ["1"] * 4 and set(q_units[7:]) == {"rad"}
    assert v_units[:6] == ["m/s"] * 3 + ["rad/s"] * 3 and set(v_units[6:]) == {"rad/s"}
    model = pin.Model()  # the other kinds: an unaligned prismatic axis, a planar joint
    model.addJoint(0, pin.JointModelPrismaticUnaligned(np.array([1.0, 1.0, 0.0]) / np.sqrt(2)), pin.SE3.Identity(), "p")
    model.addJoint(1, pin.JointModelPlanar(), pin.SE3.Identity(), "planar")
    assert state_units(model) == (["m", "m", "m", "1", "1"], ["m/s", "m/s", "m/s", "rad/s"])


def test_run_plot_units_titles_and_coinciding_curves(tmp_path, monkeypatch):
    """The point-mass scene's prismatic states are plotted in [m] and [m/s]; every panel has a title of its
    own; identical curves are drawn once with their labels joined ("coincide"); the energy panel says
    what its reference is."""
    import matplotlib.figure

    figures = []
    original = matplotlib.figure.Figure.savefig

    def keep(fig, path, **kwargs):
        figures.append(fig)
        return original(fig, path, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    mech = mbi.Mechanism.from_model("point_mass_3d")
    assert {j.shortname() for j in mech.model.joints[1:]} <= {"JointModelPX", "JointModelPY", "JointModelPZ"}
    # two contacts at the same point strike at once: their curves coincide
    contacts = [mbi.SceneContact(frame="mass", law="newton", e=0.5), mbi.SceneContact(frame="mass", law="newton", e=0.5)]
    scene = mbi.Scene(mechanism=mech, q=[0.0, 0.0, 0.2], contacts=contacts, duration=0.5, states=["q2", "v2"],
                      simultaneous="newton")
    tr = mbi.simulate(scene)
    report.write_outputs(scene, tr, tmp_path)
    fig = figures[-1]
    axes = [ax for ax in fig.axes if ax.axison]
    titles = [ax.get_title() for ax in axes]
    assert all(titles) and len(set(titles)) == len(titles), titles
    assert "energy relative to its initial value" in titles[0] and "zero at world z = 0" in titles[0]
    assert np.allclose(axes[0].get_lines()[0].get_ydata()[0], 0.0)
    by_title = dict(zip(titles, axes))
    assert by_title["recorded positions"].get_ylabel() == "[m]"
    assert by_title["recorded linear velocities"].get_ylabel() == "[m/s]"
    gaps = by_title["gaps of the contacts"]
    labels = [t.get_text() for t in gaps.get_legend().get_texts()]
    assert any("0: mass, 1: mass (coincide)" == label for label in labels), labels
    assert len([line for line in gaps.get_lines() if not line.get_label().startswith("_")
                and "coincide" in line.get_label()]) == 1

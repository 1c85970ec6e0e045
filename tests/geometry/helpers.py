"""Mechanisms and configurations shared by the geometry tests (loaded once per session)."""

from __future__ import annotations

import functools

import numpy as np
import pinocchio as pin

import mbimpact as mbi
from mbimpact import geometry as G

TINY_MJCF = """<mujoco model="tiny">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="box" pos="0 0 0.5">
      <freejoint name="box_free"/>
      <geom name="box_geom" type="box" size="0.2 0.15 0.1" mass="3"/>
      <body name="arm" pos="0.3 0 0">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom name="ball_geom" type="sphere" size="0.05" mass="0.5"/>
        <geom name="stick" type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02" mass="0.1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@functools.lru_cache(maxsize=None)
def model(name: str) -> mbi.Mechanism:
    """mbimpact's own models (floating box and sphere) and example-robot-data robots, loaded once."""
    if name in ("sphere", "box"):
        return mbi.Mechanism.from_model(name)
    return mbi.Mechanism.from_robot(name)


def two_balls(r1: float = 0.1, r2: float = 0.2) -> mbi.Mechanism:
    """Two free-flying balls (masses 1 and 2), built in code: collision spheres attached to frames."""
    m = pin.Model()
    for k, (name, mass, r) in enumerate((("a", 1.0, r1), ("b", 2.0, r2))):
        j = m.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), f"{name}_joint")
        m.appendBodyToJoint(j, pin.Inertia.FromSphere(mass, r), pin.SE3.Identity())
        m.addBodyFrame(name, j, pin.SE3.Identity(), m.addJointFrame(j, 0))
    mech = mbi.Mechanism(m, "two_balls")
    cm = mech.collision_model()
    cm.add("ball_a", "a", G.Sphere(r1))
    cm.add("ball_b", "b", G.Sphere(r2))
    return mech


def floating_q(mech: mbi.Mechanism, rng: np.random.Generator, height: float = 0.3) -> np.ndarray:
    """A random configuration with the free-flyer base near (0, 0, height) and a random attitude."""
    q = mech.random_configuration(rng)
    q[:3] = rng.normal(size=3) * 0.05 + [0.0, 0.0, height]
    q[3:7] = pin.Quaternion(pin.exp3(rng.normal(size=3))).coeffs()
    return q


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)

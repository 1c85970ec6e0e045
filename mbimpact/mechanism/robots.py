"""Where the URDFs of example-robot-data and of mbimpact's own models live.

The PyPI wheel of example-robot-data ships the robot descriptions as package
data (under ``cmeel.prefix/share/example-robot-data/robots``) but no Python
loader, so the files are located here from the installed distribution.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import RobotNotFoundError

__all__ = ["file_path", "ROBOTS", "robot_names", "robot_urdf", "robots_dir", "robots_share_dir", "models_dir", "model_path",
           "model_names", "close_matches"]

#: name -> (URDF path below the robots folder, has a floating base)
ROBOTS: dict[str, tuple[str, bool]] = {
    "a1": ("a1_description/urdf/a1.urdf", True),
    "anymal": ("anymal_b_simple_description/robots/anymal.urdf", True),
    "anymal_c": ("anymal_c_simple_description/urdf/anymal.urdf", True),
    "anymal_kinova": ("anymal_b_simple_description/robots/anymal-kinova.urdf", True),
    "asr_twodof": ("asr_twodof_description/urdf/TwoDofs.urdf", False),
    "b1": ("b1_description/urdf/b1.urdf", True),
    "b1_z1": ("b1_description/urdf/b1-z1.urdf", True),
    "baxter": ("baxter_description/urdf/baxter.urdf", False),
    "bolt": ("bolt_description/robots/bolt.urdf", True),
    "double_pendulum": ("double_pendulum_description/urdf/double_pendulum.urdf", False),
    "double_pendulum_continuous": ("double_pendulum_description/urdf/double_pendulum_continuous.urdf", False),
    "double_pendulum_simple": ("double_pendulum_description/urdf/double_pendulum_simple.urdf", False),
    "finger_edu": ("finger_edu_description/robots/finger_edu.urdf", False),
    "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", True),
    "go1": ("go1_description/urdf/go1.urdf", True),
    "go2": ("go2_description/urdf/go2.urdf", True),
    "hector": ("hector_description/robots/quadrotor_base.urdf", True),
    "hyq": ("hyq_description/robots/hyq_no_sensors.urdf", True),
    "icub": ("icub_description/robots/icub.urdf", True),
    "icub_reduced": ("icub_description/robots/icub_reduced.urdf", True),
    "iris": ("iris_description/robots/iris_simple.urdf", True),
    "kinova": ("kinova_description/robots/kinova.urdf", False),
    "laikago": ("laikago_description/urdf/laikago.urdf", True),
    "panda": ("panda_description/urdf/panda.urdf", False),
    "quadruped": ("quadruped_description/urdf/quadruped.urdf", True),
    "romeo": ("romeo_description/urdf/romeo.urdf", True),
    "simple_humanoid": ("simple_humanoid_description/urdf/simple_humanoid.urdf", True),
    "so100": ("so_arm_description/urdf/so100.urdf", False),
    "so101": ("so_arm_description/urdf/so101.urdf", False),
    "solo8": ("solo_description/robots/solo.urdf", True),
    "solo12": ("solo_description/robots/solo12.urdf", True),
    "talos": ("talos_data/robots/talos_reduced.urdf", True),
    "talos_full": ("talos_data/robots/talos_full_v2.urdf", True),
    "talos_arm": ("talos_data/robots/talos_left_arm.urdf", False),
    "tiago": ("tiago_description/robots/tiago.urdf", False),
    "tiago_dual": ("tiago_description/robots/tiago_dual.urdf", False),
    "tiago_no_hand": ("tiago_description/robots/tiago_no_hand.urdf", False),
    "ur3": ("ur_description/urdf/ur3_robot.urdf", False),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", False),
    "ur10": ("ur_description/urdf/ur10_robot.urdf", False),
    "ur5_gripper": ("ur_description/urdf/ur5_gripper.urdf", False),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", False),
    "z1": ("z1_description/urdf/z1.urdf", False),
}

_ROBOTS_SUBDIR = "cmeel.prefix/share/example-robot-data/robots"


def robots_dir() -> Path:
    """Folder of the installed example-robot-data robot descriptions.

    Raises
    ------
    RobotNotFoundError
        example-robot-data is not installed or ships no robots folder.
    """
    import importlib.metadata  # on use: the import costs `import mbimpact` a tenth of its time

    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError as exc:
        raise RobotNotFoundError(
            "example-robot-data is not installed; `pip install example-robot-data`"
        ) from exc
    path = Path(str(dist.locate_file(_ROBOTS_SUBDIR)))
    if not path.is_dir():
        raise RobotNotFoundError(f"example-robot-data is installed but has no robots folder at {path}")
    return path


def robot_names() -> list[str]:
    """Names accepted by :func:`robot_urdf` and ``Mechanism.from_robot``."""
    return sorted(ROBOTS)


def robots_share_dir() -> Path:
    """The folder that ``package://example-robot-data/...`` mesh paths resolve against."""
    return robots_dir().parents[1]


def close_matches(name: str, names: list[str]) -> list[str]:
    """Up to 8 names similar to ``name`` or containing it (for error messages)."""
    import difflib  # on use, for error messages

    close = difflib.get_close_matches(name, names, n=5, cutoff=0.5)
    close += [n for n in names if name.lower() in n.lower() and n not in close]
    return close[:8]


def _unknown(kind: str, name: str, names: list[str]) -> RobotNotFoundError:
    close = close_matches(name, names)
    hint = f"close matches: {', '.join(close)}" if close else f"known: {', '.join(names)}"
    return RobotNotFoundError(f"{kind} {name!r} not found; {hint}")


def robot_urdf(name: str) -> tuple[Path, bool]:
    """URDF path of an example-robot-data robot and whether it has a floating base.

    Raises
    ------
    RobotNotFoundError
        No robot of that name (the message lists close matches), or a name that is not a string.
    """
    if not isinstance(name, str):
        raise RobotNotFoundError(f"a robot is named by a string (mbimpact.robot_names()), got {type(name).__name__}")
    if name not in ROBOTS:
        raise _unknown("robot", name, robot_names())
    rel, floating = ROBOTS[name]
    return robots_dir() / rel, floating


def models_dir() -> Path:
    """Folder of mbimpact's own models (URDFs and scenes).

    Installed as package data ``mbimpact/models``; in a source checkout it is
    the top-level ``models/`` folder.
    """
    import importlib.resources  # on use

    packaged = Path(str(importlib.resources.files("mbimpact"))) / "models"
    if packaged.is_dir():
        return packaged
    return Path(__file__).resolve().parents[2] / "models"


def model_names() -> list[str]:
    """Names of mbimpact's own URDF models (file stems in :func:`models_dir`)."""
    return sorted(p.stem for p in models_dir().glob("*.urdf"))


def model_path(name: str) -> Path:
    """Path of one of mbimpact's own URDF models, e.g. ``model_path("double_pendulum")``.

    Raises
    ------
    RobotNotFoundError
        No model of that name (the message lists close matches), or a name that is not a string.
    """
    if not isinstance(name, str):
        raise RobotNotFoundError(f"a model is named by a string (mbimpact.model_names()), got {type(name).__name__}")
    path = models_dir() / f"{name}.urdf"
    if not path.is_file():
        raise _unknown("model", name, model_names())
    return path


def file_path(kind: str, path: object) -> Path:
    """``path`` as a :class:`~pathlib.Path` (a :class:`RobotNotFoundError` if it is not a path)."""
    if not isinstance(path, (str, os.PathLike)):
        raise RobotNotFoundError(f"a {kind} file is given by a path (str or pathlib.Path), got {type(path).__name__}")
    try:
        return Path(path)
    except TypeError as exc:  # an os.PathLike that does not return a str
        raise RobotNotFoundError(f"a {kind} file is given by a path (str or pathlib.Path): {exc}") from None

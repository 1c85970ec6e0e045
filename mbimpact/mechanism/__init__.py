"""Stage 1 of the pipeline, the Pinocchio bridge: mechanisms, robots, contacts (the pipeline that
computes an impact from them is :mod:`mbimpact.pipeline`)."""

from .contact import Contact, PointContact
from .mechanism import MassFactor, Mechanism
from .robots import model_names, model_path, models_dir, robot_names, robot_urdf
from .units import state_units
from .velocity import joint_velocity

__all__ = [
    "Mechanism",
    "MassFactor",
    "Contact",
    "PointContact",
    "joint_velocity",
    "state_units",
    "robot_names",
    "robot_urdf",
    "model_names",
    "model_path",
    "models_dir",
]

"""Stage 1 of the pipeline, the Pinocchio bridge: mechanisms, robots, contacts, :func:`impact`."""

from .contact import Contact, PointContact
from .impact import impact, impact_batch
from .mechanism import MassFactor, Mechanism
from .robots import model_names, model_path, models_dir, robot_names, robot_urdf

__all__ = [
    "Mechanism",
    "MassFactor",
    "Contact",
    "PointContact",
    "impact",
    "impact_batch",
    "robot_names",
    "robot_urdf",
    "model_names",
    "model_path",
    "models_dir",
]

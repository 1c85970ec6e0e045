"""Scenes and their simulation: only the effects a scene declares are computed.

A scene (:class:`Scene`, or a TOML file read by :func:`load_scene`, schema in
:mod:`.schema`) declares a mechanism, its contacts and surfaces with their laws, the
forces present and the duration; :func:`simulate` runs it with the guarantees described
in :mod:`.simulator`. :mod:`.section4` is the paper's application: a point bouncing on a
vibrating rough surface of revolution.
"""

from .scene import PD, Scene, scene_names, scene_path
from .scene_contacts import SceneCollision, SceneContact
from .scene_file import load_scene
from .schema import reference
from .simulator import simulate
from .surfaces import Surface
from .sweep import sweep
from .trajectory import STATUSES, ContactEvent, ImpactRecord, Trajectory

__all__ = ["Scene", "SceneContact", "SceneCollision", "PD", "Surface", "load_scene", "reference", "scene_names", "scene_path",
           "simulate", "Trajectory", "ContactEvent", "ImpactRecord", "STATUSES", "sweep"]


def __getattr__(name: str) -> object:
    """The application of section 4, :mod:`.section4`, reached as an attribute and imported on first use."""
    if name == "section4":
        import importlib

        module = importlib.import_module(".section4", __name__)
        globals()[name] = module
        return module
    raise AttributeError(f"module 'mbimpact.simulation' has no attribute {name!r}")

"""Scenes and their simulation: only the effects a scene declares are computed.

A scene (:class:`Scene`, or a TOML file read by :func:`load_scene`) declares a
mechanism, its contacts and surfaces with their laws, the forces present and the
duration; :func:`simulate` runs it. :mod:`.section4` is the paper's application: a
point bouncing on a vibrating rough surface of revolution.
"""

from .scene import Scene, SceneContact, SceneError, Surface, load_scene, scene_names, scene_path
from .simulator import ImpactRecord, Trajectory, simulate
from .sweep import sweep

__all__ = ["Scene", "SceneContact", "SceneError", "Surface", "load_scene", "scene_names", "scene_path", "simulate",
           "Trajectory", "ImpactRecord", "sweep"]

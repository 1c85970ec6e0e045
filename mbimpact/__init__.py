"""mbimpact — Ivanov's constructive model of impact on rough surfaces for multibody systems.

The pipeline: Pinocchio (A(q), J(q)) → metric (N, Delassus W) → roughness (facets
and their measure) → law (the flux-weighted average (2.8)) → result (I by (1.1)).
"""

from . import compare, figures, sweep, vibro
from .contact import PointContact, impact, impact_batch
from .coulomb import CoulombLaw
from .errors import (
    AccuracyWarning,
    FrameNotFoundError,
    ImpactWarning,
    NoSeparationWarning,
    ImpactError,
    IntegrationError,
    NameNotFoundError,
    NoFacingFacetError,
    NoImpactError,
    NonFiniteError,
    NotPositiveDefiniteError,
    ParameterError,
    RobotNotFoundError,
    RoughnessError,
    ShapeError,
)
from .laws import ImpactLaw, NewtonLaw
from .mechanism import Mechanism
from .metric import ContactMetric, local_basis
from .relief import HeightMap, Profile
from .resolve import Resolved, resolve
from .resolve_rough import RoughResolved, resolve_rough
from .restitution import e_from_k, impact_duration, k_from_e
from .result import BatchResult, ImpactResult
from .robots import model_names, model_path, models_dir, robot_names, robot_urdf
from .roughlaw import RoughLaw
from .roughness import Cone, Facets, FiniteRoughness, Roughness, Sawtooth, Smooth
from .scene import Scene, SceneContact, SceneError, Surface, load_scene, scene_names
from .simulate import ImpactRecord, Trajectory, simulate
from .simultaneous import SimultaneousReport, compare_simultaneous
from .slopes import GaussianSlopes, IsotropicSlopes

__version__ = "0.1.0"

__all__ = [
    # pipeline
    "Mechanism",
    "PointContact",
    "impact",
    "impact_batch",
    "resolve",
    "resolve_rough",
    "Resolved",
    "RoughResolved",
    "compare_simultaneous",
    "SimultaneousReport",
    # scenes
    "Scene",
    "SceneContact",
    "Surface",
    "SceneError",
    "load_scene",
    "scene_names",
    "simulate",
    "Trajectory",
    "ImpactRecord",
    "ContactMetric",
    "local_basis",
    # roughness measures
    "Roughness",
    "Smooth",
    "Sawtooth",
    "Cone",
    "Facets",
    "FiniteRoughness",
    "IsotropicSlopes",
    "GaussianSlopes",
    "Profile",
    "HeightMap",
    # laws and results
    "ImpactLaw",
    "NewtonLaw",
    "RoughLaw",
    "CoulombLaw",
    "ImpactResult",
    "BatchResult",
    "ImpactWarning",
    "AccuracyWarning",
    "NoSeparationWarning",
    # Kelvin–Voigt restitution
    "e_from_k",
    "k_from_e",
    "impact_duration",
    # models
    "robot_names",
    "robot_urdf",
    "model_names",
    "model_path",
    "models_dir",
    # errors
    "ImpactError",
    "ShapeError",
    "NonFiniteError",
    "NotPositiveDefiniteError",
    "ParameterError",
    "RoughnessError",
    "NameNotFoundError",
    "RobotNotFoundError",
    "FrameNotFoundError",
    "NoImpactError",
    "NoFacingFacetError",
    "IntegrationError",
    # submodules of the section-4, comparison and sweep tools
    "compare",
    "figures",
    "sweep",
    "vibro",
    "__version__",
]

"""mbimpact — Ivanov's constructive model of impact on rough surfaces for multibody systems.

The pipeline, one subpackage per stage; a stage imports only the stages before it:

1. :mod:`mbimpact.mechanism` — Pinocchio: A(q), the contact Jacobian J(q);
   :mod:`mbimpact.geometry` — contacts from the mechanism's own collision geometry (coal);
2. :mod:`mbimpact.metric` — the A-metric at the contact: Delassus matrix W, local frame;
3. :mod:`mbimpact.roughness` — facets and their measure (G, P), integrated by the rules of
   :mod:`mbimpact.quadrature`;
4. :mod:`mbimpact.facets` — the impact on one facet (Newton's (2.6), or Coulomb, compliant, ...);
   :mod:`mbimpact.averaging` — the rules that compute the two integrals of (2.8);
5. :mod:`mbimpact.laws` — Newton's law, the rough law (2.8), Coulomb's law, each returning
   I = A Δv = Jᵀ P by (1.1);
6. :mod:`mbimpact.pipeline` — the stages assembled for a mechanism (:func:`impact`,
   :func:`impact_batch`).

Every stage shares :mod:`mbimpact.results` (the outcomes, which check themselves),
:mod:`mbimpact.errors` and :mod:`mbimpact.common`.

Around it: :mod:`mbimpact.compliant` (the model resolved in time),
:mod:`mbimpact.simulation` (scenes and their simulation, section 4),
:mod:`mbimpact.calibration` (calibration of laws against measured impacts) and
:mod:`mbimpact.apps` (the ``mbimpact`` command, loaded on use). The theory the code
implements is in :mod:`mbimpact.theory`.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .averaging import METHODS as AVERAGING_METHODS
from .averaging import Averaging
from .common.compiled import compile_kernels
from .common.threads import kernel_threads, set_kernel_threads
from .errors import (
    AccuracyWarning,
    CollisionNotFoundError,
    FitError,
    FrameNotFoundError,
    GeometryError,
    ImpactError,
    ImpactWarning,
    IntegrationError,
    NameNotFoundError,
    NoFacingFacetError,
    NoImpactError,
    NonFiniteError,
    NoSeparationWarning,
    NotPositiveDefiniteError,
    ParameterError,
    RobotNotFoundError,
    RoughnessError,
    SceneError,
    ShapeError,
    TableError,
    UnreachableVelocityError,
    URDFError,
)
from .facets import (
    FACETS,
    CompliantFacet,
    CoulombFacet,
    FacetLaw,
    HuntCrossleyFacet,
    NewtonFacet,
    e_from_k,
    facet_law,
    impact_duration,
    k_from_e,
)
from .laws import CoulombLaw, ImpactLaw, NewtonLaw, RoughLaw
from .mechanism import (
    Contact,
    Mechanism,
    PointContact,
    model_names,
    model_path,
    models_dir,
    joint_velocity,
    robot_names,
    robot_urdf,
)
from .metric import ContactMetric, local_basis
from .pipeline import impact, impact_batch, impact_outcomes
from .results import BatchResult, ContactImpulses, ImpactResult
from .results.outcomes import ImpactOutcomes
from .roughness import (
    Cone,
    Facets,
    FiniteRoughness,
    GaussianSlopes,
    HeightMap,
    IsotropicSlopes,
    Profile,
    Roughness,
    Sawtooth,
    Smooth,
)

if TYPE_CHECKING:  # loaded on first use: see _ON_USE below
    from .compliant import Resolved, RoughResolved, SimultaneousReport, compare_simultaneous, resolve, resolve_rough
    from .calibration import Ball, Fit, ImpactTable, PointMass, fit
    from .geometry import (
        Box,
        Capsule,
        CollisionModel,
        Cylinder,
        Gap,
        GapArrays,
        GapModel,
        GeometryContact,
        HalfSpace,
        Mesh,
        Shape,
        Sphere,
        contact_points,
        gap_model,
        gaps,
    )
    from .simulation import (
        PD,
        ContactEvent,
        ImpactRecord,
        Scene,
        SceneCollision,
        SceneContact,
        Surface,
        Trajectory,
        load_scene,
        scene_names,
        simulate,
        sweep,
    )

__version__ = "0.3.0"

__all__ = [
    # pipeline
    "Mechanism",
    "Contact",
    "PointContact",
    "impact",
    "impact_batch",
    "impact_outcomes",
    "joint_velocity",
    "ContactMetric",
    "local_basis",
    # collision geometry
    "GeometryContact",
    "CollisionModel",
    "Shape",
    "HalfSpace",
    "Box",
    "Sphere",
    "Capsule",
    "Cylinder",
    "Mesh",
    "Gap",
    "GapArrays",
    "GapModel",
    "gaps",
    "gap_model",
    "contact_points",
    # roughness measures
    "Roughness",
    "FiniteRoughness",
    "Smooth",
    "Sawtooth",
    "Cone",
    "Facets",
    "IsotropicSlopes",
    "GaussianSlopes",
    "Profile",
    "HeightMap",
    # facet laws (what is averaged)
    "FacetLaw",
    "NewtonFacet",
    "CoulombFacet",
    "CompliantFacet",
    "HuntCrossleyFacet",
    "FACETS",
    "facet_law",
    # averaging
    "Averaging",
    "AVERAGING_METHODS",
    # laws and results
    "ImpactLaw",
    "NewtonLaw",
    "RoughLaw",
    "CoulombLaw",
    "ImpactResult",
    "BatchResult",
    "ContactImpulses",
    "ImpactOutcomes",
    "e_from_k",
    "k_from_e",
    "impact_duration",
    "compile_kernels",
    "kernel_threads",
    "set_kernel_threads",
    # compliant route
    "resolve",
    "Resolved",
    "resolve_rough",
    "RoughResolved",
    "compare_simultaneous",
    "SimultaneousReport",
    # calibration
    "ImpactTable",
    "Ball",
    "PointMass",
    "fit",
    "Fit",
    # scenes
    "Scene",
    "SceneContact",
    "SceneCollision",
    "Surface",
    "load_scene",
    "scene_names",
    "simulate",
    "Trajectory",
    "ContactEvent",
    "ImpactRecord",
    "PD",
    "sweep",
    # models
    "robot_names",
    "robot_urdf",
    "model_names",
    "model_path",
    "models_dir",
    # errors and warnings
    "ImpactError",
    "ShapeError",
    "NonFiniteError",
    "NotPositiveDefiniteError",
    "ParameterError",
    "UnreachableVelocityError",
    "RoughnessError",
    "NameNotFoundError",
    "RobotNotFoundError",
    "URDFError",
    "FrameNotFoundError",
    "CollisionNotFoundError",
    "GeometryError",
    "TableError",
    "FitError",
    "NoImpactError",
    "NoFacingFacetError",
    "IntegrationError",
    "SceneError",
    "ImpactWarning",
    "AccuracyWarning",
    "NoSeparationWarning",
    "__version__",
]

# subpackages reached as attributes (mbi.simulation.section4.stability(...)), imported on first use: the
# apps pull in matplotlib, the scenes jsonschema and scipy
_LAZY = {"apps": ".apps", "section4": ".simulation.section4", "theory": ".theory", "simulation": ".simulation",
         "calibration": ".calibration", "compliant": ".compliant", "geometry": ".geometry",
         "averaging": ".averaging"}

# Public names of the subpackages a single impact does not need, imported on first use: the scenes
# and their simulator, the compliant route, calibration and collision geometry would otherwise
# double the time of `import mbimpact`. (Keep in step with the TYPE_CHECKING imports above.)
_ON_USE: dict[str, tuple[str, ...]] = {
    ".compliant": ("Resolved", "RoughResolved", "SimultaneousReport", "compare_simultaneous", "resolve",
        "resolve_rough"),
    ".calibration": ("Ball", "Fit", "ImpactTable", "PointMass", "fit"),
    ".geometry": ("Box", "Capsule", "CollisionModel", "Cylinder", "Gap", "GapArrays", "GapModel",
        "GeometryContact", "HalfSpace", "Mesh", "Shape", "Sphere", "contact_points", "gap_model", "gaps"),
    ".simulation": ("PD", "ContactEvent", "ImpactRecord", "Scene", "SceneCollision", "SceneContact",
        "Surface", "Trajectory", "load_scene", "scene_names", "simulate", "sweep"),
}
_ORIGIN = {name: module for module, names in _ON_USE.items() for name in names}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module = importlib.import_module(_LAZY[name], __name__)
        globals()[name] = module
        return module
    origin = _ORIGIN.get(name)
    if origin is not None:
        value = getattr(importlib.import_module(origin, __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mbimpact' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_ORIGIN) | set(_LAZY))

"""A Pinocchio model and the two quantities the impact laws need from it.

From a mechanism at configuration q the laws need the mass matrix A(q)
(``pin.crba``, armature included) and the world-aligned translational Jacobian
of a contact point. Models are built from URDF kinematics and inertias only:
no meshes are loaded.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from ._validate import as_vector
from .errors import FrameNotFoundError, ParameterError, RobotNotFoundError
from .robots import close_matches, model_path, robot_urdf

__all__ = ["Mechanism"]


@dataclass(frozen=True, eq=False)
class Mechanism:
    """A Pinocchio model with its workspace.

    Attributes
    ----------
    model : pinocchio.Model
        Kinematics and inertias.
    name : str
        Human-readable name (robot name or URDF stem).
    source : pathlib.Path or None
        URDF the model was built from.
    """

    model: Any
    name: str = "mechanism"
    source: Path | None = None
    _local: threading.local = field(init=False, repr=False)
    _frame_ids: dict[str, int] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.model, pin.Model):
            raise ParameterError(f"model must be a pinocchio.Model, got {type(self.model).__name__}")
        object.__setattr__(self, "_local", threading.local())
        object.__setattr__(self, "_frame_ids", {})

    @property
    def data(self) -> Any:
        """Pinocchio workspace, one per thread: a sequence of calls (crba, then the
        Cholesky factor, then a solve) never sees another thread's intermediate state."""
        data = getattr(self._local, "data", None)
        if data is None:
            data = self._local.data = self.model.createData()
        return data

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        # the workspace is per thread and per process: rebuild it on unpickling
        return (type(self), (self.model, self.name, self.source))

    # ------------------------------------------------------------ constructors
    @classmethod
    def from_urdf(cls, path: str | Path, floating: bool = False, name: str | None = None) -> Mechanism:
        """Build from a URDF file (kinematics and inertias, no meshes).

        Parameters
        ----------
        path : str or Path
            URDF file.
        floating : bool
            Add a free-flyer root joint (nq = nv + 1 for its quaternion).
        """
        path = Path(path)
        if not path.is_file():
            raise RobotNotFoundError(f"URDF file {str(path)!r} not found")
        try:
            if floating:
                model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
            else:
                model = pin.buildModelFromUrdf(str(path))
        except (RuntimeError, ValueError) as exc:
            raise RobotNotFoundError(f"could not parse URDF {str(path)!r}: {exc}") from exc
        return cls(model, name or path.stem, path)

    @classmethod
    def from_robot(cls, name: str, floating: bool | None = None) -> Mechanism:
        """An example-robot-data robot by name (``"ur5"``, ``"panda"``, ``"solo12"``, ...).

        Parameters
        ----------
        floating : bool, optional
            Override the robot's default (legged and flying robots float).
        """
        path, default_floating = robot_urdf(name)
        return cls.from_urdf(path, default_floating if floating is None else floating, name)

    @classmethod
    def from_model(cls, name: str, floating: bool = False) -> Mechanism:
        """One of mbimpact's own models under ``models/`` (``"point_mass_2d"``, ...)."""
        return cls.from_urdf(model_path(name), floating, name)

    # ------------------------------------------------------------ dimensions
    @property
    def nq(self) -> int:
        """Configuration dimension."""
        return int(self.model.nq)

    @property
    def nv(self) -> int:
        """Velocity (tangent) dimension."""
        return int(self.model.nv)

    @property
    def frame_names(self) -> list[str]:
        """Names of all frames."""
        return [f.name for f in self.model.frames]

    def frame_id(self, frame: str) -> int:
        """Index of a frame, with the close matches in the error if it is unknown."""
        fid = self._frame_ids.get(frame)
        if fid is not None:
            return fid
        if not self.model.existFrame(frame):
            names = self.frame_names
            close = close_matches(frame, names)
            hint = f"frames with {frame!r} or close to it: {', '.join(close)}" if close else (
                f"{len(names)} frames, e.g. {', '.join(names[-5:])}"
            )
            raise FrameNotFoundError(f"frame {frame!r} not found in {self.name}; {hint}")
        fid = self._frame_ids[frame] = int(self.model.getFrameId(frame))
        return fid

    # ------------------------------------------------------------ states
    def neutral(self) -> NDArray[np.float64]:
        """Neutral configuration (zeros, identity quaternions), shape (nq,)."""
        return pin.neutral(self.model)

    def random_configuration(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """A seeded random configuration within joint limits (±π where unbounded)."""
        lo = np.where(np.isfinite(self.model.lowerPositionLimit), self.model.lowerPositionLimit, -np.pi)
        hi = np.where(np.isfinite(self.model.upperPositionLimit), self.model.upperPositionLimit, np.pi)
        lo, hi = np.maximum(lo, -np.pi), np.minimum(hi, np.pi)
        hi = np.maximum(lo, hi)
        x = rng.uniform(lo, hi)
        return pin.normalize(self.model, x)

    def check_state(self, q: ArrayLike, v: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Validate ``q`` (nq,) and ``v`` (nv,); quaternions must be normalised."""
        q = as_vector("q", q, self.nq)
        v = as_vector("v", v, self.nv)
        # only quaternion and unit-complex joints (nq > nv) have a norm to check
        if self.model.nq != self.model.nv and not pin.isNormalized(self.model, q, 1e-9):
            raise ParameterError(
                "q is not a valid configuration: a quaternion or unit-complex block is not normalised; "
                "use pinocchio.normalize(model, q)"
            )
        return q, v

    # ------------------------------------------------------------ dynamics
    def mass_matrix(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """A(q) from ``pin.crba`` (armature included), full symmetric, shape (nv, nv)."""
        return pin.crba(self.model, self.data, q).copy()

    def factorise(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """A(q) as :meth:`mass_matrix`, keeping its sparse Cholesky factor (``pin.cholesky``)
        in the workspace for :meth:`solve` — the factorisation ``pin.impulseDynamics`` uses."""
        A = self.mass_matrix(q)
        pin.cholesky.decompose(self.model, self.data)
        return A

    def solve(self, b: NDArray[np.float64]) -> NDArray[np.float64]:
        """A⁻¹ b, shape (nv,), with the factor of the last :meth:`factorise` call."""
        return pin.cholesky.solve(self.model, self.data, b)

    def inverse_mass_matrix(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """A(q)⁻¹ from ``pin.computeMinverse`` (ABA-based, no factorisation), shape (nv, nv)."""
        return pin.computeMinverse(self.model, self.data, q).copy()

    def point_jacobian(
        self, q: NDArray[np.float64], frame: str, point: NDArray[np.float64] | None = None
    ) -> NDArray[np.float64]:
        """World-aligned translational Jacobian of a point fixed to a frame, shape (3, nv).

        Parameters
        ----------
        frame : str
            Frame the point is attached to.
        point : ndarray, shape (3,), optional
            Offset of the point from the frame origin, in the frame's own axes.
        """
        fid = self.frame_id(frame)
        # computeFrameJacobian also updates data.oMf[fid], used for the offset below
        J6 = pin.computeFrameJacobian(self.model, self.data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        Jp = J6[:3].copy()
        if point is not None and (point[0] or point[1] or point[2]):
            r = self.data.oMf[fid].rotation @ point  # offset in world axes
            Jp -= pin.skew(r) @ J6[3:]  # v_p = v_o + ω × r
        return Jp

    def frame_position(self, q: NDArray[np.float64], frame: str, point: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """World position of a point fixed to a frame, shape (3,)."""
        fid = self.frame_id(frame)
        pin.framesForwardKinematics(self.model, self.data, q)
        M = self.data.oMf[fid]
        return M.translation + (M.rotation @ point if point is not None else 0.0)

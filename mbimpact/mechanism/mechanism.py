"""A Pinocchio model and the two quantities the impact laws need from it.

From a mechanism at configuration q the laws need the mass matrix A(q)
(``pin.crba``, armature included) and the world-aligned translational Jacobian
of a contact point. Models are built from URDF kinematics and inertias; the
collision geometry is loaded where a contact needs it.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field
from pathlib import Path
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from ..common.geometry import offset_point_jacobian
from ..common.validation import FLOAT64, as_array, as_vector
from ..errors import FrameNotFoundError, ParameterError, RobotNotFoundError
from . import front
from .mass_factor import MassFactor, new_token, pivots_valid
from .parse import parse_file
from .robots import close_matches, file_path, model_path, robot_urdf

if TYPE_CHECKING:  # the geometry layer is imported on use: frame contacts never load it
    from ..geometry.collision_model import CollisionModel

__all__ = ["Mechanism", "MassFactor"]

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
    _dims: tuple[int, int] = field(init=False, repr=False)  # (nq, nv), read on every call

    def __post_init__(self) -> None:
        if not isinstance(self.model, pin.Model):
            raise ParameterError(f"model must be a pinocchio.Model, got {type(self.model).__name__}")
        if self.model.nv == 0:
            raise ParameterError(f"{self.name} has no degree of freedom (nv = 0): nothing can move")
        object.__setattr__(self, "_local", threading.local())
        object.__setattr__(self, "_frame_ids", {})
        object.__setattr__(self, "_dims", (int(self.model.nq), int(self.model.nv)))

    def workspace(self) -> threading.local:
        """This thread's workspace (``.data``: a Pinocchio Data): a sequence of calls (crba,
        then the Cholesky factor, then a solve) never sees another thread's intermediate state."""
        local = self._local
        if getattr(local, "data", None) is None:
            local.data = self.model.createData()
        return local

    @property
    def data(self) -> Any:
        """This thread's Pinocchio workspace. The factors of A(q) that metrics keep for later solves
        (:meth:`ContactMetric.solve`) live in it: Pinocchio algorithms that factorise A in it
        (``pin.impulseDynamics``, ``pin.cholesky.decompose``) make those solves wrong; give your own
        Pinocchio calls ``model.createData()``. Impact results never depend on it afterwards."""
        return self.workspace().data

    def __repr__(self) -> str:  # the model's own text lists every joint, frame and inertia
        floating = self.model.njoints > 1 and self.model.joints[1].shortname() == "JointModelFreeFlyer"
        return f"Mechanism({self.name!r}, nq={self.nq}, nv={self.nv}, floating={floating}, frames={len(self.model.frames)})"

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        # the workspace is per thread and per process: rebuild it on unpickling
        return (type(self), (self.model, self.name, self.source))

    # ------------------------------------------------------------ constructors
    @classmethod
    def from_urdf(cls, path: str | Path, floating: bool = False, name: str | None = None) -> Mechanism:
        """Build from a URDF file (kinematics and inertias).

        Parameters
        ----------
        path : str or Path
            URDF file.
        floating : bool
            Add a free-flyer root joint (nq = nv + 1 for its quaternion).

        Raises
        ------
        RobotNotFoundError
            The file is missing.
        URDFError
            The file cannot be parsed (the message gives the parser's complaint).
        """
        def build(file: str) -> Any:
            return pin.buildModelFromUrdf(file, pin.JointModelFreeFlyer()) if floating else pin.buildModelFromUrdf(file)

        return cls._from_file("URDF", build, path, floating, name)

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
    def from_model(cls, name: str, floating: bool | None = None) -> Mechanism:
        """One of mbimpact's own models under ``models/`` (``"point_mass_2d"``, ``"box"``, ...).

        Parameters
        ----------
        floating : bool, optional
            Add a free-flyer root. Default: only for the models that have no joint (the
            solid ``box`` and ``sphere``), which would not move otherwise.
        """
        path = model_path(name)
        if floating is None:
            floating = pin.buildModelFromUrdf(str(path)).nv == 0
        return cls.from_urdf(path, floating, name)

    @classmethod
    def from_mjcf(cls, path: str | Path, floating: bool = False, name: str | None = None) -> Mechanism:
        """Build from a MuJoCo MJCF file through Pinocchio's parser (kinematics and inertias; the
        collision geoms are loaded on first use, see :meth:`collision_model`).

        The MJCF's own joints are kept: a body with a ``<freejoint>`` floats. Where MJCF places
        such a body (its ``pos``) is only in ``model.referenceConfigurations["qpos0"]``; the
        neutral configuration puts it at the origin.

        Limits of Pinocchio 4.1's parser: only the first top-level ``<body>`` of ``<worldbody>``
        is read (wrap several free bodies in one jointless body), a jointless first body loses its
        ``pos``, and the file must be a path (not an XML string).

        Parameters
        ----------
        path : str or Path
            MJCF (``.xml``) file.
        floating : bool
            Add a free-flyer root joint (for a model whose root body has no joint of its own).

        Raises
        ------
        RobotNotFoundError
            The file is missing.
        URDFError
            The file cannot be parsed.
        """
        import warnings

        def build(file: str) -> Any:
            if not floating:
                return pin.buildModelFromMJCF(file)
            with warnings.catch_warnings():  # 4.1 deprecates this form (it returns the constraints too)
                warnings.simplefilter("ignore", DeprecationWarning)
                return pin.buildModelFromMJCF(file, pin.JointModelFreeFlyer(), "root_joint")[0]

        return cls._from_file("MJCF", build, path, floating, name)

    @classmethod
    def _from_file(cls, kind: str, build: Callable[[str], Any], path: str | Path, floating: bool,
                   name: str | None) -> Mechanism:
        """Validate ``floating`` and ``path``, then build the model, naming parse errors."""
        if not isinstance(floating, bool):
            raise ParameterError(f"floating must be True or False, got {floating!r}")
        path = file_path(kind, path)
        if not path.is_file():
            raise RobotNotFoundError(f"{kind} file {str(path)!r} not found")
        return cls(parse_file(kind, build, path), name or path.stem, path)

    # ------------------------------------------------------------ dimensions
    @property
    def nq(self) -> int:
        """Configuration dimension."""
        return self._dims[0]

    @property
    def nv(self) -> int:
        """Velocity (tangent) dimension."""
        return self._dims[1]

    @property
    def frame_names(self) -> list[str]:
        """Names of all frames."""
        return [f.name for f in self.model.frames]

    def frame_id(self, frame: str) -> int:
        """Index of a frame by name.

        When several frames share the name (a link and its joint, e.g. in anymal_c),
        the link's BODY frame is taken: contact points live on links.

        Raises
        ------
        FrameNotFoundError
            No frame of that name (the message lists close matches).
        """
        fid = self._frame_ids.get(frame) if isinstance(frame, str) else None
        if fid is not None:
            return fid
        if not isinstance(frame, str):
            raise FrameNotFoundError(f"a frame is named by a string, got {type(frame).__name__}")
        matches = [i for i, f in enumerate(self.model.frames) if f.name == frame]
        if not matches:
            names = self.frame_names
            close = close_matches(frame, names)
            hint = f"frames with {frame!r} or close to it: {', '.join(close)}" if close else (
                f"{len(names)} frames, e.g. {', '.join(names[-5:])}"
            )
            raise FrameNotFoundError(f"frame {frame!r} not found in {self.name}; {hint}")
        bodies = [i for i in matches if self.model.frames[i].type == pin.FrameType.BODY]
        fid = self._frame_ids[frame] = (bodies or matches)[0]
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

    def check_configuration(self, q: ArrayLike) -> NDArray[np.float64]:
        """Validate ``q`` (nq,): finite, real, quaternions normalised.

        Raises
        ------
        ShapeError, NonFiniteError, ParameterError
        """
        nq, nv = self._dims
        q = as_vector("q", q, nq)
        # only quaternion and unit-complex joints (nq > nv) have a norm to check
        if nq != nv and not pin.isNormalized(self.model, q, 1e-9):
            raise ParameterError(
                "q is not a valid configuration: a quaternion or unit-complex block is not normalised; "
                "use pinocchio.normalize(model, q)"
            )
        return q

    def check_state(self, q: ArrayLike, v: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Validate ``q`` (nq,) and ``v`` (nv,); quaternions must be normalised."""
        nq, nv = self._dims
        # one pass for the usual call (both float64 vectors of the right lengths, finite: see as_vector
        # for the float sums); anything else, or a sum that overflows, takes the checks that name it
        if (type(q) is np.ndarray and type(v) is np.ndarray and q.dtype is FLOAT64 and v.dtype is FLOAT64
                and q.shape == (nq,) and v.shape == (nv,) and math.isfinite(sum(q.tolist()) + sum(v.tolist()))):
            if nq != nv and not pin.isNormalized(self.model, q, 1e-9):
                return self.check_configuration(q), v  # names the block
            return q, v
        return self.check_configuration(q), as_vector("v", v, nv)

    # ------------------------------------------------------------ dynamics
    def mass_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """A(q) from ``pin.crba`` (armature included), full symmetric, shape (nv, nv)."""
        return pin.crba(self.model, self.data, self.check_configuration(q)).copy()

    def factorise(self, q: NDArray[np.float64]) -> tuple[NDArray[np.float64], MassFactor]:
        """A(q) and its sparse Cholesky factor (``pin.cholesky``), for a validated ``q``.

        The factor is the one ``pin.impulseDynamics`` uses; it stays in this thread's
        workspace, and :meth:`MassFactor.solve` rebuilds it if that was reused.
        """
        local = self.workspace()
        model, data = self.model, local.data
        A = pin.crba(model, data, q).copy()
        pin.cholesky.decompose(model, data)
        local.token = token = new_token()
        return A, MassFactor(self, q.copy(), token, pivots_valid(data))

    def factor_arrays(self, q: NDArray[np.float64]
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """A(q) and its sparse Cholesky factor A = U D Uᵀ (``pin.cholesky``, what
        ``pin.impulseDynamics`` uses) for a validated ``q``, as arrays: what the compiled single-impact
        routes read (:mod:`mbimpact.metric.kernels`).

        Returns
        -------
        A : ndarray, shape (nv, nv)
            A(q) from ``pin.crba``, full symmetric, the caller's own copy.
        U : ndarray, shape (nv, nv)
            Unit upper triangular factor.
        D : ndarray, shape (nv,)
            Pivots (all finite and > 0 if and only if A(q) is positive definite).

        ``U`` and ``D`` are views of this thread's workspace, valid until the next call on this
        mechanism in this thread: read them at once.
        """
        local = self._local
        data = getattr(local, "data", None) or self.workspace().data
        if getattr(local, "factor_of", None) is not data:  # views of the factor's memory, which Pinocchio
            local.U, local.D, local.factor_of = data.U, data.D, data  # never moves; kept with their Data
        A = pin.crba(self.model, data, q)
        if not A.flags.owndata:  # Pinocchio 4 hands back its own copy; a view of the workspace must be copied
            A = A.copy()
        pin.cholesky.decompose(self.model, data)
        local.token = new_token()  # the workspace holds a new factor: the others must re-factorise
        return A, local.U, local.D

    def front_end(self) -> object | None:
        """This thread's workspace bound to the compiled front end (:mod:`mbimpact.mechanism.front`), or
        None where that is not in use.

        A call through it leaves A(q)'s factor in the workspace, as :meth:`factor_arrays` does: the
        factors kept for later solves (:class:`MassFactor`) re-factorise at their next one.
        """
        native = front.NATIVE
        if native is None:
            return None
        local = self._local
        bound = getattr(local, "bound", None)
        if bound is None:
            bound = local.bound = native.bind(self.model, self.workspace().data)
        local.token = new_token()
        return bound

    def front_stage_one(self, q: Any, v: Any, fid: int, point: NDArray[np.float64]
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                   NDArray[np.float64]] | None:
        """Stage one of an impact in one call of the compiled front end: q and v checked, the point's
        Jacobian and A(q) with its factor, the values of :meth:`check_state`, :meth:`frame_jacobian`
        and :meth:`factor_arrays` (to rounding, for an offset point).

        Parameters
        ----------
        q, v : object
            The state as given (not yet checked).
        fid : int
            Frame index.
        point : ndarray, shape (3,)
            Offset of the point from the frame origin, in the frame's axes (zeros: the origin).

        Returns
        -------
        (A, U, D, J) or None
            A (nv, nv) and J (3, nv), the caller's own, and the factor A = U D Uᵀ as
            :meth:`factor_arrays` gives it (views of the workspace: read them at once). None where
            the front end is not in use, or q and v are not float64 arrays of the right lengths,
            finite, with normalised quaternions: :meth:`check_state` then names or converts them.
        """
        bound = self.front_end()
        native = front.NATIVE
        if bound is None or native is None:
            return None
        n = self._dims[1]
        A, J = np.empty((n, n)), np.empty((3, n))
        if native.stage_one(bound, q, v, fid, point, A, J) != native.DONE:
            return None
        local = self._local
        data = local.data
        if getattr(local, "factor_of", None) is not data:
            local.U, local.D, local.factor_of = data.U, data.D, data
        return A, local.U, local.D, J

    def front_fill_rows(self, Q: NDArray[np.float64], fid: int, point: NDArray[np.float64], A: NDArray[np.float64],
                        J: NDArray[np.float64], U: NDArray[np.float64] | None = None,
                        D: NDArray[np.float64] | None = None) -> int | None:
        """:meth:`front_stage_one` for the rows of a finite ``Q`` (B, nq), in one call: each row's A(q) into
        ``A[i]`` (B, nv, nv), the point's Jacobian into ``J[i]`` (B, 3, nv) and, where given, the factor
        into ``U[i]`` (B, nv, nv) and ``D[i]`` (B, nv); the values of :meth:`fill_factors` and
        :meth:`fill_frame_jacobians` (to rounding, for an offset point).

        Returns
        -------
        int or None
            The rows filled: B, or the first row whose quaternion blocks are not normalised. None
            where the front end is not in use (nothing filled).
        """
        bound = self.front_end()
        native = front.NATIVE
        if bound is None or native is None:
            return None
        return native.stage_rows(bound, Q, fid, point, A, J, U, D)

    def fill_factors(self, Q: NDArray[np.float64], A: NDArray[np.float64], U: NDArray[np.float64] | None = None,
                     D: NDArray[np.float64] | None = None) -> None:
        """:meth:`factor_arrays` for every row of a validated ``Q`` (B, nq) in one lean loop: A(q) into
        ``A[i]`` (B, nv, nv) and, where ``U`` (B, nv, nv) and ``D`` (B, nv) are given, its factor
        A = U D Uᵀ into ``U[i]`` and ``D[i]``: each row what :meth:`factor_arrays` returns, to the bit
        (:func:`mbimpact.impact_batch` gathers its stacks so)."""
        local = self._local
        model, data = self.model, getattr(local, "data", None) or self.workspace().data
        crba = pin.crba
        if U is None or D is None:
            for i, q in enumerate(Q):
                A[i] = crba(model, data, q)
            return
        decompose, factor_U, factor_D = pin.cholesky.decompose, data.U, data.D  # views Pinocchio never moves
        for i, q in enumerate(Q):
            A[i] = crba(model, data, q)
            decompose(model, data)
            U[i], D[i] = factor_U, factor_D
        local.token = new_token()  # the workspace holds a new factor: the others must re-factorise

    def inverse_mass_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """A(q)⁻¹ from ``pin.computeMinverse`` (ABA-based, no factorisation), shape (nv, nv)."""
        return pin.computeMinverse(self.model, self.data, self.check_configuration(q)).copy()

    def point_jacobian(self, q: ArrayLike, frame: str, point: ArrayLike | None = None) -> NDArray[np.float64]:
        """World-aligned translational Jacobian of a point fixed to a frame, shape (3, nv).

        Parameters
        ----------
        q : array_like, shape (nq,)
        frame : str
            Frame the point is attached to.
        point : array_like, shape (3,), optional
            Offset of the point from the frame origin, in the frame's own axes.
        """
        q = self.check_configuration(q)
        return self.frame_jacobian(q, self.frame_id(frame), _offset(point))

    def frame_jacobian(self, q: NDArray[np.float64], fid: int, point: NDArray[np.float64] | None) -> NDArray[np.float64]:
        """:meth:`point_jacobian` for a validated q, a frame index and an offset (hot path)."""
        data = getattr(self._local, "data", None) or self.workspace().data
        # computeFrameJacobian also updates data.oMf[fid], used for the offset below
        J6 = pin.computeFrameJacobian(self.model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        if J6.shape != (6, self._dims[1]):
            J6 = np.asarray(J6).reshape(6, self._dims[1])
        if point is None:
            return J6[:3]  # a view of the fresh (6, nv) array Pinocchio returned: nothing else holds it
        return offset_point_jacobian(J6, data.oMf[fid].rotation @ point)

    def fill_frame_jacobians(self, Q: NDArray[np.float64], fid: int, point: NDArray[np.float64] | None,
                             J: NDArray[np.float64]) -> None:
        """:meth:`frame_jacobian` for every row of a validated ``Q`` (B, nq) in one lean loop, into
        ``J[i]`` (B, 3, nv): each row its result, to the bit."""
        model, data = self.model, getattr(self._local, "data", None) or self.workspace().data
        jacobian, world = pin.computeFrameJacobian, pin.LOCAL_WORLD_ALIGNED
        if point is not None or self._dims[1] == 1:  # an offset (read from data.oMf[fid], which each
            for i, q in enumerate(Q):                # computeFrameJacobian updates), or a (6,) Jacobian
                J[i] = self.frame_jacobian(q, fid, point)
            return
        for i, q in enumerate(Q):
            J[i] = jacobian(model, data, q, fid, world)[:3]

    def frame_position(self, q: ArrayLike, frame: str, point: ArrayLike | None = None) -> NDArray[np.float64]:
        """World position of a point fixed to a frame, shape (3,)."""
        q = self.check_configuration(q)
        fid = self.frame_id(frame)
        pin.framesForwardKinematics(self.model, self.data, q)
        M = self.data.oMf[fid]
        p = _offset(point)
        return M.translation + (M.rotation @ p if p is not None else 0.0)

    # ------------------------------------------------------------ collision geometry
    def collision_model(self) -> CollisionModel:
        """The collision objects of the mechanism (:class:`mbimpact.geometry.CollisionModel`).

        Loaded from the model file on the first call (URDF ``<collision>`` elements or MJCF
        collision geoms; meshes as convex hulls), then kept with the mechanism; nothing is loaded
        before, so frame contacts never pay for it. A mechanism built from a ``pinocchio.Model``
        without a file gets an empty model, to which shapes can be attached
        (:meth:`~mbimpact.geometry.CollisionModel.add`).

        Raises
        ------
        GeometryError
            A mesh cannot be found or read.
        """
        from ..geometry.loading import collision_model

        return collision_model(self)

    def collision_names(self) -> list[str]:
        """Names of the mechanism's collision objects (loads them, see :meth:`collision_model`)."""
        return self.collision_model().names


def _offset(point: ArrayLike | None) -> NDArray[np.float64] | None:
    """A validated (3,) offset, or None for the frame origin."""
    if point is None:
        return None
    p = as_array("point", point, 1, (3,))
    return p if p.any() else None



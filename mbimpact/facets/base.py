"""The family of facet laws: what happens on one facet of the microrelief, (2.4)–(2.6).

The rough law (2.8) averages the impacts on the facets that face the motion with the
flux weights (2.7). The paper resolves each facet impact by a Kelvin–Voigt force
along the facet normal and obtains Newton's law on the facet, (2.5)–(2.6). A *facet
law* replaces that one step: the weights stay as they are, only the impulse a single
facet delivers changes.

Each facet's contact problem lives in contact space with W fixed, as in (2.4): the
facet frame is a rotation whose last column is the facet normal m, the Delassus
matrix and the contact velocity are rotated into it, the law returns the contact
impulse there, and it is rotated back:

    W_f = Rᵀ W R,   u_f = Rᵀ u,   P = R P_f(W_f, u_f),   R e_d = m.

Every law here is isotropic in the facet's tangent plane, so the choice of the
tangent columns of R does not matter (:func:`facet_frames` takes the minimal
rotation from n⁰ to m).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..errors import ShapeError

__all__ = ["FacetLaw", "facet_frames", "to_facet_frame", "method_label", "split_method"]


class FacetLaw(ABC):
    """Base class: the contact impulse of one facet impact, vectorised over facets.

    Attributes
    ----------
    name : str
        Registry name (:data:`mbimpact.facets.FACETS`), also the label the result carries
        (``result.method`` is ``"adaptive[coulomb]"`` for an adaptive average of Coulomb facets).
    homogeneous : bool
        Whether the impulse is positively homogeneous of degree 1 in the velocity (property 1°).
        A speed-dependent law (:class:`~mbimpact.HuntCrossleyFacet`) is not; :class:`~mbimpact.RoughLaw`
        then hands it physical velocities (see :meth:`mbimpact.RoughLaw.impulses`).
    default_rtol : float
        The relative accuracy the rough law's adaptive quadrature asks for by default with
        this facet law (:meth:`quadrature_rtol`): tighter than the law's own accuracy makes no sense.
    e : float
        The normal restitution of a facet impact (for a speed-dependent law: at 1 m/s).
    """

    name: ClassVar[str]
    homogeneous: ClassVar[bool] = True
    default_rtol: ClassVar[float] = 1e-12
    e: float

    def quadrature_rtol(self, d: int | None) -> float:
        """The default ``rtol`` of a rough law with this facet law in a d-dimensional contact space
        (None: either): ten times the facet impulse's own accuracy, at least 1e-12."""
        return self.default_rtol

    @property
    def newton_restitution(self) -> float | None:
        """e when the facet impulse is Newton's, −(1+e) (mᵀu / mᵀWm) m, so that the closed-form
        averages (``ring``, ``tilt-table``, ``laplace``, ``poles``) and the compiled backends of the
        refinable rules apply; None otherwise."""
        return None

    def impulse(self, m: NDArray[np.float64], W: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """Contact impulses of facet impacts, in the frame of the base surface.

        Parameters
        ----------
        m : ndarray, shape (N, d)
            Unit facet normals, local frame of the base surface (last axis along n⁰).
        W : ndarray, shape (d, d)
            Delassus matrix in the same frame, shared by all facets (W fixed, (2.4)).
        u : ndarray, shape (N, d)
            Contact velocities, one per facet, facing it: ``mᵢᵀuᵢ < 0``. Units are the
            caller's; a homogeneous law gives impulses in the matching units, a speed-dependent
            one reads them as m/s.

        Returns
        -------
        ndarray, shape (N, d)
            Contact impulses P (same frame).
        """
        if m.ndim != 2 or u.shape != m.shape or W.shape != (m.shape[1], m.shape[1]):
            raise ShapeError(f"facet impulses need m (N, d), u (N, d) and W (d, d); got m {m.shape}, "
                             f"u {u.shape}, W {W.shape}")
        R = facet_frames(m)
        Wf, uf = to_facet_frame(R, W, u)
        Pf = self.facet_impulse(Wf, uf)
        return np.einsum("nij,nj->ni", R, Pf)

    @abstractmethod
    def facet_impulse(self, W: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """Contact impulses in the facet frames (last axis along the facet normal).

        Parameters
        ----------
        W : ndarray, shape (N, d, d)
            Delassus matrices in the facet frames, W_f = Rᵀ W R.
        u : ndarray, shape (N, d)
            Contact velocities in the facet frames, ``u[:, -1] < 0``.

        Returns
        -------
        ndarray, shape (N, d)
            P_f with P_f[:, -1] ≥ 0 the normal impulse.
        """

    def label(self) -> str:
        """The short label a result carries: the registry name."""
        return self.name


def facet_frames(m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotations R (N, d, d) with last column the facet normal m (N, d), m[:, -1] > 0.

    3-D: the minimal rotation taking n⁰ = e₃ to m (Rodrigues), R = I + [k]ₓ + [k]ₓ² / (1 + m₃)
    with k = e₃ × m; 2-D: the rotation by the facet's tilt, columns (m₂, −m₁) and m.
    """
    N, d = m.shape
    R = np.empty((N, d, d))
    if d == 2:
        R[:, 0, 0], R[:, 1, 0] = m[:, 1], -m[:, 0]
        R[:, :, 1] = m
        return R
    x, y, z = m[:, 0], m[:, 1], m[:, 2]
    f = 1.0 / (1.0 + z)
    R[:, 0, 0], R[:, 1, 0], R[:, 2, 0] = 1.0 - x * x * f, -x * y * f, -x
    R[:, 0, 1], R[:, 1, 1], R[:, 2, 1] = -x * y * f, 1.0 - y * y * f, -y
    R[:, :, 2] = m
    return R


def to_facet_frame(R: NDArray[np.float64], W: NDArray[np.float64], u: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """W_f = Rᵀ W R (N, d, d) and u_f = Rᵀ u (N, d) for facet frames R (N, d, d)."""
    Rt = np.swapaxes(R, 1, 2)
    Wf = Rt @ (W @ R)
    Wf = 0.5 * (Wf + np.swapaxes(Wf, 1, 2))
    return Wf, np.einsum("nji,nj->ni", R, u)


def method_label(averaging: str, facet: FacetLaw) -> str:
    """What a rough-law result records in ``method``: the averaging's name for Newton facets
    (unchanged: ``"ring"``, ``"adaptive"``, …), ``"<averaging>[<facet>]"`` otherwise
    (``"adaptive[compliant]"``)."""
    return averaging if facet.newton_restitution is not None else f"{averaging}[{facet.label()}]"


def split_method(method: str) -> tuple[str, str]:
    """(averaging, facet law name) of a result's ``method`` (the facet is ``"newton"`` without brackets)."""
    if method.endswith("]") and "[" in method:
        averaging, facet = method[:-1].split("[", 1)
        return averaging, facet
    return method, "newton"

"""Ivanov's rough-surface law (2.8): the flux-weighted average of facet impacts.

The facet impact is Newton's (2.6) by default, the paper's; any facet law of
:mod:`mbimpact.facets` can replace it (``RoughLaw(roughness, facet=CoulombFacet(e, mu))``):
the flux weights (2.7) stay, only the impulse of one facet changes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..averaging import AUTO_ORDER, METHODS, Averaging, Graded, Ring
from ..averaging.integrand import AveragingSpec, Flux, check_flux, general_facets
from ..common.validation import as_count, as_scalar
from ..errors import ParameterError, RoughnessError
from ..facets.base import FacetLaw, method_label
from ..facets.newton import NewtonFacet
from ..facets.restitution import restitution_from
from ..metric.delassus import ContactMetric
from ..results.impact import ContactImpulses
from ..roughness.base import Roughness
from ..roughness.cone import Cone
from .base import ImpactLaw, WrappedLaw
from .compiled import CompiledImpact
from .cone_plan import cone_impact
from .repeat import repeated

if TYPE_CHECKING:
    from ..results.outcomes import ImpactOutcomes

__all__ = ["RoughLaw"]

class RoughLaw(ImpactLaw):
    """Ivanov's constructive impact on a rough surface, (2.8).

    The velocity jump is the flux-weighted average of the Newton impacts on the
    facets that face the velocity,

        Δv = −(1+e) ∫_{G*} (N, v₋)² N dP / ∫_{G*} (N, v₋) dP,

    computed in contact space as P = −(1+e) Σ wᵢ (mᵢᵀu / mᵢᵀWmᵢ) mᵢ / Σ wᵢ with
    wᵢ the facet weight of (2.7) on G* = {mᵢᵀu < 0} (:mod:`mbimpact.averaging.integrand`).

    The model assumes one micro-impact per facet: a Newton impact on the facet hit
    first, then separation. Its results are valid while the averaged outcome leaves
    the surface (``result.separates``); see ``repeat``.

    Parameters
    ----------
    roughness : Roughness
        Facet-normal measure (:class:`Smooth`, :class:`Sawtooth`, :class:`Cone`,
        :class:`Facets`, :class:`GaussianSlopes`, :class:`Profile`, ...).
    e : float or FacetLaw, optional
        Facet restitution in [0, 1] of Newton facets: ``RoughLaw(rough, e)`` is
        ``RoughLaw(rough, facet=NewtonFacet(e))``. A facet law given here is taken as ``facet``.
    k : float, optional
        Kelvin–Voigt damping ratio in [0, 1] instead of ``e``; exactly one.
    facet : FacetLaw, optional
        The impact on one facet, instead of ``e``/``k`` (:mod:`mbimpact.facets`):
        :class:`NewtonFacet` (the paper's, with every averaging method),
        :class:`CoulombFacet`, :class:`CompliantFacet`, :class:`HuntCrossleyFacet`
        (the quadrature rules only: ``exact``, ``fixed``, ``adaptive``, ``graded``,
        ``monte-carlo``; naming another is a :class:`ParameterError`). Results record the
        facet law in ``method``:
        ``"adaptive[coulomb]"`` (Newton facets keep the bare averaging name).
    flux : {"physical", "configuration"}
        Weight of a facet in (2.7). ``"physical"`` (default): pᵢ (−mᵢᵀu), the rate
        at which the contact point, moving along u = J v, sweeps facet i of a
        physical surface whose measure P is a share of true physical area — what
        (2.7) becomes when P is moved into configuration space, where a physical
        facet's A-metric area is its physical area times √(mᵀWm).
        ``"configuration"``: pᵢ (−(N_i, v)) = pᵢ (−mᵢᵀu)/√(mᵢᵀWmᵢ), the paper's
        (2.7) read literally, valid only when the roughness measure is defined on
        configuration-space area (e.g. J = I). The two coincide when W ∝ I (a
        point mass).
    method : str, Averaging subclass or instance
        How the integrals of (2.8) are computed: ``"auto"`` (default) or a name of
        :data:`mbimpact.averaging.METHODS` (``"exact"``, ``"ring"``, ``"tilt-table"``,
        ``"laplace"``, ``"poles"``, ``"graded"``, ``"fixed"``, ``"adaptive"``,
        ``"monte-carlo"``). The result records which ran (``result.method``; a rule's
        compiled backend as ``"adaptive[compiled]"``).
    rtol : float, optional
        Relative accuracy of the adaptive quadrature for measures that are not
        finite (default: the facet law's :meth:`~mbimpact.facets.FacetLaw.quadrature_rtol`:
        1e-12 for Newton and Hunt–Crossley facets, 1e-4 to 1e-3 for Coulomb and compliant
        ones); node counts are doubled until two successive results agree to ``rtol``
        (or to the rounding floor 100 ε √K of a K-facet sum, if larger).
        When W nearly annihilates the impulse (|W| |P| ≫ |W P|, an ill-conditioned
        contact) the results stop improving above rtol; refinement then stops and
        an :class:`AccuracyWarning` reports the error reached.
    nodes : int, optional
        Fixed node count (per piece of the rule) instead of adaptive refinement; the
        error estimate then compares with ``nodes // 2``.
    max_nodes : int, optional
        Node count at which refinement stops (an :class:`AccuracyWarning` is
        issued if ``rtol`` was not reached); default: the measure's ``node_limit``.
    samples, seed : int
        Monte Carlo sample count and seed (``method="monte-carlo"``).
    repeat : bool
        The model assumes one micro-impact per facet. When the averaged outcome
        still approaches the surface (κ < 0: steep facets at normal incidence, or
        an oblique impact on an anisotropic W), further micro-impacts follow. With
        ``repeat=True`` the law is applied again to the new contact velocity, with
        the same W, until the contact separates; once the velocity's direction has
        settled (a fixed direction or a two-cycle between the walls of a valley, along
        which the velocity shrinks geometrically) or is seen to converge geometrically
        to such a direction, the limit is the impulse that stops the contact point,
        P = −W⁺ u₋. Default False: one application, and a
        :class:`NoSeparationWarning` when the contact still approaches.
        The work is bounded (class attributes below): beyond ``exact_budget`` the
        micro-impacts are averaged coarsely, and they stop at ``repeat_budget``; an
        :class:`AccuracyWarning` says when that limited a result.

    Attributes
    ----------
    max_node_count, max_samples : int
        Upper bounds of ``nodes``/``max_nodes`` and ``samples``.
    max_repeats : int
        ``repeat=True``: at most this many further applications of (2.8) (:mod:`mbimpact.laws.repeat`).
    repeat_budget : int
        ``repeat=True``: at most this many facets averaged for them, counted for the
        quadratures refined in nodes a piece (fixed, adaptive, graded) by
        :meth:`Roughness.rule_size` (a :class:`GaussianSlopes` puts up to 60 n² facets on
        a velocity with a graded rule of n nodes a piece, 2 n² with its plain rule; a
        :class:`Cone` n). A contact still approaching at either limit is returned as it
        is, with an :class:`AccuracyWarning`. The default, a few seconds of graded
        product rules, admits the ~150 coarse micro-impacts of a velocity creeping along a
        valley of a nearly singular W.
    exact_budget : int
        ``repeat=True``: the facets of ``repeat_budget`` averaged to ``rtol`` (one graded
        pass of 256 nodes a piece, ~3 of 128, ~20 plain ones of 256). Later micro-impacts
        are coarse: averaged to ``coarse_rtol`` with at most ``coarse_facets`` facets. Where
        the contact is then found to be stopped (P = −W⁺ u₋) they only decided that, and
        the result keeps its accuracy; where it separates, their error enters the error
        estimate (an :class:`AccuracyWarning` if it exceeds ``rtol``). Their errors could
        lead the velocity astray: once Σ error_k |W P_k| reaches a tenth of the contact's
        distance to the tangent plane (|u| · −n⁰ᵀu/|u|), they cannot tell whether it
        separates, and the result falls back to the micro-impacts averaged to ``rtol``,
        with an :class:`AccuracyWarning`.
    coarse_facets : int
        Facets of a coarse micro-impact's rule, at most (32 nodes a piece for a graded
        :class:`GaussianSlopes` rule, 128 for its plain one; never above ``max_nodes``,
        never below one refinement of the measure's ``initial_nodes``).
    coarse_rtol : float
        Accuracy of the coarse micro-impacts (``rtol`` if larger).
    settled : float
        ``repeat=True``: a direction that comes back to within this (1 − cos) after one or
        two micro-impacts, with a shrinking speed, has settled.
    contraction : float
        ``repeat=True``: directions whose changes shrink by a ratio r below this are taken
        to converge geometrically, and have settled once the rest of their motion,
        at most step · r / (1 − r), cannot reach a tenth of the way to the tangent plane.

    Notes
    -----
    A speed-dependent facet law (:class:`HuntCrossleyFacet`) makes the law inhomogeneous:
    :meth:`impulses` then hands the averaging physical contact velocities (m/s) instead of
    unit ones, and :meth:`contact_impulses` reads its ``U`` as physical.

    For a nearly singular W (an arm near a singular posture) the kernels of (2.8)
    peak sharply where mᵀWm is smallest; ``"auto"`` then takes the poles out (``"poles"``,
    one velocity on a :class:`Cone`) or grades the rule towards the peaks by sinh maps
    (``"graded"``), converging with tens of nodes where a uniform rule needs 10⁵. Single
    velocities with Newton facets run the refinable rules compiled (numba, loaded on
    first use; a :class:`Cone`'s whole impact in one call, :meth:`compiled_impact`);
    batches at one W use closed-form expansions (``"ring"``, ``"tilt-table"``) and
    Gaussian slopes their Laplace reduction (``"laplace"``).
    """

    #: Upper bounds that keep a typo from turning into hours of work.
    max_node_count: ClassVar[int] = 1 << 16
    max_samples: ClassVar[int] = 10_000_000
    max_repeats: ClassVar[int] = 2000
    repeat_budget: ClassVar[int] = 15_000_000
    exact_budget: ClassVar[int] = 3_000_000
    coarse_facets: ClassVar[int] = 100_000
    coarse_rtol: ClassVar[float] = 1e-8
    settled: ClassVar[float] = 1e-12
    contraction: ClassVar[float] = 0.99

    def __init__(
        self,
        roughness: Roughness,
        e: float | FacetLaw | None = None,
        *,
        k: float | None = None,
        facet: FacetLaw | None = None,
        flux: Flux = "physical",
        method: str | Averaging | type[Averaging] = "auto",
        rtol: float | None = None,
        nodes: int | None = None,
        max_nodes: int | None = None,
        samples: int = 10_000,
        seed: int = 0,
        repeat: bool = False,
    ) -> None:
        if not isinstance(roughness, Roughness):
            raise RoughnessError(
                "roughness must be a Roughness measure (Smooth, Sawtooth, Cone, Facets, ...), "
                f"got {type(roughness).__name__}"
            )
        facet = _facet_law(e, k, facet)
        newton_e = facet.newton_restitution
        e_value = facet.e if newton_e is None else newton_e
        if rtol is None:
            rtol = facet.quadrature_rtol(roughness.dim)
        node_count = None if nodes is None else as_count("nodes", nodes, 1, self.max_node_count)
        limit = roughness.node_limit if max_nodes is None else as_count(
            "max_nodes", max_nodes, max(1, roughness.initial_nodes), self.max_node_count)
        self.spec = AveragingSpec(
            roughness, e_value, check_flux(flux), as_scalar("rtol", rtol, 0.0, 1.0, hi_open=True), node_count, limit,
            as_count("samples", samples, 2, self.max_samples), as_count("seed", seed, 0, 2**63 - 1), facet,
        )
        self.e = e_value
        self.facet = facet
        self.method = _method(method, self.spec)
        self._auto: tuple[AveragingSpec, tuple[Averaging, ...]] | None = None  # see _auto_methods
        self._cone: tuple[tuple[Any, ...], CompiledImpact | None] | None = None  # see compiled_impact
        if not isinstance(repeat, bool):
            raise ParameterError(f"repeat must be True or False, got {repeat!r}")
        self.repeat = repeat
        if self.method is not None and self.method.name == "monte-carlo":
            roughness.sample(np.random.default_rng(0), 2)  # fail now if it cannot be sampled

    def __getstate__(self) -> dict[str, Any]:
        # the caches of "auto" (its methods, the compiled route's node tables) are rebuilt on use, not pickled
        state = self.__dict__.copy()
        state["_auto"] = state["_cone"] = None
        state.pop("_repr", None)
        return state

    # the settings, read back
    roughness = property(lambda self: self.spec.roughness, doc="The facet measure.")
    flux = property(lambda self: self.spec.flux, doc="The facet weight of (2.7).")
    rtol = property(lambda self: self.spec.rtol, doc="Relative accuracy of refinable rules.")
    nodes = property(lambda self: self.spec.nodes, doc="Fixed node count, or None.")
    max_nodes = property(lambda self: self.spec.max_nodes, doc="Node count at which refinement stops.")
    samples = property(lambda self: self.spec.samples, doc="Monte Carlo sample count.")
    seed = property(lambda self: self.spec.seed, doc="Monte Carlo seed.")

    def replace(self, **changes: Any) -> RoughLaw:
        """A copy with some settings changed, e.g. ``law.replace(repeat=True)``.

        Accepts the constructor's keywords (``roughness``, ``e`` or ``k`` (Newton facets), ``facet``,
        ``flux``, ``method``, ``rtol``, ``nodes``, ``max_nodes``, ``samples``, ``seed``, ``repeat``).
        A law at its default accuracy keeps the default of the new facet law and roughness.
        """
        settings: dict[str, Any] = {
            "facet": self.facet, "flux": self.flux, "method": self.method if self.method is not None else "auto",
            "rtol": self.rtol, "nodes": self.nodes, "max_nodes": self.max_nodes, "samples": self.samples,
            "seed": self.seed, "repeat": self.repeat,
        }
        unknown = set(changes) - set(settings) - {"roughness", "e", "k"}
        if unknown:
            raise ParameterError(f"RoughLaw.replace got unknown settings {sorted(unknown)}; valid: roughness, e, k, "
                                 + ", ".join(settings))
        roughness = changes.pop("roughness", self.roughness)
        if "e" in changes or "k" in changes:
            if "facet" in changes or self.facet.newton_restitution is None:
                raise ParameterError(f"RoughLaw.replace: e and k set the restitution of Newton facets; this law has "
                                     f"{self.facet!r}: give facet=... instead")
            changes["facet"] = NewtonFacet(restitution_from(changes.pop("e", None), changes.pop("k", None)))
        if "rtol" not in changes and self.rtol == self.facet.quadrature_rtol(self.roughness.dim):
            del settings["rtol"]  # the default accuracy goes with the facet law and the roughness
        settings.update(changes)
        return RoughLaw(roughness, **settings)

    def __repr__(self) -> str:
        # cached for the settings it was made of: a warning of every impact in a loop names the law
        key = (self.spec, self.method, self.repeat)
        cached = self.__dict__.get("_repr")
        if cached is not None and cached[0] == key:
            return str(cached[1])
        text = self._describe()
        self._repr = (key, text)
        return text

    def _describe(self) -> str:
        extra = "" if self.flux == "physical" else f", flux={self.flux!r}"
        if self.method is not None:
            extra += f", method={self.method.name!r}"
        if self.method is not None and self.method.name == "monte-carlo":
            extra += f", samples={self.samples}"
        elif self.nodes is not None:
            extra += f", nodes={self.nodes}"
        if self.repeat:
            extra += ", repeat=True"
        if self.facet.newton_restitution is None:
            return f"RoughLaw({self.roughness!r}, facet={self.facet!r}{extra})"
        return f"RoughLaw({self.roughness!r}, e={self.e:g}{extra})"

    @property
    def dim(self) -> int | None:
        return self.roughness.dim

    def impulses(self, metric: ContactMetric, U: NDArray[np.float64], R: NDArray[np.float64]) -> ContactImpulses:
        """:meth:`ImpactLaw.impulses`; for a speed-dependent facet law the averaging gets the physical speeds.

        :meth:`ImpactLaw.impulses` scales every row to unit speed (property 1°) before
        :meth:`contact_impulses`. A facet law that is not homogeneous (``facet.homogeneous``
        False) needs the speed: the same pipeline then runs through a per-call view of this law
        that carries the row speeds |U| and multiplies them back in before averaging.
        """
        if self.facet.homogeneous:
            return super().impulses(metric, U, R)
        with np.errstate(divide="ignore", invalid="ignore"):
            big = np.abs(U).max(axis=1)
            speed = big * np.linalg.norm(U / big[:, None], axis=1)  # as ImpactLaw.impulses computes it
        return _AtSpeeds(self, speed).impulses(metric, U, R)

    def outcomes(self, A: ArrayLike, J: ArrayLike, v: ArrayLike, frame: ArrayLike) -> ImpactOutcomes:
        """The impact of :meth:`apply` as a random variable over the microrelief, (2.6)–(2.7): its mean
        (:meth:`apply` itself), the facets met with their flux weights and each facet's impact, samples
        and spread (:class:`~mbimpact.ImpactOutcomes`, :mod:`mbimpact.laws.outcomes`). Arguments and
        errors as :meth:`apply`; a :class:`ParameterError` with ``repeat=True``."""
        from .outcomes import rough_outcomes  # deferred: it builds on this module

        return rough_outcomes(self, A, J, v, frame)

    def outcomes_batch(self, A: ArrayLike, J: ArrayLike, V: ArrayLike, frame: ArrayLike
                       ) -> tuple[ImpactOutcomes, ...]:
        """:meth:`outcomes` of every row of ``V`` (B, n) at one configuration, in row order."""
        from .outcomes import rough_outcomes_batch

        return rough_outcomes_batch(self, A, J, V, frame)

    def compiled_impact(self) -> CompiledImpact | None:
        """One velocity on a :class:`~mbimpact.Cone` by ``"auto"``: the whole impact in one compiled call
        (:func:`mbimpact.laws.compiled_cone.cone_impact`), running the compiled steps of the rules of
        ``"auto"`` (:meth:`mbimpact.averaging.Averaging.cone_step`) in their order. None where a rule that
        ``"auto"`` may run for one velocity has no compiled step, for another measure or method, repeated
        micro-impacts, facets other than Newton's, a fixed node count, or a subclass (which may change any
        step).

        Made again whenever what it was made of changes (the spec, ``method``, ``repeat``, the rules'
        thresholds). Its node tables hold the first three levels only (32, 64 and 128 nodes for a cone;
        16 … 128 for the pole rule): a velocity that needs more is declined by the compiled call and goes
        on with every level in Python, so that a law never builds tables up to ``max_nodes`` for the few
        impacts that need them."""
        key = (self.spec, self.method, self.repeat, Graded.peaked, Ring.min_rows)
        cached = self.__dict__.get("_cone")
        if cached is not None and cached[0] == key:
            return cached[1]
        compiled = None
        spec = self.spec
        if (type(self) is RoughLaw and self.method is None and not self.repeat and type(spec.roughness) is Cone
                and spec.roughness.alpha > 0.0 and spec.nodes is None and not general_facets(spec)):
            compiled = cone_impact(spec, self._auto_methods())
        self._cone = (key, compiled)
        return compiled

    @property
    def homogeneous(self) -> bool:
        """Whether the facet law is homogeneous (a speed-dependent one gets the physical speeds:
        :meth:`impulses`)."""
        return self.facet.homogeneous

    def contact_impulses(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        # contact_impulses_at(W, U, None) without its layers: a single impact's hot path
        out = self.average_to(self.spec, W, U)[0]
        return repeated(self, W, U, out) if self.repeat else out

    def contact_impulses_at(self, W: NDArray[np.float64], U: NDArray[np.float64],
                            speed: NDArray[np.float64] | None) -> ContactImpulses:
        """:meth:`contact_impulses` for unit velocities ``U`` (B, d) whose physical speeds are ``speed`` (B,).

        ``speed`` matters only for a speed-dependent facet law; None takes ``U`` as physical. The
        impulses returned are those of the unit velocities (divided by ``speed``), like every law's.
        """
        if speed is None or self.facet.homogeneous:
            out = self.average(W, U)
            speed = None
        else:
            out = self.average(W, U * speed[:, None])
            out = ContactImpulses(out.P / speed[:, None], out.error, out.nodes, out.method)
        if not self.repeat:
            return out
        return repeated(self, W, U, out, speed)

    def separation_advice(self) -> str:
        if self.repeat:  # the repetition stopped first: its AccuracyWarning says at which budget
            return "repeat=True stopped before the contact separated (see the AccuracyWarning)"
        return "further micro-impacts follow: use repeat=True to apply them"

    def average(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        """One application of (2.8) to local-frame velocities U (B, d) — unit ones, or physical ones for
        a speed-dependent facet law — by the law's averaging method (or the first of
        :data:`mbimpact.averaging.AUTO_ORDER` that accepts). Facet laws other than Newton's label
        ``method`` with their name (``"adaptive[coulomb]"``)."""
        return self.average_to(self.spec, W, U)[0]

    def average_to(self, spec: AveragingSpec, W: NDArray[np.float64], U: NDArray[np.float64]
                   ) -> tuple[ContactImpulses, Averaging]:
        """:meth:`average` to the accuracy of ``spec`` (this law's, or that of coarse repeated micro-impacts:
        :func:`mbimpact.laws.repeat.coarse_spec`), and the rule that ran."""
        general = general_facets(spec)
        if self.method is not None:
            out = self.method.average(spec, W, U)
            if out is None:
                raise ParameterError(f"{self!r}: {self.method.reason(spec)}")
            return (_labelled(out, self.facet) if general else out), self.method
        for method in self._auto_methods():
            if method.worthwhile(spec, W, U):
                out = method.average(spec, W, U)
                if out is not None:
                    return (_labelled(out, self.facet) if general else out), method
        raise AssertionError(f"no averaging method accepted {self!r}")  # pragma: no cover — adaptive always does

    def _auto_methods(self) -> tuple[Averaging, ...]:
        """The methods of :data:`~mbimpact.averaging.AUTO_ORDER` that support this law's measure and
        facet law, in order: they depend on the spec alone, so they are sorted out once per spec."""
        cached = getattr(self, "_auto", None)
        if cached is not None and cached[0] is self.spec:
            return cached[1]
        spec = self.spec
        general = general_facets(spec)
        methods = tuple(m for m in (_INSTANCES[name] for name in AUTO_ORDER)
                        if (not general or m.any_facet) and m.supports(spec))
        self._auto = (spec, methods)
        return methods


class _AtSpeeds(WrappedLaw):
    """A rough law with a speed-dependent facet law at given row speeds: the pipeline of
    :meth:`ImpactLaw.impulses` with :meth:`RoughLaw.contact_impulses_at` as its core."""

    def __init__(self, law: RoughLaw, speed: NDArray[np.float64]) -> None:
        super().__init__(law)
        self.rough, self.speed = law, speed

    def contact_impulses(self, W: NDArray[np.float64], U: NDArray[np.float64]) -> ContactImpulses:
        return self.rough.contact_impulses_at(W, U, self.speed)


def _facet_law(e: object, k: float | None, facet: object) -> FacetLaw:
    """The facet law of ``RoughLaw(roughness, e | k | facet)``."""
    if isinstance(e, FacetLaw):
        if facet is not None:
            raise ParameterError("give the facet law once: RoughLaw(roughness, facet=...) or "
                                 "RoughLaw(roughness, facet)")
        e, facet = None, e
    if facet is None:
        return NewtonFacet(restitution_from(e, k))  # type: ignore[arg-type]
    if not isinstance(facet, FacetLaw):
        raise ParameterError(f"facet must be a facet law (NewtonFacet, CoulombFacet, CompliantFacet, "
                             f"HuntCrossleyFacet, ...), got {facet!r}")
    if e is not None or k is not None:
        raise ParameterError(f"give either e/k (Newton facets) or facet, not both; {facet!r} has its own restitution")
    return facet


def _labelled(out: ContactImpulses, facet: FacetLaw) -> ContactImpulses:
    """The result of an average of facets other than Newton's: ``method`` names both, "adaptive[coulomb]"
    (:func:`mbimpact.facets.method_label`)."""
    return ContactImpulses(out.P, out.error, out.nodes, method_label(out.method, facet))


# one stateless instance of each method, for "auto"
_INSTANCES: dict[str, Averaging] = {name: cls() for name, cls in METHODS.items()}


def _method(method: object, spec: AveragingSpec) -> Averaging | None:
    """The averaging method a user asked for (None: auto), checked against the measure and the facet law."""
    if isinstance(method, str):
        if method == "auto":
            return None
        if method not in METHODS:
            raise ParameterError(f"unknown averaging method {method!r}; valid: 'auto', "
                                 + ", ".join(repr(n) for n in METHODS))
        chosen: Averaging = _INSTANCES[method]
    elif isinstance(method, type) and issubclass(method, Averaging):
        chosen = method()
    elif isinstance(method, Averaging):
        chosen = method
    else:
        raise ParameterError(f"method must be 'auto', a name of mbimpact.averaging.METHODS or an Averaging, "
                             f"got {method!r}")
    if not chosen.supports(spec):
        usable = [n for n, m in _INSTANCES.items() if m.supports(spec)]
        raise ParameterError(f"the '{chosen.name}' averaging cannot average {spec.roughness!r}; "
                             f"methods for this measure: {', '.join(usable)}")
    if general_facets(spec) and not chosen.any_facet:
        usable = [n for n, m in _INSTANCES.items() if m.any_facet and m.supports(spec)]
        raise ParameterError(f"the '{chosen.name}' averaging integrates Newton facets in closed form and cannot "
                             f"average {spec.facet!r}; methods for this facet law and measure: {', '.join(usable)}")
    return chosen

"""Fuzzing every public constructor and function with bad inputs: a named error or a finite answer.

Each example takes one public entry point with a valid set of arguments (:data:`TARGETS`), replaces
one argument by a bad value — the wrong type (None, a string, a dict, an object), a bad shape
(a row or a column dropped, an axis added, a ragged list), NaN, ±inf, a complex array, a number
near the ends of the float range, a count of 10⁹ — and calls it under a time limit. Asserted:

* the call returns within :data:`LIMIT` (a hang fails the test);
* it raises an :class:`mbimpact.ImpactError` (a named error) and nothing else: no ``TypeError``,
  ``AttributeError``, ``IndexError``, ``ZeroDivisionError``, scipy or Pinocchio error, and no
  numpy ``RuntimeWarning`` (turned into errors here);
* or it returns, and then every velocity and impulse it returns is finite, and a law's impact
  creates no energy beyond the rounding bound of :func:`tests.helpers.energy_bound`.

A value that happens to be valid (a list instead of an array, 0 for a restitution) must simply work.
The default run takes a small derandomised sample; ``pytest -m slow`` runs 10⁴ examples.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mbimpact as mbi
from tests.helpers import energy_bound, mechanism, time_limit

LIMIT = 20.0  # seconds per call

# ---------------------------------------------------------------- valid arguments

A3 = np.array([[2.0, 0.3, 0.1], [0.3, 1.0, 0.2], [0.1, 0.2, 1.5]])
J3 = np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.3], [0.1, 0.0, 1.0]])
V3 = np.array([0.3, -0.2, -1.0])
N3 = np.array([0.0, 0.0, 1.0])
A2, J2, V2, N2 = A3[:2, :2].copy(), np.eye(2), np.array([0.3, -1.0]), np.array([0.0, 1.0])
TILT = 0.3
FACET_NORMALS = np.array([[0.0, 0.0, 1.0], [math.sin(TILT), 0.0, math.cos(TILT)],
                          [0.0, -math.sin(TILT), math.cos(TILT)]])
UR5_Q = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])


def ur5() -> mbi.Mechanism:
    return mechanism("ur5")


def ur5_v(u: tuple[float, float, float] = (0.3, 0.0, -1.0)) -> np.ndarray:
    """A UR5 velocity whose tool0 moves with u (approaching the table z = const)."""
    return np.linalg.lstsq(ur5().point_jacobian(UR5_Q, "tool0"), np.array(u), rcond=None)[0]


def apply3(rough: mbi.Roughness) -> mbi.ImpactResult:
    return mbi.RoughLaw(rough, 0.5).apply(A3, J3, V3, N3)


def apply2(rough: mbi.Roughness) -> mbi.ImpactResult:
    return mbi.RoughLaw(rough, 0.5).apply(A2, J2, V2, N2)


def bad_pdf_nan(a: np.ndarray) -> np.ndarray:
    return np.full_like(a, math.nan)


def bad_pdf_negative(a: np.ndarray) -> np.ndarray:
    return -np.ones_like(a)


def bad_pdf_short(a: np.ndarray) -> np.ndarray:
    return np.ones_like(a)[:-1]


def bad_pdf_complex(a: np.ndarray) -> np.ndarray:
    return np.ones_like(a) * (1 + 1j)


def bad_pdf_string(a: np.ndarray) -> str:
    return "x"


def bad_pdf_zero(a: np.ndarray) -> np.ndarray:
    return np.zeros_like(a)


def bad_pdf_huge(a: np.ndarray) -> np.ndarray:
    return np.full_like(a, 1e308)


@dataclass(frozen=True)
class Target:
    """A public entry point: ``call(**kwargs)`` with valid ``kwargs``; ``extra`` bad values per argument."""

    name: str
    call: Callable[..., Any]
    kwargs: dict[str, Any]
    extra: dict[str, list[Any]] = field(default_factory=dict)
    fixed: tuple[str, ...] = ()  # arguments not fuzzed (the object a method is called on)
    finite: bool = True  # whether every float the call returns must be finite

    def __repr__(self) -> str:
        return self.name


def _law_apply(law: Any, A: Any, J: Any, v: Any, frame: Any) -> Any:
    return law.apply(A, J, v, frame)


def _law_apply_batch(law: Any, A: Any, J: Any, V: Any, frame: Any) -> Any:
    return law.apply_batch(A, J, V, frame)


MECH = ("mech",)  # the mechanism a method is called on


def _mech_method(method: str) -> Callable[..., Any]:
    def call(mech: Any, **kw: Any) -> Any:
        return getattr(mech, method)(**kw)

    return call


LAWS = [mbi.NewtonLaw(0.5), mbi.RoughLaw(mbi.Cone(0.3), 0.5), mbi.CoulombLaw(0.5, 0.3)]


TARGETS: list[Target] = [
    Target("NewtonLaw", lambda **kw: mbi.NewtonLaw(**kw).apply(A3, J3, V3, N3), {"e": 0.5}),
    Target("NewtonLaw(k)", lambda **kw: mbi.NewtonLaw(**kw).apply(A3, J3, V3, N3), {"k": 0.3}),
    Target("RoughLaw", lambda **kw: mbi.RoughLaw(**kw).apply(A3, J3, V3, N3),
           {"roughness": mbi.Cone(0.3), "e": 0.5, "flux": "physical", "method": "auto", "rtol": 1e-8, "nodes": None,
            "max_nodes": 64, "samples": 1000, "seed": 0, "repeat": False},
           {"method": ["foo", "ring", "tilt-table", "monte-carlo", "exact"], "flux": ["area", "configuration"]}),
    Target("RoughLaw(facet)", lambda **kw: mbi.RoughLaw(mbi.Cone(0.3), **kw).apply(A3, J3, V3, N3),
           {"facet": mbi.CoulombFacet(0.5, 0.3)}, {"facet": [mbi.NewtonFacet(0.5), mbi.HuntCrossleyFacet(0.2)]}),
    Target("CoulombLaw", lambda **kw: mbi.CoulombLaw(**kw).apply(A3, J3, V3, N3),
           {"e": 0.5, "mu": 0.3, "restitution": "energetic", "rtol": 1e-10},
           {"restitution": ["newton", "poisson", "stronge"]}),
    Target("Cone", lambda **kw: apply3(mbi.Cone(**kw)), {"alpha": TILT}),
    Target("Sawtooth", lambda **kw: apply2(mbi.Sawtooth(**kw)), {"alpha": TILT}),
    Target("Facets", lambda **kw: apply3(mbi.Facets(**kw)),
           {"normals": FACET_NORMALS, "weights": np.array([1.0, 2.0, 3.0])}),
    Target("IsotropicSlopes", lambda **kw: apply3(mbi.IsotropicSlopes(**kw)),
           {"pdf": np.cos, "dim": 3, "support": (0.0, 0.8)},
           {"pdf": [bad_pdf_nan, bad_pdf_negative, bad_pdf_short, bad_pdf_complex, bad_pdf_string, bad_pdf_zero,
                    bad_pdf_huge]}),
    Target("GaussianSlopes", lambda **kw: apply3(mbi.GaussianSlopes(**kw)), {"sigma": 0.3, "dim": 3}),
    Target("GaussianSlopes(2)", lambda **kw: apply2(mbi.GaussianSlopes(**kw)), {"sigma": 0.3, "dim": 2}),
    Target("Profile", lambda **kw: apply2(mbi.Profile(**kw)),
           {"heights": np.array([0.0, 0.02, -0.01, 0.03, 0.0]), "dx": 0.1, "shadowing": True, "periodic": False}),
    Target("HeightMap", lambda **kw: apply3(mbi.HeightMap(**kw)),
           {"z": np.array([[0.0, 0.01, 0.0], [0.02, -0.01, 0.01], [0.0, 0.01, 0.03]]), "dx": 0.1, "dy": 0.1,
            "shadowing": False}),
    Target("local_basis", mbi.local_basis, {"frame": N3, "d": 3}),
    Target("e_from_k", mbi.e_from_k, {"k": 0.3}),
    Target("k_from_e", mbi.k_from_e, {"e": 0.5}),
    Target("impact_duration", mbi.impact_duration, {"M": 1e3, "k": 0.3}, finite=False),  # k = 1: never separates
    Target("CoulombFacet", lambda **kw: mbi.RoughLaw(mbi.Cone(0.3), facet=mbi.CoulombFacet(**kw)).apply(A3, J3, V3, N3),
           {"e": 0.5, "mu": 0.3, "restitution": "energetic", "steps": 50}),
    Target("CompliantFacet", lambda **kw: mbi.CompliantFacet(**kw), {"e": 0.5, "mu": 0.3, "stiffness_ratio": 0.8,
                                                                     "resolution": 16}),
    Target("HuntCrossleyFacet", lambda **kw: mbi.RoughLaw(mbi.Cone(0.3), facet=mbi.HuntCrossleyFacet(**kw)).apply(
        A3, J3, V3, N3), {"alpha": 0.2}),
    Target("facet_law", lambda **kw: mbi.facet_law(**kw), {"name": "coulomb", "e": 0.5, "mu": 0.3}),
    Target("apply", _law_apply, {"law": LAWS[1], "A": A3, "J": J3, "v": V3, "frame": N3}, {"law": LAWS}, ("law",)),
    Target("apply(2-D)", _law_apply, {"law": mbi.RoughLaw(mbi.Sawtooth(0.3), 0.5), "A": A2, "J": J2, "v": V2,
                                      "frame": N2}, fixed=("law",)),
    Target("apply_batch", _law_apply_batch,
           {"law": LAWS[0], "A": A3, "J": J3, "V": np.stack([V3, 2 * V3]), "frame": N3},
           {"law": LAWS}, ("law",)),
    Target("impact", mbi.impact, {"mech": "ur5", "q": UR5_Q, "v": "ur5_v", "contact": mbi.PointContact("tool0"),
                                  "law": LAWS[1]}, {"law": LAWS}),
    Target("impact_batch", mbi.impact_batch, {"mech": "ur5", "Q": np.stack([UR5_Q, UR5_Q]), "V": "ur5_V",
                                              "contact": mbi.PointContact("tool0"), "law": LAWS[0]}),
    Target("PointContact", lambda **kw: mbi.impact(ur5(), UR5_Q, ur5_v(), mbi.PointContact(**kw), mbi.NewtonLaw(0.5)),
           {"frame": "tool0", "normal": N3, "point": np.array([0.0, 0.0, 0.05]), "tangent": np.array([1.0, 0.0, 0.0])},
           {"frame": ["tool", "TOOL0", "universe", "root_joint"]}),
    Target("resolve", mbi.resolve, {"mech": "ur5", "q": UR5_Q, "v": "ur5_v", "contacts": mbi.PointContact("tool0"),
                                    "facets": np.array([math.sin(0.2), 0.0, math.cos(0.2)]), "M": 1e3, "e": 0.5,
                                    "dynamics": "impact", "gravity": True, "rtol": 1e-8, "method": "LSODA",
                                    "t_max": 0.5, "surface_points": None, "max_evaluations": 5000},
           {"dynamics": ["full"], "method": ["Radau", "BDF", "RK45"]}),
    Target("resolve_rough", mbi.resolve_rough, {"mech": "ur5", "q": UR5_Q, "v": "ur5_v",
                                                "contact": mbi.PointContact("tool0"), "roughness": mbi.Cone(0.2),
                                                "samples": 3, "seed": 0, "flux": "physical", "dynamics": "impact"}),
    Target("compare_simultaneous", mbi.compare_simultaneous,
           {"mech": "ur5", "q": UR5_Q, "v": "ur5_v", "contacts": [mbi.PointContact("tool0")], "law": LAWS[0],
            "tol": 1e-2, "max_rounds": 100, "dynamics": "impact"}),
    Target("Mechanism", mbi.Mechanism, {"model": "ur5.model"}),
    Target("from_robot", mbi.Mechanism.from_robot, {"name": "ur5", "floating": False},
           {"name": ["UR5", "ur55", "../ur5", "talos_full "]}),
    Target("from_model", mbi.Mechanism.from_model, {"name": "point_mass_2d", "floating": None},
           {"name": ["box.urdf", "models/box", "point_mass"]}),
    Target("from_urdf", mbi.Mechanism.from_urdf,
           {"path": str(mbi.models_dir() / "point_mass_2d.urdf"), "floating": False},
           {"path": ["/", "/dev/null", "/etc/hostname", "no/such.urdf", "models"]}),
    Target("point_jacobian", _mech_method("point_jacobian"), {"mech": "ur5", "q": UR5_Q, "frame": "tool0",
                                                              "point": np.array([0.0, 0.0, 0.1])}, fixed=MECH),
    Target("frame_position", _mech_method("frame_position"), {"mech": "ur5", "q": UR5_Q, "frame": "tool0",
                                                              "point": np.array([0.0, 0.0, 0.1])}, fixed=MECH),
    Target("mass_matrix", _mech_method("mass_matrix"), {"mech": "ur5", "q": UR5_Q}, fixed=MECH),
    Target("inverse_mass_matrix", _mech_method("inverse_mass_matrix"), {"mech": "ur5", "q": UR5_Q}, fixed=MECH),
    Target("check_state", _mech_method("check_state"), {"mech": "ur5", "q": UR5_Q, "v": np.ones(6)}, fixed=MECH),
    Target("frame_id", _mech_method("frame_id"), {"mech": "ur5", "frame": "tool0"}, fixed=MECH),
    Target("ContactMetric", mbi.ContactMetric.from_arrays, {"A": A3, "J": J3}),
    Target("Surface", mbi.Surface, {"kind": "paraboloid", "normal": N3, "origin": np.zeros(3), "rho": 2.0,
                                    "amplitude": 0.01, "frequency": 5.0, "phase": 0.3}),
    Target("SceneContact", mbi.SceneContact, {"frame": "tool0", "law": LAWS[0], "surface": mbi.Surface(),
                                              "point": np.zeros(3), "friction": 0.3, "tangent": np.array([1.0, 0, 0]),
                                              "stiffness": 1e5}),
    Target("PD", mbi.PD, {"kp": 10.0, "kd": 1.0, "q_ref": UR5_Q}),
    Target("HalfSpace", mbi.HalfSpace, {"normal": N3, "offset": 0.1, "name": "floor"}),
    Target("Box", mbi.Box, {"size": np.array([1.0, 2.0, 0.5]), "position": np.zeros(3), "rotation": np.eye(3),
                            "name": "box"}),
    Target("Sphere", mbi.Sphere, {"radius": 0.2, "position": np.zeros(3), "rotation": np.eye(3), "name": "ball"}),
    Target("Ball", mbi.Ball, {"radius": 0.02, "mass": 0.05, "inertia": 8e-6}),
    Target("robot_urdf", mbi.robot_urdf, {"name": "ur5"}),
    Target("model_path", mbi.model_path, {"name": "box"}),
    Target("load_scene", mbi.load_scene, {"source": "ball_drop"}, {"source": ["/", "/dev/null", "ball_drop.toml",
                                                                              "models/scenes"]}),
    Target("ImpactTable", mbi.ImpactTable, {"theta_deg": np.array([0.0, 30.0, 60.0]),
                                            "columns": {"kappa": np.array([0.8, 0.7, 0.6])}},
           {"columns": [None, [("kappa", [0.8, 0.7, 0.6])], "kappa", {"kappa": np.array([0.8, 0.7, 0.6j])}]}),
]
BY_NAME = {t.name: t for t in TARGETS}


def resolve_kwargs(kwargs: dict[str, Any]) -> dict[str, Any]:
    """The placeholders of :data:`TARGETS` (objects built on use, once per session)."""
    out = dict(kwargs)
    for key, val in kwargs.items():
        if isinstance(val, str) and val == "ur5" and key == "mech":
            out[key] = ur5()
        elif isinstance(val, str) and val == "ur5_v":
            out[key] = ur5_v()
        elif isinstance(val, str) and val == "ur5_V":
            out[key] = np.stack([ur5_v(), ur5_v((0.0, 0.2, -0.5))])
        elif isinstance(val, str) and val == "ur5.model":
            out[key] = ur5().model
    return out


# ---------------------------------------------------------------- bad values

class Opaque:
    """An object of no numeric meaning."""

    def __repr__(self) -> str:
        return "Opaque()"


SPECIAL: list[Any] = [
    None, "x", "", "1.5", b"1", True, False, math.nan, math.inf, -math.inf, -1, -0.5, 0, 0.0, -0.0, 5e-324, 1e-300,
    1e-160, 1e160, 1e300, 1.7e308, 2**63, 10**30, -(10**30), 10**9, 1j, 1 + 1j, [], [[]], [1.0], [1.0, 2.0],
    [[1.0, 2.0], [3.0]], {}, {"a": 1}, (), Opaque(), np.float64(math.nan), np.float32(0.5), np.int64(3),
    np.array(0.5), np.array([]), np.array(["a", "b"]), np.array([1 + 0j]), np.array([math.nan]), np.zeros((0, 3)),
    np.ones((2, 2, 2)), np.array([True]), slice(1), print,
]


def _entries(x: np.ndarray) -> list[Any]:
    return [math.nan, math.inf, -math.inf, 1.7e308, -1.7e308, 5e-324, 1e300, -1e-300]


@st.composite
def mutated_array(draw: st.DrawFn, x: np.ndarray) -> Any:
    """A bad (or oddly typed but valid) version of a valid array ``x``."""
    x = np.asarray(x, dtype=float)
    kind = draw(st.sampled_from(["entry", "scale", "complex", "real-complex", "drop-row", "drop-col", "add-axis",
                                 "ravel", "transpose", "list", "ragged", "object", "string", "bool", "float32", "int",
                                 "empty", "special"]))
    if kind == "entry" and x.size:
        y = x.copy()
        y.flat[draw(st.integers(0, x.size - 1))] = draw(st.sampled_from(_entries(x)))
        return y
    if kind == "scale":
        with np.errstate(over="ignore", under="ignore"):
            return x * np.power(10.0, draw(st.integers(-330, 330)))
    if kind == "complex":
        return x * (1.0 + 1e-3j)
    if kind == "real-complex":
        return x.astype(complex)
    if kind == "drop-row" and x.ndim >= 1 and len(x):
        return x[:-1]
    if kind == "drop-col" and x.ndim == 2:
        return x[:, :-1]
    if kind == "add-axis":
        return x[None]
    if kind == "ravel":
        return x.ravel()
    if kind == "transpose":
        return x.T
    if kind == "list":
        return x.tolist()
    if kind == "ragged" and x.ndim >= 1 and len(x) > 1:
        rows = x.tolist()
        rows[-1] = [rows[-1]] if x.ndim == 1 else rows[-1][:-1]
        return rows
    if kind == "object":
        return x.astype(object)
    if kind == "string":
        return x.astype(str)
    if kind == "bool":
        return x.astype(bool)
    if kind == "float32":
        return x.astype(np.float32)
    if kind == "int":
        return x.astype(np.int64)
    if kind == "empty":
        return np.zeros((0,) + x.shape[1:])
    return draw(st.sampled_from(SPECIAL))


@st.composite
def bad_calls(draw: st.DrawFn, targets: list[Target]) -> tuple[Target, str, Any]:
    """A target, the name of one of its arguments, and a bad value for it."""
    target = draw(st.sampled_from(targets))
    key = draw(st.sampled_from(sorted(set(target.kwargs) - set(target.fixed))))
    valid = resolve_kwargs({key: target.kwargs[key]})[key]
    choices = [st.sampled_from(SPECIAL)]
    if isinstance(valid, np.ndarray):
        choices.append(mutated_array(valid))
    elif isinstance(valid, (float, int)) and not isinstance(valid, bool):
        choices.append(st.floats(allow_nan=True, allow_infinity=True))
        choices.append(st.integers(-(2**70), 2**70))
    elif isinstance(valid, tuple):
        choices.append(st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4).map(tuple))
    elif isinstance(valid, str):
        choices.append(st.text(max_size=12))
    if key in target.extra:
        choices.append(st.sampled_from(target.extra[key]))
    bad = draw(st.one_of(*choices))
    return target, key, bad


# ---------------------------------------------------------------- the check

def outputs(out: Any) -> list[np.ndarray]:
    """The float arrays a result carries (velocities, impulses, matrices)."""
    if isinstance(out, (mbi.ImpactResult, mbi.BatchResult)):
        names = ("v_plus", "P", "u_plus") if isinstance(out, mbi.ImpactResult) else ("V_plus", "P", "U_plus")
        return [np.asarray(getattr(out, n)) for n in names]
    if isinstance(out, (mbi.Resolved, mbi.RoughResolved)):
        return [out.v_plus]
    if isinstance(out, mbi.SimultaneousReport):
        return [out.resolved.v_plus, out.sequential]
    if isinstance(out, np.ndarray) and out.dtype.kind == "f":
        return [out]
    if isinstance(out, tuple):
        return [x for x in out if isinstance(x, np.ndarray) and x.dtype.kind == "f"]
    if isinstance(out, float):
        return [np.array(out)]
    return []


def call_checked(target: Target, kwargs: dict[str, Any]) -> Any:
    """Call ``target`` under the time limit: an ImpactError is fine; any other exception, any warning
    outside mbimpact's tree (numpy's RuntimeWarning, scipy's IntegrationWarning, LSODA's UserWarning),
    a non-finite output or created energy fails."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no foreign warning leaks out
        warnings.simplefilter("ignore", mbi.ImpactWarning)  # honest warnings are allowed
        try:
            with time_limit(LIMIT):
                out = target.call(**resolve_kwargs(kwargs))
        except mbi.ImpactError:
            return None
    for x in outputs(out) if target.finite else []:
        assert np.all(np.isfinite(x)), (target, x)
    if isinstance(out, mbi.ImpactResult) and np.isfinite(out.energy_loss) and not (
            isinstance(out.law, mbi.CoulombLaw) and out.law.restitution == "newton"):
        W = out.J @ np.linalg.solve(out.A, out.J.T)
        lam = np.linalg.eigvalsh(0.5 * (W + W.T))
        cond = float(lam[-1] / max(lam[0], lam[-1] * 1e-16))
        assert out.energy_loss >= -energy_bound(out, cond)[0], (target, out.energy_loss)
    return out


# ---------------------------------------------------------------- tests

@pytest.mark.parametrize("target", TARGETS, ids=repr)
def test_every_target_works_with_its_valid_arguments(target):
    """The fuzz starts from valid calls: each must succeed, so that a bad value is what fails."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", mbi.ImpactWarning)
        with time_limit(LIMIT):
            out = target.call(**resolve_kwargs(target.kwargs))
    for x in outputs(out):
        assert np.all(np.isfinite(x))


@settings(max_examples=500, deadline=None)
@given(bad_calls(TARGETS))
def test_bad_inputs_raise_named_errors(case):
    target, key, bad = case
    call_checked(target, {**target.kwargs, key: bad})


# ---------------------------------------------------------------- nightly size: pytest -m slow

@pytest.mark.slow
@settings(max_examples=10_000, deadline=None)
@given(bad_calls(TARGETS))
def test_bad_inputs_raise_named_errors_nightly(case):
    test_bad_inputs_raise_named_errors.hypothesis.inner_test(case)

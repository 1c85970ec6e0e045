"""Bench of the impact laws: accuracy against time, cost against Pinocchio, batches, the compliant route.

1. ``accuracy`` — error against a converged reference vs wall time per impact for each way of
   averaging (2.8) over a cone of facets: the corrected closed form (2.10) where it exists, the
   exact-arc quadrature at several node counts, uniform azimuth sampling (G* by indicator), and
   Monte Carlo; then Gaussian slopes at a near-singular posture (graded quadrature, the Laplace reduction
   and Monte Carlo).
2. ``overhead`` — per-call time of :func:`mbimpact.impact` divided by the time of the frame
   Jacobian plus ``pin.impulseDynamics`` at the same q, v; beside it the Pinocchio calls alone and
   the floor of validating q, v and building the result.
3. ``batch`` — impacts per second of :meth:`ImpactLaw.apply_batch` for robots of increasing size
   and for several node counts.
4. ``compliant`` — error of the impact resolved in time (:func:`mbimpact.resolve`) against the
   closed facet law, and its cost, for M = 1e2 … 1e6 and several integrator tolerances.
"""

from __future__ import annotations

import functools
import math
import time
import warnings
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from ...errors import NoSeparationWarning
from ...facets import CompliantFacet, CoulombFacet, HuntCrossleyFacet
from ...laws import ImpactLaw, NewtonLaw, RoughLaw
from ...mechanism import Mechanism, PointContact, joint_velocity
from ...pipeline import impact
from ...results import ImpactResult
from ...roughness import Cone, Facets, GaussianSlopes
from ..progress import Progress
from .common import BenchRow, moving_frame, per_call, per_call_together

__all__ = ["accuracy", "overhead", "batch", "compliant", "OVERHEAD_ROBOTS", "BATCH_ROBOTS"]

ALPHA = 0.4  # cone tilt: G* is cut for β > π/2 − α ≈ 67°
E = 0.5


def closed_form_cone(alpha: float, e: float, v: np.ndarray) -> np.ndarray:
    """Corrected (2.10) for a point mass and a cone of tilt α (whole cone facing)."""
    vl, vn = v[:2], abs(v[2])
    ca, s2c = math.cos(alpha), math.sin(alpha) ** 2 * math.cos(alpha)
    return (1 + e) / ca * np.array([-vl[0] * s2c, -vl[1] * s2c, vn * ca**3 + (vl @ vl) / vn * s2c / 2])


def _uniform_facets(alpha: float, count: int) -> Facets:
    phi = 2 * math.pi * (np.arange(count) + 0.5) / count
    s, c = math.sin(alpha), math.cos(alpha)
    return Facets(np.column_stack([s * np.cos(phi), s * np.sin(phi), np.full(count, c)]))


def _measurer(rows: list[BenchRow], label: str, A: np.ndarray, J: np.ndarray, v: np.ndarray, ref: np.ndarray,
              min_time: float) -> Callable[..., None]:
    """``measure(method, param, law=None, fn=None)``: one accuracy row against ``ref``."""
    W = J @ np.linalg.solve(A, J.T)

    def measure(method: str, param: float, law: ImpactLaw | None, fn: Callable[[], np.ndarray] | None = None) -> None:
        call = fn if fn is not None else (lambda: law.apply(A, J, v, [0, 0, 1]).P)  # type: ignore[union-attr]
        P = call()
        err = float(np.linalg.norm(W @ (P - ref)) / np.linalg.norm(W @ ref))  # error of Δu = W P
        rows.append(BenchRow("accuracy", label, method, param, err, per_call(call, min_time)))

    return measure


def _incident(beta_deg: float) -> np.ndarray:
    beta = math.radians(beta_deg)
    return np.array([math.sin(beta) * math.cos(0.3), math.sin(beta) * math.sin(0.3), -math.cos(beta)])


def accuracy(quick: bool, min_time: float, progress: Progress) -> list[BenchRow]:
    rows: list[BenchRow] = []
    ur5 = Mechanism.from_robot("ur5")
    q = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
    J_ur5 = ur5.point_jacobian(q, "tool0")
    upright = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])  # elbow straight: W's eigenvalues span 1e7
    singular = (ur5.mass_matrix(upright), ur5.point_jacobian(upright, "tool0"))
    cases = {"point mass": (np.eye(3), np.eye(3)), "UR5 tool0": (ur5.mass_matrix(q), J_ur5),
             "UR5 near-singular": singular}
    betas = (0.0, 30.0, 60.0, 75.0, 85.0) if not quick else (30.0, 75.0)
    gl_nodes = (4, 8, 16, 32, 64)
    uniform = (16, 64, 256, 1024) if not quick else (16, 256)
    mc = (100, 1000, 10_000, 100_000) if not quick else (100, 10_000)
    for case, (A, J) in cases.items():
        for beta_deg in betas:
            u = _incident(beta_deg)
            v = joint_velocity(A, J, u) if case != "point mass" else u
            ref = RoughLaw(Cone(ALPHA), E, nodes=1024).apply(A, J, v, [0, 0, 1]).P
            label = f"{case}, beta={beta_deg:g}"
            measure = _measurer(rows, label, A, J, v, ref, min_time)
            if case == "point mass" and math.tan(beta_deg * math.pi / 180) * math.tan(ALPHA) < 1:
                measure("closed form (2.10)", 0, None, lambda: closed_form_cone(ALPHA, E, v))
            for n in gl_nodes:
                measure("exact-arc quadrature", n, RoughLaw(Cone(ALPHA), E, nodes=n))
            measure("adaptive (rtol=1e-12)", 0, RoughLaw(Cone(ALPHA), E))
            for n in uniform:
                measure("uniform sampling", n, RoughLaw(_uniform_facets(ALPHA, n), E))
            for n in mc:
                measure("Monte Carlo", n, RoughLaw(Cone(ALPHA), E, method="monte-carlo", samples=n, seed=1))
            progress.step(label)
    # a continuous measure at the hard posture: tilt and azimuth graded towards the peaks of 1/mᵀWm
    A, J = singular
    slopes = GaussianSlopes(0.3)
    for beta_deg in (30.0, 75.0) if not quick else (75.0,):
        v = joint_velocity(A, J, _incident(beta_deg))
        ref = RoughLaw(slopes, E, nodes=128).apply(A, J, v, [0, 0, 1]).P
        label = f"UR5 near-singular, GaussianSlopes(0.3), beta={beta_deg:g}"
        measure = _measurer(rows, label, A, J, v, ref, min_time)
        for n in (8, 16, 32) if quick else (8, 16, 32, 64):
            measure("graded tilt x azimuth", n, RoughLaw(slopes, E, nodes=n))
        # what "auto" runs (the τ-integral of the Laplace reduction), and the graded product rule it replaced
        measure("laplace (rtol=1e-12)", 0, RoughLaw(slopes, E, method="laplace"))
        measure("graded, compiled (rtol=1e-12)", 0, RoughLaw(slopes, E, method="graded"))
        for n in (1000, 100_000) if quick else (1000, 10_000, 100_000):
            measure("Monte Carlo", n, RoughLaw(slopes, E, method="monte-carlo", samples=n, seed=1))
        progress.step(label)
    return rows


OVERHEAD_ROBOTS = ("ur5", "panda", "solo12", "talos")


def overhead(robots: tuple[str, ...], min_time: float, progress: Progress) -> list[BenchRow]:
    rows: list[BenchRow] = []
    for name in robots:
        mech = Mechanism.from_robot(name)
        rng = np.random.default_rng(7)
        q = mech.random_configuration(rng)
        frame = moving_frame(mech, q)
        J = mech.point_jacobian(q, frame)
        v = -J[2] / max(float(np.linalg.norm(J[2])), 1e-12) + 0.1 * rng.normal(size=mech.nv)
        if J[2] @ v >= 0:
            v = -J[2]
        rows += _overhead_case(mech, name, q, frame, v, min_time, floors=True)
        if name == "ur5":  # the elbow straight: W's eigenvalues 1e7 apart (a near-singular arm)
            q = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])
            v = joint_velocity(mech.mass_matrix(q), mech.point_jacobian(q, "tool0"), [0.3, 0.1, -1.0])
            rows += _overhead_case(mech, "ur5, elbow straight (anisotropic W)", q, "tool0", v, min_time,
                                   floors=False)
        if name == "solo12":  # a foot on the ground: W's eigenvalues 30× apart, the cone's kernels peak
            q = mech.neutral()
            q[2] = 0.336
            v = np.zeros(mech.nv)
            v[[0, 2]] = 0.3, -1.0
            rows += _overhead_case(mech, "solo12, foot on the ground (anisotropic W)", q, "FL_FOOT", v, min_time,
                                   floors=False)
        progress.step(name)
    return rows


def _overhead_case(mech: Mechanism, case: str, q: np.ndarray, frame: str, v: np.ndarray, min_time: float,
                   floors: bool) -> list[BenchRow]:
    """The rows of :func:`overhead` for one state: the reference, the floors (``floors``) and the laws."""
    contact = PointContact(frame)
    fid = mech.frame_id(frame)
    J = mech.point_jacobian(q, frame)
    model, data = mech.model, mech.model.createData()

    def baseline() -> None:
        Jf = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        pin.impulseDynamics(model, data, q, v, Jf[2:3], E, 0.0)

    def pin_work() -> None:  # the Pinocchio calls mbi.impact makes for Newton's law, nothing else
        pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        pin.crba(model, data, q)
        pin.cholesky.decompose(model, data)

    reference = "Jacobian + pin.impulseDynamics"
    fns: dict[str, Callable[[], object]] = {reference: baseline}
    if floors:
        fns["Pinocchio calls inside impact(NewtonLaw) only"] = pin_work
        newton = NewtonLaw(E)
        A, size = mech.mass_matrix(q), 3 * mech.nv + 12

        def python_floor() -> None:  # what impact() pays around the physics: the checks and the result
            mech.check_state(q, v)
            ImpactResult.from_buffer(np.empty(size), A, J, newton)

        fns["validation + result object only (no physics)"] = python_floor
    for label, law in (("impact, NewtonLaw", NewtonLaw(E)), ("impact, RoughLaw(Cone)", RoughLaw(Cone(0.3), E)),
                       ("impact, RoughLaw(GaussianSlopes(0.3))", RoughLaw(GaussianSlopes(0.3), E))):
        fns[label] = functools.partial(impact, mech, q, v, contact, law)
    with warnings.catch_warnings():  # a foot on the ground keeps approaching (κ < 0): reported, not the point
        warnings.simplefilter("ignore", NoSeparationWarning)
        # timed in alternation: the ratios do not depend on which stretch of a busy machine each one met
        times = per_call_together(fns, min_time)
    return [BenchRow("overhead", case, label, mech.nv, 0.0, t, t / times[reference]) for label, t in times.items()]


BATCH_ROBOTS = ("finger_edu", "ur5", "panda", "solo12", "talos", "tiago_dual")


def batch(robots: tuple[str, ...], size: int, progress: Progress) -> list[BenchRow]:
    rows: list[BenchRow] = []
    laws: list[tuple[str, float, ImpactLaw]] = [
        ("NewtonLaw", 0, NewtonLaw(E)),
        ("RoughLaw(8 facets)", 8, RoughLaw(_uniform_facets(0.3, 8), E)),
        ("RoughLaw(Cone), nodes", 16, RoughLaw(Cone(0.3), E, nodes=16)),
        ("RoughLaw(Cone), nodes", 32, RoughLaw(Cone(0.3), E, nodes=32)),
        ("RoughLaw(Cone), nodes", 64, RoughLaw(Cone(0.3), E, nodes=64)),
        ("RoughLaw(Cone), adaptive", 0, RoughLaw(Cone(0.3), E)),
        # a continuous tilt density: "auto" takes the Laplace reduction until the rows seen at one W pay
        # for a table in the incidence; the table itself, built on its first call, then a lookup
        ("RoughLaw(GaussianSlopes(0.3)), auto", 0, RoughLaw(GaussianSlopes(0.3), E)),
        ("RoughLaw(GaussianSlopes(0.3)), tilt-table", 0, RoughLaw(GaussianSlopes(0.3), E, method="tilt-table")),
    ]
    for name in robots:
        mech = Mechanism.from_robot(name)
        rng = np.random.default_rng(11)
        q = mech.random_configuration(rng)
        frame = moving_frame(mech, q)
        J = mech.point_jacobian(q, frame)
        A = mech.mass_matrix(q)
        n0 = np.array([0.0, 0.0, 1.0])
        if np.linalg.norm(J[2]) < 1e-9:  # planar mechanism moving sideways: strike along its plane
            n0 = J @ rng.normal(size=mech.nv)
            n0 /= np.linalg.norm(n0)
        V = rng.normal(size=(size, mech.nv))
        V[V @ (J.T @ n0) > 0] *= -1
        V = V[V @ (J.T @ n0) < 0]
        for label, param, law in laws:
            passes = []
            for _ in range(2):  # the first pass also pays for page faults (and a table's construction)
                start = time.perf_counter()
                law.apply_batch(A, J, V, n0).V_plus  # read: a lazy batch forms it on access
                passes.append(time.perf_counter() - start)
            if isinstance(law, RoughLaw) and isinstance(law.roughness, GaussianSlopes):
                # the first call decides (or builds the table), the second reuses what it found
                first = ", first call (builds the table)" if law.method is not None else ", first call"
                for suffix, elapsed in ((first, passes[0]), (", second call", passes[1])):
                    rows.append(BenchRow("batch", f"{name} (n={mech.nv})", label + suffix, param, 0.0,
                                         elapsed / len(V), len(V) / elapsed))
                continue
            elapsed = min(passes)
            rows.append(BenchRow("batch", f"{name} (n={mech.nv})", label, param, 0.0, elapsed / len(V), len(V) / elapsed))
        # the other facet laws average a facet impact that is itself an integration (Coulomb: in
        # impulse space, compliant: in time) at every node: a few rows show their cost
        few = V[: max(10, min(len(V), size // 250))]
        for label, facet in (("coulomb", CoulombFacet(E, 0.3)), ("compliant", CompliantFacet(E, 0.3, 0.8)),
                             ("hunt-crossley", HuntCrossleyFacet(0.1))):
            law = RoughLaw(Cone(0.3), facet=facet)
            start = time.perf_counter()
            with warnings.catch_warnings():  # κ < 0 at steep random incidences is reported, not the point here
                warnings.simplefilter("ignore", NoSeparationWarning)
                law.apply_batch(A, J, few, n0)
            elapsed = time.perf_counter() - start
            rows.append(BenchRow("batch", f"{name} (n={mech.nv})", f"RoughLaw(Cone), {label} facets, adaptive", 0,
                                 0.0, elapsed / len(few), len(few) / elapsed))
        progress.step(name)
    rows += _anisotropic_first_call(size)
    return rows


def _anisotropic_first_call(size: int) -> list[BenchRow]:
    """The first apply_batch of GaussianSlopes(0.3) at an anisotropic W (eigenvalues 0.2, 40, 200, a random
    orientation; ``size`` rows, at most 20,000): a fresh measure each pass (no table built before), best of
    three passes."""
    rng = np.random.default_rng(3)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    W = Q @ np.diag([0.2, 40.0, 200.0]) @ Q.T
    J = np.linalg.cholesky(W)  # A = I: J A⁻¹ Jᵀ = W
    U = rng.normal(size=(min(size, 20_000), 3))
    U[:, 2] = -np.abs(U[:, 2]) - 0.1
    V = np.linalg.solve(J, U.T).T
    best = math.inf
    for _ in range(3):
        law = RoughLaw(GaussianSlopes(0.3), E)
        start = time.perf_counter()
        law.apply_batch(np.eye(3), J, V, [0.0, 0.0, 1.0]).V_plus
        best = min(best, time.perf_counter() - start)
    return [BenchRow("batch", "anisotropic W (eigenvalues 0.2, 40, 200)",
                     "RoughLaw(GaussianSlopes(0.3)), first call", 0, 0.0, best / len(V), len(V) / best)]


def compliant(quick: bool, min_time: float, progress: Progress) -> list[BenchRow]:
    """Resolved Kelvin–Voigt impact (full dynamics) against the closed facet law."""
    from ...compliant import resolve

    mech = Mechanism.from_robot("ur5")
    q = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
    contact = PointContact("tool0")
    facet = np.array([math.sin(0.3), 0.0, math.cos(0.3)])
    J = mech.point_jacobian(q, "tool0")
    v = joint_velocity(mech.mass_matrix(q), J, [0.3, 0.0, -1.0])
    frame = contact.basis() @ np.column_stack([[math.cos(0.3), 0, -math.sin(0.3)], [0, 1, 0], facet])
    law = NewtonLaw(E)
    closed = law.apply(mech.mass_matrix(q), J, v, frame).dv
    facet_contact = PointContact("tool0", normal=frame[:, 2])
    t_closed = per_call(lambda: impact(mech, q, v, facet_contact, law), min_time)
    V = np.tile(v, (10_000, 1))
    A = mech.mass_matrix(q)
    t_batch = per_call(lambda: law.apply_batch(A, J, V, frame).V_plus, min_time) / len(V)
    rows = [BenchRow("compliant", "UR5 tool0, one facet", "closed facet law (Newton), one call", 0, 0.0, t_closed,
                     t_closed / t_batch),
            BenchRow("compliant", "UR5 tool0, one facet", "closed facet law (Newton), per impact in a batch",
                     0, 0.0, t_batch, 1.0)]
    Ms = (1e2, 1e4, 1e6) if quick else (1e2, 1e3, 1e4, 1e5, 1e6)
    for tol in ((1e-6,) if quick else (1e-4, 1e-6, 1e-9)):
        for M in Ms:
            def run() -> np.ndarray:
                return resolve(mech, q, v, contact, facet, M=M, e=E, rtol=tol).dv

            err = float(np.linalg.norm(run() - closed) / np.linalg.norm(closed))
            t = per_call(run, min_time)
            rows.append(BenchRow("compliant", f"rtol={tol:g}", "resolve (full dynamics)", M, err, t, t / t_batch))
    progress.step("compliant")
    return rows



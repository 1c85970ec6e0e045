"""Bench of the everyday paths against their speed goals: batches across configurations, the
Coulomb law against Pinocchio's conic solvers, the package import, and the table of goals.

1. ``configurations`` — :func:`mbimpact.impact_batch` over distinct configurations of the UR5
   (one velocity each) against a loop of the frame Jacobian plus ``pin.impulseDynamics``; the rough
   cone and the Coulomb law also with their compiled calls on the calling thread alone.
2. ``coulomb`` — one plastic Coulomb impact of the UR5, sticking and sliding, by
   :class:`~mbimpact.CoulombLaw` against Pinocchio's PGS and ADMM solvers on the same q, v (each
   from q: Jacobian, Delassus matrix, solve), with the impulses' agreement; and the rate of
   :meth:`CoulombLaw.apply_batch`, and what the first calls of a process pay for the package's compiled
   kernels (:func:`mbimpact.compile_kernels`).
3. ``threads`` — batches at one UR5 configuration in fresh interpreters with BLAS on one thread and
   on its default threads (:func:`threads`).
4. ``import`` — wall time of ``import mbimpact`` in a fresh interpreter, less the interpreter's own
   start-up: with the bytecode cached (what the goal reads), and in the environment as it is.

:func:`goals` reads the rows of a run against the goals, and says by how much each is missed.
"""

from __future__ import annotations

import functools
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ...laws import CoulombLaw, NewtonLaw, RoughLaw
from ...mechanism import Mechanism, PointContact, joint_velocity
from ...pipeline import impact, impact_batch
from ...roughness import Cone
from ..progress import Progress
from ...common.threads import kernel_threads, set_kernel_threads
from .common import BenchRow, per_call_together

__all__ = ["configurations", "coulomb", "threads", "batch_rates", "import_time", "CACHED_IMPORT", "goals", "Goal",
           "conic_problem"]

E = 0.5


def _pin_loop(mech: Mechanism, fid: int, Q: np.ndarray, V: np.ndarray) -> float:
    """Seconds per impact of a Python loop of Jacobian + pin.impulseDynamics (Newton, e = E)."""
    model, data = mech.model, mech.model.createData()
    start = time.perf_counter()
    for q, v in zip(Q, V):
        Jf = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        pin.impulseDynamics(model, data, q, v, Jf[2:3], E, 0.0)
    return (time.perf_counter() - start) / len(Q)


def configurations(quick: bool, progress: Progress) -> list[BenchRow]:
    """impact_batch across distinct UR5 configurations, per impact, against the Pinocchio loop."""
    mech = Mechanism.from_robot("ur5")
    frame, contact = "tool0", PointContact("tool0")
    rng = np.random.default_rng(3)
    size = 2_000 if quick else 10_000
    Q = np.array([mech.random_configuration(rng) for _ in range(size)])
    V = rng.normal(size=(size, mech.nv))
    for i, q in enumerate(Q):  # every row approaches the plane z = const
        jz = mech.point_jacobian(q, frame)[2]
        if jz @ V[i] >= 0.0:
            V[i] -= (1.0 + jz @ V[i]) * jz / max(float(jz @ jz), 1e-12)
    fid = mech.frame_id(frame)
    t_pin = min(_pin_loop(mech, fid, Q, V) for _ in range(2))
    threads = kernel_threads()
    case = f"ur5 (n={mech.nv}), {size} configurations"
    rows = [BenchRow("configurations", case, "loop of Jacobian + pin.impulseDynamics", 1, 0.0, t_pin, 1.0)]
    # the factored laws' compiled calls on the kernel threads (overlapping Pinocchio's work), and on the
    # calling thread alone: what the threads add
    for label, law, counts in (("impact_batch, NewtonLaw", NewtonLaw(E), (threads,)),
                               ("impact_batch, RoughLaw(Cone)", RoughLaw(Cone(0.3), E), (threads, 1)),
                               ("impact_batch, CoulombLaw", CoulombLaw(E, 0.3), (threads, 1))):
        for count in dict.fromkeys(counts):
            previous = set_kernel_threads(count)
            try:
                passes = []
                for _ in range(2):
                    start = time.perf_counter()
                    impact_batch(mech, Q, V, contact, law)
                    passes.append((time.perf_counter() - start) / size)
            finally:
                set_kernel_threads(previous)
            method = label if count == threads else f"{label}, {count} kernel thread"
            rows.append(BenchRow("configurations", case, method, count, 0.0, min(passes), min(passes) / t_pin))
    progress.step("configurations")
    return rows


def conic_problem(mech: Mechanism, q: np.ndarray, frame: str, mu: float, solver: str = "admm") -> tuple[Any, ...]:
    """What Pinocchio's conic solvers need for one point contact with a Coulomb cone at q.

    Returns ``(constraint_model, models, datas, settings, result, solver)`` for ``solver`` "pgs"
    or "admm", with tolerances of 1e-12; the constraint's velocity is +J v in world-aligned axes.
    """
    model, data = mech.model, mech.model.createData()
    fr = model.frames[mech.frame_id(frame)]
    pin.framesForwardKinematics(model, data, q)
    R = data.oMi[fr.parentJoint].rotation
    # the world is the first body, so that the constraint velocity is +J v in world-aligned axes
    cm = pin.PointContactConstraintModel(model, 0, pin.SE3(np.eye(3), mech.frame_position(q, frame)),
                                         fr.parentJoint, pin.SE3(R.T, fr.placement.translation))
    cm.setFriction(mu)
    models = pin.StdVec_ConstraintModel()
    models.append(pin.ConstraintModel(cm))
    datas = pin.StdVec_ConstraintData()
    datas.append(models[0].createData())
    if solver == "pgs":
        settings, result, engine = pin.PGSSolverSettings(), pin.PGSSolverResult(), pin.PGSConstraintSolver(3)
    else:
        settings, result, engine = pin.ADMMSolverSettings(), pin.ADMMSolverResult(), pin.ADMMConstraintSolver(3)
    settings.absolute_feasibility_tol = settings.absolute_complementarity_tol = 1e-12
    settings.relative_feasibility_tol = settings.relative_complementarity_tol = 1e-12
    return cm, models, datas, settings, result, engine


def coulomb(min_time: float, progress: Progress, quick: bool = True) -> list[BenchRow]:
    """One plastic Coulomb impact of the UR5 (sticking, sliding): CoulombLaw against PGS and ADMM."""
    mech = Mechanism.from_robot("ur5")
    frame, contact = "tool0", PointContact("tool0")
    q = mech.neutral() + 0.3
    model, data = mech.model, mech.model.createData()
    fid = mech.frame_id(frame)
    J = mech.point_jacobian(q, frame)
    rows: list[BenchRow] = []
    v_n = joint_velocity(mech.mass_matrix(q), J, [0.0, 0.0, -1.0])

    def baseline() -> None:
        Jf = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        pin.impulseDynamics(model, data, q, v_n, Jf[2:3], E, 0.0)

    # each case timed in alternation with the reference (per_call_together), so that whether Coulomb
    # beats PGS does not depend on which stretch of a busy machine each measurement met; the ratios
    # divide by the reference's best time over both cases
    reference = "Jacobian + pin.impulseDynamics"
    case_rows: list[tuple[str, str, float, float, float]] = []  # case, method, mu, agreement, seconds
    t_ref = math.inf
    for case, mu, u in (("sticking (mu=3)", 3.0, [0.2, 0.1, -1.0]), ("sliding (mu=0.2)", 0.2, [1.0, 0.5, -1.0])):
        v = joint_velocity(mech.mass_matrix(q), J, u)
        law = CoulombLaw(0.0, mu)
        P = impact(mech, q, v, contact, law).P
        fns: dict[str, Any] = {reference: baseline, "impact, CoulombLaw": functools.partial(impact, mech, q, v,
                                                                                            contact, law)}
        agreement = {"impact, CoulombLaw": 0.0}
        for solver in ("pgs", "admm"):
            cm, models, datas, settings, result, engine = conic_problem(mech, q, frame, mu, solver)

            def conic(cm: Any = cm, models: Any = models, datas: Any = datas, settings: Any = settings,
                      result: Any = result, engine: Any = engine, cdata: Any = cm.createData(),
                      v: np.ndarray = v) -> np.ndarray:
                # the same work as impact(): kinematics, Jacobian, Delassus matrix, solve (from q, v)
                pin.computeJointJacobians(model, data, q)
                cm.calc(model, data, cdata)
                Jc = cm.jacobian(model, data, cdata)
                W = Jc @ np.linalg.solve(pin.crba(model, data, q), Jc.T)
                engine.solve(pin.DelassusOperatorDense(W), Jc @ v, models, datas, settings, result)
                return np.asarray(result.retrieveConstraintImpulses())

            label = f"Pinocchio {solver.upper()} (J, W, solve)"
            agreement[label] = float(np.linalg.norm(conic() - P) / np.linalg.norm(P))
            fns[label] = conic
        times = per_call_together(fns, min_time)
        t_ref = min(t_ref, times.pop(reference))
        case_rows += [(case, label, mu, agreement[label], t) for label, t in times.items()]
    rows.append(BenchRow("coulomb", "ur5, normal incidence", reference, 0, 0.0, t_ref, 1.0))
    rows += [BenchRow("coulomb", f"ur5, {case}", label, mu, agree, t, t / t_ref)
             for case, label, mu, agree, t in case_rows]
    # the batch: every row integrates its own impact (closed forms, or a turning 3-D slip)
    rng = np.random.default_rng(5)
    U = np.column_stack([rng.normal(size=(200, 2)), -rng.uniform(0.2, 1.0, 200)])
    Vb = joint_velocity(mech.mass_matrix(q), J, U)
    A = mech.mass_matrix(q)
    law = CoulombLaw(E, 0.3)
    start = time.perf_counter()
    law.apply_batch(A, J, Vb, [0.0, 0.0, 1.0])
    t = (time.perf_counter() - start) / len(Vb)
    rows.append(BenchRow("coulomb", "ur5, 200 random incidences", "CoulombLaw.apply_batch (e=0.5, mu=0.3)", 0.3, 0.0,
                         t, t / t_ref))
    rows += _first_call(quick)
    progress.step("coulomb")
    return rows


def _first_call(quick: bool) -> list[BenchRow]:
    """What the first impacts of a process pay for the compiled kernels (numba's import, then loading
    each kernel module from numba's disk cache), in a fresh interpreter: one row a module and their
    total; unless ``quick``, also their cold compilation (an empty ``NUMBA_CACHE_DIR``, as on a fresh
    install)."""
    code = "import json, mbimpact; print(json.dumps(mbimpact.compile_kernels()))"
    cases = [("first call, kernels cached on disk", None)] + ([] if quick else [("first call, cold compile", "")])
    rows = []
    for label, cache in cases:
        with tempfile.TemporaryDirectory() as tmp:
            env = dict(os.environ)
            if cache is not None:
                env["NUMBA_CACHE_DIR"] = tmp
            out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, env=env)
        times = json.loads(out.stdout.splitlines()[-1])
        for module, (imported, jitted) in times.items():
            rows.append(BenchRow("coulomb", f"JIT, {label}", f"import + load or compile {module}", 0, 0.0,
                                 imported + jitted, math.nan))
        total = sum(a + b for a, b in times.values())
        rows.append(BenchRow("coulomb", f"JIT, {label}", "all compiled kernels (mbimpact.compile_kernels())", 0, 0.0,
                             total, math.nan))
    return rows


def batch_rates(size: int) -> dict[str, float]:
    """Impacts per second of ``apply_batch`` at one UR5 configuration, NewtonLaw and RoughLaw(Cone):
    best of 3 passes over ``size`` approaching velocities (what :func:`threads` runs in a child). Each
    pass reads the post-impact velocities ``V_plus``, which a lazy batch forms on access."""
    mech = Mechanism.from_robot("ur5")
    rng = np.random.default_rng(11)
    q = mech.random_configuration(rng)
    J, A, n0 = mech.point_jacobian(q, "tool0"), mech.mass_matrix(q), np.array([0.0, 0.0, 1.0])
    V = rng.normal(size=(size, mech.nv))
    V[V @ (J.T @ n0) > 0] *= -1
    rates = {}
    for label, law in (("NewtonLaw", NewtonLaw(E)), ("RoughLaw(Cone)", RoughLaw(Cone(0.3), E))):
        best = math.inf
        for _ in range(3):
            start = time.perf_counter()
            law.apply_batch(A, J, V, n0).V_plus
            best = min(best, time.perf_counter() - start)
        rates[label] = size / best
    return rates


_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def threads(quick: bool, progress: Progress) -> list[BenchRow]:
    """:func:`batch_rates` in two fresh interpreters: BLAS on one thread, and BLAS left to its default
    (one thread per core) — the batches must not depend on it."""
    size = 20_000 if quick else 100_000
    code = f"import json; from mbimpact.apps.bench.speed import batch_rates; print(json.dumps(batch_rates({size})))"
    rows = []
    for label, value in (("BLAS threads = 1", "1"), ("BLAS threads: default", None)):
        env = {k: v for k, v in os.environ.items() if k not in _THREAD_VARIABLES}
        if value is not None:
            env.update(dict.fromkeys(_THREAD_VARIABLES, value))
        out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, env=env)
        for method, rate in json.loads(out.stdout.splitlines()[-1]).items():
            rows.append(BenchRow("threads", f"ur5, {label}", f"apply_batch, {method}", size, 0.0, 1.0 / rate, rate))
    progress.step("threads")
    return rows


#: The case of :func:`import_time` that the goal reads: the modules' bytecode cached, as ``pip install`` leaves it.
CACHED_IMPORT = "fresh interpreter, bytecode cached"


def import_time(progress: Progress) -> list[BenchRow]:
    """``import mbimpact`` in a fresh interpreter, less the interpreter's own start-up (best of 3): three rows.

    1. :data:`CACHED_IMPORT`: every module's bytecode already compiled, as ``pip install`` leaves an
       installed package (written once into a private ``PYTHONPYCACHEPREFIX``, so that the installation
       itself is left untouched). This is what a user's ``import`` costs, and what the goal reads.
    2. The same for numpy and Pinocchio alone: the part of that import which is theirs.
    3. The environment as it is: with ``PYTHONDONTWRITEBYTECODE`` set, an editable install's modules, which
       have no bytecode, are compiled from source at every import (about 0.1 s of it on the machine of
       the README's figures).
    """
    def best(code: str, env: dict[str, str]) -> float:
        times = []
        for _ in range(3):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-c", code], check=True, env=env)
            times.append(time.perf_counter() - start)
        return min(times)

    rows = []
    with tempfile.TemporaryDirectory() as cache:
        cached = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        cached["PYTHONPYCACHEPREFIX"] = cache
        subprocess.run([sys.executable, "-c", "import mbimpact"], check=True, env=cached)  # writes the bytecode
        start = best("pass", cached)
        rows.append(BenchRow("import", CACHED_IMPORT, "import mbimpact", 0, 0.0,
                             best("import mbimpact", cached) - start, math.nan))
        rows.append(BenchRow("import", CACHED_IMPORT, "import numpy, pinocchio (what it imports first)", 0, 0.0,
                             best("import numpy, pinocchio", cached) - start, math.nan))
    as_is = dict(os.environ)
    flag = as_is.get("PYTHONDONTWRITEBYTECODE")
    t = best("import mbimpact", as_is) - best("pass", as_is)
    rows.append(BenchRow("import", f"fresh interpreter, this environment (PYTHONDONTWRITEBYTECODE "
                         f"{'set' if flag else 'unset'})", "import mbimpact", 0, 0.0, t, math.nan))
    progress.step("import")
    return rows


@dataclass(frozen=True)
class Goal:
    """One speed goal read off a run: ``measured`` against ``target`` (``below``: lower is better)."""

    what: str
    target: float
    measured: float
    unit: str
    below: bool = True

    @property
    def met(self) -> bool:
        return self.measured <= self.target if self.below else self.measured >= self.target

    @property
    def factor(self) -> float:
        """How far the goal is missed, ≥ 1 (1: met)."""
        f = self.measured / self.target if self.below else self.target / self.measured
        return max(f, 1.0)


def goals(rows: list[BenchRow]) -> list[Goal]:
    """The speed goals the rows of a run measure (those whose rows ran)."""
    out: list[Goal] = []

    def find(part: str, case: str | None, method: str) -> list[BenchRow]:
        return [r for r in rows if r.part == part and (case is None or r.case.startswith(case)) and r.method == method]

    for r in find("overhead", None, "impact, NewtonLaw"):
        out.append(Goal(f"{r.case}: impact, NewtonLaw per call (× Jacobian + impulseDynamics)", 1.5, r.ratio, "×"))
    for r in find("overhead", None, "impact, RoughLaw(Cone)"):  # ≤ 5× where W is strongly anisotropic
        out.append(Goal(f"{r.case}: impact, RoughLaw(Cone) per call", 5.0 if "anisotropic" in r.case else 3.0,
                        r.ratio, "×"))
    for r in find("overhead", None, "impact, RoughLaw(GaussianSlopes(0.3))"):
        out.append(Goal(f"{r.case}: impact, RoughLaw(GaussianSlopes) per call", 20.0, r.ratio, "×"))
    for r in find("coulomb", None, "impact, CoulombLaw"):
        out.append(Goal(f"{r.case}: impact, CoulombLaw per call", 20.0, r.ratio, "×"))
        pgs = find("coulomb", r.case, "Pinocchio PGS (J, W, solve)")
        if pgs:
            out.append(Goal(f"{r.case}: CoulombLaw time / Pinocchio PGS time", 1.0, r.seconds / pgs[0].seconds, "×"))
    for r in find("batch", "ur5", "NewtonLaw"):
        out.append(Goal("ur5: apply_batch, NewtonLaw, one configuration", 1e7, r.ratio, "impacts/s", below=False))
    for r in find("batch", "ur5", "RoughLaw(Cone), adaptive"):
        out.append(Goal("ur5: apply_batch, RoughLaw(Cone), one configuration", 1e6, r.ratio, "impacts/s",
                        below=False))
    for r in find("batch", "anisotropic W", "RoughLaw(GaussianSlopes(0.3)), first call"):
        out.append(Goal(f"{r.case}: apply_batch, RoughLaw(GaussianSlopes(0.3)), first call", 1e5, r.ratio,
                        "impacts/s", below=False))
    for r in rows:
        if r.part == "threads":
            target = 1e7 if r.method.endswith("NewtonLaw") else 1e6
            out.append(Goal(f"{r.case}: {r.method}, one configuration", target, r.ratio, "impacts/s", below=False))
    for law in ("NewtonLaw", "RoughLaw(Cone)", "CoulombLaw"):
        for r in find("configurations", "ur5", f"impact_batch, {law}"):
            out.append(Goal(f"{r.case}: impact_batch, {law}", 1e5, 1.0 / r.seconds, "impacts/s", below=False))
    for r in find("import", CACHED_IMPORT, "import mbimpact"):
        out.append(Goal("import mbimpact", 0.3, r.seconds, "s"))
    for r in find("first-run", None, "empty kernel cache"):
        out.append(Goal(f"{r.case}, empty kernel cache", 10.0, r.seconds, "s"))
    return out

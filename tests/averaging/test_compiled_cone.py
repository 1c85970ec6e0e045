"""The adaptive rule's compiled backend on a cone (:mod:`mbimpact.averaging.compiled.cone`) against an
independent numpy reference of its first pass.

The reference below computes both levels of the rule as one product of a table of harmonics
T(θ) = (1, cos θ, sin θ, cos 2θ, sin 2θ) with small coefficient matrices, then P = (1+e) N / D and
the relative difference of the levels. The kernel sums node by node instead: the two agree to
rounding, amplified as every impulse of (2.8) is by |W| |P| / |W P|, and decide alike. The same
kernel source run interpreted (``NUMBA_DISABLE_JIT=1``) agrees with the compiled one; only the
first single impact on a cone imports numba.
"""

from __future__ import annotations

import functools
import math
import os
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.averaging import backends
from mbimpact.averaging.compiled import CONE as KERNELS
from mbimpact.averaging.compiled.codes import DEGENERATE_FACET, SETTLED
from mbimpact.common.geometry import DEGENERATE, facing_half_width_scalar, ring_quadratic_form
from mbimpact.quadrature.rules import gauss_legendre

from tests.helpers import relative_du, spd, unit_velocities

EPS = np.finfo(float).eps
ROOT = Path(__file__).resolve().parents[2]
_ORDER = np.array([0.0, 1.0, 1.0, 2.0, 2.0])
_PHASE = np.array([0.0, 0.0, math.pi / 2, 0.0, math.pi / 2])


@pytest.fixture(autouse=True, scope="module")
def _compiled() -> None:
    """Load (or, with a cold numba cache, compile: ~2 s) the kernel before the tests."""
    KERNELS.compile()


def first_pass(spec, W, u):
    """The compiled backend where it settles at its first pass (n and 2n nodes), else None."""
    status, out = backends.adaptive(spec, W, u)
    return out if status == SETTLED and out.nodes == 2 * spec.roughness.initial_nodes else None


@functools.lru_cache(maxsize=4)
def harmonics(n: int, full: bool) -> tuple[np.ndarray, np.ndarray]:
    """Full ring: T (3n, 5) at θ = 2πj/n, 2πj/2n; arc: the Gauss–Legendre nodes × harmonic orders.
    And the level weights (2, 3n) (divided by 2π on the arc)."""
    levels = np.zeros((2, 3 * n))
    if full:
        theta = np.concatenate([2 * math.pi * np.arange(n) / n, 2 * math.pi * np.arange(2 * n) / (2 * n)])
        levels[0, :n], levels[1, n:] = 1.0 / n, 1.0 / (2 * n)
        return np.cos(np.multiply.outer(theta, _ORDER) - _PHASE), levels
    (x1, w1), (x2, w2) = gauss_legendre(n), gauss_legendre(2 * n)
    levels[0, :n], levels[1, n:] = w1 / (2 * math.pi), w2 / (2 * math.pi)
    return np.multiply.outer(np.concatenate([x1, x2]), _ORDER), levels


def reference(alpha: float, W: np.ndarray, u: np.ndarray, n: int, flux: str, e: float, rtol: float
              ) -> tuple[np.ndarray, float] | None:
    """The first pass of the adaptive rule on a cone by numpy harmonics: (P at 2n nodes, error
    estimate), or None where the pass declines (a degenerate facet, no weight, not settled)."""
    ux, uy, uz = u.tolist()
    ut = math.hypot(ux, uy)
    cp, sp = (ux / ut, uy / ut) if ut > 0.0 else (1.0, 0.0)
    s, c = math.sin(alpha), math.cos(alpha)
    h = facing_half_width_scalar(s, c, ut, -uz)
    q0, a1, b1, a2, b2 = ring_quadratic_form(s, c, W)
    c2, s2 = cp * cp - sp * sp, 2.0 * cp * sp
    # columns: mᵀu and mᵀWm in the harmonics of θ = φ − ψ; then the three components of m
    row1 = [s * ut, a1 * cp + b1 * sp, s * cp, s * sp, 0.0]
    row2 = [0.0, b1 * cp - a1 * sp, -s * sp, s * cp, 0.0]
    if h == math.pi:
        T, levels = harmonics(n, True)
    else:  # θ = π + h x: cos θ and sin θ change sign
        X, unit = harmonics(n, False)
        T, levels = np.cos(h * X - _PHASE), h * unit
        row1, row2 = [-x for x in row1], [-x for x in row2]
    coef = np.array([[c * uz, q0, 0.0, 0.0, c], row1, row2, [0.0, a2 * c2 + b2 * s2, 0.0, 0.0, 0.0],
                     [0.0, b2 * c2 - a2 * s2, 0.0, 0.0, 0.0]])
    values = T @ coef[:, :2]
    su, q = np.minimum(values[:, 0], 0.0), values[:, 1]
    if not q.min() > DEGENERATE * np.trace(W):
        return None
    if flux == "configuration":
        r = 1.0 / np.sqrt(q)
        weight = -su * r
        kernel = weight * weight * r
    else:
        weight = -su
        kernel = su * su / q
    N, D = (levels * kernel) @ T @ coef[:, 2:], levels @ weight
    if not (D > 0.0).all():
        return None
    P = (1.0 + e) * N / D[:, None]
    coarse, fine = P @ W
    err = float(np.linalg.norm(fine - coarse) / np.linalg.norm(fine))
    if not err <= max(rtol, 100 * EPS * math.sqrt(2 * n)):
        return None
    return P[1], err


def cases(seed: int, count: int):
    """Unit-trace W (SPD, cond 1 to 1e3, anisotropic), tilts across (0, π/2), e in [0, 1], both
    fluxes, unit velocities of both regimes (the whole ring facing, or an arc)."""
    rng = np.random.default_rng(seed)
    for k in range(count):
        W = spd(rng, 3, 10 ** rng.uniform(0.0, 3.0))
        W /= np.trace(W)
        alpha = rng.uniform(1e-3, math.pi / 2 - 1e-3)
        law = mbi.RoughLaw(mbi.Cone(alpha), rng.uniform(0.0, 1.0), flux=("physical", "configuration")[k % 2])
        for u in unit_velocities(rng, 6):
            yield law.spec, W, u


def amplification(P: np.ndarray, W: np.ndarray) -> float:
    """|W| |P| / |W P| (|W| ≤ tr W = 1): how much a relative change of P by rounding can show in W P."""
    return float(np.linalg.norm(P) / np.linalg.norm(P @ W))


def test_the_kernel_equals_the_numpy_harmonics():
    """The same decision at the first pass on every case; P to within 32 ε |W||P|/|WP| by W P (observed
    ≤ 12 ε: ~1e-15 for ordinary W), the error estimate to within 64 ε |W||P|/|WP| (both are rounding when
    settled)."""
    settled = declined = 0
    for spec, W, u in cases(17, 400):
        ref = reference(spec.roughness.alpha, W, u, 32, spec.flux, spec.e, spec.rtol)
        out = first_pass(spec, W, u[None])
        assert (out is None) == (ref is None)
        if out is None:
            declined += 1
            continue
        settled += 1
        amp = amplification(ref[0], W)
        assert relative_du(out.P, ref[0][None], W)[0] <= 32 * EPS * amp
        assert abs(out.error[0] - ref[1]) <= 64 * EPS * amp
        assert out.nodes == 64 and out.method == "adaptive[compiled]"
    assert settled > 1000 and declined > 100  # both outcomes, many times


def test_a_degenerate_facet_or_an_exhausted_node_budget_declines():
    """A facet the mechanism cannot push (mᵀWm = 0 on a node of the full ring: φ = 0), in either
    flux, is left to the numpy rule (which masks it); max_nodes below the pair's 2n nodes leaves no
    compiled levels."""
    alpha = 0.4
    m = np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    W = (np.eye(3) - np.outer(m, m)) / 2.0
    u = np.array([[0.0, 0.0, -1.0]])
    for flux in ("physical", "configuration"):
        spec = mbi.RoughLaw(mbi.Cone(alpha), 0.5, flux=flux).spec
        assert reference(alpha, W, u[0], 32, flux, 0.5, spec.rtol) is None
        assert backends.adaptive(spec, W, u) == (DEGENERATE_FACET, None)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mbi.AccuracyWarning)  # 1/mᵀWm is not integrable there: it says so
            out = mbi.averaging.Adaptive().average(spec, W, u)
        assert out.method == "adaptive" and np.isfinite(out.P).all()
    spec = mbi.RoughLaw(mbi.Cone(alpha), 0.5, max_nodes=63).spec
    assert backends.level_plan(spec)[0] == 31 and first_pass(spec, np.eye(3) / 3.0, u) is None


def test_the_compiled_kernel_equals_its_source_interpreted():
    """What ``NUMBA_DISABLE_JIT=1`` runs (the kernel's Python function) gives the same decision, and
    impulses and error estimates within a few ε (libm's and CPython's hypot, cos, acos may differ in
    the last bit)."""
    kernels = KERNELS.get()
    table = kernels.rule_table(32, 4)
    for spec, W, u in cases(5, 40):
        out = []
        compiled = kernels.cone_adaptive
        for kernel in (compiled, getattr(compiled, "py_func", compiled)):
            P, err = np.empty((1, 3)), np.empty(1)
            status, _ = kernel(spec.roughness.alpha, W, u[None], table, 4, spec.flux == "configuration", spec.e,
                               spec.rtol, DEGENERATE, P, err)
            out.append((status, P, err[0]))
        (status, P, err), (status_py, P_py, err_py) = out
        assert status == status_py
        if status == SETTLED:
            amp = amplification(P[0], W)
            assert relative_du(P, P_py, W)[0] <= 8 * EPS * amp and abs(err - err_py) <= 16 * EPS * amp


def test_only_a_single_impact_on_a_cone_imports_numba():
    """``import mbimpact`` does not import numba (it costs ~0.3 s); the first single impact on a cone does."""
    script = textwrap.dedent("""
        import sys
        import numpy as np
        import mbimpact as mbi
        assert "numba" not in sys.modules
        W = np.array([[1.0, 0.3, 0.2], [0.3, 0.8, -0.1], [0.2, -0.1, 0.5]])
        result = mbi.RoughLaw(mbi.Cone(0.4), 0.5).apply(np.linalg.inv(W), np.eye(3), [0.3, 0.1, -1.0], [0, 0, 1])
        assert result.method == "adaptive[compiled]" and "numba" in sys.modules
    """)
    subprocess.run([sys.executable, "-c", script], check=True, cwd=ROOT, timeout=300,
                   env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))


def test_compile_kernels_reports_the_first_call_cost():
    imported, jitted = KERNELS.compile()  # loaded already (the module fixture): nothing left to pay
    assert 0.0 <= imported < 0.05 and 0.0 <= jitted < 0.05

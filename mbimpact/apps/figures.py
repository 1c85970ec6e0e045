"""The paper's Fig. 1 and claims 1°–5° of section 3, computed by the library.

Every figure has a data function (tested against the closed forms of THEORY.md)
and a plotting function; ``mbimpact figures --out DIR`` writes them all.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from ..laws import CoulombLaw
from ..laws import NewtonLaw
from ..roughness import Profile
from ..laws import RoughLaw
from ..roughness import Cone, Sawtooth

__all__ = ["fig1_data", "sawtooth_mu", "claims_data", "rough_vs_coulomb_data", "write_all"]

I2, I3 = np.eye(2), np.eye(3)


def sawtooth_mu(alpha: float, tan_beta: np.ndarray) -> np.ndarray:
    """The solid line of Fig. 1, (3.1): 2 tan²α tan β/(tan²α tan²β + 1) below the switch, tan α above."""
    ta = math.tan(alpha)
    first = np.arctan(tan_beta) < math.pi / 2 - alpha
    return np.where(first, 2 * ta**2 * tan_beta / (ta**2 * tan_beta**2 + 1), ta)


def fig1_data(alpha: float = 0.5, e: float = 0.5, points: int = 120) -> dict[str, np.ndarray]:
    """μ against tan β: the sawtooth by the library and by (3.1), and a shadowed smooth profile.

    The smooth profile is a sinusoid whose steepest slope equals tan α, sampled
    finely and shadowed exactly (:class:`Profile` with ``shadowing=True``).
    """
    tb = np.geomspace(0.02, 50.0, points)
    saw = RoughLaw(Sawtooth(alpha), e)
    x = np.linspace(0.0, 1.0, 2001)
    prof = Profile(math.tan(alpha) / (2 * math.pi) * np.sin(2 * math.pi * x), float(x[1]), shadowing=True, periodic=True)
    smooth = RoughLaw(prof, e)
    mu_saw = np.array([saw.apply(I2, I2, [t, -1.0], [0, 1]).mu for t in tb])
    mu_smooth = np.array([smooth.apply(I2, I2, [t, -1.0], [0, 1]).mu for t in tb])
    return {"tan_beta": tb, "mu_sawtooth": mu_saw, "mu_formula": sawtooth_mu(alpha, tb), "mu_smooth_shadowed": mu_smooth}


def claims_data(alpha: float = 0.4, e: float = 0.8) -> dict[str, np.ndarray]:
    """Quantities behind claims 1°–5° for a point mass on a cone of facets.

    1° Δv/|v| for |v| over 12 decades (must not change); 2° the angle between
    Δv_l and v_l (must be 180°) and the distance of Δv from the plane of v, n⁰;
    3° κ at normal incidence against α with (4.2); 4° κ against tan β at fixed
    v_n; 5° |Δv − Δv_Newton| as α → 0.
    """
    law = RoughLaw(Cone(alpha), e)
    v = np.array([0.6, 0.3, -1.0])
    scales = np.geomspace(1e-6, 1e6, 13)
    dirs = np.array([law.apply(I3, I3, s * v, [0, 0, 1]).dv / s for s in scales])
    az = np.linspace(0, 2 * math.pi, 24, endpoint=False)
    angle, offplane = [], []
    for a in az:
        w = np.array([1.5 * math.cos(a), 1.5 * math.sin(a), -1.0])
        dv = law.apply(I3, I3, w, [0, 0, 1]).dv
        cosang = dv[:2] @ w[:2] / (np.linalg.norm(dv[:2]) * np.linalg.norm(w[:2]))
        angle.append(math.degrees(math.acos(max(-1.0, min(1.0, cosang)))))
        offplane.append(abs(np.linalg.det(np.column_stack([w, [0, 0, 1], dv]))) / (np.linalg.norm(w) * np.linalg.norm(dv)))
    alphas = np.linspace(0.0, 1.4, 30)
    kappa_normal = np.array([RoughLaw(Cone(a), e).apply(I3, I3, [0, 0, -1.0], [0, 0, 1]).kappa for a in alphas])
    tb = np.linspace(0.0, 20.0, 60)
    kappa_beta = np.array([law.apply(I3, I3, [t, 0.0, -1.0], [0, 0, 1]).kappa for t in tb])
    small = np.geomspace(1e-6, 0.5, 20)
    newton = NewtonLaw(e).apply(I3, I3, v, [0, 0, 1]).dv
    to_newton = np.array([np.linalg.norm(RoughLaw(Cone(a), e).apply(I3, I3, v, [0, 0, 1]).dv - newton) for a in small])
    return {
        "scales": scales, "dv_over_speed": dirs, "azimuth": az, "angle_dvl_vl_deg": np.array(angle),
        "offplane": np.array(offplane), "alpha": alphas, "kappa_normal": kappa_normal,
        "kappa_4_2": (1 + e) * np.cos(alphas) ** 2 - 1, "tan_beta": tb, "kappa_beta": kappa_beta,
        "alpha_small": small, "distance_to_newton": to_newton,
    }


def rough_vs_coulomb_data(alpha: float = 0.4, e: float = 0.8, mu: float | None = None) -> dict[str, np.ndarray]:
    """κ(β) and μ(β) of the rough law and the Coulomb law (Stronge) for a point mass.

    The Coulomb μ defaults to the rough law's friction ratio at β = 45°. The
    constructive law has κ rising with β and μ falling at grazing incidence only
    through shadowing; the axiomatic law keeps κ = e and μ at its constant while
    sliding, then drops μ when the contact sticks at steep incidence.
    """
    rough = RoughLaw(Cone(alpha), e)
    if mu is None:
        mu = rough.apply(I3, I3, [1.0, 0.0, -1.0], [0, 0, 1]).mu
    coulomb = CoulombLaw(e, mu, "energetic")
    beta = np.linspace(0.0, 88.0, 45)
    out: dict[str, list[float]] = {k: [] for k in ("kappa_rough", "mu_rough", "kappa_coulomb", "mu_coulomb")}
    for b in np.radians(beta):
        v = [math.sin(b), 0.0, -math.cos(b)]
        r, c = rough.apply(I3, I3, v, [0, 0, 1]), coulomb.apply(I3, I3, v, [0, 0, 1])
        out["kappa_rough"].append(r.kappa)
        out["mu_rough"].append(r.mu)
        out["kappa_coulomb"].append(c.kappa)
        out["mu_coulomb"].append(c.mu)
    return {"beta_deg": beta, "mu_coulomb_param": np.array(mu), **{k: np.array(v) for k, v in out.items()}}


def _save(fig: object, path: Path) -> Path:
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)  # type: ignore[attr-defined]
    plt.close(fig)  # type: ignore[arg-type]
    return path


def write_all(out: str | Path) -> list[Path]:
    """Write fig1.png, claims.png, rough_vs_coulomb.png, stability_map.png and fig1.csv into ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    written = []
    d = fig1_data()
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(d["tan_beta"], d["mu_formula"], "k-", label="sawtooth, formula (3.1)")
    ax.plot(d["tan_beta"], d["mu_sawtooth"], "o", ms=3, label="sawtooth, library (2.8)")
    ax.plot(d["tan_beta"], d["mu_smooth_shadowed"], "--", label="smooth profile, shadowed")
    ax.set(xscale="log", xlabel="tan β", ylabel="μ = |Δv_l| / |Δv_n|", title="Fig. 1 (α = 0.5)")
    ax.legend()
    written.append(_save(fig, out / "fig1.png"))
    with (out / "fig1.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(d))
        w.writerows(zip(*d.values()))
    written.append(out / "fig1.csv")

    c = claims_data()
    fig, axes = plt.subplots(1, 5, figsize=(22, 4))
    axes[0].plot(c["scales"], c["dv_over_speed"], marker="o")
    axes[0].set(xscale="log", xlabel="|v| scale", ylabel="Δv / scale", title="1° direction independent of |v|")
    axes[1].plot(np.degrees(c["azimuth"]), c["angle_dvl_vl_deg"], "o")
    axes[1].set(xlabel="azimuth of v_l [deg]", ylabel="angle(Δv_l, v_l) [deg]", ylim=(170, 190), title="2° Δv_l opposes v_l")
    axes[2].plot(c["alpha"], c["kappa_normal"], "o", ms=3, label="library")
    axes[2].plot(c["alpha"], c["kappa_4_2"], "k-", label="(4.2)")
    axes[2].set(xlabel="α", ylabel="κ at normal incidence", title="3° Newton behaviour, κ of (4.2)")
    axes[2].legend()
    axes[3].plot(c["tan_beta"], c["kappa_beta"])
    axes[3].axhline(1.0, color="k", lw=0.5)
    axes[3].set(xlabel="tan β (v_n fixed)", ylabel="κ", title="4° κ rises with |v_l|, exceeds 1")
    axes[4].loglog(c["alpha_small"], c["distance_to_newton"], "o-")
    axes[4].set(xlabel="α", ylabel="|Δv − Δv_Newton|", title="5° smooth limit")
    fig.tight_layout()
    written.append(_save(fig, out / "claims.png"))

    r = rough_vs_coulomb_data()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    axes[0].plot(r["beta_deg"], r["kappa_rough"], label="constructive (cone α = 0.4)")
    axes[0].plot(r["beta_deg"], r["kappa_coulomb"], label=f"Coulomb μ = {float(r['mu_coulomb_param']):.3f} (Stronge)")
    axes[0].set(xlabel="β [deg]", ylabel="κ")
    axes[1].plot(r["beta_deg"], r["mu_rough"], label="constructive")
    axes[1].plot(r["beta_deg"], r["mu_coulomb"], label="Coulomb")
    axes[1].set(xlabel="β [deg]", ylabel="μ = |P_t| / P_n")
    axes[0].legend()
    fig.suptitle("Constructive vs axiomatic impact, point mass, e = 0.8")
    fig.tight_layout()
    written.append(_save(fig, out / "rough_vs_coulomb.png"))

    from ..simulation.section4 import stability_map

    sm = stability_map(np.array([0.2, 0.35, 0.5, 0.6]))
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(sm["alpha_fine"], sm["B"], "k-", label="B of (4.3): stable below")
    ax.scatter(sm["alpha"][~sm["grew"]], sm["inv_rho"][~sm["grew"]], marker="o", label="simulated: decays")
    ax.scatter(sm["alpha"][sm["grew"]], sm["inv_rho"][sm["grew"]], marker="x", color="r", label="simulated: grows")
    ax.set(xlabel="cone tilt α", ylabel="ρ⁻¹ [ω²/g]", title="Section 4 stability map (e = 0.8, m = 1)")
    ax.legend()
    written.append(_save(fig, out / "stability_map.png"))
    return written

"""The paper's Fig. 1 and claims 1°–5° of section 3, computed by the library.

Every figure has a data function (tested against the closed forms of :mod:`mbimpact.theory`)
and a plotting function; ``mbimpact figures --out DIR`` writes them all.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from typing import Any

from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_array
from ..errors import ParameterError
from ..laws import CoulombLaw, NewtonLaw, RoughLaw
from ..roughness import Cone, Profile, Sawtooth

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


def shadowing_data(profile: Profile, u: ArrayLike) -> dict[str, NDArray[np.float64]]:
    """The parts of a measured profile that an approach along ``u`` reaches first (Fig. 2).

    Parameters
    ----------
    profile : Profile
        A planar measured relief.
    u : array_like, shape (2,)
        Approach velocity (tangential, normal), normal component < 0.

    Returns
    -------
    dict
        ``x``, ``h``: the profile; ``lit`` (S, 2, 2): the reached piece of every segment as
        two (x, h) points (zero length when the segment is shadowed or faces away);
        ``fraction``: the reached fraction of each segment (:meth:`Profile.lit_fraction`).
    """
    if not isinstance(profile, Profile):
        raise ParameterError(f"shadowing figures need a Profile, got {type(profile).__name__}")
    u = as_array("u", u, 1, (2,))
    if not u[1] < 0:
        raise ParameterError(f"u must approach the base line (u[1] < 0), got {u.tolist()}")
    h = profile.heights
    x = profile.dx * np.arange(h.size)
    frac = profile.lit_fraction(u)
    # a segment is reached from its downstream end on (the running maximum of the heights seen
    # along the approach): the end the motion goes towards
    x0, x1, h0, h1 = x[:-1], x[1:], h[:-1], h[1:]
    if u[0] >= 0:
        start = (x1 - frac * profile.dx, h1 - frac * (h1 - h0))
        lit = np.stack([np.column_stack(start), np.column_stack([x1, h1])], axis=1)
    else:
        end = (x0 + frac * profile.dx, h0 + frac * (h1 - h0))
        lit = np.stack([np.column_stack([x0, h0]), np.column_stack(end)], axis=1)
    return {"x": x, "h": h, "lit": lit, "fraction": frac}


def plot_shadowing(profile: Profile, u: ArrayLike, ax: Any = None, rays: int = 9) -> Any:
    """Draw a profile with the parts an approach along ``u`` reaches first (the idea of the
    paper's Fig. 2): reached parts bold, shadowed ones thin, a few approach lines.

    Parameters
    ----------
    profile : Profile
    u : array_like, shape (2,)
    ax : matplotlib Axes, optional
        Where to draw (a new figure otherwise).
    rays : int
        Number of approach lines drawn (each stops where it first meets the profile).

    Returns
    -------
    matplotlib Axes
    """
    import matplotlib.pyplot as plt

    d = shadowing_data(profile, u)
    u = np.asarray(u, dtype=float)
    if ax is None:
        _, ax = plt.subplots(figsize=(8, 3))
    ax.plot(d["x"], d["h"], color="0.6", lw=1, label="shadowed or facing away")
    for (a, b), f in zip(d["lit"], d["fraction"]):
        if f > 0:
            ax.plot([a[0], b[0]], [a[1], b[1]], color="C3", lw=2.5)
    ax.plot([], [], color="C3", lw=2.5, label="reached first")
    x, h = d["x"], d["h"]
    relief = float(h.max() - h.min()) or 1.0
    top = float(h.max()) + 0.6 * relief
    slope = u[0] / -u[1]  # horizontal travel per unit of descent
    drop = top - float(h.min())
    t = np.linspace(0.0, 1.0, 8001)
    for x_start in np.linspace(x[0], x[-1], rays) - slope * (top - float(h.mean())):
        path = np.column_stack([x_start + slope * drop * t, top - drop * t])
        inside = (path[:, 0] >= x[0]) & (path[:, 0] <= x[-1])
        hit = inside & (path[:, 1] <= np.interp(path[:, 0], x, h))
        if hit.any():  # each line stops where it first meets the profile
            ax.annotate("", xy=path[int(np.argmax(hit))], xytext=path[0],
                        arrowprops={"arrowstyle": "->", "color": "C0", "lw": 0.8})
    # heights exaggerated, as profiles usually are: an affine map keeps lines straight and the
    # first point a line meets the first point, so the reached parts are drawn truthfully
    ax.set(xlabel="x", ylabel="height", xlim=(x[0], x[-1]), ylim=(float(h.min()) - 0.1 * relief, top))
    ax.legend(fontsize=8, loc="lower left", framealpha=0.9)
    return ax


#: The cases of the section-4 map: cones (cups, m = 1 and 2) and the planar sawtooth with B < 0 (a dome).
STABILITY_CASES = ((Cone(0.3), 0.8, 1), (Cone(0.3), 0.8, 2), (Cone(0.5), 0.8, 1), (Sawtooth(0.7), 1.0, 1),
                   (Sawtooth(0.7), 1.0, 2))


def stability_figure(path: str | Path, cases: Any = STABILITY_CASES, ratios: Any = None, executor: Any = None) -> Path:
    """Section 4's stability map: simulated growth rates of a small offset against ρ⁻¹ for several
    cases, with the boundary B of (4.3) drawn over them; the numbers go to a CSV beside the PNG."""
    import matplotlib.pyplot as plt

    from ..simulation.section4 import stability_map

    rows = stability_map(list(cases), ratios, executor=executor)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.with_suffix(".csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["case", "B", "rho_inv_over_B", "rho_inv", "growth_simulated", "growth_theory", "status"])
        for row in rows:
            for r, g, th, st in zip(row["ratio"], row["growth"], row["theory"], row["status"]):
                w.writerow([row["label"], row["B"], r, r * row["B"], g, th, st])
    fig, axes = plt.subplots(1, len(rows), figsize=(4.2 * len(rows), 3.8), squeeze=False)
    for ax, row in zip(axes[0], rows):
        B = row["B"]
        x = row["ratio"] * B
        lo, hi = sorted((0.0, B))
        ax.axvspan(lo, hi, color="C2", alpha=0.15, label="stable by (4.3): 0 < ρ⁻¹/B < 1")
        ax.axvline(B, color="k", lw=1)
        ax.axhline(0.0, color="0.5", lw=0.5)
        ax.plot(x, row["theory"], "k-", lw=0.8, label="linear 2×2 map")
        done = np.isfinite(row["growth"])
        grow = done & (row["growth"] > 0)
        ax.scatter(x[done & ~grow], row["growth"][done & ~grow], marker="o", color="C0", label="simulated: decays")
        ax.scatter(x[grow], row["growth"][grow], marker="x", color="C3", label="simulated: grows")
        for xi in x[~done]:  # a run that did not complete within its bounds: shown, not waited on
            ax.axvline(xi, color="C1", ls=":", lw=1)
        ax.set(xlabel="ρ⁻¹ [ω²/g]  (< 0: dome)", ylabel="growth per period", title=row["label"].replace(", e=", "\ne="))
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path)


def _save(fig: object, path: Path) -> Path:
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)  # type: ignore[attr-defined]
    plt.close(fig)  # type: ignore[arg-type]
    return path


def write_all(out: str | Path) -> list[Path]:
    """Write fig1.png, fig2.png, claims.png, rough_vs_coulomb.png, stability_map.png and fig1.csv into ``out``."""
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

    # Fig. 2's idea on a measured-like profile: what two approach directions reach first
    rng = np.random.default_rng(2)
    heights = np.cumsum(rng.normal(0.0, 0.04, 41))
    heights -= np.linspace(heights[0], heights[-1], heights.size)  # periodic
    profile = Profile(heights, 0.05, shadowing=True, periodic=True)
    fig, axes = plt.subplots(2, 1, figsize=(9, 5.5))
    for ax, (ut, title) in zip(axes, ((0.5, "steep incidence, tan β = 0.5"), (3.0, "grazing incidence, tan β = 3"))):
        plot_shadowing(profile, [ut, -1.0], ax)
        ax.set_title(f"Fig. 2: parts of a profile reached first ({title})")
    fig.tight_layout()
    written.append(_save(fig, out / "fig2.png"))

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

    written.append(stability_figure(out / "stability_map.png"))
    return written

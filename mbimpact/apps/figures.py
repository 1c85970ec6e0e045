"""The paper's Fig. 1 and claims 1°–5° of section 3, computed by the library.

Every figure has a data function (tested against the closed forms of :mod:`mbimpact.theory`)
and a function that draws it on a :class:`matplotlib.figure.Figure`; :func:`build_all` makes
them all and ``mbimpact figures --out DIR`` (:func:`write_all`) writes them.
"""

from __future__ import annotations

import csv
import inspect
import math
import textwrap
import warnings
from collections.abc import Callable
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..common.validation import as_array
from ..errors import NoSeparationWarning, ParameterError
from ..laws import CoulombLaw, NewtonLaw, RoughLaw
from ..roughness import Cone, Profile, Sawtooth

__all__ = ["fig1_data", "sawtooth_mu", "claims_data", "rough_vs_coulomb_data", "shadowing_data", "plot_shadowing",
           "fig1_figure", "fig2_figure", "claims_figure", "rough_vs_coulomb_figure", "stability_plot",
           "stability_figure", "Drawn", "build_all", "write_all"]

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
    with warnings.catch_warnings():
        # claim 3° is shown up to steep facets on purpose: beyond cos²α = 1/(1+e) the contact still
        # approaches after the impact (κ < 0), which the figure marks; the warning would only repeat it
        warnings.simplefilter("ignore", NoSeparationWarning)
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


def plot_shadowing(profile: Profile, u: ArrayLike, ax: Any = None, rays: int = 9, unit: str = "mm") -> Any:
    """Draw a profile with the parts an approach along ``u`` reaches first (the idea of the
    paper's Fig. 2): reached parts bold, shadowed ones thin, a few approach lines.

    Parameters
    ----------
    profile : Profile
    u : array_like, shape (2,)
    ax : matplotlib Axes, optional
        Where to draw (a new figure otherwise).
    rays : int
        Number of approach lines drawn (each starts inside the drawn range and stops where it
        first meets the profile).
    unit : str
        Length unit of the profile's abscissa and heights, for the axis labels.

    Returns
    -------
    matplotlib Axes
        Drawn at equal scales, so the approach lines keep their true angle.
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
    travel = slope * drop  # the widest a line can travel sideways before it meets the profile
    first, last = (x[0], x[-1] - travel) if travel >= 0 else (x[0] - travel, x[-1])
    t = np.linspace(0.0, 1.0, 8001)
    for x_start in np.linspace(first, last, rays):
        path = np.column_stack([x_start + travel * t, top - drop * t])
        hit = path[:, 1] <= np.interp(path[:, 0], x, h)
        if hit.any():  # each line stops where it first meets the profile
            ax.annotate("", xy=path[int(np.argmax(hit))], xytext=path[0],
                        arrowprops={"arrowstyle": "->", "color": "C0", "lw": 0.8})
    ax.plot([], [], color="C0", lw=0.8, label="approach along u")
    ax.set(xlabel=f"x [{unit}]", ylabel=f"height [{unit}]", xlim=(x[0], x[-1]),
           ylim=(float(h.min()) - 0.1 * relief, top + 0.1 * relief))
    ax.set_aspect("equal")
    return ax


def fig1_figure(d: dict[str, np.ndarray], alpha: float = 0.5, e: float = 0.5) -> Any:
    """Fig. 1 from :func:`fig1_data`: the friction ratio μ against tan β."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.5, 4.8), layout="constrained")
    ax = fig.subplots()
    ax.plot(d["tan_beta"], d["mu_formula"], "k-", label="sawtooth, formula (3.1)")
    ax.plot(d["tan_beta"], d["mu_sawtooth"], "o", ms=3, label="sawtooth, library (2.8): coincides with (3.1)")
    ax.plot(d["tan_beta"], d["mu_smooth_shadowed"], "--", label="sinusoid of steepest slope tan α, shadowed")
    ax.set(xscale="log", xlabel="tan β = |v_l| / |v_n|  [–]", ylabel="μ = |Δv_l| / |Δv_n|  [–]",
           title=f"Fig. 1: friction ratio of a rough plane, point mass\nfacet tilt α = {alpha:g} rad, "
                 f"facet restitution e = {e:g}")
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def fig2_figure(seed: int = 2) -> Any:
    """Fig. 2's idea on a measured-like profile (a periodic random walk): what two approach
    directions reach first."""
    from matplotlib.figure import Figure

    rng = np.random.default_rng(seed)
    heights = np.cumsum(rng.normal(0.0, 0.04, 41))
    heights -= np.linspace(heights[0], heights[-1], heights.size)  # periodic
    profile = Profile(heights, 0.05, shadowing=True, periodic=True)
    fig = Figure(figsize=(10, 5.2), layout="constrained")
    axes = fig.subplots(2, 1)
    for ax, (ut, what) in zip(axes, ((0.5, "steep"), (3.0, "grazing"))):
        plot_shadowing(profile, [ut, -1.0], ax)
        ax.set_title(f"{what} incidence: u = ({ut:g}, −1), tan β = {ut:g}, β = {math.degrees(math.atan(ut)):.1f}° "
                     "from the normal", fontsize=10)
    fig.suptitle("Fig. 2: the parts of a rough profile an approach reaches first (equal scales)")
    fig.legend(*axes[1].get_legend_handles_labels(), loc="outside lower center", ncols=3, fontsize=9)
    return fig


def claims_figure(c: dict[str, np.ndarray], alpha: float = 0.4, e: float = 0.8) -> Any:
    """Claims 1°–5° of section 3 from :func:`claims_data`, one panel each."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(17, 10), layout="constrained")
    axes = list(fig.subplots(2, 3).flat)
    axes[5].set_visible(False)
    case = f"cone α = {alpha:g} rad, e = {e:g}"
    for k, name in enumerate(("Δv_x (tangential)", "Δv_y (tangential)", "Δv_z (normal)")):
        axes[0].plot(c["scales"], c["dv_over_speed"][:, k], marker="o", label=name)
    axes[0].set(xscale="log", xlabel="speed factor s of v = s·(0.6, 0.3, −1) m/s  [–]", ylabel="Δv / s  [m/s]",
                title=f"1° the velocity change is proportional to the speed: Δv/s is the same over 12 decades of s "
                      f"({case})")
    axes[0].legend(fontsize=8)
    axes[1].plot(np.degrees(c["azimuth"]), c["angle_dvl_vl_deg"], "o")
    axes[1].set(xlabel="azimuth of v_l  [deg]", ylabel="angle between Δv_l and v_l  [deg]", ylim=(170, 190),
                title=f"2° the tangential change opposes the tangential velocity, for every azimuth of v_l "
                      f"(|v_l| = 1.5 |v_n|, {case})")
    crit = math.acos(math.sqrt(1.0 / (1.0 + e)))
    axes[2].axvspan(crit, float(c["alpha"][-1]), color="0.85",
                    label=f"κ < 0 (α > {crit:.2f}):\nstill approaching, on purpose")
    axes[2].plot(c["alpha"], c["kappa_normal"], "o", ms=3, label="library")
    axes[2].plot(c["alpha"], c["kappa_4_2"], "k-", label="(4.2): (1+e) cos²α − 1,\ncoincides")
    axes[2].set(xlabel="facet tilt α  [rad]", ylabel="κ at normal incidence  [–]",
                title=f"3° at normal incidence the law is Newton's, with κ of (4.2) (cones of tilt α, e = {e:g})")
    axes[2].legend(fontsize=8, loc="lower left")
    axes[3].plot(c["tan_beta"], c["kappa_beta"], label="library")
    axes[3].axhline(1.0, color="k", lw=0.5, label="κ = 1")
    axes[3].set(xlabel="tan β = |v_l| / |v_n|, v_n fixed  [–]", ylabel="κ  [–]",
                title=f"4° κ rises with the tangential speed and exceeds 1 ({case})")
    axes[3].legend(fontsize=8)
    axes[4].loglog(c["alpha_small"], c["distance_to_newton"], "o-")
    axes[4].set(xlabel="facet tilt α  [rad]", ylabel="|Δv − Δv_Newton|  [m/s]",
                title=f"5° the smooth limit: Δv tends to Newton's as α → 0, like α² (cones, e = {e:g}, "
                      "v = (0.6, 0.3, −1) m/s)")
    for ax in axes:
        ax.set_title("\n".join(textwrap.wrap(ax.get_title(), 52)), fontsize=11)
        ax.grid(alpha=0.3)
    fig.suptitle("Claims 1°–5° of section 3: a point mass striking a cone of facets (Ivanov's constructive law)")
    return fig


def rough_vs_coulomb_figure(r: dict[str, np.ndarray], alpha: float = 0.4, e: float = 0.8) -> Any:
    """κ(β) and μ(β) of the constructive and the axiomatic law, from :func:`rough_vs_coulomb_data`."""
    from matplotlib.figure import Figure

    from matplotlib.ticker import NullFormatter

    mu = float(r["mu_coulomb_param"])
    stick = math.degrees(math.atan(mu * (1 + e)))  # a point mass slides through iff tan β > μ(1+e)
    fig = Figure(figsize=(11.5, 4.6), layout="constrained")
    axes = fig.subplots(1, 2)
    rough, coulomb = f"constructive: cone α = {alpha:g} rad", f"Coulomb (Stronge, energetic), μ = {mu:.3f}"
    axes[0].plot(r["beta_deg"], r["kappa_rough"], label=rough)
    axes[0].plot(r["beta_deg"], r["kappa_coulomb"], label=f"{coulomb}: κ = e")
    axes[0].set(yscale="log", xlabel="incidence from the normal β  [deg]", ylabel="κ, log scale  [–]",
                title="normal restitution κ")
    axes[0].set_yticks([0.5, 1, 2, 5, 10], ["0.5", "1", "2", "5", "10"])
    axes[0].yaxis.set_minor_formatter(NullFormatter())
    axes[1].plot(r["beta_deg"], r["mu_rough"], label=rough)
    axes[1].plot(r["beta_deg"], r["mu_coulomb"], label=f"{coulomb}: sticks below β = {stick:.1f}°")
    axes[1].set(xlabel="incidence from the normal β  [deg]", ylabel="μ = |P_t| / P_n  [–]",
                title="impulse ratio μ")
    for ax in axes:
        ax.legend(fontsize=8, loc="upper left")
        ax.grid(alpha=0.3)
    fig.suptitle(f"Constructive vs axiomatic impact: point mass, |v| = 1 m/s, e = {e:g}; "
                 "Coulomb's μ is the rough law's at β = 45°")
    return fig


#: The cases of the section-4 map: cones (cups, m = 1 and 2) and the planar sawtooth with B < 0 (a dome).
STABILITY_CASES = ((Cone(0.3), 0.8, 1), (Cone(0.3), 0.8, 2), (Cone(0.5), 0.8, 1), (Sawtooth(0.7), 1.0, 1),
                   (Sawtooth(0.7), 1.0, 2))

#: ρ⁻¹/B of the stability map's simulations: −1.5 to 1.5, the band 0 < ρ⁻¹/B < 1 of (4.3) and both sides of it.
MAP_RATIOS = np.linspace(-1.5, 1.5, 13)

#: |growth per period| below which a simulated point counts as on the boundary (neither grows nor decays).
NEUTRAL = 1e-6


def stability_plot(rows: list[dict[str, Any]], cases: Any = STABILITY_CASES) -> Any:
    """Section 4's stability map from :func:`mbimpact.simulation.section4.stability_map`'s rows."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    from ..simulation.section4 import deviation_run, stability_map

    given = inspect.signature(stability_map).parameters
    freq = inspect.signature(deviation_run).parameters["frequency"].default
    fig = Figure(figsize=(4.4 * len(rows), 5.4), layout="constrained")
    axes = fig.subplots(1, len(rows), squeeze=False)[0]
    for ax, row, (rough, e, m) in zip(axes, rows, cases):
        B = row["B"]
        x = row["ratio"] * B
        lo, hi = sorted((0.0, B))
        ax.axvspan(lo, hi, color="C2", alpha=0.15, label="stable by (4.3): 0 < ρ⁻¹/B < 1")
        ax.axvline(B, color="C2", lw=1.5, ls="--", label="ρ⁻¹ = B, the bound of (4.3)")
        ax.axhline(0.0, color="0.5", lw=0.5, label="zero growth")
        ax.plot(x, row["theory"], "k-", lw=0.8, label="linear theory (2×2 map)")
        g = row["growth"]
        done = np.isfinite(g)
        for sel, style in ((done & (g < -NEUTRAL), {"marker": "o", "color": "C0", "label": "simulated: decays"}),
                           (done & (np.abs(g) <= NEUTRAL), {"marker": "D", "color": "C1",
                                                            "label": f"simulated: neutral, |growth| ≤ {NEUTRAL:g}"}),
                           (done & (g > NEUTRAL), {"marker": "x", "color": "C3", "label": "simulated: grows"})):
            ax.scatter(x[sel], g[sel], zorder=3, **style)
        for xi in x[~done]:  # a run that did not complete within its bounds: shown, not waited on
            ax.axvline(xi, color="C4", ls=":", lw=1, label="run not completed")
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.set(xlabel="surface curvature ρ⁻¹, < 0: dome  [ω²/g]", ylabel="growth of the offset  [1/period]",
               title=f"{type(rough).__name__.lower()} α = {rough.alpha:g} rad, e = {e:g}, m = {m}\n"
                     f"B = {B:.3g} ω²/g: stabilised by a {'cup' if B > 0 else 'dome'}")
        ax.grid(alpha=0.3)
    labels: dict[str, Any] = {}
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels()):
            labels.setdefault(label, h)
    fig.legend(labels.values(), labels.keys(), loc="outside lower center", ncols=min(6, len(labels)), fontsize=10)
    fig.suptitle(f"Section 4: bouncing along the axis of a rough surface of revolution vibrating at {freq:g} Hz "
                 f"(point mass; {given['periods'].default} periods simulated from a {given['x0'].default:g} m "
                 "offset)\nm = period of the bouncing / period of the surface;  growth = ln of the largest "
                 "|eigenvalue| of the horizontal offset's map over one bouncing period (< 0: the offset decays)",
                 fontsize=11)
    return fig


def _stability_rows(rows: list[dict[str, Any]]) -> list[list[Any]]:
    """The stability map as CSV rows, a header first."""
    out: list[list[Any]] = [["case", "B", "rho_inv_over_B", "rho_inv", "growth_simulated", "growth_theory", "status"]]
    for row in rows:
        for r, g, th, st in zip(row["ratio"], row["growth"], row["theory"], row["status"]):
            out.append([row["label"], row["B"], r, r * row["B"], g, th, st])
    return out


def _write_csv(table: list[list[Any]], path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows(table)
    return path


def stability_figure(path: str | Path, cases: Any = STABILITY_CASES, ratios: Any = None, executor: Any = None) -> Path:
    """Section 4's stability map: simulated growth rates of a small offset against ρ⁻¹ for several
    cases, with the boundary B of (4.3) drawn over them; the numbers go to a CSV beside the PNG."""
    from ..simulation.section4 import stability_map

    rows = stability_map(list(cases), ratios, executor=executor)
    path = Path(path)
    _write_csv(_stability_rows(rows), path.with_suffix(".csv"))
    return _save(stability_plot(rows, cases), path)


class _Counting(Executor):
    """An executor that runs on another and calls ``done`` as each job finishes (for a progress display)."""

    def __init__(self, inner: Executor, done: Callable[[], None]) -> None:
        self._inner, self._done = inner, done

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        future = self._inner.submit(fn, *args, **kwargs)
        future.add_done_callback(lambda _: self._done())
        return future


@dataclass(frozen=True)
class Drawn:
    """One output of ``mbimpact figures``: its file stem, the figure, and the numbers behind it (CSV rows)."""

    name: str
    figure: Any
    table: list[list[Any]] | None = None


def build_all(ratios: Any = None, executor: Executor | None = None, progress: bool = True) -> list[Drawn]:
    """Compute and draw Fig. 1, Fig. 2, claims 1°–5°, constructive vs axiomatic, and the stability map.

    Parameters
    ----------
    ratios : array_like, optional
        ρ⁻¹/B of the stability map's simulations (default :data:`MAP_RATIOS`, 13 per case).
    executor : Executor, optional
        Where the stability map's simulations run (default a process pool).
    progress : bool
        Draw a progress bar on stderr when it is a terminal.

    Returns
    -------
    list of Drawn
        ``fig1`` (with its data), ``fig2``, ``claims``, ``rough_vs_coulomb``, ``stability_map`` (with its data).
    """
    from ..simulation.section4 import stability_map
    from .progress import Progress

    ratios = MAP_RATIOS if ratios is None else np.atleast_1d(np.asarray(ratios, dtype=float))
    bar = Progress(4 + len(STABILITY_CASES) * len(ratios), "mbimpact figures", enabled=progress)
    out = []
    d = fig1_data()
    out.append(Drawn("fig1", fig1_figure(d), [list(d)] + [list(r) for r in zip(*d.values())]))
    bar.step("Fig. 1")
    out.append(Drawn("fig2", fig2_figure()))
    bar.step("Fig. 2")
    out.append(Drawn("claims", claims_figure(claims_data())))
    bar.step("claims 1°-5°")
    out.append(Drawn("rough_vs_coulomb", rough_vs_coulomb_figure(rough_vs_coulomb_data())))
    bar.step("rough vs Coulomb")
    inner = executor or ProcessPoolExecutor()
    try:
        rows = stability_map(list(STABILITY_CASES), ratios,
                             executor=_Counting(inner, lambda: bar.step("stability map")))
    finally:
        if executor is None:
            inner.shutdown()
        bar.close()
    out.append(Drawn("stability_map", stability_plot(rows), _stability_rows(rows)))
    return out


def _save(fig: Any, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    return path


def write_all(out: str | Path, progress: bool = True, ratios: Any = None, executor: Executor | None = None) -> list[Path]:
    """Write fig1.png, fig1.csv, fig2.png, claims.png, rough_vs_coulomb.png, stability_map.png and
    stability_map.csv into ``out`` (arguments as for :func:`build_all`)."""
    out = Path(out)
    written = []
    for d in build_all(ratios, executor, progress):
        written.append(_save(d.figure, out / f"{d.name}.png"))
        if d.table is not None:
            written.append(_write_csv(d.table, out / f"{d.name}.csv"))
    return written

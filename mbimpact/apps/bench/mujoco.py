"""mbimpact and MuJoCo on the same scenes, in the same run, with MuJoCo set up as its users would.

Optional: needs the ``mujoco`` package (``pip install mbimpact[bench]``); without it the part is
skipped (:data:`UNAVAILABLE` says so).

**MuJoCo's contact.** Every impact scene has one mass-normalised stiffness k = :data:`STIFFNESS`
(ω₀ = √k, a contact of about 1 ms) at every time step, so that a smaller step resolves the same
contact more finely. The damping comes from the scene's e through the clipped linear dashpot
(:mod:`~mbimpact.apps.bench.mujoco_contact`: MuJoCo's contact force cannot pull, so its restitution
is exp(−β(π − 2 arctan β)), β = ζ/√(1 − ζ²)); ``solref = (−k, −2ζ√k)``, ``solimp`` flat at 0.99
(:data:`SOLIMP`), elliptic cones, only mbimpact's contact pairs (explicit ``<pair>``). Under
Coulomb's impact law (the oblique sphere) ``solreffriction = (−k, −2√k)``, so that a slip stops
within the contact; under Newton's (no friction in the impact) MuJoCo's default, friction rows as
slow as the normal's damping. Both of MuJoCo's explicit integrators
are run, Euler (semi-implicit, joint damping implicit) and RK4, at each time step of
:data:`TIMESTEPS` (``--quick``: :data:`QUICK_TIMESTEPS`); mbimpact at each ``rtol`` of :data:`RTOLS`
(``--quick``: :data:`QUICK_RTOLS`).

**Onset phases.** A contact that begins just after a step is resolved differently from one that
begins just before the next. Each MuJoCo setting is measured :data:`PHASES` times, its step grid
shifted by φ·dt, φ = 1/8 … 1 (:mod:`~mbimpact.apps.bench.mujoco_runs`); its error is the worst of
them, and their mean is in the row's ``method``.

**Outcomes.**

* ``ball_drop`` — a sphere of mbimpact's mass, radius :data:`BALL_RADIUS`, its lowest point where
  mbimpact's point mass starts, frictionless: the apex of its lowest point after the first bounce
  (its ballistic apex from the state in which the contact ended) against e²h.
* ``ur5_forearm_box`` — the first impact's restitution κ = −u_n⁺/u_n⁻ against e, for each object
  that struck (:func:`~mbimpact.apps.bench.mujoco_runs.first_impact`); the error is the worst object's.
* ``solo12_geometry_landing`` — Solo12's feet leave the ground for 0.77 ms after their first impact,
  less than one MuJoCo contact lasts, so κ is not defined there; the outcome is the base's vertical
  velocity (world frame) from :data:`WINDOW` after the impact, as far as it differs from that of
  mbimpact at rtol = 1e-10: max |Δv_z| / |v_z⁻|.
* ``oblique sphere`` — a solid sphere (``models/sphere.urdf``) striking a plane obliquely without
  gravity, e = :data:`OBLIQUE_E`, μ = :data:`OBLIQUE_MU`, v_t/v_n = :data:`OBLIQUE_RATIO`, against
  the rigid prediction of mbimpact's CoulombLaw. The sphere's Delassus matrix is diagonal, W_nn = 1/m,
  W_tt = 1/m + r²/I = 7/(2m): the slip decelerates by μW_tt per unit normal impulse and stops at
  p_n = v_t/(μ W_tt), within the impact when v_t/v_n ≤ (7/2) μ (1 + e) = 1.89; it then sticks
  (W_tn = 0 ≤ μ W_tt), so that u_t⁺ = 0, P_t = −(2/7) m v_t: the centre's tangential velocity after is
  5/7 of before, the spin ω r = 5/7 v_t, and the normal velocity is −e times before (W_nt = 0: Newton,
  Poisson and Stronge agree). The error is the larger of the relative errors of the two velocities.

Both robots are MuJoCo's own import of the same URDF with its STL collision meshes (convex hulls in
both simulators, ``package://`` paths made absolute, visuals discarded), joint ranges dropped
(mbimpact has no joint limits), joint damping and PD torques (affine position actuators, the same
kp, kd) as in the scene.

**Timings.** Every setting is timed :data:`REPEATS` times (``--quick``: :data:`QUICK_REPEATS`),
the settings of a scene in alternation, round after round; the median is reported. mbimpact's time
is that of :func:`mbimpact.simulate` on the whole scene (which also records its samples and
events), after one untimed run (the process's first run loads the compiled kernels); MuJoCo's is
that of one bare ``mj_step(m, d, nstep)`` over the scene's duration, single-threaded.

Rows (``part == "mujoco"``):

* accuracy rows, one per scene and setting: ``case`` the scene, its simulated seconds and MuJoCo's
  ``solref`` for its e; ``method`` the simulator, its setting, what it measured and (MuJoCo) the mean
  error over the onset phases; ``param`` the deepest penetration [m]; ``error`` the relative error of
  the outcome, signed, the worst phase; ``seconds`` the median warm wall time; ``ratio`` that time
  over mbimpact's at rtol = 1e-10 on the same scene.
* equal-accuracy rows (``method`` starting with ``"at equal accuracy"``), per scene with a rigid
  prediction and tolerance of :data:`TOLERANCES`: the cheapest setting of each simulator whose worst
  error is within the tolerance; ``param`` the tolerance, ``error`` MuJoCo's error there,
  ``seconds`` MuJoCo's wall time, ``ratio`` MuJoCo's over mbimpact's (NaN: not reached).
* contact-phase rows (``case`` starting with one of :data:`STANDING`): Solo12 standing on its point
  feet, and in full runs Talos on its soles' corners and a UR5 resting its tool on a table
  (:func:`~mbimpact.apps.bench.mujoco_standing.standing_rows`); ``param`` simulated seconds per wall
  second, ``error`` the largest difference of a contact point's height from mbimpact's at the end [m],
  ``seconds`` the median warm wall time, ``ratio`` over mbimpact's.

A scene MuJoCo cannot load or express gives one row whose ``method`` is
``"MuJoCo: skipped (<reason>)"``, with NaN numbers.
"""

from __future__ import annotations

import math

from ..progress import Progress
from .common import BenchRow
from .mujoco_contact import SOLIMP, STIFFNESS, contact_solref, damping_ratio, friction_solref
from .mujoco_models import BALL_RADIUS
from .mujoco_scenes import (OBLIQUE_E, OBLIQUE_MU, OBLIQUE_RATIO, PHASES, QUICK_REPEATS, QUICK_RTOLS,
                           QUICK_TIMESTEPS, REPEATS, RTOLS, SCENES, TIMESTEPS, TOLERANCES, WINDOW,
                           equal_accuracy_rows, oblique_rows, scene_rows)
from .mujoco_standing import STANDING, standing_rows

__all__ = ["available", "mujoco_rows", "format_rows", "damping_ratio", "contact_solref", "friction_solref",
           "UNAVAILABLE", "SCENES", "STIFFNESS", "SOLIMP", "BALL_RADIUS", "QUICK_TIMESTEPS", "TIMESTEPS",
           "RTOLS", "QUICK_RTOLS", "PHASES", "TOLERANCES", "WINDOW", "STANDING", "OBLIQUE_E", "OBLIQUE_MU",
           "OBLIQUE_RATIO", "REPEATS", "QUICK_REPEATS"]

#: The line printed instead of the part when ``mujoco`` cannot be imported.
UNAVAILABLE = "mujoco: part skipped, the optional mujoco package is not installed (pip install 'mbimpact[bench]')"


def available() -> bool:
    """Whether the ``mujoco`` package can be imported."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


def mujoco_rows(quick: bool, progress: Progress) -> list[BenchRow]:
    """Rows of part ``"mujoco"`` (see the module docstring).

    Three progress steps: the ball and the sphere, the two robots, the contact phases.
    """
    import mujoco

    rows: list[BenchRow] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: None)  # an unstable setting is detected and said in its row
    try:
        rows += scene_rows(mujoco, SCENES[0], quick) + oblique_rows(mujoco, quick)
        progress.step("ball, sphere")
        for name in SCENES[1:]:
            rows += scene_rows(mujoco, name, quick)
        progress.step("robots")
        rows += equal_accuracy_rows(rows)
        rows += standing_rows(mujoco, quick)
        progress.step("standing")
    finally:
        mujoco.set_mju_user_warning(previous)
    return rows


def _num(x: float, fmt: str) -> str:
    return "" if math.isnan(x) else format(x, fmt)


def format_rows(rows: list[BenchRow]) -> str:
    """The markdown tables of these rows (what ``report.py`` prints for the part)."""
    mine = [r for r in rows if r.part == "mujoco"]
    equal = [r for r in mine if r.method.startswith("at equal accuracy")]
    standing = [r for r in mine if r.case.startswith(STANDING)]
    accuracy = [r for r in mine if r not in equal and r not in standing]
    k = STIFFNESS
    lines = ["## Against MuJoCo on the same scenes, in one run", "",
             f"MuJoCo: stiffness k = {k:.3g} s⁻² (ω₀ = {math.sqrt(k):.0f} rad/s) at every dt, damping from e by the "
             f"clipped dashpot, solimp = ({', '.join(f'{x:g}' for x in SOLIMP)}), elliptic cones, solreffriction = "
             f"({friction_solref(k)[0]:.3g}, {friction_solref(k)[1]:.4g}) under Coulomb's impact law (the sphere); "
             f"errors: the worst of "
             f"{PHASES} contact-onset phases within a step (their mean in the setting's text); wall times: medians "
             "of warm runs, the simulators alternated.", "",
             "| scene | simulator, setting: outcome | rel. error (worst phase) | deepest penetration [m] | wall s "
             "| wall s / mbimpact's |", "|---|---|---|---|---|---|"]
    lines += [f"| {r.case} | {r.method} | {_num(r.error, '+.2e')} | {_num(r.param, '.2g')} | {_num(r.seconds, '.3g')} "
              f"| {_num(r.ratio, '.3g')} |" for r in accuracy]
    if equal:
        lines += ["", "### Wall time at equal accuracy (the cheapest measured setting of each within the tolerance)",
                  "", "| scene | tolerance | settings | MuJoCo's error | MuJoCo wall s | MuJoCo / mbimpact |",
                  "|---|---|---|---|---|---|"]
        lines += [f"| {r.case} | {r.param:.0e} | {r.method.split(': ', 1)[1]} | {_num(r.error, '+.2e')} "
                  f"| {_num(r.seconds, '.3g')} | {_num(r.ratio, '.3g') or 'not reached'} |" for r in equal]
    if standing:
        lines += ["", "### Contact phase: robots standing or resting on their contact points, PD torques", "",
                  "| case | simulator, setting: outcome | simulated s per wall s | contact heights' largest difference "
                  "to mbimpact's [m] | wall s | wall s / mbimpact's |", "|---|---|---|---|---|---|"]
        lines += [f"| {r.case} | {r.method} | {_num(r.param, '.3g')} | {_num(r.error, '.2g')} | {_num(r.seconds, '.3g')} "
                  f"| {_num(r.ratio, '.3g')} |" for r in standing]
    return "\n".join(lines)

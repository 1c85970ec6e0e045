"""Command line: ``mbimpact demo|compare|figures|bench|run|scene|fit``.

Every mistake on the command line or in its inputs ends with a one-line message on stderr
and exit status 2 — never a traceback; a simulation that does not complete exits with 3.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable
from pathlib import Path

from ..errors import ImpactError, NotPositiveDefiniteError, ParameterError

__all__ = ["main"]


def _finite(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return x


def _positive_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be ≥ 1, got {n}")
    return n


def _count(hi: int) -> Callable[[str], int]:
    """An argument type: an integer in [1, ``hi``] (the bound keeps a typo from exhausting memory)."""

    def parse(text: str) -> int:
        n = _positive_int(text)
        if n > hi:
            raise argparse.ArgumentTypeError(f"must be ≤ {hi}, got {n}")
        return n

    return parse


def _within(lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False) -> Callable[[str], float]:
    """An argument type: a finite number in the interval from ``lo`` to ``hi`` (ends open where asked)."""
    lb, rb = ("(" if lo_open else "["), (")" if hi_open else "]")

    def parse(text: str) -> float:
        x = _finite(text)
        if (x <= lo if lo_open else x < lo) or (x >= hi if hi_open else x > hi):
            raise argparse.ArgumentTypeError(f"must be in {lb}{lo:g}, {hi:g}{rb}, got {text!r}")
        return x

    return parse


def _vector(text: str) -> list[float]:
    """Comma-separated finite numbers, e.g. ``0,-1.2,1.6``."""
    return [_finite(x.strip()) for x in text.split(",")]


def _out_dir(text: str) -> Path:
    """A directory that exists (or can be made) and can be written to."""
    if "\x00" in text:
        raise argparse.ArgumentTypeError(f"{text!r} is not a valid path: it contains a null byte")
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} exists and is not a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"cannot create the directory {text!r}: {exc.strerror}") from None
    if not os.access(path, os.W_OK):
        raise argparse.ArgumentTypeError(f"cannot write to the directory {text!r}")
    return path


def _out_file(text: str) -> Path:
    """A file whose directory can be written to (and that is not a directory)."""
    if "\x00" in text:
        raise argparse.ArgumentTypeError(f"{text!r} is not a valid path: it contains a null byte")
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is a directory; give a file name")
    _out_dir(str(path.parent or "."))
    return path


def _demo(args: argparse.Namespace) -> int:
    from .compare import format_table, write_csv
    from .demo import demo_rows

    rows = demo_rows(e=args.e)
    print(f"UR5 tool0 striking a table at 1 m/s, facet restitution e = {args.e:g}\n")
    print(format_table(rows))
    if args.out:
        print(f"\nwrote {write_csv(rows, args.out)}")
    return 0


def _bench(args: argparse.Namespace) -> int:
    from .bench import PARTS, format_report, plot, run_bench, write_csv

    command = " ".join(["mbimpact bench", *(["--quick"] if args.quick else []),
                        *(f"--part {p}" for p in args.parts or ())])
    rows = run_bench(quick=args.quick, show_progress=not args.no_progress, parts=tuple(args.parts or PARTS))
    report = format_report(rows, command=command)
    print(report)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "report.md").write_text(report + "\n")
        print(f"\nwrote {out / 'report.md'}")
        print(f"wrote {write_csv(rows, out / 'bench.csv')}")
        print(f"wrote {plot(rows, out / 'bench.png')}")
    return 0


def _compare(args: argparse.Namespace) -> int:
    import numpy as np

    from . import compare as cmp
    from ..mechanism import PointContact
    from ..laws import CoulombLaw
    from .demo import UR5_POSTURE
    from ..laws import NewtonLaw
    from ..mechanism import Mechanism
    from ..laws import RoughLaw
    from ..roughness import Cone, Sawtooth

    mech = Mechanism.from_urdf(args.urdf, args.floating) if args.urdf else Mechanism.from_robot(args.robot)
    if args.q is not None:
        q = mech.check_configuration(np.array(args.q))
    else:
        q = UR5_POSTURE if (args.robot == "ur5" and not args.urdf) else mech.neutral()
    if not mech.factorise(q)[1].valid:  # the approach velocity solves with A(q): name a singular one first
        raise NotPositiveDefiniteError(f"the mass matrix of {mech.name} at this posture is not positive definite "
                                       "(massless links or joints without inertia); compare needs one")
    rough = Sawtooth(args.alpha) if args.planar else Cone(args.alpha)
    laws = {
        f"Newton e={args.e:g}": NewtonLaw(args.e),
        f"rough {type(rough).__name__} alpha={args.alpha:g}": RoughLaw(rough, args.e),
        f"Coulomb mu={args.mu:g} ({args.restitution})": CoulombLaw(args.e, args.mu, args.restitution),
    }
    for name in args.facet or ():  # the rough law again, with another impact on each facet
        from ..facets import CompliantFacet, CoulombFacet, HuntCrossleyFacet

        facet = {"coulomb": lambda: CoulombFacet(args.e, args.mu),
                 "compliant": lambda: CompliantFacet(args.e, args.mu, args.stiffness_ratio),
                 # e(v) ≈ 1 − α v: the facet restitution is e at the approach speed
                 "hunt-crossley": lambda: HuntCrossleyFacet((1.0 - args.e) / args.speed)}[name]()
        laws[f"rough {type(rough).__name__} alpha={args.alpha:g}, {name} facets"] = RoughLaw(rough, facet=facet)
    contact = PointContact(args.frame, normal=np.array([0.0, 0.0, 1.0]), tangent=np.array([1.0, 0.0, 0.0]))
    betas = np.linspace(0.0, args.max_beta, args.steps)
    rows = cmp.compare_laws(mech, q, contact, laws, betas, args.speed)
    shown = {float(b) for b in betas[:: max(1, len(betas) // 8)]} | {float(betas[-1])}
    print(f"{mech.name} {args.frame}, approach speed {args.speed:g} m/s\n")
    print(cmp.format_table([r for r in rows if r.beta_deg in shown]))
    if args.out:
        out = Path(args.out)
        print(f"\nwrote {cmp.write_csv(rows, out / 'compare.csv')}")
        print(f"wrote {cmp.plot(rows, out / 'compare.png', f'{mech.name} {args.frame}')}")
    return 0


def _figures(args: argparse.Namespace) -> int:
    from .figures import write_all

    out = args.out
    if out is None:  # the default, ./figures, is made only when the figures are written
        try:
            out = _out_dir("figures")
        except argparse.ArgumentTypeError as exc:
            raise ParameterError(f"--out (default ./figures): {exc}") from None
    for path in write_all(out, progress=not args.no_progress):
        print(f"wrote {path}")
    return 0


def _run(args: argparse.Namespace) -> int:
    from ..simulation import load_scene, simulate
    from .report import summary, write_outputs

    from .progress import Progress

    scene = load_scene(args.scene)
    bar = Progress(100, scene.name, enabled=not args.no_progress)
    tr = simulate(scene, progress=lambda percent, note: bar.step(note))
    print(summary(scene, tr))
    if args.out:
        for path in write_outputs(scene, tr, args.out):
            print(f"wrote {path}")
    return 0 if tr.completed else 3


def _scene(args: argparse.Namespace) -> int:
    from ..simulation import SceneContact, load_scene, scene_names

    if not args.scene:
        print("shipped scenes: " + ", ".join(scene_names()))
        return 0
    scene = load_scene(args.scene)
    print(f"{scene.name}: valid; {scene.mechanism.name} (nq = {scene.mechanism.nq}, nv = {scene.mechanism.nv}), "
          f"{len(scene.contacts)} contact(s), {scene.duration:g} s")
    for i, c in enumerate(scene.contacts):
        where = (f"{c.frame} on a {c.surface.kind}{' (moving)' if c.surface.moving else ''}"
                 if isinstance(c, SceneContact) else f"collision pair {c.label}")
        print(f"  contact {i}: {where}, {c.law!r}, persistent friction mu = {c.friction:g}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mbimpact`` console script."""
    from .. import __version__
    from ..simulation.schema import reference
    from .fit import add_parser as add_fit_parser

    parser = argparse.ArgumentParser(prog="mbimpact", description="Impacts of mechanisms on rough surfaces (Ivanov's constructive model).")
    parser.add_argument("--version", action="version", version=f"mbimpact {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="UR5 tool hitting a table: Newton vs rough law")
    demo.add_argument("--out", type=_out_file, help="also write the table as CSV to this file")
    demo.add_argument("--e", type=_finite, default=0.8, help="facet restitution (default 0.8)")
    demo.set_defaults(func=_demo)
    bench = sub.add_parser("bench", help="accuracy vs time, overhead against Pinocchio, batch throughput, scenes")
    bench.add_argument("--quick", action="store_true", help="small grids (< 30 s)")
    bench.add_argument("--out", type=_out_dir, help="directory for report.md (the tables, with the machine, versions and date), "
                                                         "bench.csv and bench.png")
    bench.add_argument("--no-progress", action="store_true", help="do not draw the progress bar")
    bench.add_argument("--part", dest="parts", action="append",
                       choices=["accuracy", "compliant", "overhead", "batch", "configurations", "coulomb", "threads",
                                "import", "first-run", "geometry", "scenes", "mujoco"],  # bench.PARTS (not imported here: start-up)
                       help="run only this part (repeatable; default all)")
    bench.set_defaults(func=_bench)
    cmp = sub.add_parser("compare", help="Newton vs rough vs Coulomb law over the incidence angle")
    src = cmp.add_mutually_exclusive_group()
    src.add_argument("--robot", default="ur5", help="example-robot-data robot (default ur5)")
    src.add_argument("--urdf", help="URDF file instead of a robot name")
    cmp.add_argument("--floating", action="store_true", help="free-flyer root for --urdf")
    cmp.add_argument("--frame", default="tool0", help="contact frame (default tool0)")
    cmp.add_argument("--q", type=_vector, help="posture, comma-separated (default: neutral; UR5: over the table)")
    cmp.add_argument("--speed", type=_within(0.0, 1e100, lo_open=True), default=1.0,
                     help="approach speed of the contact point [m/s], 0 < speed ≤ 1e100")
    cmp.add_argument("--alpha", type=_finite, default=0.3, help="roughness tilt α of the rough law")
    cmp.add_argument("--planar", action="store_true", help="planar sawtooth instead of a spatial cone")
    cmp.add_argument("--e", type=_finite, default=0.8, help="restitution of all laws")
    cmp.add_argument("--mu", type=_finite, default=0.3, help="Coulomb friction coefficient")
    cmp.add_argument("--restitution", default="energetic", choices=["newton", "poisson", "energetic"])
    cmp.add_argument("--facet", action="append", choices=["coulomb", "compliant", "hunt-crossley"],
                     help="also the rough law with this facet law (repeatable; mu and e as above; hunt-crossley: "
                          "facet restitution e at the approach speed)")
    cmp.add_argument("--stiffness-ratio", type=_within(0.0, 1e6, lo_open=True), default=0.8,
                     help="compliant facets: tangential to normal stiffness ratio (default 0.8)")
    cmp.add_argument("--max-beta", type=_within(0.0, 90.0, hi_open=True), default=85.0,
                     help="largest incidence angle [deg], 0 ≤ β < 90")
    cmp.add_argument("--steps", type=_count(10_000), default=35, help="number of incidence angles, 1 … 10000")
    cmp.add_argument("--out", type=_out_dir, help="directory for compare.csv and compare.png")
    cmp.set_defaults(func=_compare)
    figs = sub.add_parser("figures", help="the paper's Fig. 1 and 2, claims 1°-5°, section 4's stability map")
    # no default here: argparse would convert (and so create) ./figures whenever the subcommand is parsed
    figs.add_argument("--out", type=_out_dir, help="output directory (default ./figures)")
    figs.add_argument("--no-progress", action="store_true", help="do not draw the progress bar")
    figs.set_defaults(func=_figures)
    run = sub.add_parser("run", help="simulate a scene (a TOML file or a shipped scene name)")
    run.add_argument("scene", help="path to a scene TOML, or a name from models/scenes")
    run.add_argument("--out", type=_out_dir, help="directory for trajectory.csv, events.csv and plots.png")
    run.add_argument("--no-progress", action="store_true", help="do not draw the progress bar")
    run.set_defaults(func=_run)
    scene = sub.add_parser("scene", help="check a scene file; --help prints the scene-file reference",
                           formatter_class=argparse.RawDescriptionHelpFormatter, epilog=reference())
    scene.add_argument("scene", nargs="?", help="path to a scene TOML, or a shipped name (none: list them)")
    scene.set_defaults(func=_scene)
    add_fit_parser(sub)
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except ImpactError as exc:
        print(f"mbimpact: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file that could not be written after all (disk full, removed directory)
        print(f"mbimpact: error: {exc}", file=sys.stderr)
        return 2

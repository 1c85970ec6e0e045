"""Command line: ``mbimpact demo|bench``."""

from __future__ import annotations

import argparse
import sys

from .errors import ImpactError

__all__ = ["main"]


def _demo(args: argparse.Namespace) -> int:
    from .demo import demo_rows, format_table, write_csv

    rows = demo_rows(e=args.e)
    print(f"UR5 tool0 striking a table at 1 m/s, facet restitution e = {args.e:g}\n")
    print(format_table(rows))
    if args.out:
        print(f"\nwrote {write_csv(rows, args.out)}")
    return 0


def _bench(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .bench import format_report, plot, run_bench, write_csv

    rows = run_bench(quick=args.quick, show_progress=not args.no_progress)
    print(format_report(rows))
    if args.out:
        out = Path(args.out)
        print(f"\nwrote {write_csv(rows, out / 'bench.csv')}")
        print(f"wrote {plot(rows, out / 'bench.png')}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mbimpact`` console script."""
    parser = argparse.ArgumentParser(prog="mbimpact", description="Impacts of mechanisms on rough surfaces (Ivanov's constructive model).")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="UR5 tool hitting a table: Newton vs rough law")
    demo.add_argument("--out", help="also write the table as CSV to this file")
    demo.add_argument("--e", type=float, default=0.8, help="facet restitution (default 0.8)")
    demo.set_defaults(func=_demo)
    bench = sub.add_parser("bench", help="accuracy vs time, overhead against Pinocchio, batch throughput")
    bench.add_argument("--quick", action="store_true", help="small grids (< 20 s)")
    bench.add_argument("--out", help="directory for bench.csv and bench.png")
    bench.add_argument("--no-progress", action="store_true", help="do not draw the progress bar")
    bench.set_defaults(func=_bench)
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except ImpactError as exc:
        print(f"mbimpact: error: {exc}", file=sys.stderr)
        return 2

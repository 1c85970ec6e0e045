"""Command line: ``mbimpact demo [--out FILE.csv]``."""

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


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mbimpact`` console script."""
    parser = argparse.ArgumentParser(prog="mbimpact", description="Impacts of mechanisms on rough surfaces (Ivanov's constructive model).")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="UR5 tool hitting a table: Newton vs rough law")
    demo.add_argument("--out", help="also write the table as CSV to this file")
    demo.add_argument("--e", type=float, default=0.8, help="facet restitution (default 0.8)")
    demo.set_defaults(func=_demo)
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except ImpactError as exc:
        print(f"mbimpact: error: {exc}", file=sys.stderr)
        return 2

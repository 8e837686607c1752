"""The ``catadioptric`` command. Subcommands import their heavy dependencies lazily."""
from __future__ import annotations

import argparse
import sys


def _demo(args) -> int:
    from .demo import run_geometry_demo

    run_geometry_demo(args.out, rig=args.rig)
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="catadioptric", description=__doc__)
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="geometry demo: back-projection, forward projection, images of 3D lines")
    d.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    d.add_argument("--rig", default="hyperboloid_9pct", help="rig preset (default: hyperboloid_9pct)")
    d.set_defaults(func=_demo)
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except Exception as exc:  # report bad input clearly, keep tracebacks for real bugs
        from ._checks import CatadioptricError

        if isinstance(exc, CatadioptricError):
            print(f"catadioptric: error: {exc}", file=sys.stderr)
            return 2
        raise


if __name__ == "__main__":
    sys.exit(main())

"""The ``catadioptric`` command. Each subcommand lives with its stage and imports its
heavy dependencies only when it runs."""
from __future__ import annotations

import argparse
import importlib
import sys

# modules that define ``register(subparsers)``; each adds its subcommand(s)
SUBCOMMAND_MODULES = [
    "catadioptric.demo",
    "catadioptric.centrality",
    "catadioptric.render.cli",
    "catadioptric.validate.cli",
]


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="catadioptric", description="Exact geometry of catadioptric cameras.")
    sub = p.add_subparsers(dest="command", required=True)
    for name in SUBCOMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except Exception as exc:  # bad input gets a one-line message; real bugs keep their traceback
        from ._checks import CatadioptricError

        if isinstance(exc, CatadioptricError):
            print(f"catadioptric: error: {exc}", file=sys.stderr)
            return 2
        raise


if __name__ == "__main__":
    sys.exit(main())

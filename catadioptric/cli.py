"""The ``catadioptric`` command. Each subcommand lives with its stage and imports its
heavy dependencies only when it runs; what they share (one-line errors, ``--rig``,
checked flags) is in :mod:`catadioptric.cliargs`."""
from __future__ import annotations

import importlib
import shlex
import sys

from .cliargs import Parser, print_error

# modules that define ``register(subparsers)``; each adds its subcommand(s)
SUBCOMMAND_MODULES = [
    "catadioptric.demo",
    "catadioptric.cli_centrality",
    "catadioptric.render.cli",
    "catadioptric.validate.cli",
    "catadioptric.export",
    "catadioptric.detect.cli",
    "catadioptric.twoview",
    "catadioptric.cli_chessboard",
]


def build_parser() -> Parser:
    from . import __version__

    p = Parser(prog="catadioptric", description="Exact geometry of catadioptric cameras.")
    p.add_argument("--version", action="version", version=f"catadioptric {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    for name in SUBCOMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if argv is not None and getattr(args, "command_line", "") is None:
        # reports give the command that made them: the arguments given, not the process's own
        args.command_line = "catadioptric " + " ".join(shlex.quote(str(a)) for a in argv)
    try:
        return int(args.func(args) or 0)
    except Exception as exc:  # bad input gets a one-line message; real bugs keep their traceback
        from ._checks import CatadioptricError
        from ._extras import missing_extra

        missing = missing_extra(exc)
        if missing is not None:
            return print_error(str(missing))
        if isinstance(exc, CatadioptricError):
            return print_error(str(exc))
        raise


if __name__ == "__main__":
    sys.exit(main())

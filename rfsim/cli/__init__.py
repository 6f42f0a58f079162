"""The ``rfsim`` command line.

Each subcommand lives in its own module with ``add_parser(subparsers)`` and
``run(args) -> int``. User mistakes (:class:`rfsim.errors.UserError`, which includes
config errors) print one line to stderr and exit with status 2 — never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

import rfsim
from rfsim.errors import UserError

#: Subcommand modules in help order.
_SUBCOMMANDS = ("rfsim.cli.scenario", "rfsim.cli.dataset", "rfsim.cli.decode", "rfsim.cli.bench",
                "rfsim.cli.sweep")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rfsim",
        description="Time-domain, sample-level UHF RFID (EPC Gen2) link-level simulator.",
        epilog="Run 'rfsim COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"rfsim {rfsim.__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _SUBCOMMANDS:
        importlib.import_module(name).add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``rfsim`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        return int(args.func(args) or 0)
    except UserError as err:
        print(f"rfsim: error: {err}", file=sys.stderr)
        return err.exit_code
    except KeyboardInterrupt:
        print("rfsim: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

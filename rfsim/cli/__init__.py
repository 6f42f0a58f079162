"""The ``rfsim`` command line.

Each subcommand lives in its own module with ``add_parser(subparsers)`` and
``run(args) -> int``. User mistakes (:class:`rfsim.core.errors.UserError`, which includes
config errors) print one line to stderr and exit with status 2 — never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

import rfsim
from rfsim.core.errors import Terminated, UserError
from rfsim.core.procs import terminate_as_interrupt

#: Subcommand modules in help order.
_SUBCOMMANDS = ("rfsim.cli.scenario", "rfsim.cli.dataset", "rfsim.cli.decode", "rfsim.cli.bench",
                "rfsim.cli.sweep")


class Parser(argparse.ArgumentParser):
    """``argparse`` parser whose usage errors are one line (exit 2), like every user error."""

    def error(self, message: str):  # noqa: D102 - argparse hook
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


class _Version(argparse.Action):
    """``--version``: the installed version, read only when asked (start-up stays fast)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"rfsim {rfsim.__version__}")
        parser.exit(0)


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="rfsim",
        description="Time-domain, sample-level UHF RFID (EPC Gen2) link-level simulator.",
        epilog="Run 'rfsim COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action=_Version, nargs=0, help="show the version and exit")
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
        with terminate_as_interrupt():
            return int(args.func(args) or 0)
    except UserError as err:
        print(f"rfsim: error: {err}", file=sys.stderr)
        return err.exit_code
    except Terminated as err:
        print(f"rfsim: terminated (SIGTERM){getattr(err, 'hint', '')}", file=sys.stderr)
        return err.exit_code
    except KeyboardInterrupt as err:
        print(f"rfsim: interrupted{getattr(err, 'hint', '')}", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. '| head': the reader has enough; no traceback, exit 0
        _discard_stdout()
        return 0


def _discard_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's final flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

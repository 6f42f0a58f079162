"""The ``rfsim`` command line.

Each subcommand lives in its own module with ``add_parser(subparsers)`` and
``run(args) -> int``. User mistakes (:class:`rfsim.core.errors.UserError`, which includes
config errors) print one line to stderr and exit with status 2 — never a traceback; failures
of the system (:class:`rfsim.core.errors.ResourceError`, an ``OSError`` such as a full disk or
a failing standard output, a run's process killed by a signal) print one line and exit 1.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

import rfsim
from rfsim.core.command_line import running_command
from rfsim.core.errors import ResourceError, Terminated, UserError, os_error_number, write_failure
from rfsim.core.procs import terminate_as_interrupt

#: Subcommand modules in help order.
_SUBCOMMANDS = ("rfsim.cli.scenario", "rfsim.cli.dataset", "rfsim.cli.export", "rfsim.cli.decode",
                "rfsim.cli.bench", "rfsim.cli.sweep", "rfsim.cli.clean")


class Parser(argparse.ArgumentParser):
    """``argparse`` parser whose usage errors are one line (exit 2), like every user error.

    Parameters
    ----------
    *args, **kwargs
        As for :class:`argparse.ArgumentParser`.
    """

    def error(self, message: str):
        """Print a usage error in one line, pointing at ``--help``, and exit with status 2.

        The ``argparse`` hook called on a usage error; it does not return.

        Parameters
        ----------
        message : str
            argparse's description of the error.
        """
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def positive_int(text: str) -> int:
    """An ``argparse`` type: an integer ≥ 1 written in decimal digits.

    Parameters
    ----------
    text : str
        The option's value as given.

    Returns
    -------
    int
        Its value.

    Raises
    ------
    argparse.ArgumentTypeError
        When ``text`` is not an integer ≥ 1 (the parser turns it into a one-line usage error,
        exit 2).
    """
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer >= 1")
    return int(text)


class _Version(argparse.Action):
    """``--version``: the installed version, read only when asked (start-up stays fast)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"rfsim {rfsim.__version__}")
        parser.exit(0)


def build_parser() -> argparse.ArgumentParser:
    """Build the ``rfsim`` parser with every subcommand's parser.

    Returns
    -------
    argparse.ArgumentParser
        A :class:`Parser` with ``--version`` and the subcommands, in help order; each
        subcommand sets ``func`` to its ``run``.
    """
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
    """Run the ``rfsim`` console script.

    Parses ``argv`` (``sweep`` reads its own arguments), runs the subcommand and turns its
    failures into one line on stderr (see the module docstring): no command prints the help.

    Parameters
    ----------
    argv : sequence of str or None, default None
        The arguments after the program name (None: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit status: the command's own (0 on success), 2 for a user error, 1 for a
        failure of the system, 130 when interrupted (Ctrl-C), 143 on SIGTERM, 0 after a closed
        pipe (``| head``).
    """
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["sweep"]:  # its own parser reads the rest, options first included ('sweep -q S')
        args = argparse.Namespace(command="sweep", func=importlib.import_module("rfsim.cli.sweep").run,
                                  sweep_help=False, argv=argv[1:])
    else:
        args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    stdout = sys.stdout
    sys.stdout = _Stdout(stdout)
    try:
        with terminate_as_interrupt(), running_command(argv):
            status = int(args.func(args) or 0)
            flush_stdout()  # a full or failing stdout is reported here, not at exit
            return status
    except (UserError, ResourceError) as err:
        print(f"rfsim: error: {err}", file=sys.stderr)
        if isinstance(err, ResourceError):
            try:
                sys.stdout.flush()
            except OSError:  # stdout itself failed: the interpreter's final flush must not fail again
                _discard_stdout()
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
    except OSError as err:  # the system refused a write or read (disk full, I/O error...)
        if os_error_number(err) is None:
            raise
        print(f"rfsim: error: {_os_error_line(err)}", file=sys.stderr)
        _discard_stdout()
        return 1
    finally:
        if isinstance(sys.stdout, _Stdout):
            sys.stdout = stdout


class _Stdout:
    """``sys.stdout`` during a command: a refused write (``/dev/full``, an I/O error) is a
    one-line :class:`ResourceError` naming the standard output; a closed pipe stays a
    ``BrokenPipeError`` (``| head``: quiet, exit 0). Everything else is the stream's own."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text):
        return _guarded(self._stream.write, text)

    def writelines(self, lines):
        return _guarded(self._stream.writelines, lines)

    def flush(self):
        return _guarded(self._stream.flush)

    def __getattr__(self, name):
        return getattr(self._stream, name)


def flush_stdout() -> None:
    """Flush stdout; a refused write (``/dev/full``, an I/O error) is a one-line
    :class:`ResourceError`, a closed pipe stays a ``BrokenPipeError`` (quiet, exit 0)."""
    _guarded(sys.stdout.flush)


def _guarded(method, *args):
    """``method(*args)`` on the standard output; a refused write is a one-line
    :class:`ResourceError`, a closed pipe stays a ``BrokenPipeError``."""
    try:
        return method(*args)
    except BrokenPipeError:
        raise
    except OSError as err:
        failure = write_failure(err, "the standard output", hint=False)
        if failure is None:
            raise
        raise failure from None


def _os_error_line(err: OSError) -> str:
    """One line for an operating-system error that reached the command line."""
    reason = os.strerror(os_error_number(err))
    if err.filename is not None:
        return f"{str(err.filename)!r}: {reason}"
    return f"cannot write or read: {reason}"


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

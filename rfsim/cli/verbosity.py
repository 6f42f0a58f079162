"""``-q/--quiet`` and ``-v/--verbose``: one way for every command to choose how much it says.

* default: results on stdout; stages, progress bars (terminal) or periodic progress lines
  (batch logs) and the first-run compile notice on stderr;
* ``-q``: nothing on success (errors still print their one line);
* ``-v``: also details (the resolved config of a run, every attribute in ``rfsim info``).
"""

from __future__ import annotations

import argparse
import sys

from rfsim.core.progress import Reporter


def add_verbosity_args(p: argparse.ArgumentParser) -> None:
    """Add the mutually exclusive ``-q/--quiet`` and ``-v/--verbose`` flags to a parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser (or sub-command parser); changed in place.
    """
    group = p.add_mutually_exclusive_group()
    group.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    group.add_argument("-v", "--verbose", action="store_true",
                       help="print details too (resolved config, all attributes)")


def reporter(args: argparse.Namespace) -> Reporter:
    """Make the progress reporter on stderr for parsed command-line arguments.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments; ``args.quiet`` and ``args.verbose`` (False when absent) choose the
        reporter's level.

    Returns
    -------
    rfsim.core.progress.Reporter
        A reporter writing to ``sys.stderr``.
    """
    return Reporter(sys.stderr, quiet=bool(getattr(args, "quiet", False)),
                    verbose=bool(getattr(args, "verbose", False)))


__all__ = ["add_verbosity_args", "reporter"]

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
    """Add the mutually exclusive ``-q/--quiet`` and ``-v/--verbose`` flags to ``p``."""
    group = p.add_mutually_exclusive_group()
    group.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    group.add_argument("-v", "--verbose", action="store_true",
                       help="print details too (resolved config, all attributes)")


def reporter(args: argparse.Namespace) -> Reporter:
    """The progress reporter on stderr for the parsed ``args``."""
    return Reporter(sys.stderr, quiet=bool(getattr(args, "quiet", False)),
                    verbose=bool(getattr(args, "verbose", False)))


__all__ = ["add_verbosity_args", "reporter"]

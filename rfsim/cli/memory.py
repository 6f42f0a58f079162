"""``--max-memory SIZE``: the limit on a run's estimated peak memory (:mod:`rfsim.runs.resources`)."""

from __future__ import annotations

import argparse

from rfsim.runs.resources import default_limit_bytes, parse_size


def add_max_memory_arg(p: argparse.ArgumentParser) -> None:
    """Add ``--max-memory SIZE`` to a parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser; changed in place.
    """
    p.add_argument("--max-memory", default=None, metavar="SIZE",
                   help="stop before any work when the estimated peak memory exceeds SIZE "
                        "(e.g. 2GiB, 500MB; 0 = no check; default: half the available memory)")


def max_memory(args: argparse.Namespace) -> int | None:
    """Limit on a run's estimated peak memory [B] from parsed command-line arguments.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments; ``args.max_memory`` is the ``--max-memory`` text (absent or None:
        the default limit, half the available memory; ``"0"``: no check).

    Returns
    -------
    int or None
        The limit [B], or None for no check (``0``, or the available memory is unknown).

    Raises
    ------
    rfsim.core.errors.UserError
        If the text is not a size such as ``2GiB``, ``500MB`` or ``1e9``.
    """
    text = getattr(args, "max_memory", None)
    if text is None:
        return default_limit_bytes()
    return None if text.strip() == "0" else parse_size(text)


__all__ = ["add_max_memory_arg", "max_memory"]

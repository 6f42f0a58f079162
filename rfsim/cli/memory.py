"""``--max-memory SIZE``: the limit on a run's estimated peak memory (:mod:`rfsim.runs.resources`)."""

from __future__ import annotations

import argparse

from rfsim.runs.resources import default_limit_bytes, parse_size


def add_max_memory_arg(p: argparse.ArgumentParser) -> None:
    """Add ``--max-memory SIZE`` to ``p``."""
    p.add_argument("--max-memory", default=None, metavar="SIZE",
                   help="stop before any work when the estimated peak memory exceeds SIZE "
                        "(e.g. 2GiB, 500MB; 0 = no check; default: half the available memory)")


def max_memory(args: argparse.Namespace) -> int | None:
    """The limit [B] of the parsed ``args`` (None: no check)."""
    text = getattr(args, "max_memory", None)
    if text is None:
        return default_limit_bytes()
    return None if text.strip() == "0" else parse_size(text)


__all__ = ["add_max_memory_arg", "max_memory"]

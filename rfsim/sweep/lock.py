"""A lock on a sweep's output, so two writers never write the same output at once.

A whole sweep (and ``rfsim sweep merge``) holds ``<output>.lock`` — the lock every writer of
an output file takes (:mod:`rfsim.core.locks`: ``rfsim run -o`` onto a sweep's output is
refused while the sweep runs, and the other way round); shard ``I`` of ``N`` holds
``<output>.points/shard-I-of-N.lock`` (the shards of one sweep write the same point store
side by side, each into its own segments). A second sweep on a locked output stops with a
one-line error naming the holder (exit status 2).
"""

from __future__ import annotations

from pathlib import Path

from rfsim.core.locks import FileLock, output_lock_path
from rfsim.sweep.store import points_dir


def lock_path(output: Path, shard: tuple[int, int] | None = None) -> Path:
    """The lock file of a whole sweep writing ``output`` or of one of its shards.

    Parameters
    ----------
    output : pathlib.Path
        The sweep's output file (the merged file).
    shard : tuple of (int, int), optional
        ``(I, N)``: shard ``I`` of ``N``; None (default) for the whole sweep.

    Returns
    -------
    pathlib.Path
        ``<output>.lock`` for the whole sweep (:func:`rfsim.core.locks.output_lock_path`);
        ``<output>.points/shard-I-of-N.lock`` for a shard.
    """
    if shard is None:
        return output_lock_path(output)
    return points_dir(output) / f"shard-{shard[0]}-of-{shard[1]}.lock"


class OutputLock(FileLock):
    """Context manager holding the lock of ``output`` (or of shard ``(I, N)`` of it).

    Entering it while another process holds the same lock raises a one-line
    :class:`~rfsim.core.errors.UserError` naming the holder (:class:`rfsim.core.locks.FileLock`).

    Parameters
    ----------
    output : pathlib.Path or str
        The sweep's output file.
    shard : tuple of (int, int), optional
        ``(I, N)``: lock shard ``I`` of ``N`` instead of the whole sweep (default None).
    """

    def __init__(self, output: Path, shard: tuple[int, int] | None = None):
        super().__init__(lock_path(Path(output), shard), Path(output), what="sweep output", kind="sweep")


__all__ = ["OutputLock", "lock_path"]

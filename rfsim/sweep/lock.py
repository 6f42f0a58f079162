"""A lock on a sweep's output, so two sweeps never write the same output at once.

A whole sweep (and ``rfsim sweep merge``) holds ``<output>.lock``; shard ``I`` of ``N``
holds ``<output>.points/shard-I-of-N.lock`` (the shards of one sweep write the same point
store side by side, each into its own segments). The lock is an exclusive, non-blocking
``fcntl.flock`` on that file, which holds the holder's host, pid, start time and command
line as JSON. The kernel releases the lock when its holder dies, however it dies (even
SIGKILL), so a stale lock file never blocks the next run. A second sweep on a locked
output stops with a one-line error naming the holder (exit status 2).

``flock`` works on local file systems and on the cluster file systems that support it
(NFSv4, Lustre mounted with ``-o flock``, GPFS); where it is not supported the lock is
skipped with no error.
"""

from __future__ import annotations

import errno
import json
import os
import sys
from pathlib import Path

from rfsim.core.dataset import utc_now
from rfsim.core.errors import UserError
from rfsim.sweep.store import points_dir

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None


def lock_path(output: Path, shard: tuple[int, int] | None = None) -> Path:
    """The lock file of a whole sweep writing ``output`` or of one of its shards."""
    if shard is None:
        return output.with_name(output.name + ".lock")
    return points_dir(output) / f"shard-{shard[0]}-of-{shard[1]}.lock"


def _holder_text(path: Path) -> str:
    try:
        info = json.loads(path.read_text(encoding="utf-8") or "{}")
    except (OSError, ValueError):
        return "another process"
    return (f"pid {info.get('pid', '?')} on {info.get('host', '?')} since {info.get('since', '?')} "
            f"({info.get('command', '?')})")


class OutputLock:
    """Context manager holding the lock of ``output`` (or of shard ``(I, N)`` of it)."""

    def __init__(self, output: Path, shard: tuple[int, int] | None = None):
        self.path = lock_path(Path(output), shard)
        self.output = Path(output)
        self._fd: int | None = None

    def acquire(self) -> None:
        if fcntl is None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as err:
                os.close(fd)
                if err.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise UserError(f"sweep output {str(self.output)!r} is in use by another sweep: "
                                    f"{_holder_text(self.path)}; wait for it to finish (lock file "
                                    f"{str(self.path)!r})") from None
                return  # the file system has no flock: run without the lock
            try:  # the holder before us may have removed the file while we opened it
                same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        info = {"pid": os.getpid(), "host": os.uname().nodename, "since": utc_now(),
                "command": " ".join(sys.argv)[:300]}
        os.ftruncate(fd, 0)
        os.write(fd, json.dumps(info).encode("utf-8"))
        self._fd = fd

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            self.path.unlink(missing_ok=True)
        finally:
            os.close(self._fd)  # closing releases the flock
            self._fd = None

    def __enter__(self) -> OutputLock:
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()


__all__ = ["OutputLock", "lock_path"]

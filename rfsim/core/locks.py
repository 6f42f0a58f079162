"""Locks on output files, so two rfsim processes never write the same output at once.

Every writer of an output file — ``rfsim run`` (the dataset), ``rfsim decode -o``, a whole
sweep and ``rfsim sweep merge`` (the merged file) — holds ``<output>.lock`` while it computes
and writes, so one result never silently replaces another. The lock is an exclusive,
non-blocking ``fcntl.flock`` on that file, which holds the holder's kind (``run``,
``sweep``...), host, pid, start time and command line as JSON. The kernel releases the lock
when its holder dies, however it dies (even SIGKILL), so a stale lock file never blocks the
next writer. A second writer of a locked output stops with a one-line
:class:`~rfsim.core.errors.UserError` naming the holder (exit status 2).

While holding the lock, a writer also removes the temporary files (``.<name>.<pid>.partial``)
that killed writers of the same output left behind (:func:`rfsim.core.outputs.remove_stale_partials`).

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

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None


def output_lock_path(output: str | Path) -> Path:
    """The lock file of ``output``: ``<output>.lock`` beside it."""
    output = Path(output)
    return output.with_name(output.name + ".lock")


def holder_text(path: Path) -> tuple[str, str]:
    """(kind, description) of the holder recorded in lock file ``path``."""
    try:
        info = json.loads(path.read_text(encoding="utf-8") or "{}")
    except (OSError, ValueError):
        return "rfsim process", "another process"
    return (str(info.get("kind", "rfsim process")),
            f"pid {info.get('pid', '?')} on {info.get('host', '?')} since {info.get('since', '?')} "
            f"({info.get('command', '?')})")


class FileLock:
    """Context manager holding ``lock_file`` for ``output`` (see the module docstring).

    ``what`` names the output in the error message (``"sweep output"``, ``"dataset"``);
    ``kind`` is what this holder is (``"sweep"``, ``"run"``, ``"decode"``).
    """

    def __init__(self, lock_file: Path, output: Path, *, what: str, kind: str):
        self.path, self.output = Path(lock_file), Path(output)
        self.what, self.kind = what, kind
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
                    kind, holder = holder_text(self.path)
                    raise UserError(f"{self.what} {str(self.output)!r} is in use by another {kind}: "
                                    f"{holder}; wait for it to finish (lock file {str(self.path)!r})") from None
                return  # the file system has no flock: run without the lock
            try:  # the holder before us may have removed the file while we opened it
                same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        info = {"kind": self.kind, "pid": os.getpid(), "host": os.uname().nodename, "since": utc_now(),
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

    def __enter__(self) -> FileLock:
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def output_lock(output: str | Path, *, what: str, kind: str) -> FileLock:
    """The lock of output file ``output`` (``<output>.lock``), shared by every kind of writer."""
    return FileLock(output_lock_path(output), Path(output), what=what, kind=kind)


def is_locked(output: str | Path) -> bool:
    """True when a live process holds the lock of ``output`` (probed without taking it for long)."""
    path = output_lock_path(output)
    if fcntl is None or not path.exists():
        return False
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError as err:
        return err.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES)
    finally:
        os.close(fd)
    return False


__all__ = ["FileLock", "output_lock", "output_lock_path", "holder_text", "is_locked"]

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
    """Lock file of an output file.

    Parameters
    ----------
    output : str or pathlib.Path
        The output file.

    Returns
    -------
    pathlib.Path
        ``<output>.lock`` beside it.
    """
    output = Path(output)
    return output.with_name(output.name + ".lock")


def holder_text(path: Path) -> tuple[str, str]:
    """Describe the holder recorded in a lock file.

    Parameters
    ----------
    path : pathlib.Path
        The lock file (JSON written by :meth:`FileLock.acquire`).

    Returns
    -------
    kind : str
        What the holder is (``"run"``, ``"sweep"``...); ``"rfsim process"`` when unknown.
    description : str
        ``pid P on HOST since TIME (COMMAND)``; ``"another process"`` when the file cannot be
        read or parsed.
    """
    try:
        info = json.loads(path.read_text(encoding="utf-8") or "{}")
    except (OSError, ValueError):
        return "rfsim process", "another process"
    return (str(info.get("kind", "rfsim process")),
            f"pid {info.get('pid', '?')} on {info.get('host', '?')} since {info.get('since', '?')} "
            f"({info.get('command', '?')})")


class FileLock:
    """Context manager holding a lock file for an output (see the module docstring).

    Parameters
    ----------
    lock_file : pathlib.Path
        The lock file (:func:`output_lock_path`).
    output : pathlib.Path
        The output it protects, named in the error message.
    what : str
        What the output is, for the error message (``"sweep output"``, ``"dataset"``).
    kind : str
        What this holder is (``"sweep"``, ``"run"``, ``"decode"``), recorded in the lock file.

    Attributes
    ----------
    path : pathlib.Path
        The lock file.
    output : pathlib.Path
        The output.
    what, kind : str
        As given.
    """

    def __init__(self, lock_file: Path, output: Path, *, what: str, kind: str):
        self.path, self.output = Path(lock_file), Path(output)
        self.what, self.kind = what, kind
        self._fd: int | None = None

    def acquire(self) -> None:
        """Take the lock (non-blocking) and record this holder in the lock file.

        The holder is written as JSON: kind, pid, host, start time (UTC) and command line.
        Without ``fcntl`` (not POSIX) or ``flock`` support on the file system, nothing is locked
        and no error is raised.

        Raises
        ------
        rfsim.core.errors.UserError
            If another process holds the lock; the message names the holder.
        """
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
        """Remove the lock file and release the lock (nothing if it is not held)."""
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
    """Lock of an output file, shared by every kind of writer.

    Parameters
    ----------
    output : str or pathlib.Path
        The output file; the lock file is ``<output>.lock``.
    what : str
        What the output is, for the error message (``"sweep output"``, ``"dataset"``).
    kind : str
        What this holder is (``"sweep"``, ``"run"``, ``"decode"``).

    Returns
    -------
    FileLock
        The lock, not yet taken (use it as a context manager).
    """
    return FileLock(output_lock_path(output), Path(output), what=what, kind=kind)


def is_locked(output: str | Path) -> bool:
    """Whether a live process holds the lock of an output.

    Probed with a non-blocking shared ``flock`` released at once.

    Parameters
    ----------
    output : str or pathlib.Path
        The output file.

    Returns
    -------
    bool
        True when the lock is held; False when it is not, the lock file does not exist or
        cannot be opened, or locking is not supported.
    """
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

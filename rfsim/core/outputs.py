"""Output paths checked before any simulation starts, so no computed result is lost.

:func:`check_output_file` and :func:`check_output_folder` are called by ``rfsim run``
(dataset and figure folder), ``rfsim sweep`` (merged file and point store) and the other
commands that write files, before they compute anything. They create missing parent
folders and turn every path that could not be written later — a folder where a file is
expected, a file where a folder is expected, a place without write permission or on a
read-only or virtual file system (``/proc``) — into a one-line :class:`UserError`
(exit status 2). Writability is tested by creating and removing a hidden probe file, which
also catches read-only mounts and the root user's ``/proc`` (where permission bits do not
tell).
"""

from __future__ import annotations

import contextlib
import glob
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from rfsim.core.errors import ResourceError, UserError, write_failure


def _why(err: OSError) -> str:
    return err.strerror or type(err).__name__


def _writable_folder(folder: Path, label: str) -> None:
    for anc in (folder, *folder.parents):
        if anc.exists() and not anc.is_dir():
            raise UserError(f"{label}: {str(anc)!r} is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise UserError(f"{label}: cannot create the folder {str(folder)!r} ({_why(err)})") from None
    try:
        fd, probe = tempfile.mkstemp(prefix=".rfsim-write-probe-", dir=folder)
    except OSError as err:
        raise UserError(f"{label}: cannot write into the folder {str(folder)!r} ({_why(err)})") from None
    os.close(fd)
    os.unlink(probe)


def check_output_folder(folder: str | Path, what: str) -> Path:
    """Make sure a folder is (or can be created as) a writable folder.

    Missing folders are created; writability is tested with a hidden probe file.

    Parameters
    ----------
    folder : str or pathlib.Path
        The folder.
    what : str
        The option or setting named in the message, e.g. ``"--out-dir"``.

    Returns
    -------
    pathlib.Path
        ``folder``.

    Raises
    ------
    rfsim.core.errors.UserError
        If the folder or one of its parents is a file, or the folder cannot be created or
        written into.
    """
    folder = Path(folder)
    _writable_folder(folder, f"{what} {str(folder)!r}")
    return folder


def check_output_file(path: str | Path, what: str, *, suffixes: tuple[str, ...] = ()) -> Path:
    """Make sure a file can be written (atomically, by rename) at a path.

    Missing parent folders are created; writability of the folder is tested with a hidden
    probe file.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write.
    what : str
        The option or setting named in the message, e.g. ``"--out"``.
    suffixes : tuple of str, default ()
        Allowed file name endings, e.g. ``(".h5", ".hdf5")`` (empty: any).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    rfsim.core.errors.UserError
        If the suffix is not allowed, ``path`` is a folder, or its folder cannot be created or
        written into.
    """
    path = Path(path)
    label = f"{what} {str(path)!r}"
    if suffixes and path.suffix not in suffixes:
        raise UserError(f"{label}: the file name must end in {' or '.join(suffixes)}")
    if path.is_dir():
        raise UserError(f"{label}: is a folder; expected a file name")
    _writable_folder(path.parent, label)
    return path


def partial_path(path: Path) -> Path:
    """Hidden temporary name under which this process writes a file.

    Parameters
    ----------
    path : pathlib.Path
        The file to write.

    Returns
    -------
    pathlib.Path
        ``.<name>.<pid>.partial`` beside ``path`` (``pid`` of this process).
    """
    return path.with_name(f".{path.name}.{os.getpid()}.partial")


def remove_stale_partials(path: str | Path) -> list[Path]:
    """Remove the temporary files that killed writers of a file left beside it.

    Call it only while holding the output's lock (:mod:`rfsim.core.locks`): then no other
    writer is using any of them.

    Parameters
    ----------
    path : str or pathlib.Path
        The output file; its leftovers are ``.<name>.<pid>.partial`` beside it.

    Returns
    -------
    list of pathlib.Path
        The files removed (those removed meanwhile by another process are not listed).
    """
    path = Path(path)
    removed = []
    for tmp in path.parent.glob(f".{glob.escape(path.name)}.*.partial"):
        if tmp.name[len(path.name) + 2:-len(".partial")].isdigit():
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
                removed.append(tmp)
    return removed


@contextlib.contextmanager
def atomic_path(path: str | Path, what: str) -> Iterator[Path]:
    """Give a temporary path at which to write a file, renamed over it when the block succeeds.

    The temporary path is :func:`partial_path`; it is fsync'ed and renamed over ``path`` when
    the block succeeds, removed when it fails, so the previous file, if any, stays on failure.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write.
    what : str
        What is written, for the error message, e.g. ``"the figure 'x.png'"``.

    Yields
    ------
    pathlib.Path
        The temporary path the block writes to.

    Raises
    ------
    rfsim.core.errors.ResourceError
        If the system refuses the write (disk full, I/O error), in one line naming ``what``;
        other exceptions of the block propagate.
    """
    path = Path(path)
    tmp = partial_path(path)
    try:
        yield tmp
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException as err:
        tmp.unlink(missing_ok=True)
        failure = write_failure(err, what)
        if failure is not None:
            raise ResourceError(f"{failure}; the previous file, if any, is unchanged") from None
        raise


def write_text_atomic(path: str | Path, text: str, what: str) -> Path:
    """Write text (UTF-8) to a file atomically (:func:`atomic_path`).

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    text : str
        Its content.
    what : str
        The option named in a one-line error, e.g. ``"--out"``.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    rfsim.core.errors.ResourceError
        If the system refuses the write (disk full, I/O error).
    """
    with atomic_path(path, f"{what} {str(path)!r}") as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


__all__ = ["check_output_folder", "check_output_file", "partial_path", "remove_stale_partials", "atomic_path",
           "write_text_atomic"]

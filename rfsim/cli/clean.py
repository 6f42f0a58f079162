"""``rfsim clean [PATH ...]``: remove the temporary files that killed runs left behind.

Every dataset, merged sweep file and figure is written under a hidden temporary name
(``.<name>.<pid>.partial``) and renamed when complete; a run killed meanwhile (SIGKILL,
out of memory, power loss) leaves that file behind. The next writer of the same output
removes it; ``rfsim clean`` removes them in the given folders (default: ``results`` and
the current folder) — those of an output that another rfsim process is writing now (its
lock is held, :mod:`rfsim.core.locks`) are kept.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from rfsim.core.errors import UserError

#: ``.<output name>.<pid>.partial`` (``<output name>`` may itself hold dots).
_PARTIAL = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.partial$")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the ``clean`` subcommand.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the ``rfsim`` parser; ``clean`` is added to it with ``func=run``.
    """
    p = sub.add_parser("clean", help="remove the temporary files (.partial) that killed runs left behind",
                       description="Remove the hidden .<name>.<pid>.partial files of killed runs in the "
                                   "given folders (not those of an output being written now).")
    p.add_argument("paths", nargs="*", type=Path, metavar="PATH",
                   help="folders to clean, or output files whose leftovers to remove (default: results and .)")
    p.add_argument("-n", "--dry-run", action="store_true", help="list what would be removed, remove nothing")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run)


def stale_partials(folder: Path) -> list[Path]:
    """List the ``.partial`` files in a folder whose output nobody is writing now.

    A file counts if its name is ``.<output name>.<pid>.partial`` and the lock of its output
    (:func:`rfsim.core.locks.is_locked`) is not held.

    Parameters
    ----------
    folder : pathlib.Path
        The folder (not searched recursively).

    Returns
    -------
    list of pathlib.Path
        The files, sorted by path.
    """
    from rfsim.core.locks import is_locked

    found = []
    for path in sorted(folder.glob(".*.partial")):
        match = _PARTIAL.match(path.name)
        if match and path.is_file() and not is_locked(folder / match["name"]):
            found.append(path)
    return found


def run(args: argparse.Namespace) -> int:
    """Run ``rfsim clean``: remove (or list) the stale ``.partial`` files of the given folders.

    Prints each file removed with its size and a total line (unless quiet).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments: ``paths`` (folders, or files whose folder to clean; empty:
        ``results`` and ``.``, those that exist), ``dry_run`` (bool: list only) and ``quiet``
        (bool).

    Returns
    -------
    int
        Exit status 0.

    Raises
    ------
    rfsim.core.errors.UserError
        If a path is neither a folder nor a file (or file name) in an existing folder.
    """
    paths = args.paths or [p for p in (Path("results"), Path(".")) if p.is_dir()]
    folders: list[Path] = []
    for path in paths:
        if path.is_dir():
            folders.append(path)
        elif path.parent.is_dir() and (path.exists() or path.suffix):
            folders.append(path.parent)
        else:
            raise UserError(f"{str(path)!r}: no such folder")
    removed, total_bytes = 0, 0
    for folder in dict.fromkeys(folders):
        for path in stale_partials(folder):
            try:
                size = path.stat().st_size
                if not args.dry_run:
                    path.unlink()
            except FileNotFoundError:  # removed by its next writer meanwhile
                continue
            removed += 1
            total_bytes += size
            if not args.quiet:
                print(f"{'would remove' if args.dry_run else 'removed'}: {path} ({size / 1e6:.1f} MB)")
    if not args.quiet:
        print(f"{removed} temporary file{'s' if removed != 1 else ''} of killed runs, "
              f"{total_bytes / 1e6:.1f} MB{' (dry run)' if args.dry_run else ''}")
    return 0


__all__ = ["add_parser", "run", "stale_partials"]

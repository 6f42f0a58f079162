"""The command line that is running, for the ``history`` and provenance of the files it writes.

The ``rfsim`` entry point runs each command inside :func:`running_command`; a file written
meanwhile records ``rfsim run link --seed 1`` as the user typed it. Outside the command line
(a script, a notebook kernel), :func:`command_line` is the interpreter's own ``sys.argv``.
Standard library only: the entry point imports it at start-up.
"""

from __future__ import annotations

import contextlib
import shlex
import sys
from collections.abc import Iterator, Sequence
from contextvars import ContextVar

_COMMAND: ContextVar[tuple[str, ...] | None] = ContextVar("rfsim_command_line", default=None)


@contextlib.contextmanager
def running_command(argv: Sequence[str], prog: str = "rfsim") -> Iterator[None]:
    """Make :func:`command_line` report ``prog argv…`` (what the user typed) within the block.

    Parameters
    ----------
    argv : sequence of str
        The arguments after the program name (each converted with ``str``).
    prog : str, default "rfsim"
        The program name.

    Yields
    ------
    None
        The block runs with the command recorded; the previous value is restored at its end.
    """
    token = _COMMAND.set((prog, *map(str, argv)))
    try:
        yield
    finally:
        _COMMAND.reset(token)


def command_line() -> str:
    """The command that is running, shell-quoted.

    Returns
    -------
    str
        ``rfsim run link --seed 1`` inside :func:`running_command`, else ``python`` followed by
        the interpreter's ``sys.argv``, each word quoted with :func:`shlex.join`.
    """
    argv = _COMMAND.get()
    return shlex.join(argv if argv is not None else ["python", *sys.argv])


__all__ = ["running_command", "command_line"]

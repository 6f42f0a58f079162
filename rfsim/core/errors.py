"""User-facing errors.

A :class:`UserError` is a mistake of the user (bad config key, value or input file).
The CLI prints its one-line message and exits with status 2 — never a traceback.
A :class:`ResourceError` is a failure of the system the command ran on (disk full, I/O
error, a process killed by a signal); the CLI prints its one line and exits with status 1.
"""

from __future__ import annotations

import difflib
import errno as _errno
import os
import re
from collections.abc import Iterable


class UserError(Exception):
    """A mistake in user input; ``str(err)`` is a single line for the terminal.

    Attributes
    ----------
    exit_code : int
        Exit status of the command line, 2.
    """

    exit_code = 2


class ResourceError(Exception):
    """The system, not the user, stopped a command (disk full, I/O error, a killed process).

    ``str(err)`` is a single line for the terminal.

    Attributes
    ----------
    exit_code : int
        Exit status of the command line, 1.
    """

    exit_code = 1


#: ``errno = 28`` inside the message of an error from the HDF5 library, which h5py raises
#: as an ``OSError`` (or, when closing after a failed write, a ``RuntimeError``) without
#: setting its ``errno`` attribute.
_EMBEDDED_ERRNO = re.compile(r"errno = (\d+)")


def os_error_number(err: BaseException) -> int | None:
    """The operating-system error number behind ``err``.

    Also looked for in the errors it was raised from or while handling
    (``__cause__``/``__context__``), and as ``errno = N`` inside an HDF5 message.

    Parameters
    ----------
    err : BaseException
        The error.

    Returns
    -------
    int or None
        The errno, or None when there is none.
    """
    seen: set[int] = set()
    while err is not None and id(err) not in seen:
        seen.add(id(err))
        if isinstance(err, OSError) and err.errno:
            return int(err.errno)
        if isinstance(err, (OSError, RuntimeError)):
            found = _EMBEDDED_ERRNO.search(str(err))
            if found and int(found.group(1)):
                return int(found.group(1))
        err = err.__cause__ or err.__context__
    return None


def write_failure(err: BaseException, what: str, *, hint: bool = True) -> ResourceError | None:
    """A one-line :class:`ResourceError` for a failed write of ``what`` when ``err`` comes from the operating system.

    ``ENOSPC`` (disk full), ``EDQUOT`` (quota), ``EIO`` (device error), ``EFBIG``, ``EROFS``...
    all give ``cannot write <what>: <strerror>`` (with what to do about a full disk, unless
    ``hint`` is False).

    Parameters
    ----------
    err : BaseException
        The error raised by the write.
    what : str
        What was written, e.g. ``"dataset 'x.h5'"``.
    hint : bool
        Add what to do about a full disk or quota.

    Returns
    -------
    ResourceError or None
        The error to raise, or None (not an operating-system error: a bug, let it show).
    """
    if isinstance(err, (UserError, ResourceError, KeyboardInterrupt)):
        return None
    number = os_error_number(err)
    if number is None:
        return None
    reason = os.strerror(number)
    if hint and number in (_errno.ENOSPC, _errno.EDQUOT):
        reason += " (free some space or write elsewhere)"
    return ResourceError(f"cannot write {what}: {reason}")


class ConfigError(UserError, ValueError):
    """A config key, type or value is not allowed.

    Parameters
    ----------
    key : str
        Dotted config key, e.g. ``"reader.ptx_dbm"``.
    value : object
        The offending value as given.
    allowed : str
        What would be allowed, in words (``"a number in [0, 36]"``).

    Attributes
    ----------
    key, value, allowed
        As given.
    """

    def __init__(self, key: str, value: object, allowed: str):
        self.key, self.value, self.allowed = key, value, allowed
        super().__init__(f"config key '{key}': got {value!r}; allowed: {allowed}")

    def __reduce__(self):  # picklable, so an error raised in a worker process reaches the CLI
        return (type(self), (self.key, self.value, self.allowed))


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived (``kill``, ``timeout``, SLURM ``scancel``); handled like Ctrl-C.

    Attributes
    ----------
    exit_code : int
        Exit status of the command line, 143 (128 + SIGTERM).
    """

    exit_code = 128 + 15


#: Seeds are the entropy of a ``numpy.random.SeedSequence`` and are stored as uint64.
SEED_LIMIT = 2**64
SEED_RANGE_TEXT = "an integer in [0, 2**64)"


def check_seed(value: object, what: str = "seed") -> int:
    """``value`` as a seed in [0, 2**64).

    Parameters
    ----------
    value : object
        The seed as given.
    what : str
        What the value is, for the message.

    Returns
    -------
    int
        The seed.

    Raises
    ------
    UserError
        One line, for anything but an int in [0, 2**64).
    """
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < SEED_LIMIT:
        raise UserError(f"{what} {value!r}: expected {SEED_RANGE_TEXT}")
    return value


def did_you_mean(name: str, candidates: Iterable[str]) -> str:
    """A did-you-mean hint for the closest candidate (difflib, cutoff 0.6).

    Parameters
    ----------
    name : str
        The unknown name.
    candidates : iterable of str
        The known names.

    Returns
    -------
    str
        ``" (did you mean 'x'?)"``, or ``""`` when none is close.
    """
    close = difflib.get_close_matches(name, list(candidates), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


__all__ = ["UserError", "ResourceError", "os_error_number", "write_failure",
           "ConfigError", "Terminated", "did_you_mean", "check_seed", "SEED_LIMIT", "SEED_RANGE_TEXT"]

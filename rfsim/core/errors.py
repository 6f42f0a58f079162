"""User-facing errors.

A :class:`UserError` is a mistake of the user (bad config key, value or input file).
The CLI prints its one-line message and exits with status 2 — never a traceback.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class UserError(Exception):
    """A mistake in user input; ``str(err)`` is a single line for the terminal."""

    exit_code = 2


class ConfigError(UserError, ValueError):
    """A config key, type or value is not allowed.

    Parameters
    ----------
    key : dotted config key, e.g. ``"reader.ptx_dbm"``
    value : the offending value as given
    allowed : what would be allowed, in words (``"a number in [0, 36]"``)
    """

    def __init__(self, key: str, value: object, allowed: str):
        self.key, self.value, self.allowed = key, value, allowed
        super().__init__(f"config key '{key}': got {value!r}; allowed: {allowed}")

    def __reduce__(self):  # picklable, so an error raised in a worker process reaches the CLI
        return (type(self), (self.key, self.value, self.allowed))


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived (``kill``, ``timeout``, SLURM ``scancel``); handled like Ctrl-C, exit 143."""

    exit_code = 128 + 15


#: Seeds are the entropy of a ``numpy.random.SeedSequence`` and are stored as uint64.
SEED_LIMIT = 2**64
SEED_RANGE_TEXT = "an integer in [0, 2**64)"


def check_seed(value: object, what: str = "seed") -> int:
    """``value`` as a seed in [0, 2**64); anything else is a one-line :class:`UserError`."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < SEED_LIMIT:
        raise UserError(f"{what} {value!r}: expected {SEED_RANGE_TEXT}")
    return value


def did_you_mean(name: str, candidates: Iterable[str]) -> str:
    """Return ``" (did you mean 'x'?)"`` for the closest candidate, or ``""``."""
    close = difflib.get_close_matches(name, list(candidates), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


__all__ = ["UserError", "ConfigError", "Terminated", "did_you_mean", "check_seed", "SEED_LIMIT", "SEED_RANGE_TEXT"]

"""Named, bounded memos of pure functions of constants (:class:`PureCache`).

What a run may reuse between its calls is held in the run's own objects (the air step's
:class:`rfsim.air.cache.AirCache`, a channel scene's tables). A few values are not run state
at all: a function of module constants and of configuration values alone, the same in every
run and every process (a filter's taps for a rate and a bandwidth, an antenna pattern's peak
gain, a seed's mixed entropy pool). Such a function is remembered by a :class:`PureCache`: an
explicit module object with a name, a bound and a documented rule, instead of a hidden
decorator. It never chooses a code path: a call gives the same value with the memo, after
:meth:`PureCache.clear`, or without it (:attr:`PureCache.function`).
"""

from __future__ import annotations

from typing import Callable

__all__ = ["PureCache"]

_MISSING = object()


class PureCache:
    """A bounded memo of one pure function of hashable positional arguments.

    ``cache(*args)`` returns ``function(*args)``, computed once per distinct ``args`` (compared
    by value) while the entry is kept; beyond ``max_entries`` entries the oldest is dropped
    first. The kept value is returned itself, not a copy: the function must return an
    immutable value or arrays its callers only read (made read-only where the function says so).

    Parameters
    ----------
    function : callable
        The pure function: its value depends on its arguments alone (no run state, no files
        that may change while a process runs).
    max_entries : int
        Entries kept, ≥ 1.

    Attributes
    ----------
    function : callable
        The function, to call without the memo.
    max_entries : int
        Entries kept.
    entries : dict
        The kept values by argument tuple (insertion order is the age order).

    Raises
    ------
    ValueError
        If ``max_entries`` < 1.
    """

    def __init__(self, function: Callable, max_entries: int):
        if max_entries < 1:
            raise ValueError(f"max_entries must be >= 1, got {max_entries}")
        self.function = function
        self.max_entries = int(max_entries)
        self.entries: dict = {}
        self.__doc__ = function.__doc__

    def __call__(self, *args):
        """Return ``function(*args)``, from the memo when these arguments were seen.

        Parameters
        ----------
        *args : hashable
            The function's arguments.

        Returns
        -------
        object
            The function's value.
        """
        hit = self.entries.get(args, _MISSING)
        if hit is _MISSING:
            hit = self.function(*args)
            if len(self.entries) >= self.max_entries:
                self.entries.pop(next(iter(self.entries)))
            self.entries[args] = hit
        return hit

    def clear(self) -> None:
        """Drop every kept value."""
        self.entries.clear()

    def __repr__(self) -> str:
        name = getattr(self.function, "__qualname__", repr(self.function))
        return f"PureCache({name}, {len(self.entries)}/{self.max_entries} entries)"

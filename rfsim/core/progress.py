"""Progress of long work: stage lines, tqdm bars with ETA, the first-run compile notice.

A :class:`Reporter` decides where and how progress appears:

* on a terminal, ``tqdm`` bars redrawn in place (``\\r``) with count, rate and ETA, and a
  line per stage (``rfsim: running phase-cancellation (seed 1)``);
* in batch logs (the stream is not a TTY: SLURM logs, pipes, files) the same bar as plain
  lines, ``monte carlo: 40/120 cells (33.3 %), 2.10cells/s, elapsed 00:19, ETA 00:38``
  (tqdm's rate: ``17.2s/cells`` when a step takes longer than a second), at
  most one every ``log_interval_s`` plus the first and the last, never a ``\\r``;
* nothing at all when ``quiet``.

Code that loops does not need to know which: it wraps its loop in :func:`track` and names
its stages with :func:`stage`; both do nothing unless a reporter is active
(:func:`reporting`, entered by the command line around a run). The first time numba
compiles a kernel while a reporter is active (a cache miss: the first run after install or
after a kernel changed) one line says so, because that can take tens of seconds.

The rate and ETA of a bar are measured from the end of its first step on (:class:`_Bar`):
the first step carries one-off work (numba compiling the kernels, warming caches, starting
pool workers), so counting it would predict "58 s/cell, ETA 11:40" for work that ends
seconds later. Until a second step finishes the ETA is shown as ``?``; ``elapsed`` is the
whole time.
"""

from __future__ import annotations

import contextlib
import contextvars
import sys
import threading
from collections.abc import Iterable, Iterator
from typing import Any, TextIO, TypeVar

T = TypeVar("T")

#: Text of the one line printed when numba starts compiling (cache miss).
COMPILE_NOTICE = ("compiling numba kernels (first run after install or after a kernel changed; "
                  "cached on disk for later runs, this can take up to a minute)")

#: tqdm layout of a bar in batch logs (no bar glyphs, one complete line per update).
LOG_FORMAT = "{desc}: {n_fmt}/{total_fmt} {unit} ({percentage:.1f} %), {rate_fmt}, elapsed {elapsed}, ETA {remaining}"
#: tqdm layout of a bar on a terminal.
TTY_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} {unit} [{elapsed}<{remaining}, {rate_fmt}]"

_CURRENT: contextvars.ContextVar[Reporter | None] = contextvars.ContextVar("rfsim_reporter", default=None)


class _LineWriter:
    """File wrapper for tqdm in batch logs: every status tqdm writes becomes one plain line.

    tqdm redraws with ``"\\r" + status``; here the carriage returns and padding are dropped
    and a newline is added, so a log shows one readable line per update.
    """

    def __init__(self, stream: TextIO):
        self.stream = stream
        self._last = ""

    def write(self, text: str) -> None:
        line = text.replace("\r", "").strip()
        if line and line != self._last:  # tqdm's close repeats the last status
            self.stream.write(line + "\n")
            self._last = line

    def flush(self) -> None:
        self.stream.flush()


class _NullBar:
    """Stand-in for a bar when nothing is shown."""

    n = 0

    def update(self, n: int = 1) -> None:
        self.n += n

    def close(self) -> None:
        pass


def _bar_class():
    """The tqdm subclass used for terminal and log bars (tqdm imported on first use)."""
    from tqdm import tqdm

    class _Bar(tqdm):
        """A tqdm bar whose rate and ETA leave out the first step (see the module docstring).

        ``rate = (n - n_first) / (t - t_first)`` where ``n_first`` and ``t_first`` are the
        count and time when the first update arrived; 0 (shown ``?``) before the second.
        """

        _t_first: float | None = None
        _n_first: int = 0

        def update(self, n: int = 1):
            if self._t_first is None and n:
                self._t_first, self._n_first = self._time(), self.n + n
            return super().update(n)

        @property
        def format_dict(self):
            d = super().format_dict
            done = self.n - self._n_first
            d["rate"] = (done / (self._time() - self._t_first)
                         if self._t_first is not None and done > 0 and self._time() > self._t_first else 0.0)
            return d

    return _Bar


class Reporter:
    """Where progress goes: a stream, in terminal or log style, or nothing.

    Parameters
    ----------
    stream : text stream or None, default None
        Stream for stages and bars (None: ``sys.stderr``).
    quiet : bool, default False
        Print nothing.
    verbose : bool, default False
        Also print :meth:`detail` lines.
    tty : bool or None, default None
        Force terminal (True) or log (False) style; None: ``stream.isatty()`` (False when the
        stream has no ``isatty``).
    log_interval_s : float, default 10.0
        Minimum time [s] between two plain lines of a bar in log style.

    Attributes
    ----------
    stream : text stream
        The stream written to.
    quiet, verbose, tty : bool
        As resolved from the parameters.
    log_interval_s : float
        As given [s].
    compile_noticed : bool
        Whether :data:`COMPILE_NOTICE` has been printed.
    """

    def __init__(self, stream: TextIO | None = None, *, quiet: bool = False, verbose: bool = False,
                 tty: bool | None = None, log_interval_s: float = 10.0):
        self.stream = sys.stderr if stream is None else stream
        self.quiet, self.verbose = quiet, verbose
        if tty is None:
            isatty = getattr(self.stream, "isatty", None)
            tty = bool(isatty()) if isatty else False
        self.tty = tty
        self.log_interval_s = log_interval_s
        self.compile_noticed = False
        self._lock = threading.Lock()

    def line(self, text: str) -> None:
        """Print one line (above any bar being drawn); nothing when quiet.

        Parameters
        ----------
        text : str
            The line, without a newline.
        """
        if self.quiet:
            return
        from tqdm import tqdm

        with self._lock:
            tqdm.write(text, file=self.stream)
            self.stream.flush()

    def stage(self, text: str) -> None:
        """Announce a stage of the work: ``rfsim: <text>`` (nothing when quiet).

        Parameters
        ----------
        text : str
            What is starting, e.g. ``"running phase-cancellation (seed 1)"``.
        """
        self.line(f"rfsim: {text}")

    def detail(self, text: str) -> None:
        """Print ``rfsim: <text>`` only when verbose (and not quiet).

        Parameters
        ----------
        text : str
            The detail.
        """
        if self.verbose:
            self.line(f"rfsim: {text}")

    def bar(self, total: int | None, *, desc: str, unit: str, initial: int = 0):
        """Make a progress bar, or a silent stand-in when quiet.

        On a terminal the bar is redrawn in place (:data:`TTY_FORMAT`, at most every 0.2 s); in
        log style each update is one plain line (:data:`LOG_FORMAT`, at most one every
        ``log_interval_s``). Rate and ETA leave out the first step (see the module docstring).

        Parameters
        ----------
        total : int or None
            Number of steps (None: unknown, no percentage or ETA).
        desc : str
            Label before the count, e.g. ``"monte carlo"``.
        unit : str
            What a step is, e.g. ``"cells"``.
        initial : int, default 0
            Steps already done.

        Returns
        -------
        tqdm.tqdm or stand-in
            An object with ``update(n=1)``, ``close()`` and a count ``n``.
        """
        if self.quiet:
            return _NullBar()
        tqdm = _bar_class()
        if self.tty:
            return tqdm(total=total, initial=initial, desc=desc, unit=unit, file=self.stream,
                        mininterval=0.2, leave=True, bar_format=TTY_FORMAT,
                        nrows=100)  # a terminal that reports 0 rows would otherwise hide the bar
        return tqdm(total=total, initial=initial, desc=desc, unit=unit, file=_LineWriter(self.stream),
                    mininterval=self.log_interval_s, maxinterval=float("inf"), ascii=True,
                    leave=True, bar_format=LOG_FORMAT)

    def compile_started(self) -> None:
        """Tell the reporter that numba started compiling; prints :data:`COMPILE_NOTICE` the first time."""
        if not self.compile_noticed:
            self.compile_noticed = True
            self.stage(COMPILE_NOTICE)


def current() -> Reporter | None:
    """The active reporter.

    Returns
    -------
    Reporter or None
        The reporter of the innermost :func:`reporting` block, or None outside any.
    """
    return _CURRENT.get()


def stage(text: str) -> None:
    """Announce a stage on the active reporter (nothing if none is active).

    Parameters
    ----------
    text : str
        What is starting; printed as ``rfsim: <text>``.
    """
    rep = _CURRENT.get()
    if rep is not None:
        rep.stage(text)


def track(iterable: Iterable[T], *, total: int | None = None, desc: str, unit: str = "trials") -> Iterator[T]:
    """Iterate over an iterable, advancing a progress bar of the active reporter.

    Without an active reporter this is the plain iteration. Progress is counted when an item
    is yielded, so a pool's ordered ``map`` shows the finished tasks.

    Parameters
    ----------
    iterable : iterable
        The items.
    total : int or None, default None
        Number of steps (None: ``len(iterable)`` if it has one, else unknown).
    desc : str
        Label of the bar.
    unit : str, default "trials"
        What a step is.

    Yields
    ------
    object
        The items of ``iterable``, in order.
    """
    rep = _CURRENT.get()
    if rep is None:
        yield from iterable
        return
    if total is None:
        try:
            total = len(iterable)  # type: ignore[arg-type]
        except TypeError:
            total = None
    bar = rep.bar(total, desc=desc, unit=unit)
    try:
        for item in iterable:
            yield item
            bar.update(1)
    finally:
        bar.close()


_LISTENER: list = []


def _install_compile_listener() -> None:
    """Register (once) a numba ``numba:compile`` listener that tells the active reporter.

    numba fires this event only for a real compilation, after a cache lookup failed
    (``numba.core.dispatcher.Dispatcher.compile``), so a cached kernel prints nothing.
    """
    if _LISTENER:
        return
    from numba.core import event

    class CompileListener(event.Listener):
        def on_start(self, ev: Any) -> None:
            rep = _CURRENT.get()
            if rep is not None:
                rep.compile_started()

        def on_end(self, ev: Any) -> None:
            pass

    listener = CompileListener()
    event.register("numba:compile", listener)
    _LISTENER.append(listener)


@contextlib.contextmanager
def reporting(reporter: Reporter) -> Iterator[Reporter]:
    """Make a reporter the active one inside the ``with`` block.

    Also registers (once per process) a numba compile listener, so the active reporter prints
    :data:`COMPILE_NOTICE` on the first compilation (a cache miss).

    Parameters
    ----------
    reporter : Reporter
        The reporter.

    Yields
    ------
    Reporter
        ``reporter``; the previously active one is restored when the block ends.
    """
    _install_compile_listener()
    token = _CURRENT.set(reporter)
    try:
        yield reporter
    finally:
        _CURRENT.reset(token)


__all__ = ["Reporter", "reporting", "current", "stage", "track", "COMPILE_NOTICE", "LOG_FORMAT",
           "TTY_FORMAT"]

"""Sweep progress: a one-line bar on a terminal, periodic log lines in batch logs.

On a TTY the line ``[#########.........] 120/256 runs  3.4 runs/s  ETA 0:00:40`` is
redrawn in place (``\\r``) at most ``tty_interval_s`` apart; when the stream is not a TTY
(SLURM logs, pipes) a plain line ``sweep: 120/256 runs (46.9 %), 3.4 runs/s, ETA 40 s`` is
printed every ``log_interval_s`` and once at the end. The rate counts only runs finished
in this session (resumed runs are done but not timed); ETA = remaining / rate.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO


def _clock_text(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


class Progress:
    """Progress of ``total`` runs of which ``done`` are already finished (resumed)."""

    def __init__(self, total: int, *, done: int = 0, stream: TextIO | None = None,
                 quiet: bool = False, tty: bool | None = None, log_interval_s: float = 10.0,
                 tty_interval_s: float = 0.1, width: int = 24,
                 clock: Callable[[], float] = time.monotonic):
        self.total, self.done, self.resumed = total, done, done
        self.stream = sys.stderr if stream is None else stream
        self.quiet = quiet
        self.tty = self.stream.isatty() if tty is None else tty
        self.interval_s = tty_interval_s if self.tty else log_interval_s
        self.width, self.clock = width, clock
        self.t0 = clock()
        self._last = -float("inf")
        self._last_done = -1
        self._width_used = 0

    def rate(self, now: float) -> float:
        """Runs finished per second in this session, at clock time ``now``."""
        dt = now - self.t0
        return (self.done - self.resumed) / dt if dt > 0 else 0.0

    def text(self, now: float) -> str:
        """The progress line at clock time ``now``."""
        rate = self.rate(now)
        eta = (self.total - self.done) / rate if rate > 0 else None
        if self.tty:
            filled = int(self.width * self.done / self.total) if self.total else self.width
            bar = "#" * filled + "." * (self.width - filled)
            eta_text = "?" if eta is None else _clock_text(eta)
            return f"[{bar}] {self.done}/{self.total} runs  {rate:.2f} runs/s  ETA {eta_text}"
        pct = 100.0 * self.done / self.total if self.total else 100.0
        eta_text = "?" if eta is None else f"{eta:.0f} s"
        return f"sweep: {self.done}/{self.total} runs ({pct:.1f} %), {rate:.2f} runs/s, ETA {eta_text}"

    def start(self) -> None:
        self._emit(force=True)

    def update(self, n: int = 1) -> None:
        """``n`` more runs finished."""
        self.done += n
        self._emit(force=self.done >= self.total)

    def close(self) -> None:
        if self.quiet:
            return
        if self.tty:
            self.stream.write("\r" + self.text(self.clock()).ljust(self._width_used) + "\n")
        elif self._last_done != self.done:
            self.stream.write(self.text(self.clock()) + "\n")
        self.stream.flush()

    def _emit(self, force: bool = False) -> None:
        if self.quiet:
            return
        now = self.clock()
        if not force and now - self._last < self.interval_s:
            return
        self._last = now
        text = self.text(now)
        if self.tty:  # pad over a longer previous line
            self.stream.write("\r" + text.ljust(self._width_used))
            self._width_used = max(self._width_used, len(text))
        else:
            self.stream.write(text + "\n")
        self._last_done = self.done
        self.stream.flush()


__all__ = ["Progress"]

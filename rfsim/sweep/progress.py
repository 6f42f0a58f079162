"""Sweep progress: a tqdm bar on a terminal, periodic plain lines in batch logs.

On a TTY a tqdm bar ``sweep:  47%|████▋     | 120/256 runs [00:35<00:40,  3.40runs/s]`` is
redrawn in place; when the stream is not a TTY (SLURM logs, pipes) a plain line
``sweep: 120/256 runs (46.9 %),  3.40runs/s, elapsed 00:35, ETA 00:40`` is printed at the
start, at most every ``log_interval_s`` and at the end (:class:`rfsim.core.progress.Reporter`).
Runs already finished (``--resume``) count as done from the start; tqdm's rate and ETA
count only the runs finished in this process.
"""

from __future__ import annotations

from typing import TextIO

from rfsim.core.progress import Reporter


class Progress:
    """Progress of ``total`` runs of which ``done`` are already finished (resumed).

    Parameters
    ----------
    total, done : runs in the sweep (or shard) and runs already finished
    stream : where the bar goes (default stderr); ``tty`` forces terminal or log style
    quiet : print nothing
    log_interval_s : minimum time [s] between two log lines when the stream is not a TTY
    reporter : the :class:`~rfsim.core.progress.Reporter` that draws the bar (e.g. a notebook
        widget's); replaces ``stream``, ``quiet``, ``tty`` and ``log_interval_s``
    """

    def __init__(self, total: int, *, done: int = 0, stream: TextIO | None = None,
                 quiet: bool = False, tty: bool | None = None, log_interval_s: float = 10.0,
                 reporter: Reporter | None = None):
        self.total, self.done = total, done
        self._reporter = reporter if reporter is not None else Reporter(stream, quiet=quiet, tty=tty,
                                                                        log_interval_s=log_interval_s)
        self._bar = None

    def start(self) -> None:
        """Show the bar (the first line in a log)."""
        if self._bar is None:
            self._bar = self._reporter.bar(self.total, desc="sweep", unit="runs", initial=self.done)

    def update(self, n: int = 1) -> None:
        """``n`` more runs finished."""
        self.start()
        self.done += n
        self._bar.update(n)

    def close(self) -> None:
        """Draw the final state and end the bar's line."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None


__all__ = ["Progress"]

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
    total : int
        Runs in the sweep (or shard).
    done : int, default 0
        Runs already finished (resumed); the bar starts there.
    stream : file-like, optional
        Where the bar goes (default None: stderr).
    quiet : bool, default False
        Print nothing.
    tty : bool, optional
        Force terminal (True) or log (False) style; None (default) asks the stream.
    log_interval_s : float, default 10.0
        Minimum time [s] between two log lines when the stream is not a TTY.
    reporter : rfsim.core.progress.Reporter, optional
        The reporter that draws the bar (e.g. a notebook widget's); replaces ``stream``,
        ``quiet``, ``tty`` and ``log_interval_s``.

    Attributes
    ----------
    total : int
        Runs in the sweep (or shard).
    done : int
        Runs finished so far, including the resumed ones.
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
        """Count ``n`` more runs as finished (starts the bar if needed).

        Parameters
        ----------
        n : int, default 1
            Runs finished since the last update.
        """
        self.start()
        self.done += n
        self._bar.update(n)

    def close(self) -> None:
        """Draw the final state and end the bar's line."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None


__all__ = ["Progress"]

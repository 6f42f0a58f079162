"""Monte Carlo over cells × repetitions: the size of the run and the loop that runs it.

A Monte-Carlo scenario of this kind (the sense-a-tag phase-cancellation and ST-to-ST runs)
simulates, per cell (a position of the device under test) and repetition, a batch of
positions drawn around it, and returns one column dict per (cell, repetition). The loop runs
every (cell, repetition) on worker processes (:func:`rfsim.core.procs.map_in_order`: results in
task order, so they do not depend on the number of workers) and concatenates the columns in
task order: cell 0 repetitions 0…R−1, then cell 1, ...
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from rfsim.core.config import param
from rfsim.core.procs import map_in_order


@dataclass(frozen=True)
class MonteCarloConfig:
    """Monte Carlo size: positions per cell and repetition, repetitions, worker processes.

    Parameters
    ----------
    full : bool, default False
        Paper size: 300 positions per cell, 3 repetitions (overrides the two below).
    positions_per_cell : int, default 100
        Device positions per cell and repetition, in [1, 100000].
    repetitions : int, default 1
        Repetitions (new positions and channel draws), in [1, 1000].
    workers : int, default 2
        Worker processes in [0, 256] (0 = all cores, 1 = in process).
    """

    full: bool = param(False, doc="paper size: 300 positions per cell, 3 repetitions (overrides the two below)")
    positions_per_cell: int = param(100, lo=1, hi=100000, doc="ST positions per cell and repetition")
    repetitions: int = param(1, lo=1, hi=1000, doc="repetitions (new positions and channel draws)")
    workers: int = param(2, lo=0, hi=256, doc="worker processes (0 = all cores, 1 = in process)")

    @property
    def n_positions(self) -> int:
        """Positions per cell and repetition (300 with ``full``)."""
        return 300 if self.full else self.positions_per_cell

    @property
    def n_repetitions(self) -> int:
        """Repetitions per cell (3 with ``full``)."""
        return 3 if self.full else self.repetitions


def _cell_task(args):
    cell_fn, config, cell, rep, seed = args
    return cell_fn(config, cell, rep, seed)


def run_cells(cell_fn: Callable[..., dict], config, n_cells: int, mc: MonteCarloConfig, *,
              seed: int) -> dict[str, np.ndarray]:
    """Run ``cell_fn(config, cell, rep, seed)`` for every cell and repetition on worker processes.

    Cells < ``n_cells`` and repetitions < ``mc.n_repetitions`` on ``mc.workers`` processes
    (:func:`rfsim.core.procs.map_in_order`); the returned column dicts (same keys) are
    concatenated in task order (cells outer, repetitions inner).

    Parameters
    ----------
    cell_fn : callable
        ``(config, cell, rep, seed) → dict of str to numpy.ndarray``; must be picklable (a
        module-level function) when ``mc.workers`` ≠ 1.
    config : object
        The scenario's configuration, passed on.
    n_cells : int
        Number of cells.
    mc : MonteCarloConfig
        Monte Carlo size and worker count.
    seed : int
        Run seed, passed on.

    Returns
    -------
    dict of str to numpy.ndarray
        The concatenated columns.
    """
    tasks = [(cell_fn, config, c, r, seed) for c in range(n_cells) for r in range(mc.n_repetitions)]
    parts = map_in_order(_cell_task, tasks, mc.workers, desc="monte carlo", unit="cells")
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


__all__ = ["MonteCarloConfig", "run_cells"]

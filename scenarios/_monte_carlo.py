"""Monte Carlo size of the sense-a-tag scenarios (phase-cancellation, st-to-st): positions per
cell, repetitions and worker processes, in a module of its own so that a scenario's config is
read without importing another scenario's physics."""

from __future__ import annotations

from dataclasses import dataclass

from rfsim.core.config import param


@dataclass(frozen=True)
class MonteCarloConfig:
    full: bool = param(False, doc="paper size: 300 positions per cell, 3 repetitions (overrides the two below)")
    positions_per_cell: int = param(100, lo=1, hi=100000, doc="ST positions per cell and repetition")
    repetitions: int = param(1, lo=1, hi=1000, doc="repetitions (new positions and channel draws)")
    workers: int = param(2, lo=0, hi=256, doc="worker processes (0 = all cores, 1 = in process)")

    @property
    def n_positions(self) -> int:
        return 300 if self.full else self.positions_per_cell

    @property
    def n_repetitions(self) -> int:
        return 3 if self.full else self.repetitions


__all__ = ["MonteCarloConfig"]

"""Size models of the built-in scenarios (:class:`~rfsim.runs.resources.Estimate` of a config).

A model reads only the config's keys (the core never imports the scenarios). Its peak is the
scenario's baseline (the peak resident memory of its smallest run, kernels cached, rounded up)
plus bytes per work unit times the units held at once (the rows every unit adds to the tables
the run keeps until it writes them, and the unit's working arrays), both measured on runs of
two sizes and rounded up; a run with worker processes counts one process per worker besides
the leader (each holding the same baseline). ``tests/test_resources.py`` checks that the
estimate bounds the measured peak within 2x at two sizes of every scenario.
"""

from __future__ import annotations

import math
from typing import Callable

from rfsim.runs.resources import Estimate, pool_processes, process_peak

MiB = 2**20


def estimate_of(module, config) -> Estimate | None:
    """The scenario's own ``resource_estimate(config)``, else the size model of its name (built-in
    scenario modules only), else None (no check)."""
    fn = getattr(module, "resource_estimate", None)
    if fn is None and getattr(module, "__name__", "").startswith("rfsim.scenarios."):
        fn = SIZE_MODELS.get(module.NAME)
    return fn(config) if fn is not None else None


def _model(units: float, drivers: tuple[str, ...], *, base_mib: float, bytes_per_unit: float,
           workers: int = 1, tasks: int = 1) -> Estimate:
    procs = pool_processes(workers, tasks)
    return Estimate(int(units), process_peak(bytes_per_unit, units, processes=procs, baseline_bytes=int(base_mib * MiB)),
                    drivers)


def _mc(config, cells_key: str, cells: int) -> Estimate:
    """phase-cancellation and st-to-st: cells × positions × repetitions sample rows."""
    mc = config.mc
    return _model(cells * mc.n_positions * mc.n_repetitions,
                  ("mc.positions_per_cell", "mc.repetitions", "mc.full", cells_key, "mc.workers"),
                  base_mib=BASE_MIB["mc"], bytes_per_unit=PER_UNIT["mc"], workers=mc.workers,
                  tasks=cells * mc.n_repetitions)


BASE_MIB = {}
PER_UNIT = {}

SIZE_MODELS: dict[str, Callable[..., Estimate]] = {
}

__all__ = ["SIZE_MODELS", "estimate_of"]

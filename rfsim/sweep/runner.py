"""Run a sweep: expand and validate every point, execute the missing runs, merge.

:func:`run_sweep` validates the configs of all points before anything runs, builds one
:class:`~rfsim.sweep.store.PointTask` per (point, repetition), keeps those of the shard
(``shard=(I, N)``), skips the runs whose point files are valid when ``resume`` is set,
executes the rest on the executor while updating the progress, and — for a whole sweep —
merges the point store into the output file (atomically, only once every run exists).
:func:`merge_sweep` is the merge alone (after SLURM array tasks).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from rfsim.config import to_toml
from rfsim.dataset import make_provenance, utc_now
from rfsim.errors import UserError
from rfsim.registry import get_scenario
from rfsim.sweep.executors import SerialExecutor
from rfsim.sweep.progress import Progress
from rfsim.sweep.spec import SweepSpec, point_configs, point_seed, point_values, shard_runs
from rfsim.sweep.store import (PointResult, PointTask, is_valid_point, merge_points, point_path,
                               points_dir, remove_partials, write_merged)


@dataclasses.dataclass(frozen=True)
class SweepReport:
    """What a sweep (or a shard of it) did."""

    n_runs: int
    selected: int
    computed: int
    reused: int
    output: Path | None
    wall_time_s: float
    results: tuple[PointResult, ...]


@dataclasses.dataclass(frozen=True)
class SweepPlan:
    """The validated expansion of a spec: module, per-point values/configs, all tasks."""

    spec: SweepSpec
    module: ModuleType
    values: list[dict[str, Any]]
    configs: list[Any]
    tasks: list[PointTask]

    def seeds(self) -> np.ndarray:
        """(n_points, repetitions) int64 run seeds."""
        return np.array([t.seed for t in self.tasks], dtype=np.int64).reshape(
            len(self.configs), self.spec.repetitions)


def plan_sweep(spec: SweepSpec) -> SweepPlan:
    """Expand ``spec`` and validate every point's config (nothing runs)."""
    module = get_scenario(spec.scenario)
    configs = point_configs(spec, module.Config)
    values = point_values(spec)
    tasks = [PointTask(module.__name__, cfg, i, k, point_seed(spec.seed, i, k),
                       point_path(spec.output, i, k))
             for i, cfg in enumerate(configs) for k in range(spec.repetitions)]
    return SweepPlan(spec, module, values, configs, tasks)


def _quiet(total: int, *, done: int) -> Progress:
    return Progress(total, done=done, quiet=True)


def run_sweep(spec: SweepSpec, executor: Any = None, *, shard: tuple[int, int] | None = None,
              resume: bool = False, merge: bool = True,
              progress: Callable[..., Progress] | None = None,
              on_result: Callable[[PointResult], None] | None = None) -> SweepReport:
    """Run the sweep ``spec`` (or shard ``(I, N)`` of it) on ``executor`` (serial if None).

    ``progress(total, done=...)`` builds the :class:`Progress` display (none if None).
    Returns a :class:`SweepReport`; ``output`` is the merged file, or None for a shard or
    when ``merge`` is False.
    """
    t0 = time.perf_counter()
    start_utc = utc_now()
    plan = plan_sweep(spec)
    executor = SerialExecutor() if executor is None else executor
    selected = plan.tasks if shard is None else [plan.tasks[j] for j in shard_runs(len(plan.tasks), *shard)]
    todo = [t for t in selected if not is_valid_point(t, plan.module.NAME)] if resume else selected
    points_dir(spec.output).mkdir(parents=True, exist_ok=True)
    progress_bar = (progress or _quiet)(len(selected), done=len(selected) - len(todo))
    progress_bar.start()
    results = []
    try:
        for result in executor.map(todo):
            results.append(result)
            progress_bar.update()
            if on_result is not None:
                on_result(result)
    finally:
        progress_bar.close()
    output = None
    if shard is None and merge:
        output = merge_sweep(spec, plan=plan, start_time_utc=start_utc)
    return SweepReport(len(plan.tasks), len(selected), len(results), len(selected) - len(todo),
                       output, time.perf_counter() - t0, tuple(results))


def missing_runs(plan: SweepPlan) -> list[PointTask]:
    """Runs whose point file is absent, incomplete or from another spec."""
    return [t for t in plan.tasks if not is_valid_point(t, plan.module.NAME)]


def merge_sweep(spec: SweepSpec, *, plan: SweepPlan | None = None,
                start_time_utc: str | None = None) -> Path:
    """Merge the complete point store of ``spec`` into ``spec.output`` (atomic write)."""
    plan = plan or plan_sweep(spec)
    missing = missing_runs(plan)
    if missing:
        t = missing[0]
        raise UserError(f"sweep merge: {len(missing)} of {len(plan.tasks)} runs are missing or stale "
                        f"in {str(points_dir(spec.output))!r} (first: point {t.point} repetition "
                        f"{t.repetition}); run them with 'rfsim sweep run SPEC --resume'")
    merged = merge_points([(t.point, t.repetition, t.seed, t.path) for t in plan.tasks],
                          plan.values, plan.module.Config, spec.repetitions)
    prov = make_provenance(
        config_toml=to_toml(plan.configs[0]), seed=spec.seed, scenario=plan.module.NAME,
        start_time_utc=start_time_utc or utc_now(),
        extra={"spec_toml": spec.text, "sweep_points": len(plan.configs),
               "sweep_repetitions": spec.repetitions, "sweep_runs": len(plan.tasks),
               "sweep_keys": ", ".join(spec.swept_keys), "point_seeds": plan.seeds(),
               "config_toml_is": "the resolved config of point 0"})
    path = write_merged(spec.output, merged, prov)
    remove_partials(spec.output)
    return path


__all__ = ["SweepReport", "SweepPlan", "plan_sweep", "run_sweep", "missing_runs", "merge_sweep"]

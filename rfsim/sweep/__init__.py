"""Parameter sweeps: spec → points → executor (serial, processes, Dask, SLURM shards) → merge.

Public names::

    load_spec(path) -> SweepSpec            parse_spec(mapping) -> SweepSpec
    point_values(spec), point_configs(spec, Config), point_seed(seed, point, repetition)
    plan_sweep(spec) -> SweepPlan           run_sweep(spec, executor, ...) -> SweepReport
    merge_sweep(spec) -> Path               sbatch_script(spec_path, shards, workdir=...)
    SerialExecutor(), PoolExecutor(workers), DaskExecutor(target), make_executor(...)
    Progress(total, ...)
"""

from rfsim.sweep.executors import DaskExecutor, PoolExecutor, SerialExecutor, available_cpus, make_executor
from rfsim.sweep.progress import Progress
from rfsim.sweep.runner import SweepPlan, SweepReport, merge_sweep, missing_runs, plan_sweep, run_sweep
from rfsim.sweep.slurm import sbatch_script
from rfsim.sweep.spec import (SweepSpec, load_spec, parse_spec, point_config_dict, point_configs, point_seed,
                              point_values, shard_runs)
from rfsim.sweep.store import point_path, points_dir

__all__ = [
    "SweepSpec", "load_spec", "parse_spec", "point_values", "point_config_dict", "point_configs",
    "point_seed", "shard_runs",
    "SweepPlan", "SweepReport", "plan_sweep", "run_sweep", "merge_sweep", "missing_runs",
    "SerialExecutor", "PoolExecutor", "DaskExecutor", "available_cpus", "make_executor",
    "Progress", "sbatch_script", "points_dir", "point_path",
]

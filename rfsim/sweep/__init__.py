"""Parameter sweeps: spec → points → executor (serial, processes, Dask, SLURM shards) → merge.

Public names::

    load_spec(path) -> SweepSpec            parse_spec(mapping) -> SweepSpec
    point_value(spec, i), point_values(spec), point_config(spec, Config, i), point_seed(seed, point, repetition)
    plan_sweep(spec) -> SweepPlan           run_sweep(spec, executor, ...) -> SweepReport
    merge_sweep(spec) -> Path               sbatch_script(spec_path, shards, workdir=...)
    SerialExecutor(), PoolExecutor(workers), DaskExecutor(target), make_executor(...)
    Progress(total, ...)                    extract_point(merged, point, output, repetition=None)

Modules: spec (parsing, expansion, seeds), runner (plan, run, merge), store (point store),
merge (merged file layout), extract (one point of a merged file as a dataset), executors,
slurm (sbatch script), lock, progress.
"""

from rfsim.sweep.executors import DaskExecutor, PoolExecutor, SerialExecutor, available_cpus, make_executor
from rfsim.sweep.extract import extract_point
from rfsim.sweep.progress import Progress
from rfsim.sweep.runner import SweepPlan, SweepReport, merge_sweep, missing_runs, plan_sweep, run_sweep
from rfsim.sweep.slurm import sbatch_script
from rfsim.sweep.spec import (SweepSpec, iter_point_values, load_spec, parse_spec, point_config, point_config_dict,
                              point_configs, point_seed, point_value, point_values, shard_runs)
from rfsim.sweep.store import StoreIndex, points_dir

__all__ = [
    "SweepSpec", "load_spec", "parse_spec", "point_value", "iter_point_values", "point_values",
    "point_config", "point_config_dict", "point_configs", "point_seed", "shard_runs",
    "SweepPlan", "SweepReport", "plan_sweep", "run_sweep", "merge_sweep", "missing_runs",
    "SerialExecutor", "PoolExecutor", "DaskExecutor", "available_cpus", "make_executor",
    "Progress", "sbatch_script", "points_dir", "StoreIndex", "extract_point",
]


class _SweepPackage(type(__import__("sys"))):
    """This package, callable: ``rfsim.sweep(spec, executor=...)`` runs a sweep and returns its
    merged result (:func:`rfsim.runs.api.run_sweep`), while ``rfsim.sweep.<name>`` stays the
    package's API for finer control."""

    def __call__(self, spec, *, executor=None, resume: bool = False, progress: bool = True):
        from rfsim.runs.api import run_sweep as _run_sweep_result

        return _run_sweep_result(spec, executor=executor, resume=resume, progress=progress)


__import__("sys").modules[__name__].__class__ = _SweepPackage

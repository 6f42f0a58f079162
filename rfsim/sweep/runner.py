"""Run a sweep: check the points and the outputs, execute the missing runs, merge.

:func:`run_sweep` validates the config of every point before anything runs (streaming,
one point at a time), checks that the merged file and the point store can be written,
locks the output (:mod:`rfsim.sweep.lock`), keeps the runs of the shard (``shard=(I, N)``),
skips the runs already in the point store when ``resume`` is set, executes the rest on
the executor while updating the progress, and — for a whole sweep — merges the point
store into the output file (atomically, only once every run exists).
:func:`merge_sweep` is the merge alone (after SLURM array tasks).

Nothing here holds all points in memory: a :class:`SweepPlan` computes a point's values,
config, seed and task on demand, so ``plan.tasks`` of a 10⁷-run spec costs nothing until
it is iterated.
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any, NamedTuple

import numpy as np

from rfsim.core.config import to_toml
from rfsim.core.dataset import make_provenance, utc_now
from rfsim.core.errors import UserError
from rfsim.core.outputs import check_output_file, check_output_folder, remove_stale_partials
from rfsim.runs.registry import get_scenario
from rfsim.runs.resources import check_memory
from rfsim.runs.sizes import estimate_of
from rfsim.sweep.executors import SerialExecutor
from rfsim.sweep.lock import OutputLock
from rfsim.sweep.merge import merge_store
from rfsim.sweep.progress import Progress
from rfsim.sweep.spec import (SweepSpec, axis_support, check_axis_values, point_config, point_seed, point_value,
                              shard_runs)
from rfsim.sweep.store import (CorruptRecordError, PointResult, PointTask, RecordReader, RecordRef, StoreIndex,
                               close_writers, config_digest, points_dir)

#: Provenance keeps the (points, repetitions) seed array as an attribute up to this many
#: runs (HDF5 attributes are limited to 64 kB); ``sweep_runs/seed`` always has every seed.
SEED_ATTR_MAX_RUNS = 4096


class _Lazy(Sequence):
    """A read-only sequence of ``n`` items computed by ``item(i)`` on access."""

    def __init__(self, n: int, item: Callable[[int], Any]):
        self._n, self._item = n, item

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self._item(j) for j in range(*i.indices(self._n))]
        if i < 0:
            i += self._n
        if not 0 <= i < self._n:
            raise IndexError(i)
        return self._item(i)


@dataclasses.dataclass(frozen=True)
class SweepReport:
    """What a sweep (or a shard of it) did.

    Attributes
    ----------
    n_runs : int
        Runs of the whole sweep (points × repetitions).
    selected : int
        Runs of this call (the shard's runs, or all of them).
    computed : int
        Runs executed in this call.
    reused : int
        Runs found complete in the point store and skipped (``resume``).
    output : pathlib.Path or None
        The merged file; None for a shard or when the merge was not asked for.
    wall_time_s : float
        Wall-clock time of the call [s].
    results : tuple of rfsim.sweep.store.PointResult
        The results of the computed runs, in completion order.
    """

    n_runs: int
    selected: int
    computed: int
    reused: int
    output: Path | None
    wall_time_s: float
    results: tuple[PointResult, ...]


class _PointValue(NamedTuple):
    """A plan's cache entry: the value (config or digest) of one point."""

    point: int
    value: Any


@dataclasses.dataclass(frozen=True, eq=False)
class SweepPlan:
    """The expansion of a spec, computed on demand: per-point values, configs, seeds, tasks.

    Build it with :func:`plan_sweep`. Nothing is held per point: the sequences below compute
    each item on access.

    Attributes
    ----------
    spec : SweepSpec
        The sweep.
    module : module
        The scenario module (its ``Config``, ``NAME`` and ``run``).
    n_points : int
        Points of the sweep.
    values : sequence of dict
        Per point, the swept dotted keys and their values (:func:`rfsim.sweep.spec.point_value`).
    configs : sequence of Config
        Per point, the validated config (:meth:`config`).
    tasks : sequence of rfsim.sweep.store.PointTask
        Per run (``point * repetitions + repetition``), its task (:meth:`task`).
    """

    spec: SweepSpec
    module: ModuleType
    _cache: dict = dataclasses.field(default_factory=dict, repr=False)

    def _last(self, name: str, i: int, compute: Callable[[], Any]) -> Any:
        """The cache entry ``name`` if it holds point ``i``'s value, else ``compute()``, kept
        as the entry (one point per name: the last one asked for)."""
        hit = self._cache.get(name)
        if hit is not None and hit.point == i:
            return hit.value
        value = compute()
        self._cache[name] = _PointValue(i, value)
        return value

    @property
    def n_points(self) -> int:
        """Points of the sweep."""
        return self.spec.n_points

    @property
    def values(self) -> Sequence[dict[str, Any]]:
        """Swept values of each point, computed on access."""
        return _Lazy(self.n_points, lambda i: point_value(self.spec, i))

    @property
    def configs(self) -> Sequence[Any]:
        """Validated config of each point, computed on access."""
        return _Lazy(self.n_points, self.config)

    @property
    def tasks(self) -> Sequence[PointTask]:
        """Task of each run (flat index ``point * repetitions + repetition``), computed on access."""
        return _Lazy(self.spec.n_runs, self.task)

    def config(self, i: int) -> Any:
        """Validated config of point ``i`` (the last point's is cached).

        Parameters
        ----------
        i : int
            Point index, in ``[0, n_points)``.

        Returns
        -------
        Config
            The scenario's config with the point's values applied
            (:func:`rfsim.sweep.spec.point_config`).
        """
        return self._last("config", i, lambda: point_config(self.spec, self.module.Config, i))

    def digest(self, i: int) -> bytes:
        """Digest of point ``i``'s config, as the point store records it (the last is cached).

        Parameters
        ----------
        i : int
            Point index.

        Returns
        -------
        bytes
            The first 16 bytes of the SHA-256 of the config's TOML text
            (:func:`rfsim.sweep.store.config_digest`).
        """
        return self._last("digest", i, lambda: config_digest(self.config(i)))

    def task(self, run: int) -> PointTask:
        """Task of one run.

        Parameters
        ----------
        run : int
            Flat run index ``point * repetitions + repetition``.

        Returns
        -------
        rfsim.sweep.store.PointTask
            Scenario module name, config, point, repetition, seed
            (:func:`rfsim.sweep.spec.point_seed`) and point store folder of the run.
        """
        i, k = divmod(run, self.spec.repetitions)
        return PointTask(self.module.__name__, self.config(i), i, k, point_seed(self.spec.seed, i, k),
                         points_dir(self.spec.output))

    def seeds(self) -> np.ndarray:
        """Seeds of every run.

        Returns
        -------
        ndarray of int64, shape (n_points, repetitions)
            ``point_seed(spec.seed, point, repetition)``.
        """
        return np.array([point_seed(self.spec.seed, i, k) for i in range(self.n_points)
                         for k in range(self.spec.repetitions)], dtype=np.int64).reshape(
            self.n_points, self.spec.repetitions)

    def numeric_keys(self) -> dict[str, np.dtype]:
        """Swept keys whose values are all numbers (or all booleans), with their column dtype.

        Returns
        -------
        dict of str to numpy.dtype
            Dotted key → dtype of the NumPy array of its axis values; other keys (text,
            lists, tables, mixed) are left out and stored as text by the merge.
        """
        out: dict[str, np.dtype] = {}
        for axis in self.spec.axes:
            for j, key in enumerate(axis.keys):
                vals = axis_support(axis, j)
                if all(isinstance(v, bool) for v in vals) or all(
                        isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
                    out[key] = np.asarray(vals).dtype
        return out


def plan_sweep(spec: SweepSpec, *, check: str = "all", module: ModuleType | None = None) -> SweepPlan:
    """The plan of ``spec``, with its point configs checked as asked.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    check : {"all", "sample", "none"}, default "all"
        ``"all"`` validates every point's config (one at a time); ``"sample"`` the first
        three points in full and every axis value against its key's type and range
        (:func:`~rfsim.sweep.spec.check_axis_values`; dry-run, SLURM plan); ``"none"``
        nothing.
    module : module, optional
        Scenario module to use instead of the one registered under ``spec.scenario``.

    Returns
    -------
    SweepPlan
        The plan.

    Raises
    ------
    ValueError
        ``check`` is not one of the three.
    rfsim.core.errors.ConfigError
        A checked point has an invalid config value.
    """
    module = module or get_scenario(spec.scenario)
    plan = SweepPlan(spec, module)
    if check == "sample":
        for i in range(min(3, spec.n_points)):
            point_config(spec, module.Config, i)
        check_axis_values(spec, module.Config)
    elif check == "all":
        for i in range(spec.n_points):
            point_config(spec, module.Config, i)
    elif check != "none":
        raise ValueError(f"check={check!r}: expected 'all', 'sample' or 'none'")
    return plan


def _quiet(total: int, *, done: int) -> Progress:
    return Progress(total, done=done, quiet=True)


def check_sweep_memory(spec: SweepSpec, limit_bytes: int | None, processes: int, *,
                       module: ModuleType | None = None) -> None:
    """Stop before any run when the sweep's largest point would need too much memory.

    The largest estimated peak memory of the sweep's points
    (:func:`rfsim.runs.sizes.estimate_of`) times ``processes`` is compared with
    ``limit_bytes``; a scenario without an estimate is not checked.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    limit_bytes : int or None
        Memory limit [bytes]; None: no check.
    processes : int
        Processes that run points at once.
    module : module, optional
        Scenario module to use instead of the one registered under ``spec.scenario``.

    Raises
    ------
    UserError
        The estimated peak exceeds the limit (one line, naming the size drivers).
    """
    if limit_bytes is None:
        return
    plan = plan_sweep(spec, check="none", module=module)
    worst = None
    for i in range(plan.n_points):
        est = estimate_of(plan.module, plan.config(i))
        if est is None:
            return
        if worst is None or est.peak_bytes > worst.peak_bytes:
            worst = est
    check_memory(worst, limit_bytes, what=f"a point of sweep {spec.scenario!r}", processes=processes)


def check_sweep_outputs(spec: SweepSpec) -> None:
    """Check that the merged file and the point store can be written (before anything runs).

    Parameters
    ----------
    spec : SweepSpec
        The sweep; its ``output`` must end in ``.h5`` or ``.hdf5``.

    Raises
    ------
    UserError
        The output file or the point store folder cannot be written.
    """
    check_output_file(spec.output, "sweep output", suffixes=(".h5", ".hdf5"))
    check_output_folder(points_dir(spec.output), "sweep point store")


def _found(plan: SweepPlan, index: StoreIndex, run: int):
    i, k = divmod(run, plan.spec.repetitions)
    return index.find(i, k, point_seed(plan.spec.seed, i, k), plan.digest(i))


def _reusable(ref: RecordRef | None, reader: RecordReader) -> bool:
    """A run found in the point store whose record also reads back whole (its CRC): a
    damaged record is run again, and the merge takes the new record (the newest segment
    wins), so one flipped byte costs one run, not its segment."""
    if ref is None:
        return False
    try:
        reader.read(ref)
    except CorruptRecordError:
        return False
    return True


def run_sweep(spec: SweepSpec, executor: Any = None, *, shard: tuple[int, int] | None = None,
              resume: bool = False, merge: bool = True,
              progress: Callable[..., Progress] | None = None,
              on_result: Callable[[PointResult], None] | None = None,
              module: ModuleType | None = None) -> SweepReport:
    """Run the sweep ``spec`` (or shard ``(I, N)`` of it) on ``executor``.

    Every point's config is validated and the outputs checked before anything runs; the
    output is locked (:class:`rfsim.sweep.lock.OutputLock`) for the whole call.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    executor : object, optional
        An executor of :mod:`rfsim.sweep.executors` (anything with ``map(tasks, n_tasks=)``
        or ``map(tasks)``); None (default): :class:`~rfsim.sweep.executors.SerialExecutor`.
    shard : tuple of (int, int), optional
        ``(I, N)``: run only shard ``I`` of ``N`` (:func:`rfsim.sweep.spec.shard_runs`) and
        do not merge; None (default): the whole sweep.
    resume : bool, default False
        Skip the runs already in the point store whose records read back whole.
    merge : bool, default True
        Merge the point store into ``spec.output`` after a whole sweep.
    progress : callable, optional
        ``progress(total, done=...)`` builds the :class:`~rfsim.sweep.progress.Progress`
        display; None (default): no display.
    on_result : callable, optional
        Called with each :class:`~rfsim.sweep.store.PointResult` as it arrives.
    module : module, optional
        Scenario module to run instead of the one named in the spec.

    Returns
    -------
    SweepReport
        What was run; its ``output`` is the merged file, or None for a shard or when
        ``merge`` is False.

    Raises
    ------
    UserError
        An output cannot be written, the output is locked by another process, or (merge)
        runs are missing from the point store.
    """
    t0 = time.perf_counter()
    start_utc = utc_now()
    plan = plan_sweep(spec, module=module)
    check_sweep_outputs(spec)
    executor = SerialExecutor() if executor is None else executor
    with OutputLock(spec.output, shard=shard):
        if shard is None:
            remove_stale_partials(spec.output)
        runs: Sequence[int] = range(spec.n_runs) if shard is None else shard_runs(spec.n_runs, *shard)
        if resume:
            index = StoreIndex(points_dir(spec.output))
            with RecordReader() as reader:
                todo = [j for j in runs if not _reusable(_found(plan, index, j), reader)]
            del index
        else:
            todo = runs
        progress_bar = (progress or _quiet)(len(runs), done=len(runs) - len(todo))
        progress_bar.start()
        results = []
        try:
            for result in _map(executor, (plan.task(j) for j in todo), len(todo)):
                results.append(result)
                progress_bar.update()
                if on_result is not None:
                    on_result(result)
        finally:
            progress_bar.close()
            close_writers()
        output = None
        if shard is None and merge:
            output = _merge(plan, start_utc)
    return SweepReport(spec.n_runs, len(runs), len(results), len(runs) - len(todo),
                       output, time.perf_counter() - t0, tuple(results))


def _map(executor: Any, tasks: Iterator[PointTask], n: int) -> Iterator[PointResult]:
    try:
        return executor.map(tasks, n_tasks=n)
    except TypeError:  # an executor written for the plain map(tasks) protocol
        return executor.map(list(tasks))


def missing_runs(plan: SweepPlan) -> list[PointTask]:
    """Runs that are not (or not for this spec) in the point store.

    A run counts as present when the store has a record of its point, repetition, seed and
    config digest.

    Parameters
    ----------
    plan : SweepPlan
        The sweep's plan.

    Returns
    -------
    list of rfsim.sweep.store.PointTask
        The tasks of the missing runs, in run order.
    """
    index = StoreIndex(points_dir(plan.spec.output))
    return [plan.task(j) for j in range(plan.spec.n_runs) if _found(plan, index, j) is None]


def merge_sweep(spec: SweepSpec, *, plan: SweepPlan | None = None, start_time_utc: str | None = None,
                module: ModuleType | None = None) -> Path:
    """Merge the complete point store of ``spec`` into ``spec.output`` (atomic write).

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    plan : SweepPlan, optional
        The sweep's plan, when the caller already holds the output lock (as
        :func:`run_sweep` does); None (default): plan, check the output and lock it here.
    start_time_utc : str, optional
        Start time recorded in the provenance (default: now).
    module : module, optional
        Scenario module to use instead of the one registered under ``spec.scenario``.

    Returns
    -------
    pathlib.Path
        The merged file (layout: :mod:`rfsim.sweep.merge`).

    Raises
    ------
    UserError
        A run is missing or stale in the point store, the output cannot be written or is
        locked by another process.
    """
    if plan is None:
        plan = plan_sweep(spec, check="none", module=module)
        check_sweep_outputs(spec)
        with OutputLock(spec.output):
            remove_stale_partials(spec.output)
            return _merge(plan, start_time_utc)
    return _merge(plan, start_time_utc)


def _merge(plan: SweepPlan, start_time_utc: str | None) -> Path:
    spec = plan.spec
    index = StoreIndex(points_dir(spec.output))
    n = spec.n_runs
    where = np.zeros((n, 3), np.int64)  # segment, offset, length of each run's record
    seeds = np.zeros(n, np.int64)
    missing, first = 0, None
    for j in range(n):
        i, k = divmod(j, spec.repetitions)
        seeds[j] = point_seed(spec.seed, i, k)
        hit = index.locate(i, k, int(seeds[j]), plan.digest(i))
        if hit is None:
            missing += 1
            first = first or (i, k)
        else:
            where[j] = hit
    if missing:
        raise UserError(f"sweep merge: {missing} of {n} runs are missing or stale in "
                        f"{str(points_dir(spec.output))!r} (first: point {first[0]} repetition {first[1]}); "
                        "run them with 'rfsim sweep run SPEC --resume'")
    logs = index.logs
    del index
    refs = _Lazy(n, lambda j: RecordRef(logs[where[j, 0]], int(where[j, 1]), int(where[j, 2])))
    runs = np.arange(n, dtype=np.int64)
    extra = {"spec_toml": spec.text, "sweep_points": spec.n_points, "sweep_repetitions": spec.repetitions,
             "sweep_runs": n, "sweep_keys": ", ".join(spec.swept_keys),
             "config_toml_is": "the resolved config of point 0"}
    if not spec.text:  # built from a mapping: keep it, so that a point's config can be rebuilt
        extra["spec_json"] = json.dumps(spec.data, default=str)
    if n <= SEED_ATTR_MAX_RUNS:
        extra["point_seeds"] = plan.seeds()
    prov = make_provenance(config_toml=to_toml(plan.config(0)), seed=spec.seed, scenario=plan.module.NAME,
                           start_time_utc=start_time_utc or utc_now(), extra=extra)
    return merge_store(spec.output, refs, (runs // spec.repetitions, runs % spec.repetitions, seeds),
                       lambda i: point_value(spec, i), spec.n_points, spec.repetitions,
                       spec.swept_keys, plan.module.Config, prov, plan.numeric_keys())


__all__ = ["SweepReport", "SweepPlan", "plan_sweep", "run_sweep", "missing_runs", "merge_sweep",
           "check_sweep_memory", "check_sweep_outputs", "SEED_ATTR_MAX_RUNS"]

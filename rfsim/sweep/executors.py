"""Where the runs of a sweep execute: in-process, a local process pool, or Dask.

An executor maps :func:`rfsim.sweep.store.run_point` over an iterable of
:class:`~rfsim.sweep.store.PointTask` (``map(tasks, n_tasks)``, consumed lazily) and
yields a :class:`~rfsim.sweep.store.PointResult` as each run finishes (in completion
order; every run is its own record in the point store, so the order never changes the
result). SLURM arrays need no
executor here: each array task runs its shard with one of these (see
:mod:`rfsim.sweep.slurm`).

* :class:`SerialExecutor` — one run after the other in this process;
* :class:`PoolExecutor` — ``concurrent.futures.ProcessPoolExecutor`` with ``workers``
  processes (default: the CPUs this process may run on, ``os.sched_getaffinity``);
* :class:`DaskExecutor` — ``dask.distributed``: an existing scheduler (``ADDRESS``), a
  ``LocalCluster`` on loopback (``local[:N]``, dashboard on a free loopback port) or a ``Client`` given in Python. Tasks are
  submitted with ``retries`` and ``pure=False``; a run lost with a killed worker is
  rescheduled by the scheduler on another worker.
"""

from __future__ import annotations

import concurrent.futures as cf
import itertools
import logging
import os
import re
import uuid
from collections.abc import Iterable, Iterator
from typing import Any

from rfsim.core.errors import UserError
from rfsim.core.procs import worker_pool
from rfsim.sweep.store import PointResult, PointTask, run_point, run_points


def available_cpus() -> int:
    """CPUs this process may run on (``os.sched_getaffinity`` where it exists)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


def batch_size(n_tasks: int | None, workers: int) -> int:
    """Runs per submitted task: 1 for small sweeps, up to :data:`MAX_BATCH` for huge ones.

    About 8 batches per worker, so the per-task overhead of the pool or the scheduler is
    paid once per batch while the load stays balanced.
    """
    if not n_tasks:
        return 1
    return max(1, min(MAX_BATCH, n_tasks // (8 * max(workers, 1))))


#: Largest number of runs sent to a worker in one task.
MAX_BATCH = 256


def batches(tasks: Iterable[PointTask], size: int) -> Iterator[list[PointTask]]:
    """``tasks`` in lists of ``size`` (the last one shorter), consumed lazily."""
    it = iter(tasks)
    while chunk := list(itertools.islice(it, size)):
        yield chunk


class SerialExecutor:
    """Run every task in this process, in order."""

    name = "serial"
    workers = 1

    def map(self, tasks: Iterable[PointTask], n_tasks: int | None = None) -> Iterator[PointResult]:
        for task in tasks:
            yield run_point(task)

    def close(self) -> None:
        pass


class PoolExecutor:
    """A local process pool of ``workers`` processes (:func:`rfsim.core.procs.worker_pool`).

    Tasks are sent in batches (:func:`batch_size`) with at most ``4 × workers`` batches in
    flight, so a sweep of millions of runs is never held in memory as futures. The workers
    die with the leader, even when it is killed with SIGKILL.
    """

    name = "pool"

    def __init__(self, workers: int | None = None):
        self.workers = available_cpus() if workers is None else int(workers)
        if self.workers < 1:
            raise UserError(f"--workers {workers}: expected an integer >= 1")

    def map(self, tasks: Iterable[PointTask], n_tasks: int | None = None) -> Iterator[PointResult]:
        if n_tasks is None:
            tasks = list(tasks)
            n_tasks = len(tasks)
        if not n_tasks:
            return
        n_workers = min(self.workers, n_tasks)
        chunks = batches(tasks, batch_size(n_tasks, n_workers))
        with worker_pool(n_workers) as pool:
            pending = {pool.submit(run_points, c) for c in itertools.islice(chunks, 4 * n_workers)}
            while pending:
                done, pending = cf.wait(pending, return_when=cf.FIRST_COMPLETED)
                for fut in done:
                    results = fut.result()
                    for c in itertools.islice(chunks, 1):
                        pending.add(pool.submit(run_points, c))
                    yield from results

    def close(self) -> None:
        pass


def _import_distributed():
    try:
        import dask.distributed as distributed
    except ImportError:
        raise UserError("--dask needs dask.distributed: pip install 'rfsim[dask]'") from None
    return distributed


#: A Dask scheduler address: [scheme://]host:port, or scheme://host (default port).
_ADDRESS = re.compile(r"(?:(?:tcp|tls|ucx|ws|wss|inproc)://[^\s/:]+(?::\d{1,5})?|[^\s/:]+:\d{1,5})")


def parse_dask_target(text: str) -> tuple[str, int | None]:
    """``"local"`` / ``"local:N"`` → ("local", N or None); anything else is an address."""
    if text == "local" or text.startswith("local:"):
        _, _, n = text.partition(":")
        if not n:
            return "local", None
        if not n.isdigit() or int(n) < 1:
            raise UserError(f"--dask {text!r}: expected local or local:N with N >= 1 workers")
        return "local", int(n)
    if not _ADDRESS.fullmatch(text):
        raise UserError(f"--dask {text!r}: expected a scheduler address (tcp://host:8786, "
                        "host:8786) or local[:N]")
    return text, None


class DaskExecutor:
    """Run the tasks on a Dask cluster.

    Parameters
    ----------
    target : scheduler address (``"tcp://host:8786"``), ``"local"`` / ``"local:N"`` (a
        ``LocalCluster`` of N single-threaded worker processes bound to 127.0.0.1; N
        defaults to the available CPUs), or an existing ``dask.distributed.Client``.
    retries : resubmissions of a run whose task raised (worker loss is handled by the
        scheduler, which reschedules the runs of a dead worker).
    """

    name = "dask"

    def __init__(self, target: Any = "local", *, retries: int = 3):
        distributed = _import_distributed()
        self.retries = retries
        self._cluster = None
        self._own_client = False
        if isinstance(target, distributed.Client):
            self.client = target
        else:
            address, n = parse_dask_target(str(target))
            if address == "local":
                n = available_cpus() if n is None else n
                self._cluster = distributed.LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                    dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR)
                self.client = distributed.Client(self._cluster)
            else:
                try:
                    self.client = distributed.Client(address, timeout="20s")
                except (OSError, ValueError) as err:  # refused/timed out, or a malformed address
                    raise UserError(f"--dask {address!r}: cannot connect to the scheduler "
                                    f"({str(err).splitlines()[0] if str(err) else type(err).__name__})") from None
            self._own_client = True
        self.workers = len(self.client.scheduler_info().get("workers", {}))

    def map(self, tasks: Iterable[PointTask], n_tasks: int | None = None) -> Iterator[PointResult]:
        distributed = _import_distributed()
        if n_tasks is None:
            tasks = list(tasks)
            n_tasks = len(tasks)
        batch = uuid.uuid4().hex  # task keys unique per call: never reuse an older future
        chunks = batches(tasks, batch_size(n_tasks, self.workers))
        counter = itertools.count()

        live: set = set()

        def submit(chunk):
            fut = self.client.submit(run_points, chunk, pure=False, retries=self.retries,
                                     key=f"rfsim-sweep-{batch}-{next(counter)}")
            live.add(fut)
            return fut

        queue = distributed.as_completed([submit(c) for c in itertools.islice(chunks, 4 * max(self.workers, 1))])
        try:
            for fut in queue:
                results = fut.result()
                live.discard(fut)
                for c in itertools.islice(chunks, 1):
                    queue.add(submit(c))
                yield from results
        except BaseException:
            self.client.cancel(list(live))
            raise

    def close(self) -> None:
        if self._own_client:
            self.client.close()
        if self._cluster is not None:
            self._cluster.close()


def make_executor(*, serial: bool = False, workers: int | None = None, dask: Any = None):
    """The executor chosen on the command line (process pool by default)."""
    if sum(x is not None and x is not False for x in (serial or None, workers, dask)) > 1:
        raise UserError("choose one of --serial, --workers N, --dask ADDRESS|local[:N]")
    if serial:
        return SerialExecutor()
    if dask is not None:
        return DaskExecutor(dask)
    return PoolExecutor(workers)


__all__ = [
    "available_cpus",
    "SerialExecutor",
    "PoolExecutor",
    "DaskExecutor",
    "parse_dask_target",
    "make_executor",
    "batch_size",
    "batches",
]

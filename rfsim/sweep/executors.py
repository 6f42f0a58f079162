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
    """CPUs this process may run on.

    Returns
    -------
    int
        The size of ``os.sched_getaffinity(0)`` where it exists, else ``os.cpu_count()``
        (1 when unknown).
    """
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


def batch_size(n_tasks: int | None, workers: int) -> int:
    """Runs per submitted task: 1 for small sweeps, up to :data:`MAX_BATCH` for huge ones.

    About 8 batches per worker, so the per-task overhead of the pool or the scheduler is
    paid once per batch while the load stays balanced.

    Parameters
    ----------
    n_tasks : int or None
        Runs to execute; None or 0 when unknown or empty.
    workers : int
        Worker processes (values < 1 count as 1).

    Returns
    -------
    int
        ``max(1, min(MAX_BATCH, n_tasks // (8 * workers)))``; 1 when ``n_tasks`` is None or 0.
    """
    if not n_tasks:
        return 1
    return max(1, min(MAX_BATCH, n_tasks // (8 * max(workers, 1))))


#: Largest number of runs sent to a worker in one task.
MAX_BATCH = 256


def batches(tasks: Iterable[PointTask], size: int) -> Iterator[list[PointTask]]:
    """Split ``tasks`` into lists of ``size``, consumed lazily.

    Parameters
    ----------
    tasks : iterable of rfsim.sweep.store.PointTask
        The runs to batch.
    size : int
        Runs per batch, >= 1.

    Yields
    ------
    list of rfsim.sweep.store.PointTask
        ``size`` consecutive tasks (the last list may be shorter).
    """
    it = iter(tasks)
    while chunk := list(itertools.islice(it, size)):
        yield chunk


class SerialExecutor:
    """Run every task in this process, in order.

    Attributes
    ----------
    name : str
        ``"serial"``.
    workers : int
        1.
    """

    name = "serial"
    workers = 1

    def map(self, tasks: Iterable[PointTask], n_tasks: int | None = None) -> Iterator[PointResult]:
        """Run the tasks one after the other in this process.

        Parameters
        ----------
        tasks : iterable of rfsim.sweep.store.PointTask
            The runs, consumed lazily.
        n_tasks : int, optional
            Ignored (the signature of every executor's ``map``).

        Yields
        ------
        rfsim.sweep.store.PointResult
            The result of each run, in task order.
        """
        for task in tasks:
            yield run_point(task)

    def close(self) -> None:
        """Release nothing (the signature of every executor's ``close``)."""
        pass


class PoolExecutor:
    """A local process pool of ``workers`` processes (:func:`rfsim.core.procs.worker_pool`).

    Tasks are sent in batches (:func:`batch_size`) with at most ``4 × workers`` batches in
    flight, so a sweep of millions of runs is never held in memory as futures. The workers
    die with the leader, even when it is killed with SIGKILL.

    Parameters
    ----------
    workers : int, optional
        Worker processes, >= 1; None (default): :func:`available_cpus`.

    Attributes
    ----------
    name : str
        ``"pool"``.
    workers : int
        Worker processes.

    Raises
    ------
    UserError
        ``workers`` < 1.
    """

    name = "pool"

    def __init__(self, workers: int | None = None):
        self.workers = available_cpus() if workers is None else int(workers)
        if self.workers < 1:
            raise UserError(f"--workers {workers}: expected an integer >= 1")

    def map(self, tasks: Iterable[PointTask], n_tasks: int | None = None) -> Iterator[PointResult]:
        """Run the tasks in batches on the process pool (a pool started per call).

        Parameters
        ----------
        tasks : iterable of rfsim.sweep.store.PointTask
            The runs, consumed lazily.
        n_tasks : int, optional
            Number of tasks, for the batch size; None (default): ``tasks`` is read into a
            list to count them.

        Yields
        ------
        rfsim.sweep.store.PointResult
            The result of each run, in completion order.
        """
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
        """Release nothing: each :meth:`map` call closes its own pool."""
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
    """Parse the ``--dask`` option: a local cluster or a scheduler address.

    Parameters
    ----------
    text : str
        ``"local"``, ``"local:N"`` (N >= 1 workers) or a scheduler address
        (``tcp://host:8786``, ``host:8786``).

    Returns
    -------
    tuple of (str, int or None)
        ``("local", N)`` (N None for ``"local"``), or ``(address, None)``.

    Raises
    ------
    UserError
        ``local:N`` with N not an integer >= 1, or ``text`` not a scheduler address.
    """
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
    target : str or dask.distributed.Client, default "local"
        A scheduler address (``"tcp://host:8786"``), ``"local"`` / ``"local:N"`` (a
        ``LocalCluster`` of N single-threaded worker processes bound to 127.0.0.1; N
        defaults to the available CPUs), or an existing ``dask.distributed.Client``.
    retries : int, default 3
        Resubmissions of a run whose task raised (worker loss is handled by the
        scheduler, which reschedules the runs of a dead worker).

    Attributes
    ----------
    name : str
        ``"dask"``.
    client : dask.distributed.Client
        The client the tasks are submitted through.
    workers : int
        Workers of the cluster when the executor was made.
    retries : int
        Resubmissions of a failed task.

    Raises
    ------
    UserError
        dask.distributed is not installed, ``target`` is malformed, or the scheduler
        cannot be reached.
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
        """Submit the tasks in batches to the cluster, at most ``4 × workers`` batches at once.

        Each call uses fresh task keys. When the consumer stops early (or a task fails for
        good) the batches still in flight are cancelled.

        Parameters
        ----------
        tasks : iterable of rfsim.sweep.store.PointTask
            The runs, consumed lazily.
        n_tasks : int, optional
            Number of tasks, for the batch size; None (default): ``tasks`` is read into a
            list to count them.

        Yields
        ------
        rfsim.sweep.store.PointResult
            The result of each run, in completion order.
        """
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
        """Close the client and the local cluster made by this executor (not a client given)."""
        if self._own_client:
            self.client.close()
        if self._cluster is not None:
            self._cluster.close()


def make_executor(*, serial: bool = False, workers: int | None = None, dask: Any = None):
    """The executor chosen on the command line (process pool by default).

    Parameters
    ----------
    serial : bool, default False
        Run in this process (:class:`SerialExecutor`).
    workers : int, optional
        Worker processes of a :class:`PoolExecutor` (default None: all available CPUs).
    dask : str or dask.distributed.Client, optional
        Target of a :class:`DaskExecutor`.

    Returns
    -------
    SerialExecutor or PoolExecutor or DaskExecutor
        The executor.

    Raises
    ------
    UserError
        More than one of ``serial``, ``workers`` and ``dask`` given, or the chosen
        executor's own error.
    """
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

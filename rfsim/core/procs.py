"""Worker processes that never outlive their leader, and SIGTERM handled like Ctrl-C.

Every process pool of rfsim (sweep executors, scenarios' Monte-Carlo pools) is made with
:func:`worker_pool`. Its workers

* ask the kernel to kill them when the leader dies (Linux ``prctl(PR_SET_PDEATHSIG,
  SIGKILL)``), and, on every POSIX system, watch their parent process id from a daemon
  thread every :data:`WATCH_INTERVAL_S` and exit when they have been re-parented (the
  leader was killed, even with SIGKILL, which no handler can see);
* ignore SIGINT: Ctrl-C reaches the whole process group, and the leader alone decides
  (it stops the pool, see below), so workers print no tracebacks of their own.
* keep the memory they free for their next arrays (glibc ``malloc`` settings,
  :data:`WORKER_MMAP_THRESHOLD_B`, :data:`WORKER_TRIM_THRESHOLD_B`) instead of mapping and
  zero-filling it afresh for every task.

Leaving the ``with worker_pool(...)`` block by an exception (Ctrl-C, SIGTERM, an error)
cancels the queued tasks and terminates the running workers at once instead of waiting
for their tasks to finish.

:func:`terminate_as_interrupt` turns SIGTERM (what ``kill``, ``timeout`` and SLURM's
``scancel`` send) into :class:`rfsim.core.errors.Terminated`, a ``KeyboardInterrupt``, so that
every cleanup path written for Ctrl-C (atomic writes removing their temporary file, pools
stopping their workers) runs for SIGTERM too.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import functools
import ctypes
import gc
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator

from rfsim.core.errors import ResourceError, Terminated

#: How often a worker checks that its leader is still alive [s].
WATCH_INTERVAL_S = 0.5
_PR_SET_PDEATHSIG = 1
#: A worker's glibc ``malloc``: blocks up to this size come from the heap, not from a mapping of
#: their own [B] (glibc's largest dynamic threshold, ``M_MMAP_THRESHOLD``)
WORKER_MMAP_THRESHOLD_B = 32 * 2**20
#: A worker's glibc ``malloc`` gives the heap's free top back to the system above this size [B]
#: (``M_TRIM_THRESHOLD``)
WORKER_TRIM_THRESHOLD_B = 512 * 2**20
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
#: The cyclic garbage collector's first threshold during a simulation (:func:`few_collections`):
#: net allocations of tracked objects (containers, class instances) between two collections of
#: the youngest generation (CPython's default 700).
RUN_GC_THRESHOLD = 50_000


def _set_parent_death_signal() -> None:
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover - exotic libc
        pass


def _reuse_freed_memory() -> None:
    """Let glibc's ``malloc`` keep the memory a worker frees for its next arrays.

    A task's large arrays (a cell's (positions, samples) blocks, tens of MB) would otherwise
    each be a fresh mapping that the kernel zero-fills page by page and unmaps when freed, on
    every task: ≈ 40 ms of system CPU per phase-cancellation cell (3,800 page faults), ≈ 10 ms
    with the heap reused (360 faults). The peak stays that of the largest task. A no-op outside
    glibc (no ``mallopt``).
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.mallopt(_M_MMAP_THRESHOLD, WORKER_MMAP_THRESHOLD_B)
        libc.mallopt(_M_TRIM_THRESHOLD, WORKER_TRIM_THRESHOLD_B)
    except (OSError, AttributeError):  # pragma: no cover - another C library
        pass


@contextlib.contextmanager
def few_collections(threshold: int = RUN_GC_THRESHOLD) -> Iterator[None]:
    """Within the block, the cyclic garbage collector runs after ``threshold`` net allocations
    of tracked objects instead of CPython's 700 (``gc.set_threshold``; the older generations'
    thresholds kept); the thresholds before it are restored when the block ends.

    A simulation's objects (records, a trial's tag and its state, per-read results) are freed
    by reference counting: what the collector does in a run is traverse live objects and find
    nothing. Measured in the batched canonical exchange (1,024 trials, fresh tags): 98
    collections of the youngest generation and 9 of the middle one, ≈ 42 µs of CPU time per
    trial (≈ 6 % of it), and the objects they found unreachable were 7 (type objects of
    ``ctypes``, no array); with ``threshold`` = 50,000 no collection ran in those trials. In a
    1,000-tag inventory the collector took 147 ms of ≈ 1.9 s (93 + 9 + 1 collections; 1 with
    50,000). Cyclic garbage lives longer (at most ``threshold`` net allocations more), so
    the blocks that hold memory in cycles are not made faster this way; every run's peak
    memory is checked by the tests of :mod:`rfsim.runs.sizes`. Worker processes forked inside
    the block inherit the setting.

    Parameters
    ----------
    threshold : int, default RUN_GC_THRESHOLD
        The youngest generation's threshold within the block (≥ 1).

    Yields
    ------
    None
    """
    before = gc.get_threshold()
    gc.set_threshold(int(threshold), *before[1:])
    try:
        yield
    finally:
        gc.set_threshold(*before)


def _watch_parent(parent_pid: int) -> None:
    event = threading.Event()
    while not event.wait(WATCH_INTERVAL_S):
        if os.getppid() != parent_pid:
            os._exit(1)


def worker_init(leader_pid: int) -> None:
    """Initializer of every worker process (see the module docstring).

    A worker whose parent is already gone (re-parented to init, pid 1) when it starts exits
    at once.

    Parameters
    ----------
    leader_pid : int
        The process that made the pool.
    """
    _set_parent_death_signal()
    _reuse_freed_memory()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    parent = os.getppid()  # the leader itself (fork) or its fork server
    if parent == 1 or (parent != leader_pid and not _alive(leader_pid)):
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True,
                     name="rfsim-leader-watch").start()
    # what the worker inherited (modules, kernels, the leader's data) lives as long as it
    # does: out of the collector's generations, it is not traversed again by every full
    # collection of the tasks' garbage (nor are its pages, shared with the leader, written)
    gc.freeze()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # pragma: no cover - exists, owned by someone else
        return True
    return True


def terminate_workers(pool: cf.ProcessPoolExecutor) -> None:
    """Cancel the queued tasks of ``pool`` and kill its running workers now.

    Parameters
    ----------
    pool : concurrent.futures.ProcessPoolExecutor
        The pool.
    """
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    _terminate(processes)


def _terminate(processes: list) -> None:
    """SIGTERM the processes, then join each (at most 5 s each)."""
    for p in processes:
        with contextlib.suppress(Exception):
            p.terminate()
    for p in processes:
        with contextlib.suppress(Exception):
            p.join(5.0)


@contextlib.contextmanager
def worker_pool(max_workers: int) -> Iterator[cf.ProcessPoolExecutor]:
    """A ``ProcessPoolExecutor`` whose workers die with the leader; torn down on exceptions.

    Parameters
    ----------
    max_workers : int
        Worker processes.

    Yields
    ------
    concurrent.futures.ProcessPoolExecutor
        The pool (shut down when the block ends).

    Raises
    ------
    ResourceError
        When a worker died without a word (the pool broke), naming its exit status.
    """
    pool = _Pool(max_workers=max_workers, initializer=worker_init, initargs=(os.getpid(),))
    try:
        yield pool
    except BaseException as err:
        manager = getattr(pool, "_executor_manager_thread", None)
        if isinstance(err, cf.process.BrokenProcessPool) and manager is not None:
            # the pool's thread terminates and joins the other workers: joined here first, every
            # worker's exit status is read (not lost to a race of two waits for the same child)
            manager.join(WORKER_EXIT_GRACE_S)
        statuses = _exit_statuses(pool)
        terminate_workers(pool)
        if isinstance(err, cf.process.BrokenProcessPool):  # a worker died without a word
            raise _worker_failure(statuses) from None
        raise
    close_workers(pool)


#: After a pool's last task, how long its workers have to end on their own before they are
#: terminated [s] (:func:`close_workers`)
WORKER_EXIT_GRACE_S = 10.0


def close_workers(pool: cf.ProcessPoolExecutor, grace_s: float = WORKER_EXIT_GRACE_S) -> None:
    """Shut ``pool`` down once its tasks are done, without waiting for ever on a stuck worker.

    The workers are asked to end (``shutdown``); those still running after ``grace_s``, or as
    soon as one of them is found killed by a signal, are terminated. An idle worker waits for
    its next task holding the task queue's lock (``multiprocessing.Queue.get``); killed there
    (SIGKILL, the out-of-memory killer) it never releases it, and the others never read the
    request to end: ``ProcessPoolExecutor.shutdown(wait=True)`` would join them for ever.

    Parameters
    ----------
    pool : concurrent.futures.ProcessPoolExecutor
        A pool whose submitted tasks have all completed.
    grace_s : float, optional
        Longest wait for the workers to end on their own [s].
    """
    import multiprocessing.connection as mpc

    processes = list((getattr(pool, "_processes", None) or {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)
    pool.shutdown(wait=False)
    deadline = time.monotonic() + grace_s
    while alive := [p for p in processes if p.is_alive()]:
        killed = any(p.exitcode is not None and p.exitcode < 0 for p in processes)
        left = deadline - time.monotonic()
        if killed or left <= 0:
            _terminate(alive)
            break
        mpc.wait([p.sentinel for p in alive], timeout=min(left, 0.1))
    if manager is not None:
        manager.join(grace_s)  # ends once its workers have


class _Pool(cf.ProcessPoolExecutor):
    """A ``ProcessPoolExecutor`` that remembers every worker it started, so that the exit
    status of one that died is still known after the pool dropped it (broken pool)."""

    def _spawn_process(self):
        super()._spawn_process()
        self.started = {**getattr(self, "started", {}), **(self._processes or {})}


def _exit_statuses(pool: cf.ProcessPoolExecutor) -> list[int]:
    """The exit codes of the pool's workers that have ended (``-N``: killed by signal N)."""
    processes = {**(getattr(pool, "_processes", None) or {}), **getattr(pool, "started", {})}.values()
    codes = []
    for p in processes:
        with contextlib.suppress(Exception):
            if not p.is_alive():
                p.join(1.0)
                codes.append(p.exitcode)
    return [c for c in codes if c is not None]


def _worker_failure(exit_codes: list[int]) -> ResourceError:
    """The one-line error for a process pool whose worker died (``exit_codes`` of the ended ones)."""
    # a broken pool terminates the other workers (SIGTERM): the signal that broke it comes first
    signals = sorted((-code for code in exit_codes if code < 0), key=lambda sig: sig == signal.SIGTERM)
    if signals:
        # a wait status whose low bits are the signal: what child_failure reads
        return ResourceError(str(child_failure(signals[0])).replace("the run's process", "a worker process", 1))
    return ResourceError("a worker process ended abruptly (killed, most likely because the system ran out of "
                         "memory; see 'dmesg'); try fewer workers or a smaller config")


def map_in_order(fn, tasks, workers: int, *, desc: str, unit: str) -> list:
    """``[fn(t) for t in tasks]`` on worker processes, results in task order.

    With a pool the first task runs in a pilot process that compiles or loads the kernels
    it needs, then the next :data:`PILOT_QUEUE` tasks, and ends; the workers, forked from
    this process after it loaded the same kernels, run the rest. Unless no kernel is cached
    yet (:func:`rfsim.core._jit.first_compilation`: then this process waits for the pilot's
    kernels, each compiled once), this process runs the second task meanwhile, which loads
    the kernels here (a kernel missing from the on-disk cache is compiled in a short-lived
    child, :func:`rfsim.core._jit.compiling_elsewhere`). The order of the results does not
    depend on the number of workers; progress is shown with :func:`rfsim.core.progress.track`
    and every pool is a :func:`worker_pool`.

    Parameters
    ----------
    fn : callable
        Picklable (module-level) function of one task.
    tasks : iterable
        The tasks.
    workers : int
        Worker processes (0 = all cores, 1 = in this process).
    desc : str
        Progress description.
    unit : str
        Progress unit.

    Returns
    -------
    list
        ``fn(t)`` for every task, in task order.
    """
    from rfsim.core.progress import track  # progress pulls in tqdm: only when a loop runs

    tasks = list(tasks)
    w = workers or (os.cpu_count() or 1)
    if w <= 1 or len(tasks) <= 1:
        return [fn(t) for t in track(tasks, desc=desc, unit=unit)]

    def results():
        # The first task runs in a pilot process, which compiles the numba kernels it needs
        # (or loads them from the on-disk cache) and writes them to that cache, then the next
        # tasks queued behind it; this process loads the same kernels before it forks the
        # workers, which inherit them instead of each loading them again. With kernels in the
        # cache, this process runs the second task meanwhile, which loads them here (both
        # cores busy from the start); on the first compilation (an empty cache) it waits for
        # the pilot's list and loads them from the cache then, so that each is compiled once.
        from rfsim.core._jit import compiling_elsewhere, first_compilation

        ahead = not first_compilation()  # this process runs the second task while the pilot runs the first
        with worker_pool(1) as pilot:
            pilot_first = pilot.submit(_run_and_list_kernels, fn, tasks[0])
            queue = _Dispatch(fn, tasks[1 + ahead:])
            queue.fill(pilot, PILOT_QUEUE)
            if ahead:
                with compiling_elsewhere(run_in_child):
                    second = fn(tasks[1])
            first, kernels, modules = pilot_first.result()
            yield first
            if ahead:
                yield second
            n = min(w, len(queue.tasks) - queue.next)  # tasks not handed to the pilot
            if not n:
                yield from queue.in_order({pilot: 0})
                return
            load_kernels(kernels)  # those this process does not hold yet
            _import_all(modules)
            _release_freed_memory()  # not inherited by every worker
            with worker_pool(n) as pool:
                yield from queue.in_order({pilot: 0, pool: n})

    return list(track(results(), total=len(tasks), desc=desc, unit=unit))


#: Tasks the pilot of :func:`map_in_order` runs after its first (queued behind it, so that it does
#: not wait for this process's task to end before its next). One: each more task raised the pilot's
#: peak (phase-cancellation full run: 305 MiB with one, 339 with two; the workers 303)
PILOT_QUEUE = 1


def _release_freed_memory() -> None:
    """Give the heap's free memory back to the system (glibc ``malloc_trim``; a no-op elsewhere)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).malloc_trim(0)


class _Dispatch:
    """Tasks handed to several pools, each kept at its number of workers (no task waits in a
    pool's queue while another pool idles), the results given back in task order; a pool
    given no workers (0) gets no new task and is shut down once its tasks have ended."""

    def __init__(self, fn, tasks):
        self.fn, self.tasks, self.next = fn, tasks, 0
        self.running: dict[cf.Future, tuple[int, cf.ProcessPoolExecutor]] = {}

    def fill(self, pool: cf.ProcessPoolExecutor, slots: int) -> None:
        """Submit tasks to ``pool`` until it runs ``slots`` of them (or none are left)."""
        busy = sum(1 for _, p in self.running.values() if p is pool)
        for _ in range(slots - busy):
            if self.next == len(self.tasks):
                return
            self.running[pool.submit(self.fn, self.tasks[self.next])] = (self.next, pool)
            self.next += 1

    def in_order(self, slots: dict[cf.ProcessPoolExecutor, int]):
        """Yield every result in task order, refilling the pools (``pool → workers``) as tasks end."""
        done: dict[int, object] = {}
        for pool, n in slots.items():
            self.fill(pool, n)
        for i in range(len(self.tasks)):
            while i not in done:
                finished, _ = cf.wait(self.running, return_when=cf.FIRST_COMPLETED)
                for future in finished:
                    index, pool = self.running.pop(future)
                    done[index] = future.result()
                    self.fill(pool, slots[pool])
                    if not slots[pool] and all(p is not pool for _, p in self.running.values()):
                        pool.shutdown(wait=False)
            yield done.pop(i)


def _run_and_list_kernels(fn, task):
    """``fn(task)``, with the numba kernels (and signatures) this process holds afterwards
    (:func:`rfsim.core._jit.compiled_signatures`) and the modules it imported."""
    from rfsim.core._jit import compiled_signatures

    before = set(sys.modules)
    out = fn(task)
    return out, compiled_signatures(), [name for name in sys.modules if name not in before]


def _import_all(names) -> None:
    """Import the modules ``names`` (in import order) here, so that the workers forked later
    inherit them instead of each importing them again (scipy.signal alone is ≈ 0.5 s CPU);
    a module that cannot be imported by its name alone is left to the tasks that need it."""
    import importlib

    for name in names:
        if name not in sys.modules:
            with contextlib.suppress(Exception):
                importlib.import_module(name)


def load_kernels(kernels) -> None:
    """Load into this process the kernels listed by :func:`rfsim.core._jit.compiled_signatures` in another one.

    From the on-disk cache; compiled here where it has no entry.

    Parameters
    ----------
    kernels : object
        The listing :func:`rfsim.core._jit.compiled_signatures` returned.
    """
    from rfsim.core._jit import load_signatures

    load_signatures(kernels)


def _has_file_descriptors() -> bool:
    """True when this process's stdout and stderr are real files (a forked child's output
    then goes where this process's goes)."""
    try:
        sys.stdout.fileno()
        sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):
        return False
    return True


def run_in_child(fn, *, while_waiting=None) -> None:
    """``fn()`` in a forked child process, which exits afterwards.

    All the memory the child allocated (numba's compiler, imported libraries, the arrays of
    a run) is returned to the system when it exits, not merely freed inside this process.
    Ctrl-C reaches both processes (one process group): the child cleans up and reports the
    interrupt. SIGTERM reaching only this process (:func:`terminate_as_interrupt`) is passed
    on to the child, which then cleans up the same way; a child whose leader dies is killed.
    Without ``fork``, or when stdout/stderr are not real files (e.g. captured in memory),
    ``fn()`` runs in this process.

    Parameters
    ----------
    fn : callable
        The work, without arguments.
    while_waiting : callable or None
        Runs here meanwhile (e.g. the imports of what comes after the child), before the
        child's result is read.

    Raises
    ------
    Exception
        The child's exception, if any, raised here (with the child's traceback as a note
        where it is not a :class:`~rfsim.core.errors.UserError` nor an interrupt).
    ResourceError
        When the child ended without reporting (:func:`child_failure`).
    """
    import pickle
    import traceback

    from rfsim.core.errors import UserError

    if not hasattr(os, "fork") or not _has_file_descriptors():
        fn()
        return
    sys.stdout.flush()
    sys.stderr.flush()
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns into the caller's code
        try:
            os.close(read_fd)
            _set_parent_death_signal()
            err = None
            try:
                fn()
            except BaseException as e:  # reported to the leader, which raises it
                err = e
                if not isinstance(e, (UserError, ResourceError, KeyboardInterrupt)):
                    e.add_note("in the child process:\n" + "".join(traceback.format_exception(e)).rstrip())
            try:
                data = pickle.dumps(err)
            except Exception:
                data = pickle.dumps(RuntimeError(f"{type(err).__name__}: {err}"))
            with os.fdopen(write_fd, "wb") as f:
                f.write(data)
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(0)
    os.close(write_fd)
    try:
        if while_waiting is not None:
            while_waiting()
        with os.fdopen(read_fd, "rb") as f:
            data = f.read()
    except BaseException as interrupt:  # Ctrl-C or SIGTERM here: wait for the child to clean up
        if isinstance(interrupt, Terminated):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGTERM)
        os.waitpid(pid, 0)
        raise
    _, status = os.waitpid(pid, 0)
    if not data:
        raise child_failure(status)
    err = pickle.loads(data)
    if err is not None:
        raise err


def child_failure(status: int) -> ResourceError:
    """The one-line error for a child process that ended without reporting.

    Parameters
    ----------
    status : int
        The child's wait status.

    Returns
    -------
    ResourceError
        Naming the signal and its likely cause, or the exit status.
    """
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        try:
            name = signal.Signals(number).name
        except ValueError:
            name = f"signal {number}"
        cause = {signal.SIGKILL: "most likely the system ran out of memory and its out-of-memory "
                                 "killer chose it (see 'dmesg'); try fewer workers or a smaller config",
                 signal.SIGSEGV: "a crash in compiled code", signal.SIGBUS: "a crash in compiled code "
                 "or a file that shrank while mapped"}.get(number, "it was sent from outside")
        return ResourceError(f"the run's process was killed by {name}: {cause}; no output was written")
    return ResourceError(f"the run's process ended without a result (exit status "
                         f"{os.waitstatus_to_exitcode(status)}); no output was written")


def _raise_terminated(signum, frame, *, owner_pid: int) -> None:
    if os.getpid() != owner_pid:
        # a process forked while the handler was installed (a worker before its initializer
        # resets SIGTERM): it ends as the default action would, without a traceback
        os._exit(128 + signal.SIGTERM)
    raise Terminated()


def _redeliver_later() -> None:
    time.sleep(0.05)
    os.kill(os.getpid(), signal.SIGTERM)


@contextlib.contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`~rfsim.core.errors.Terminated` (main thread only).

    A process forked inside the block inherits the handler; there SIGTERM ends the process
    quietly (exit status 143) instead of raising, so a worker signalled before its initializer
    has reset SIGTERM prints no traceback.

    A Python exception raised while the interpreter runs a callback whose errors it
    ignores (e.g. an at-fork handler while a worker process is being started) would be
    lost; such a swallowed :class:`Terminated` reaches ``sys.unraisablehook``, which here
    delivers SIGTERM again a moment later instead of printing it.

    Yields
    ------
    None
        The block runs with the handler installed; the previous handler and hook are restored
        after it.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, functools.partial(_raise_terminated, owner_pid=os.getpid()))
    previous_hook = sys.unraisablehook

    def hook(unraisable) -> None:
        if isinstance(unraisable.exc_value, Terminated):
            threading.Thread(target=_redeliver_later, daemon=True).start()
        else:
            previous_hook(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
        sys.unraisablehook = previous_hook


__all__ = ["WATCH_INTERVAL_S", "PILOT_QUEUE", "RUN_GC_THRESHOLD", "few_collections", "WORKER_MMAP_THRESHOLD_B", "WORKER_TRIM_THRESHOLD_B",
           "WORKER_EXIT_GRACE_S", "worker_init", "worker_pool", "close_workers", "terminate_workers",
           "terminate_as_interrupt",
           "map_in_order", "load_kernels", "run_in_child", "child_failure"]

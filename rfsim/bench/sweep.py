"""Benchmark of the sweep executors: process-pool scaling, Dask per-task overhead, memory.

* **Scaling**: a sweep of ``n_points`` points of the ``gen2-waveforms`` scenario (all four
  link profiles at ``fs_hz``, ~0.2–0.3 s per point including its record in the point store at 40 MS/s) on
  a process pool of 1 and of 2 workers; speed-up = t(1) / t(2). Only the execution phase
  is timed (every point computed and written to the point store); the merge is not.
* **Dask overhead**: ``dask_points`` tiny points (one FM0 profile at 5.12 MS/s, ~20 ms
  each) on a ``LocalCluster`` of ``dask_workers`` single-threaded worker processes; the
  per-task overhead is ``wall · workers / n − mean in-task time`` (time a worker slot
  spends per task beyond running it), next to the same points run serially.
* **Memory**: the peak resident set (``ru_maxrss``) of each worker process, as reported
  by the workers with their results.

The numba kernels are compiled/loaded once in this process before timing; pool workers
are forked from it. Load average and CPU count are recorded: on a shared machine the
numbers are only as good as the idle cores were.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np

from rfsim.sweep import PoolExecutor, SerialExecutor, available_cpus, parse_spec, run_sweep
from rfsim.sweep.store import PointResult


def _spec(output: Path, n_points: int, base: dict, seed: int = 0):
    return parse_spec({
        "scenario": "gen2-waveforms", "seed": seed, "output": str(output), "base": base,
        "axes": [{"kind": "grid", "key": "pie_rise_fall_tari",
                  "values": [float(v) for v in np.linspace(0.05, 0.3, n_points)]}]})


def _per_worker_rss(results: tuple[PointResult, ...]) -> dict[int, float]:
    rss: dict[int, float] = {}
    for r in results:
        rss[r.pid] = max(rss.get(r.pid, 0.0), r.peak_rss_mb)
    return rss


def _timed(spec, executor) -> tuple[float, tuple[PointResult, ...]]:
    t0 = time.perf_counter()
    report = run_sweep(spec, executor, merge=False)
    return time.perf_counter() - t0, report.results


def bench_sweep(n_points: int = 64, *, fs_hz: float = 40e6, dask_points: int = 200,
                dask_workers: int = 2, with_dask: bool = True) -> dict:
    """Measure pool scaling (1 vs 2 workers), Dask per-task overhead and worker memory.

    The cases are those of the module docstring; only the execution phase of a sweep is timed
    (every point computed and written to the point store), not the merge.

    Parameters
    ----------
    n_points : int, default 64
        Points of the scaling sweep (``gen2-waveforms``, all four link profiles).
    fs_hz : float, default 40e6
        Sample rate of the scaling sweep's points [Hz].
    dask_points : int, default 200
        Tiny points of the serial and Dask runs (one FM0 profile at 5.12 MS/s).
    dask_workers : int, default 2
        Single-threaded worker processes of the Dask ``LocalCluster``.
    with_dask : bool, default True
        Run the Dask part (needs ``dask.distributed``).

    Returns
    -------
    dict
        ``cpus_available``, ``loadavg_start`` / ``loadavg_end``, ``n_points``, ``fs_hz``; per pool
        size w ∈ {1, 2} ``pool<w>_wall_s`` [s], ``pool<w>_point_mean_s`` [s] and
        ``pool<w>_worker_peak_rss_mb`` [MB]; ``store_mb_per_run`` [MB], ``pool_speedup_2_vs_1``;
        ``tiny_points``, ``tiny_serial_wall_s``, ``tiny_point_mean_s`` [s]; with Dask
        ``dask_workers``, ``dask_cluster_start_s``, ``dask_wall_s``, ``dask_task_mean_s``,
        ``dask_overhead_per_task_s`` (wall · workers / n − mean in-task time),
        ``dask_noop_per_task_s`` [s], ``dask_worker_peak_rss_mb`` [MB] and ``dask_workers_used``.
    """
    out: dict = {"cpus_available": available_cpus(), "loadavg_start": os.getloadavg()[0],
                 "n_points": n_points, "fs_hz": fs_hz}
    heavy = {"fs_hz": fs_hz}
    tiny = {"profiles": ["fm0-640k"], "fs_hz": 5.12e6}
    with tempfile.TemporaryDirectory(prefix="rfsim-bench-sweep-") as tmp:
        root = Path(tmp)
        run_sweep(_spec(root / "warm.h5", 1, heavy), SerialExecutor(), merge=False)  # numba load
        for workers in (1, 2):
            wall, results = _timed(_spec(root / f"pool{workers}" / "s.h5", n_points, heavy),
                                   PoolExecutor(workers))
            out[f"pool{workers}_wall_s"] = wall
            out[f"pool{workers}_point_mean_s"] = float(np.mean([r.wall_time_s for r in results]))
            out[f"pool{workers}_worker_peak_rss_mb"] = max(_per_worker_rss(results).values())
            files = list((root / f"pool{workers}" / "s.h5.points").glob("seg-*"))
            out["store_mb_per_run"] = sum(p.stat().st_size for p in files) / 1e6 / n_points
            for p in files:
                p.unlink()  # ~12 MB per run at 40 MS/s
        out["pool_speedup_2_vs_1"] = out["pool1_wall_s"] / out["pool2_wall_s"]
        wall, results = _timed(_spec(root / "serial-tiny" / "s.h5", dask_points, tiny), SerialExecutor())
        out["tiny_points"] = dask_points
        out["tiny_serial_wall_s"] = wall
        out["tiny_point_mean_s"] = float(np.mean([r.wall_time_s for r in results]))
        if with_dask:
            out.update(_bench_dask(root, dask_points, dask_workers, tiny))
    out["loadavg_end"] = os.getloadavg()[0]
    return out


def _bench_dask(root: Path, n: int, workers: int, tiny: dict) -> dict:
    import dask.distributed as distributed

    from rfsim.sweep import DaskExecutor

    out: dict = {"dask_workers": workers}
    t0 = time.perf_counter()
    cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address="127.0.0.1:0",
                                       silence_logs=40)
    client = distributed.Client(cluster)
    out["dask_cluster_start_s"] = time.perf_counter() - t0
    try:
        executor = DaskExecutor(client)
        _timed(_spec(root / "dask-warm" / "s.h5", workers * 2, tiny), executor)  # imports, numba
        wall, results = _timed(_spec(root / "dask" / "s.h5", n, tiny), executor)
        mean_task = float(np.mean([r.wall_time_s for r in results]))
        out["dask_wall_s"] = wall
        out["dask_task_mean_s"] = mean_task
        out["dask_overhead_per_task_s"] = wall * workers / n - mean_task
        rss = _per_worker_rss(results)
        out["dask_worker_peak_rss_mb"] = max(rss.values())
        out["dask_workers_used"] = len(rss)
        # the bare scheduler round trip: n no-op tasks
        t0 = time.perf_counter()
        futures = [client.submit(int, i, pure=False) for i in range(n)]
        client.gather(futures)
        out["dask_noop_per_task_s"] = (time.perf_counter() - t0) / n
    finally:
        client.close()
        cluster.close()
    return out


__all__ = ["bench_sweep"]

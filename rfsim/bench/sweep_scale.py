"""Sweeps at scale: a toy scenario run 10⁴–10⁵ times through the real sweep machinery.

The toy scenario (this module: ``NAME``, ``Config``, ``run``, ``plot``) draws, from its run
seed, a table of ``rows`` rows (two float64 columns, an int64 and a boolean column), a
16-bin "spectrum" grid and two root attributes — about 3 kB of arrays per run, so the
cost measured is that of the sweep (validation, task batching, the append-only point
store, the streaming merge), not of a simulation.

:func:`bench_sweep_scale` runs a sweep of ``n_points × repetitions`` runs on a process
pool and reports, each measured:

* ``run_wall_s`` (validation + execution; merge excluded) and ``merge_wall_s``;
* ``files_created`` in the point store (one segment log + index per worker process);
* ``leader_peak_rss_mb`` during the runs, ``worker_peak_rss_mb`` and
  ``merge_peak_rss_mb`` (``VmHWM`` of this process, reset before the merge through
  ``/proc/self/clear_refs``, Linux; otherwise ``ru_maxrss``) next to
  ``rss_before_merge_mb``, the resident set just before it (imports and earlier work);
* ``store_mb``, ``merged_mb`` and their ratio;
* ``resume_wall_s``: a ``--resume`` of the finished sweep (index read, every run found).
"""

from __future__ import annotations

import dataclasses
import os
import re
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rfsim.core.config import param
from rfsim.core.dataset import Dataset, column
from rfsim.core.rng import trial_rng

NAME = "sweep-scale-toy"
DESCRIPTION = "toy scenario for sweep benchmarks (a few kB of seeded random arrays per run)"


@dataclasses.dataclass(frozen=True)
class Config:
    """Settings of the toy scenario (fields with units and ranges in their ``param`` declarations)."""
    gain_db: float = param(0.0, lo=-30.0, hi=30.0, unit="dB", doc="gain applied to the drawn powers")
    rows: int = param(64, lo=1, hi=100_000, doc="rows of the toy table")


def run(config: Config, *, seed: int) -> Dataset:
    """Draw the seeded toy dataset.

    Parameters
    ----------
    config : Config
        The toy's settings (``gain_db`` scales the drawn powers, ``rows`` sizes the table).
    seed : int
        Run seed; the draws come from ``trial_rng(seed, 0)``.

    Returns
    -------
    rfsim.core.dataset.Dataset
        Table ``reads`` (``power_w`` [W], ``phase_rad`` [rad], ``slot``, ``ok``; ``rows`` rows),
        grid ``spectrum`` (16 bins 902–928 MHz, ``p_w`` [W]) and the root attributes
        ``mean_power_w`` [W] and ``n_ok``.
    """
    rng = trial_rng(seed, 0)
    g = 10 ** (config.gain_db / 10)
    ds = Dataset(title="sweep-scale toy")
    ds.add_table("reads", {
        "power_w": column(rng.exponential(1e-6, config.rows) * g, "W", "drawn received power"),
        "phase_rad": column(rng.uniform(-np.pi, np.pi, config.rows), "rad", "drawn phase"),
        "slot": column(rng.integers(0, 16, config.rows), "1", "drawn slot"),
        "ok": column(rng.random(config.rows) < 0.9, "1", "drawn success flag"),
    })
    f = np.linspace(902e6, 928e6, 16)
    ds.add_grid("spectrum", {"f_hz": column(f, "Hz", "frequency")},
                {"p_w": column(rng.exponential(1e-9, 16) * g, "W", "drawn power per bin")})
    ds.attrs["mean_power_w"] = float(ds.tables["reads"]["power_w"].data.mean())
    ds.attrs["n_ok"] = int(ds.tables["reads"]["ok"].data.sum())
    return ds


def plot(path, out_dir):
    """Make the toy scenario's figures: none.

    Parameters
    ----------
    path : str or pathlib.Path
        The dataset file (not read).
    out_dir : str or pathlib.Path
        Folder of the figures (not written).

    Returns
    -------
    list
        Empty: the toy has no figures.
    """
    return []


def _peak_rss_mb() -> float:
    try:
        status = Path("/proc/self/status").read_text()
        return int(re.search(r"VmHWM:\s*(\d+)", status).group(1)) / 1024
    except (OSError, AttributeError):
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return rss / 1024 if sys.platform != "darwin" else rss / 2**20


def _rss_mb() -> float:
    try:
        return int(re.search(r"VmRSS:\s*(\d+)", Path("/proc/self/status").read_text()).group(1)) / 1024
    except (OSError, AttributeError):
        return float("nan")


def _reset_peak_rss() -> None:
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        pass


def bench_sweep_scale(n_points: int = 10_000, repetitions: int = 10, *, workers: int = 2, rows: int = 64,
                      folder: str | None = None) -> dict:
    """Run and merge a toy sweep of ``n_points × repetitions`` runs on a process pool.

    The figures are those of the module docstring, each measured.

    Parameters
    ----------
    n_points : int, default 10_000
        Points of the sweep (a grid over ``gain_db``).
    repetitions : int, default 10
        Runs per point.
    workers : int, default 2
        Worker processes of the pool.
    rows : int, default 64
        Rows of each run's toy table.
    folder : str or None, default None
        Parent of the temporary sweep folder; None: the system's temporary folder.

    Returns
    -------
    dict
        ``n_runs``, ``workers``, ``rows_per_run``, ``loadavg_start`` / ``loadavg_end``,
        ``run_wall_s`` [s], ``runs_per_s``, ``leader_peak_rss_mb``, ``worker_peak_rss_mb``,
        ``files_created``, ``store_mb``, ``rss_before_merge_mb``, ``merge_wall_s`` [s],
        ``merge_peak_rss_mb``, ``merged_mb``, ``merged_over_store``, ``resume_wall_s`` [s] and
        ``resume_reused`` (runs found by the resume); memory in MB.
    """
    from rfsim.sweep import PoolExecutor, merge_sweep, parse_spec, run_sweep
    from rfsim.sweep.store import points_dir

    module = sys.modules[__name__]
    out: dict = {"n_runs": n_points * repetitions, "workers": workers, "rows_per_run": rows,
                 "loadavg_start": os.getloadavg()[0]}
    with tempfile.TemporaryDirectory(prefix="rfsim-bench-scale-", dir=folder) as tmp:
        output = Path(tmp) / "scale.h5"
        spec = parse_spec({"scenario": NAME, "seed": 1, "repetitions": repetitions, "output": str(output),
                           "base": {"rows": rows},
                           "axes": [{"kind": "grid", "key": "gain_db",
                                     "values": [float(v) for v in np.linspace(-20, 20, n_points)]}]})
        _reset_peak_rss()
        t0 = time.perf_counter()
        report = run_sweep(spec, PoolExecutor(workers), merge=False, module=module)
        out["run_wall_s"] = time.perf_counter() - t0
        out["runs_per_s"] = out["n_runs"] / out["run_wall_s"]
        out["leader_peak_rss_mb"] = _peak_rss_mb()
        out["worker_peak_rss_mb"] = max(r.peak_rss_mb for r in report.results)
        store = points_dir(output)
        files = [p for p in store.iterdir()]
        out["files_created"] = len(files)
        out["store_mb"] = sum(p.stat().st_size for p in files) / 1e6
        del report
        out["rss_before_merge_mb"] = _rss_mb()
        _reset_peak_rss()
        t0 = time.perf_counter()
        merge_sweep(spec, module=module)
        out["merge_wall_s"] = time.perf_counter() - t0
        out["merge_peak_rss_mb"] = _peak_rss_mb()
        out["merged_mb"] = output.stat().st_size / 1e6
        out["merged_over_store"] = out["merged_mb"] / out["store_mb"]
        t0 = time.perf_counter()
        again = run_sweep(spec, PoolExecutor(workers), resume=True, merge=False, module=module)
        out["resume_wall_s"] = time.perf_counter() - t0
        out["resume_reused"] = again.reused
    out["loadavg_end"] = os.getloadavg()[0]
    return out


__all__ = ["NAME", "DESCRIPTION", "Config", "run", "plot", "bench_sweep_scale"]

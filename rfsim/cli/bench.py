"""``rfsim bench``: time rfsim's own hot paths and print a table (and JSON with --json).

``rfsim bench all --json FILE`` runs every benchmark and writes every figure, with the
machine facts (:func:`machine_facts`), into one file. ``--repeat N`` runs the chosen
benchmarks N times in turn (every benchmark once, then every one again, …, so that a slow
stretch of a shared machine falls on all of them) and reports each numeric figure as the median
of its N runs with its minimum and maximum (:func:`summarize_runs`). Each benchmark runs under the
garbage collector's setting of a run (:func:`rfsim.core.procs.few_collections`). Peak memory is the process's maximum
resident set size (``resource.getrusage``), read after each benchmark (a running maximum:
each benchmark's figure includes those run before it); ``startup`` and ``scenarios`` run whole
``rfsim`` commands as child processes and report each command's own wall time, CPU time and
peak (:mod:`rfsim.bench.startup`).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import statistics
import sys
import time
from pathlib import Path

from rfsim.cli import positive_int
from rfsim.core.errors import UserError

#: name → (module, function, keyword arguments of the quick variant)
BENCHMARKS = {
    "linecode": ("rfsim.bench.linecode", "benchmark_linecode", {"n_bits": 10**5}),
    "channels": ("rfsim.bench.channels", "bench_channels", {"n_links": 200, "n_samples": 200_000}),
    "bulk-links": ("rfsim.bench.channels", "bench_bulk_links", {"n_links": 20_000, "repeats": 1}),
    "inventory": ("rfsim.bench.inventory", "bench_inventory", {"n_tags": 20, "sample_populations": (10, 20),
                                                                "populations": (10, 50), "runs": 5}),
    "exchange": ("rfsim.bench.exchange", "bench_exchange", {"n_rounds": 20}),
    "exchange-batch": ("rfsim.bench.exchange", "bench_exchange_batch", {"batch": 32, "n_batches": 1}),
    "exchange-pcg64": ("rfsim.bench.exchange", "bench_exchange_pcg64", {"n_rounds": 20}),
    "exchange-batch-pcg64": ("rfsim.bench.exchange", "bench_exchange_batch_pcg64", {"batch": 32, "n_batches": 1}),
    "exchange-statistic": ("rfsim.bench.exchange_statistic", "bench_exchange_statistic", {"batch": 32, "n_batches": 1}),
    "floor": ("rfsim.bench.floor", "bench_floor", {"n_rounds": 40}),
    "sweep": ("rfsim.bench.sweep", "bench_sweep", {"n_points": 16, "dask_points": 50}),
    "preamble": ("rfsim.bench.preamble", "bench_preamble", {"repeats": 2}),
    "decode": ("rfsim.bench.decode", "bench_decode", {"duration_s": 2.0, "reply_counts": (10, 100)}),
    "startup": ("rfsim.bench.startup", "bench_startup", {"repeats": 1}),
    "scenarios": ("rfsim.bench.startup", "bench_scenario_memory", {"names": ("gen2-waveforms", "link")}),
    "campaigns": ("rfsim.bench.campaigns", "bench_campaigns", {"names": ("st-to-st",)}),
}


def machine_facts() -> dict:
    """Describe where the figures were measured.

    Returns
    -------
    dict
        ``cpu`` (model name), ``logical_cores``, ``load_average_at_start`` (1, 5 and 15 min;
        empty where unknown), ``platform``, the versions ``python``, ``numpy``, ``numba``,
        ``scipy``, ``h5py`` and ``rfsim``, ``git_revision`` and ``start_time_utc``.
    """
    import platform

    import numba
    import numpy as np
    import scipy

    import rfsim
    from rfsim.core.dataset import git_revision, utc_now

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), cpu)
    except OSError:
        pass
    try:
        load = list(os.getloadavg())
    except OSError:
        load = []
    return {"cpu": cpu, "logical_cores": os.cpu_count(), "load_average_at_start": load,
            "platform": platform.platform(), "python": platform.python_version(), "numpy": np.__version__,
            "numba": numba.__version__, "scipy": scipy.__version__, "h5py": _h5py_version(),
            "rfsim": rfsim.__version__, "git_revision": git_revision(), "start_time_utc": utc_now()}


def _h5py_version() -> str:
    import h5py

    return h5py.__version__


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the ``bench`` subcommand.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the ``rfsim`` parser; ``bench`` is added to it with ``func=run``.
    """
    p = sub.add_parser("bench", help="time the hot paths (waveforms, channels) on this machine",
                       description="Run rfsim's benchmarks on one core and print their measurements.")
    p.add_argument("names", nargs="*", metavar="NAME",
                   help=f"benchmarks to run, or 'all' (default: all of {', '.join(BENCHMARKS)}); with --json "
                        "the file also holds the machine facts (CPU, cores, load average at the start, versions)")
    p.add_argument("--quick", action="store_true", help="smaller problem sizes (seconds, not minutes)")
    p.add_argument("--json", type=Path, default=None, metavar="FILE", help="also write the results as JSON")
    p.add_argument("--repeat", type=positive_int, default=1, metavar="N",
                   help="run the chosen benchmarks N times in turn and report each figure as the median of the N "
                        "runs with its min and max (default 1)")
    p.set_defaults(func=run)


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def summarize_runs(runs: list[dict]) -> dict:
    """One benchmark's figures over repeated runs: the median of each numeric figure.

    Parameters
    ----------
    runs : list of dict
        The benchmark's result of each run, in run order (at least one).

    Returns
    -------
    dict
        Per key of the first run: for a figure that is a number (int or float, not bool) in
        every run, the median of the runs (:func:`statistics.median`: the middle value, or the
        mean of the two middle ones for an even count; NaN when any run gave NaN); any other
        figure as the first run gave it when every run gave the same, else the list of the
        runs' values. Then ``repeat`` (the number of runs), ``min`` and ``max`` (dicts of the
        numeric figures' smallest and largest values) and ``runs`` (the runs themselves).
    """
    out, low, high = {}, {}, {}
    for key in runs[0]:
        values = [run.get(key) for run in runs]
        if all(_is_number(v) for v in values):
            if any(math.isnan(v) for v in values):
                out[key] = low[key] = high[key] = math.nan
            else:
                out[key], low[key], high[key] = statistics.median(values), min(values), max(values)
        else:
            out[key] = values[0] if all(v == values[0] for v in values) else values
    return {**out, "repeat": len(runs), "min": low, "max": high, "runs": runs}


def _show(name: str, out: dict) -> None:
    """Print one benchmark's figures under ``[name]`` (with ``[min – max]`` after a median)."""
    print(f"[{name}]")
    low, high = out.get("min", {}), out.get("max", {})
    for key, value in out.items():
        if key in ("repeat", "min", "max", "runs") and "runs" in out:
            continue
        shown = f"{value:.6g}" if isinstance(value, float) else str(value)
        if key in low and low[key] != high[key]:
            shown += f"  [{low[key]:.6g} – {high[key]:.6g}]"
        print(f"  {key:<40} {shown}")
    if "runs" in out:
        print(f"  (median of {out['repeat']} runs [min – max])")


def _peak_rss_mb() -> float:
    rss_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss_kb / 1024.0 if sys.platform != "darwin" else rss_kb / 2**20


def run(args: argparse.Namespace) -> int:
    """Run ``rfsim bench``: time the chosen benchmarks and print (and optionally write) the table.

    Each benchmark's figures are printed under ``[name]`` with its wall time [s] and the
    process's peak resident memory so far [MB]; with ``--json`` they are written with
    :func:`machine_facts` to one file.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments: ``names`` (benchmark names, empty or ``["all"]`` for all of
        :data:`BENCHMARKS`), ``quick`` (bool: the smaller problem sizes), ``json``
        (pathlib.Path or None) and ``repeat`` (int ≥ 1: runs of each benchmark, in turn;
        above 1 each figure is :func:`summarize_runs`' median of them).

    Returns
    -------
    int
        Exit status 0.

    Raises
    ------
    rfsim.core.errors.UserError
        For an unknown benchmark name or an unusable ``--json`` path.
    """
    import importlib

    from rfsim.core.outputs import check_output_file, write_text_atomic
    from rfsim.core.procs import few_collections

    names = list(BENCHMARKS) if not args.names or args.names == ["all"] else args.names
    unknown = [n for n in names if n not in BENCHMARKS]
    if unknown:
        raise UserError(f"unknown benchmark {unknown[0]!r}; available: {', '.join(BENCHMARKS)}")
    if args.json is not None:
        check_output_file(args.json, "--json")
    machine = machine_facts()
    repeat = int(getattr(args, "repeat", 1))
    runs: dict[str, list[dict]] = {name: [] for name in names}
    results = {}
    for r in range(repeat):
        for name in names:
            module, func, quick_kwargs = BENCHMARKS[name]
            fn = getattr(importlib.import_module(module), func)
            t0 = time.perf_counter()
            with few_collections():  # as a run simulates (rfsim.core.procs.few_collections)
                out = fn(**(quick_kwargs if args.quick else {}))
            out = dict(out)
            out["wall_time_s"] = time.perf_counter() - t0
            out["peak_rss_mb"] = _peak_rss_mb()
            runs[name].append(out)
            if repeat == 1:
                results[name] = out
                _show(name, out)
            else:
                print(f"[{name}] run {r + 1} of {repeat} done in {out['wall_time_s']:.1f} s", flush=True)
    if repeat > 1:
        for name in names:
            results[name] = summarize_runs(runs[name])
            _show(name, results[name])
    if args.json is not None:
        doc = {"machine": machine, **results}
        write_text_atomic(args.json, json.dumps(doc, indent=2, default=float) + "\n", "--json")
        print(f"written: {args.json}")
    return 0

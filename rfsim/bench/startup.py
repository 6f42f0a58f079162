"""Benchmarks of whole ``rfsim`` commands, each run as a child process: the start-up of
``rfsim --help``, ``rfsim list`` and ``rfsim config NAME``, and the peak memory and CPU time
of every scenario's default run.

Each command is timed as its own process, started by a small intermediate interpreter: wall
time from start to exit, CPU time (user + system) and peak resident set size from
``os.wait4`` — the figures ``/usr/bin/time -v`` reports; the CPU time and the peak include the
command's pool workers (waited for by the command), the peak being that of the largest single
process.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile


#: Run in a small interpreter of its own: start ``rfsim argv`` (output discarded), wait for
#: it with ``os.wait4`` and print its figures as JSON. A child keeps the peak RSS of the
#: process it was forked from (Linux carries the high-water mark over fork and exec), so
#: the command must be started from a small process, not from the benchmark (which has
#: NumPy, numba and the earlier benchmarks' arrays in memory), as ``/usr/bin/time`` does.
_MEASURE = """
import json, os, subprocess, sys, time
t0 = time.perf_counter()
p = subprocess.Popen([sys.executable, "-m", "rfsim", *json.loads(sys.argv[1])],
                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
_, status, u = os.wait4(p.pid, 0)
wall = time.perf_counter() - t0
p.returncode = os.waitstatus_to_exitcode(status)
print(json.dumps({"wall_s": wall, "cpu_s": u.ru_utime + u.ru_stime, "peak_rss_mb": u.ru_maxrss / 1024.0,
                  "exit_status": p.returncode}))
"""


def run_measured(argv: list[str], *, cwd: str | None = None) -> dict:
    """Run ``rfsim argv`` as a child process (output discarded) and measure it.

    Measured by a small intermediate process (``_MEASURE``) with ``os.wait4``, as
    ``/usr/bin/time -v`` does.

    Parameters
    ----------
    argv : list of str
        Arguments of the ``rfsim`` command.
    cwd : str or None, default None
        Working directory of the command.

    Returns
    -------
    dict
        ``wall_s`` [s], ``cpu_s`` [s] (user + system of the command and its waited-for
        descendants), ``peak_rss_mb`` [MB] (the largest process) and ``exit_status``.

    Raises
    ------
    subprocess.CalledProcessError
        The intermediate process fails.
    """
    out = subprocess.run([sys.executable, "-c", _MEASURE, json.dumps(list(argv))], capture_output=True, text=True,
                         cwd=cwd, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _scenario_names() -> list[str]:
    from rfsim.runs.registry import scenario_descriptions

    return list(scenario_descriptions())


def bench_startup(*, repeats: int = 3, names: tuple[str, ...] | None = None) -> dict:
    """Time the start-up of ``rfsim --help``, ``rfsim list`` and ``rfsim config NAME``.

    Parameters
    ----------
    repeats : int, default 3
        Runs of each command (the median is kept).
    names : tuple of str or None, default None
        Scenarios for ``rfsim config NAME``; None: every registered scenario.

    Returns
    -------
    dict
        ``repeats``; the median wall and CPU time [s] of each command (keys ``<command>_wall_s``,
        ``<command>_cpu_s``, e.g. ``config_link_cpu_s``), and the largest of the ``config``
        figures (``config_max_wall_s``, ``config_max_cpu_s``).

    Raises
    ------
    RuntimeError
        A command exits with a non-zero status.
    """
    commands = {"help": ["--help"], "list": ["list"]}
    for name in names or _scenario_names():
        commands[f"config_{name}"] = ["config", name]
    out: dict = {"repeats": repeats}
    for key, argv in commands.items():
        runs = [run_measured(argv) for _ in range(repeats)]
        if any(r["exit_status"] != 0 for r in runs):
            raise RuntimeError(f"'rfsim {' '.join(argv)}' failed (exit status {runs[0]['exit_status']})")
        for fig in ("wall_s", "cpu_s"):
            out[f"{key}_{fig}"] = sorted(r[fig] for r in runs)[repeats // 2]
    for fig in ("wall_s", "cpu_s"):
        out[f"config_max_{fig}"] = max(v for k, v in out.items() if k.startswith("config_") and k.endswith(fig))
    return out


def bench_scenario_memory(*, names: tuple[str, ...] | None = None) -> dict:
    """Measure every scenario's default run: peak memory, CPU time and wall time.

    ``rfsim run NAME -q`` with figures, into a temporary folder (kernels cached by the runs
    before it).

    Parameters
    ----------
    names : tuple of str or None, default None
        Scenarios to run; None: every registered scenario.

    Returns
    -------
    dict
        Per scenario ``<name>_peak_rss_mb`` [MB] (the largest process), ``<name>_cpu_s`` [s]
        (leader and workers) and ``<name>_wall_s`` [s]; and the largest peak,
        ``max_peak_rss_mb``.

    Raises
    ------
    RuntimeError
        A run exits with a non-zero status.
    """
    out: dict = {}
    with tempfile.TemporaryDirectory(prefix="rfsim-bench-") as tmp:
        for name in names or _scenario_names():
            r = run_measured(["run", name, "--out-dir", tmp, "-q"])
            if r["exit_status"] != 0:
                raise RuntimeError(f"'rfsim run {name}' failed (exit status {r['exit_status']})")
            for fig in ("peak_rss_mb", "cpu_s", "wall_s"):
                out[f"{name}_{fig}"] = r[fig]
    out["max_peak_rss_mb"] = max(v for k, v in out.items() if k.endswith("_peak_rss_mb"))
    return out


__all__ = ["bench_startup", "bench_scenario_memory", "run_measured"]

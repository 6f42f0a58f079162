"""Benchmark of the paper-size campaigns: the scenarios whose ``mc.full`` option runs the
source's full Monte Carlo (``phase-cancellation``: 13 cells × 300 positions × 3 repetitions,
all techniques; ``st-to-st``: the Fig. 5.8 size), each as a whole ``rfsim run`` command in a
child process (:func:`rfsim.bench.startup.run_measured`): wall time, CPU time of the command
and its pool workers, and the peak resident set size. Their speed is measured here, not
asserted by the tests (a slower or busier machine is not a failure).
"""

from __future__ import annotations

import os
import tempfile

from rfsim.bench.startup import run_measured

#: Scenarios with a paper-size campaign (``mc.full = true``).
CAMPAIGNS = ("phase-cancellation", "st-to-st")


def bench_campaigns(*, names: tuple[str, ...] = CAMPAIGNS, seed: int = 1) -> dict:
    """Time the paper-size campaigns, each as a whole ``rfsim run`` command in a child process.

    ``rfsim run NAME --seed SEED --set mc.full=true --no-plot -q`` for each of ``names`` (dataset
    into a temporary folder; kernels cached by an earlier run), measured by
    :func:`rfsim.bench.startup.run_measured`.

    Parameters
    ----------
    names : tuple of str, default CAMPAIGNS
        Scenarios to run.
    seed : int, default 1
        Root seed of the runs.

    Returns
    -------
    dict
        ``<name>_wall_s`` and ``<name>_cpu_s`` [s], ``<name>_peak_rss_mb`` [MB] per scenario, and
        ``load_average_1min`` / ``load_average_1min_after``, the 1-minute load average before and
        after (the wall time depends on it).

    Raises
    ------
    RuntimeError
        A run exits with a non-zero status.
    """
    out: dict = {"load_average_1min": os.getloadavg()[0]}
    with tempfile.TemporaryDirectory(prefix="rfsim-bench-") as tmp:
        for name in names:
            argv = ["run", name, "--seed", str(seed), "--set", "mc.full=true", "--no-plot", "-q",
                    "-o", os.path.join(tmp, f"{name}.h5")]
            r = run_measured(argv)
            if r["exit_status"] != 0:
                raise RuntimeError(f"'rfsim {' '.join(argv)}' failed (exit status {r['exit_status']})")
            for fig in ("wall_s", "cpu_s", "peak_rss_mb"):
                out[f"{name}_{fig}"] = r[fig]
    out["load_average_1min_after"] = os.getloadavg()[0]
    return out


__all__ = ["bench_campaigns", "CAMPAIGNS"]

"""Compare the summary figures of every scenario between two rfsim installs (or two seeds).

For each scenario the script runs ``BEFORE run <scenario> --seed S_BEFORE --no-plot -q -o
<dir>/<scenario>.h5`` and the same with AFTER and S_AFTER (each run at most ``--timeout``
seconds: a slower scenario is listed with its time and skipped), reduces both datasets to their
summary figures with Monte-Carlo standard errors (``tests/reference/distribution.py``) and prints
a markdown table: scenario, figure, before ± se, after ± se, z, agree, judged with one Bonferroni
family over all figures (family-wise false-alarm rate 1e-3), then the run times.

The "before" side can instead be a stored table (``--before-table``, e.g.
``tests/reference/distribution_before.json``), and ``--write-before`` stores the before figures
with their provenance (the command, the datasets' git revision, the seed, run times); without
``--after`` only the before side is run (and stored).

Examples
--------
Two seeds of one install (the machinery)::

    python tests/tools/distribution_table.py --before .venv/bin/rfsim --after .venv/bin/rfsim \\
        --seed-before 1 --seed-after 2 --scenarios link,st-to-st -o table.md

An old install against a new one, every scenario::

    python tests/tools/distribution_table.py --before OLD/bin/rfsim --after NEW/bin/rfsim \\
        --seed-before 1 --seed-after 2 -o table.md
"""

from __future__ import annotations

import argparse
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from reference.distribution import EXTRACTORS, compare, load_table, markdown, save_table, summary_figures  # noqa: E402


def run_scenario(rfsim: str, scenario: str, seed: int, out: Path, timeout_s: float, reuse: bool) -> dict:
    """Run one scenario at its default config; returns status, wall and CPU seconds.

    Parameters
    ----------
    rfsim : str
        The rfsim executable.
    scenario : str
        Scenario name.
    seed : int
        Root seed (``--seed``).
    out : pathlib.Path
        Dataset file to write.
    timeout_s : float
        Longest run [s]; a longer one is stopped and reported as skipped.
    reuse : bool
        Keep an existing ``out`` instead of running again.

    Returns
    -------
    dict
        ``status`` ("ok", "reused", "timeout" or "failed: ..."), ``wall_s``, ``cpu_s``,
        ``command``.
    """
    command = [rfsim, "run", scenario, "--seed", str(seed), "--no-plot", "-q", "-o", str(out)]
    shown = f"rfsim run {scenario} --seed {seed} --no-plot -q -o <dir>/{out.name}"
    info = {"command": shown, "wall_s": math.nan, "cpu_s": math.nan}
    if reuse and out.exists():
        return {**info, "status": "reused"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    try:
        proc = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        return {**info, "status": "timeout", "wall_s": time.perf_counter() - start}
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    info["wall_s"] = time.perf_counter() - start
    info["cpu_s"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if proc.returncode != 0:
        return {**info, "status": f"failed: {proc.stderr.strip().splitlines()[-1:]}"}
    return {**info, "status": "ok"}


def side(rfsim: str, seed: int, folder: Path, scenarios: list[str], timeout_s: float, reuse: bool):
    """Run (or reuse) every scenario of one side; figures and run info per scenario."""
    figures, runs = {}, {}
    folder.mkdir(parents=True, exist_ok=True)
    for scenario in scenarios:
        out = folder / f"{scenario}.h5"
        runs[scenario] = run_scenario(rfsim, scenario, seed, out, timeout_s, reuse)
        if runs[scenario]["status"] in ("ok", "reused"):
            figures[scenario] = summary_figures(out, scenario)
            with h5py.File(out, "r") as h:
                runs[scenario]["git_revision"] = str(h["provenance"].attrs.get("git_revision", ""))
        print(f"{scenario}: {runs[scenario]['status']} {runs[scenario]['wall_s']:.1f} s wall, "
              f"{runs[scenario]['cpu_s']:.1f} s CPU", file=sys.stderr)
    return figures, runs


def times_table(before: dict, after: dict) -> str:
    """Markdown table of run status and times of both sides."""
    lines = ["| scenario | before | after |", "|---|---|---|"]

    def cell(info: dict | None) -> str:
        if info is None:
            return "stored"
        return f"{info['status']}, {info['wall_s']:.1f} s wall, {info['cpu_s']:.1f} s CPU"

    for s in sorted(set(before) | set(after)):
        lines.append(f"| {s} | {cell(before.get(s))} | {cell(after.get(s))} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Command line (module docstring); returns 0 when every judged figure agrees, else 1."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", help="rfsim executable of the code before")
    ap.add_argument("--after", help="rfsim executable of the code after (none: only store the before side)")
    ap.add_argument("--before-table", help="stored before figures (JSON) instead of running --before")
    ap.add_argument("--seed-before", type=int, default=1)
    ap.add_argument("--seed-after", type=int, default=2)
    ap.add_argument("--scenarios", default=",".join(sorted(EXTRACTORS)), help="comma-separated (default: all)")
    ap.add_argument("--timeout", type=float, default=180.0, help="longest run of one scenario [s] (default 180)")
    ap.add_argument("--workdir", default=None, help="folder of the datasets (default: a temporary folder)")
    ap.add_argument("--reuse", action="store_true", help="keep datasets already in --workdir")
    ap.add_argument("--write-before", help="store the before figures (JSON) with their provenance")
    ap.add_argument("--note", default="", help="a note stored with --write-before")
    ap.add_argument("-o", "--output", help="write the markdown here too")
    args = ap.parse_args(argv)
    scenarios = [s for s in args.scenarios.split(",") if s]
    work = Path(args.workdir or tempfile.mkdtemp(prefix="distribution-"))
    if args.before_table:
        before, meta = load_table(args.before_table)
        before = {s: f for s, f in before.items() if s in scenarios}
        before_runs = {}
    else:
        if not args.before:
            ap.error("--before or --before-table is needed")
        before, before_runs = side(args.before, args.seed_before, work / "before", scenarios, args.timeout, args.reuse)
    if args.write_before:
        commits = sorted({r.get("git_revision", "") for r in before_runs.values()} - {""})
        shown = ["python tests/tools/distribution_table.py", "--before rfsim", f"--seed-before {args.seed_before}",
                 f"--scenarios {args.scenarios}", f"--timeout {args.timeout:g}", "--workdir <dir>",
                 "--reuse" if args.reuse else "", f"--write-before {Path(args.write_before).name}"]
        meta = {"seed": args.seed_before, "commit": ",".join(commits), "note": args.note, "runs": before_runs,
                "command": " ".join(c for c in shown if c)}
        save_table(args.write_before, before, meta)
    if not args.after:
        return 0
    after, after_runs = side(args.after, args.seed_after, work / "after", scenarios, args.timeout, args.reuse)
    both = set(before) & set(after)
    rows, z_max = compare({s: f for s, f in before.items() if s in both}, {s: f for s, f in after.items() if s in both})
    skipped = sorted(set(scenarios) - both)
    text = (markdown(rows, z_max) + f"\nNot compared (a run timed out or failed): {', '.join(skipped) or 'none'}.\n"
            + "\nRuns (default config):\n\n" + times_table(before_runs, after_runs))
    print(text)
    if args.output:
        Path(args.output).write_text(text)
    return 0 if all(r.agree is not False for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())

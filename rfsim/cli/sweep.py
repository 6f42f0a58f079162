"""``rfsim sweep``: run, dry-run, plan (SLURM), merge and extract parameter sweeps.

Shape (a verb first, the spec second, then options; the verb ``run`` may be left out)::

    rfsim sweep [run] SPEC.toml [--output FILE] [--serial | --workers N | --dask ADDRESS|local[:N]]
                                [--resume] [--quiet] [--shard I/N] [--dry-run] [--max-runs N] [--yes]
    rfsim sweep dry-run SPEC.toml [--output FILE] [--show K]
    rfsim sweep plan SPEC.toml --slurm --shards N [--output FILE] [--out SCRIPT] [--cpus-per-task C]
                               [--partition P] [--account A] [--time T] [--mem M] [--job-name NAME]
    rfsim sweep slurm SPEC.toml --shards N ...     (= plan --slurm)
    rfsim sweep merge SPEC.toml [--output FILE] [--quiet]
    rfsim sweep extract MERGED.h5 --point N [--repetition K] -o POINT.h5
    rfsim sweep repair SPEC.toml [--quiet]

A relative ``output`` in the spec resolves against the spec file's folder; ``--output``
replaces it and resolves against the working directory.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from rfsim.cli import positive_int
from rfsim.cli.memory import add_max_memory_arg, max_memory
from rfsim.core.errors import UserError

_VERBS = ("run", "dry-run", "plan", "slurm", "merge", "extract", "repair")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the ``sweep`` subcommand, whose arguments are left to :func:`build_parser`.

    The entry point hands every argument after ``sweep`` to :func:`run`; this parser only
    registers the name and its help line.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the ``rfsim`` parser; ``sweep`` is added to it with ``func=run``.
    """
    p = sub.add_parser("sweep", add_help=False,
                       help="parameter sweeps: run (processes, Dask), dry-run, plan (SLURM), merge, extract",
                       description="Run 'rfsim sweep --help' for the forms of this command.")
    p.add_argument("-h", "--help", action="store_true", dest="sweep_help", help=argparse.SUPPRESS)
    p.add_argument("argv", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    p.set_defaults(func=run)


def _shard(text: str) -> tuple[int, int]:
    i, sep, n = text.partition("/")
    if not sep or not i.isdigit() or not n.isdigit() or int(n) < 1 or int(i) >= int(n):
        raise argparse.ArgumentTypeError(f"{text!r}: expected I/N with 0 <= I < N, e.g. 3/16")
    return int(i), int(n)


#: Runs a sweep may start without --yes.
DEFAULT_MAX_RUNS = 100_000


def _count(text: str) -> int:
    if not text.isdigit():
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer >= 0")
    return int(text)


def build_parser() -> argparse.ArgumentParser:
    """Build the parser of ``rfsim sweep`` with one sub-parser per verb.

    Returns
    -------
    argparse.ArgumentParser
        A :class:`rfsim.cli.Parser` whose verbs (``run``, ``dry-run``, ``plan``,
        ``slurm``, ``merge``, ``extract``, ``repair``) set ``handler``.
    """
    from rfsim.cli import Parser

    parser = Parser(
        prog="rfsim sweep",
        description="Parameter sweeps from a TOML spec. 'rfsim sweep SPEC.toml' is 'rfsim sweep run SPEC.toml'.",
        epilog="Every run (point, repetition) is appended to the point store <output>.points/ as it "
               "finishes; the merged file appears under the output name only when all runs exist.")
    verbs = parser.add_subparsers(dest="verb", metavar="VERB")
    output_help = ("merged file (.h5); replaces the spec's output (relative: to the working directory; "
                   "a relative output in the spec is relative to the spec's folder)")

    p = verbs.add_parser("run", help="run the sweep (or one shard) and merge it",
                         description="Run a sweep on local processes (default), serially or on Dask.")
    p.add_argument("spec", type=Path, help="sweep spec (TOML)")
    p.add_argument("-o", "--output", type=Path, default=None, metavar="FILE", help=output_help)
    how = p.add_mutually_exclusive_group()
    how.add_argument("--serial", action="store_true", help="run in this process, one run after another")
    how.add_argument("--workers", type=positive_int, default=None, metavar="N",
                     help="local worker processes (default: the available CPUs)")
    how.add_argument("--dask", default=None, metavar="ADDRESS|local[:N]",
                     help="Dask: a scheduler address (tcp://host:8786) or a LocalCluster of N workers")
    p.add_argument("--resume", action="store_true",
                   help="skip runs already in the point store for this spec")
    p.add_argument("--shard", type=_shard, default=None, metavar="I/N",
                   help="run only shard I of N (no merge; see 'rfsim sweep merge')")
    p.add_argument("--dry-run", action="store_true", help="print the expansion, run nothing")
    p.add_argument("--max-runs", type=positive_int, default=DEFAULT_MAX_RUNS, metavar="N",
                   help=f"refuse to start more than N runs without --yes (default {DEFAULT_MAX_RUNS})")
    p.add_argument("-y", "--yes", action="store_true", help="run even more than --max-runs runs")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress and no summary")
    add_max_memory_arg(p)
    p.set_defaults(handler=_run)

    p = verbs.add_parser("dry-run", help="print the number of points and the first expanded configs")
    p.add_argument("spec", type=Path, help="sweep spec (TOML)")
    p.add_argument("-o", "--output", type=Path, default=None, metavar="FILE", help=output_help)
    p.add_argument("--show", type=_count, default=3, metavar="K", help="configs to print (default 3)")
    p.set_defaults(handler=_dry_run)

    p = verbs.add_parser("plan", aliases=["slurm"], help="write a SLURM array script running the sweep in shards "
                                                         "('slurm' is 'plan --slurm')")
    p.add_argument("spec", type=Path, help="sweep spec (TOML)")
    p.add_argument("--slurm", action="store_true", help="plan a SLURM array job (required after 'plan')")
    p.add_argument("--shards", type=positive_int, required=True, metavar="N", help="number of array tasks")
    p.add_argument("-o", "--output", type=Path, default=None, metavar="FILE",
                   help=output_help + "; passed on to the script's run and merge commands")
    p.add_argument("--out", type=Path, default=None, metavar="FILE",
                   help="script file (default: print to stdout)")
    p.add_argument("--cpus-per-task", type=positive_int, default=1, metavar="C",
                   help="CPUs per array task; each task runs C worker processes (default 1)")
    p.add_argument("--partition", default="", metavar="P", help="SLURM partition (#SBATCH --partition)")
    p.add_argument("--account", default="", metavar="A", help="SLURM account to charge (#SBATCH --account)")
    p.add_argument("--time", default="", metavar="T", help="SLURM time limit per task, e.g. 01:00:00")
    p.add_argument("--mem", default="", metavar="M", help="SLURM memory per node, e.g. 4G (#SBATCH --mem)")
    p.add_argument("--job-name", default="", help="SLURM job name (default rfsim-sweep-<spec>)")
    p.set_defaults(handler=_plan)

    p = verbs.add_parser("merge", help="merge the point store of a (sharded) sweep into the output")
    p.add_argument("spec", type=Path, help="sweep spec (TOML)")
    p.add_argument("-o", "--output", type=Path, default=None, metavar="FILE", help=output_help)
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(handler=_merge)

    p = verbs.add_parser("extract", help="write one point of a merged sweep as a dataset of its own",
                         description="Write point N (one repetition, or all) of a merged sweep file as a "
                                     "standalone dataset that 'rfsim info' and 'rfsim plot' read.")
    p.add_argument("merged", type=Path, help="merged sweep file (.h5)")
    p.add_argument("--point", type=_count, required=True, metavar="N", help="point index (sweep_point)")
    p.add_argument("--repetition", type=_count, default=None, metavar="K",
                   help="repetition (sweep_repetition; default: the only one, or all of them)")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="FILE", help="dataset to write (.h5)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(handler=_extract)

    p = verbs.add_parser("repair", help="rebuild the damaged index files of the point store from their logs",
                         description="Check every index entry of the sweep's point store and rebuild each "
                                     "damaged index file from its log; then continue with 'run --resume'.")
    p.add_argument("spec", type=Path, help="sweep spec (TOML)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(handler=_repair)
    return parser


def run(args: argparse.Namespace) -> int:
    """Run ``rfsim sweep``: parse the verb and its options and call its handler.

    A first argument that is not a verb (nor ``-h``/``--help``) means ``run``; no verb
    prints the help.

    Parameters
    ----------
    args : argparse.Namespace
        ``sweep_help`` (bool: ``-h`` was given) and ``argv`` (list of str: the arguments
        after ``sweep``).

    Returns
    -------
    int
        The handler's exit status (0 on success, or after printing the help).

    Raises
    ------
    rfsim.sweep.store.DamagedIndexError
        If the point store's index is damaged; its ``spec`` is set to the spec path so the
        message can name the repair command.
    """
    argv = ["--help"] if args.sweep_help else list(args.argv)
    if argv and argv[0] not in _VERBS and argv[0] not in ("-h", "--help"):
        argv.insert(0, "run")
    parser = build_parser()
    ns = parser.parse_args(argv)
    if not getattr(ns, "handler", None):
        parser.print_help()
        return 0
    from rfsim.sweep.store import DamagedIndexError

    try:
        return int(ns.handler(ns) or 0)
    except DamagedIndexError as err:  # name the command that repairs it with this spec
        err.spec = str(ns.spec)
        raise


def _dry_run(ns: argparse.Namespace) -> int:
    from rfsim.core.config import to_toml
    from rfsim.sweep import load_spec, plan_sweep, point_seed

    spec = load_spec(ns.spec, output=ns.output)
    plan = plan_sweep(spec, check="sample")  # the shown points and every axis value once
    n = spec.n_points
    print(f"# {spec.scenario}: {n} points x {spec.repetitions} repetitions = {spec.n_runs} runs "
          f"-> {spec.output}")
    if spec.swept_keys:
        print(f"# swept keys: {', '.join(spec.swept_keys)}")
    shown = min(ns.show, n)
    for i in range(shown):
        values = ", ".join(f"{k} = {v!r}" for k, v in plan.values[i].items())
        print(f"\n# ---- point {i}: {values or '(base)'}; seed of repetition 0 = {point_seed(spec.seed, i, 0)}")
        print(to_toml(plan.configs[i]), end="")
    if n > shown:
        print(f"\n# ... {n - shown} more points")
    return 0


def _check_size(ns: argparse.Namespace, spec) -> None:
    from rfsim.sweep import shard_runs

    n = spec.n_runs if ns.shard is None else len(shard_runs(spec.n_runs, *ns.shard))
    if n > ns.max_runs and not ns.yes:
        raise UserError(f"sweep {str(ns.spec)!r}: {n} runs to do, more than --max-runs {ns.max_runs}; "
                        "add --yes to run them (or raise --max-runs)")


def _run(ns: argparse.Namespace) -> int:
    if ns.dry_run:
        ns.show = 3
        return _dry_run(ns)
    from rfsim.sweep import Progress, load_spec, make_executor, run_sweep
    from rfsim.sweep.executors import available_cpus
    from rfsim.sweep.runner import check_sweep_memory, check_sweep_outputs

    spec = load_spec(ns.spec, output=ns.output)
    _check_size(ns, spec)
    if ns.dask is None:  # a Dask cluster's workers have their own memory
        check_sweep_memory(spec, max_memory(ns), 1 if ns.serial else (ns.workers or available_cpus()))
    check_sweep_outputs(spec)  # before a Dask cluster is started or anything runs
    executor = make_executor(serial=ns.serial, workers=ns.workers, dask=ns.dask)
    try:
        def progress(total: int, *, done: int) -> Progress:
            return Progress(total, done=done, stream=sys.stderr, quiet=ns.quiet)

        report = run_sweep(spec, executor, shard=ns.shard, resume=ns.resume, progress=progress)
    except KeyboardInterrupt as err:  # Ctrl-C or SIGTERM: the finished runs are in the point store
        again = f" --output {ns.output}" if ns.output is not None else ""
        err.hint = f"; finished runs are kept, continue with: rfsim sweep run {ns.spec}{again} --resume"
        raise
    finally:
        executor.close()
    if not ns.quiet:
        what = f"shard {ns.shard[0]}/{ns.shard[1]}: " if ns.shard else ""
        print(f"sweep: {what}{report.selected} runs, {report.computed} computed, {report.reused} reused, "
              f"{report.wall_time_s:.1f} s on {executor.name} ({executor.workers} "
              f"worker{'s' if executor.workers != 1 else ''})")
        if report.output is not None:
            print(f"dataset: {report.output}")
    return 0


def _plan(ns: argparse.Namespace) -> int:
    from rfsim.core.outputs import check_output_file, write_text_atomic
    from rfsim.sweep import load_spec, plan_sweep, sbatch_script
    from rfsim.sweep.slurm import check_account, check_memory, check_partition, check_time_limit

    if ns.verb == "plan" and not ns.slurm:
        raise UserError("sweep plan: add --slurm (the only kind of plan), or use 'rfsim sweep slurm'")
    for value, check in ((ns.time, check_time_limit), (ns.partition, check_partition),
                         (ns.account, check_account), (ns.mem, check_memory)):
        if value:
            check(value)
    if ns.out is not None:
        check_output_file(ns.out, "--out")
    spec = load_spec(ns.spec, output=ns.output)  # a bad spec fails here, not on the cluster
    plan_sweep(spec, check="sample")
    if ns.shards > spec.n_runs:
        raise UserError(f"--shards {ns.shards}: more shards than runs ({spec.n_runs})")
    text = sbatch_script(ns.spec, ns.shards, workdir=Path(os.getcwd()), job_name=ns.job_name,
                         cpus_per_task=ns.cpus_per_task, time_limit=ns.time, partition=ns.partition,
                         account=ns.account, memory=ns.mem, output=ns.output)
    if ns.out is None:
        print(text, end="")
    else:
        write_text_atomic(ns.out, text, "--out")
        print(f"sbatch script: {ns.out} ({ns.shards} array tasks, {spec.n_runs} runs); "
              f"submit with: sbatch {ns.out}")
    return 0


def _merge(ns: argparse.Namespace) -> int:
    from rfsim.sweep import load_spec, merge_sweep

    path = merge_sweep(load_spec(ns.spec, output=ns.output))
    if not ns.quiet:
        print(f"dataset: {path}")
    return 0


def _extract(ns: argparse.Namespace) -> int:
    from rfsim.core.outputs import check_output_file
    from rfsim.sweep.extract import extract_point

    check_output_file(ns.output, "--output", suffixes=(".h5", ".hdf5"))
    if ns.output.resolve() == ns.merged.resolve():
        raise UserError(f"--output {str(ns.output)!r} is the merged file itself; name another file")
    path = extract_point(ns.merged, ns.point, ns.output, repetition=ns.repetition)
    if not ns.quiet:
        print(f"dataset: {path}")
    return 0


def _repair(ns: argparse.Namespace) -> int:
    from rfsim.sweep import load_spec, points_dir
    from rfsim.sweep.lock import OutputLock
    from rfsim.sweep.store import repair_store

    spec = load_spec(ns.spec)
    store = points_dir(spec.output)
    if not store.is_dir():
        raise UserError(f"sweep {str(ns.spec)!r}: no point store at {str(store)!r}")
    with OutputLock(spec.output):
        repaired = repair_store(store)
    if not ns.quiet:
        for index, n in repaired:
            print(f"rebuilt: {index} ({n} records)")
        print(f"point store {store}: {len(repaired)} index file{'s' if len(repaired) != 1 else ''} rebuilt; "
              f"continue with: rfsim sweep run {ns.spec} --resume")
    return 0

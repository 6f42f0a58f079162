"""``rfsim list``, ``rfsim config NAME`` and ``rfsim run NAME``.

``NAME`` is a scenario of ``rfsim list`` (built-in or installed plug-in) or the path of a
scenario file (``rfsim run my_scenario.py``: a module with ``NAME``, ``DESCRIPTION``,
``Config``, ``run`` and ``plot``; :mod:`rfsim.runs.registry`) or of a scene file
(``rfsim run my-scene.toml``, :mod:`rfsim.scenes.scene_file`: the file is the config).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rfsim.cli.figures import add_figure_args, figure_output_of, written_files
from rfsim.cli.memory import add_max_memory_arg, max_memory
from rfsim.cli.verbosity import add_verbosity_args, reporter
from rfsim.core.config import describe, load_config, to_toml
from rfsim.core.errors import SEED_RANGE_TEXT, UserError, check_seed
from rfsim.runs.registry import get_scenario, scenario_descriptions


_SCENARIO_HELP = ("scenario name (see 'rfsim list'), path of a scenario file (my_scenario.py) "
                  "or of a scene file (my-scene.toml)")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the ``list``, ``config`` and ``run`` subcommands.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the ``rfsim`` parser; the three subcommands are added to it.
    """
    p = sub.add_parser("list", help="list the scenarios (built-in and plug-ins) with a one-line description")
    p.set_defaults(func=_list)

    p = sub.add_parser("config", help="print a scenario's default (or resolved) config as TOML")
    p.add_argument("scenario", help=_SCENARIO_HELP)
    _add_config_args(p)
    p.add_argument("--keys", action="store_true", help="list every key with its allowed values")
    p.set_defaults(func=_config)

    p = sub.add_parser("run", help="run a scenario: writes an HDF5 dataset and figures",
                       description="Run a scenario and write <out-dir>/<scenario>.h5 plus figures.")
    p.add_argument("scenario", help=_SCENARIO_HELP)
    _add_config_args(p)
    p.add_argument("--seed", type=_seed, default=1,
                   help="root seed of the run's SeedSequence (integer in [0, 2**64), default 1)")
    p.add_argument("--out-dir", type=Path, default=None,
                   help="folder for the dataset and figures (default: results; with -o, the "
                        "dataset's folder)")
    p.add_argument("-o", "--output", type=Path, default=None,
                   help="dataset file name (default: <out-dir>/<scenario>.h5)")
    p.add_argument("--no-plot", action="store_true", help="write the dataset only")
    add_figure_args(p)
    add_max_memory_arg(p)
    add_verbosity_args(p)
    p.set_defaults(func=_run)


def _seed(text: str) -> int:
    try:
        return check_seed(int(text, 0))
    except (ValueError, UserError):
        raise argparse.ArgumentTypeError(f"{text!r}: expected {SEED_RANGE_TEXT}") from None


def _add_config_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("-c", "--config", type=Path, default=None, metavar="FILE.toml",
                   help="TOML file with config values (defaults for the rest)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override one config value, e.g. --set reader.ptx_dbm=30 (repeatable)")


def _resolve(args: argparse.Namespace):
    module = get_scenario(args.scenario)
    if hasattr(module, "scene_config"):  # a scene file is its own config
        return module, module.scene_config(args.config, args.overrides)
    return module, load_config(module.Config, args.config, args.overrides)


def _list(args: argparse.Namespace) -> int:
    descriptions = scenario_descriptions()  # read from the sources: no scenario physics imported
    width = max((len(n) for n in descriptions), default=0)
    for name, description in descriptions.items():
        print(f"{name:<{width}}  {description}")
    return 0


def _config(args: argparse.Namespace) -> int:
    module, config = _resolve(args)
    if args.keys:
        for key, default, allowed, doc in describe(module.Config):
            print(f"{key} = {default}  # {allowed}; {doc}")
    else:
        print(to_toml(config), end="")
    return 0


def _run(args: argparse.Namespace) -> int:
    from rfsim.core.plots import figure_output
    from rfsim.core.progress import reporting
    from rfsim.runs.runner import run_scenario

    module, config = _resolve(args)
    output = figure_output_of(args)  # a wrong --format is reported before the run
    with reporting(reporter(args)) as rep, figure_output(output):
        rep.detail("resolved config:\n" + to_toml(config).rstrip())
        out_dir = args.out_dir if args.out_dir is not None else (
            args.output.parent if args.output is not None else Path("results"))  # figures beside -o
        out = run_scenario(module, config, seed=args.seed, out_dir=out_dir, output=args.output,
                           make_plots=not args.no_plot, max_memory_bytes=max_memory(args))
    if not args.quiet:
        print(f"dataset: {out.dataset_path}")
        for fig in written_files(out.figure_paths, output):
            print(f"figure:  {fig}")
        print(f"done in {out.wall_time_s:.1f} s (seed {args.seed})")
    return 0

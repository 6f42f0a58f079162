"""``rfsim plot DATASET`` and ``rfsim info DATASET``: work with a dataset file alone.

``plot`` re-draws a run's figures from its HDF5 file (the scenario is the file's
``scenario`` attribute; nothing is simulated), named after the file's stem, beside it or
in ``--out-dir``. ``info`` lists what the file holds — groups with their description,
columns with dtype, units and description, the root attributes and a provenance summary;
``-v`` adds the resolved config and every provenance attribute.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import os
import sys
import textwrap
from pathlib import Path

from rfsim.cli.figures import add_figure_args, figure_output_of, written_files
from rfsim.cli.verbosity import add_verbosity_args, reporter
from rfsim.core.errors import UserError
from rfsim.core.outputs import check_output_folder


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the ``plot`` and ``info`` subcommands.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the ``rfsim`` parser; ``plot`` and ``info`` are added to it.
    """
    p = sub.add_parser("plot", help="re-draw a run's figures from its dataset file",
                       description="Re-draw the figures of a run from its HDF5 dataset alone "
                                   "(figures <stem>-*.png beside the dataset or in --out-dir). "
                                   "With --all-scenarios DIR: one contact sheet with every figure "
                                   "of every dataset in DIR (e.g. results/ after the default runs).")
    p.add_argument("dataset", type=Path, nargs="?", help="dataset file written by 'rfsim run'")
    p.add_argument("--all-scenarios", type=Path, default=None, metavar="DIR",
                   help="draw the figures of every dataset in DIR (one per scenario, in 'rfsim list' "
                        "order) side by side on one page, <out-dir>/contact-sheet.png")
    p.add_argument("--out-dir", type=Path, default=None,
                   help="folder for the figures (default: the dataset's folder, or DIR)")
    add_figure_args(p)
    add_verbosity_args(p)
    p.set_defaults(func=_plot)

    p = sub.add_parser("info", help="list a dataset's groups, columns (units, descriptions) and provenance",
                       description="Describe an HDF5 dataset: groups, columns with units and "
                                   "descriptions, root attributes, provenance summary.")
    p.add_argument("dataset", type=Path, help="dataset file (HDF5)")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="full descriptions and attributes, every provenance attribute and the resolved config")
    p.set_defaults(func=_info)


def _open(path: Path):
    """The dataset opened read-only; a missing or non-HDF5 file is a one-line user error."""
    import h5py

    if not path.exists():
        raise UserError(f"dataset {str(path)!r}: no such file")
    if path.is_dir():
        raise UserError(f"dataset {str(path)!r} is a directory, not an HDF5 file")
    try:
        return h5py.File(path, "r")
    except OSError:
        raise UserError(f"dataset {str(path)!r} is not an HDF5 file") from None


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _plot(args: argparse.Namespace) -> int:
    from rfsim.core.plots import figure_output
    from rfsim.core.progress import reporting
    from rfsim.runs.registry import get_scenario

    if (args.dataset is None) == (args.all_scenarios is None):
        raise UserError("give a dataset file or --all-scenarios DIR (one of the two)")
    if args.all_scenarios is not None:
        return _contact_sheet(args)
    with _open(args.dataset) as f:
        scenario = _text(f.attrs.get("scenario", ""))
        is_sweep = "provenance" in f and "spec_toml" in f["provenance"].attrs
    if not scenario:
        raise UserError(f"dataset {str(args.dataset)!r} has no 'scenario' attribute: not written by 'rfsim run'")
    if is_sweep:
        raise UserError(f"dataset {str(args.dataset)!r} is a merged sweep; extract a point and plot it: "
                        f"rfsim sweep extract {args.dataset} --point N -o point.h5")
    module = _figures_module(args.dataset, scenario, get_scenario)
    out_dir = args.out_dir if args.out_dir is not None else args.dataset.parent
    check_output_folder(out_dir, "--out-dir")  # before drawing: a file, /proc, no permission
    output = figure_output_of(args)
    with reporting(reporter(args)) as rep, figure_output(output):
        rep.stage(f"drawing the {scenario} figures of {args.dataset}")
        try:
            figures = module.plot(args.dataset, out_dir)
        except (KeyError, ValueError) as exc:
            raise UserError(f"dataset {str(args.dataset)!r} lacks what the {scenario} figures need "
                            f"({type(exc).__name__}: {exc})") from None
    if not args.quiet:
        for fig in written_files(figures, output):
            print(f"figure:  {fig}")
    return 0


def _figures_module(path: Path, scenario: str, get_scenario):
    """The module whose ``plot`` draws the figures of dataset ``path``: its scenario's, or the
    scene-file figures (:func:`rfsim.scenes.scene_file.plot`) when a scene file wrote it (its
    scenario is named after the file, its resolved config is ``scene_json``)."""
    import importlib
    import tomllib

    try:
        return get_scenario(scenario)
    except UserError:
        import h5py

        with h5py.File(path, "r") as f:
            text = _text(f["provenance"].attrs.get("config_toml", "")) if "provenance" in f else ""
        try:
            is_scene = "scene_json" in tomllib.loads(text)
        except tomllib.TOMLDecodeError:
            is_scene = False
        if not is_scene:
            raise
        return importlib.import_module("rfsim.scenes.scene_file")


def _scenario_of(path: Path) -> str:
    """The scenario that wrote the dataset ``path`` ('' for a merged sweep, a foreign or
    unreadable file)."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            if "provenance" in f and "spec_toml" in f["provenance"].attrs:
                return ""
            return _text(f.attrs.get("scenario", ""))
    except OSError:
        return ""


def _contact_sheet(args: argparse.Namespace) -> int:
    """``rfsim plot --all-scenarios DIR``: every dataset's figures (drawn afresh into a
    temporary folder, PNG) on one page, scenarios in 'rfsim list' order, then by file name."""
    import tempfile

    from rfsim.core.plots import FigureOutput, contact_sheet, figure_output
    from rfsim.core.progress import reporting
    from rfsim.runs.registry import get_scenario, scenario_descriptions

    folder = args.all_scenarios
    if not folder.is_dir():
        raise UserError(f"--all-scenarios {str(folder)!r}: not a folder")
    out_dir = args.out_dir if args.out_dir is not None else folder
    check_output_folder(out_dir, "--out-dir")
    output = figure_output_of(args)
    order = list(scenario_descriptions())
    found = [(p, _scenario_of(p)) for p in sorted(folder.glob("*.h5"))]
    found = sorted(((p, s) for p, s in found if s), key=lambda ps: (order.index(ps[1]) if ps[1] in order
                                                                     else len(order), ps[0].name))
    if not found:
        raise UserError(f"--all-scenarios {str(folder)!r}: no dataset written by 'rfsim run' in it")
    images = []
    with reporting(reporter(args)) as rep, tempfile.TemporaryDirectory(prefix="rfsim-sheet-") as tmp:
        with figure_output(FigureOutput(("png",), dpi=100)):
            for path, scenario in found:
                rep.stage(f"drawing the {scenario} figures of {path}")
                try:
                    drawn = _figures_module(path, scenario, get_scenario).plot(path, Path(tmp))
                except (KeyError, ValueError, UserError) as exc:
                    rep.stage(f"skipped {path}: its figures could not be drawn ({type(exc).__name__}: {exc})")
                    continue
                images += [(Path(p).stem, Path(p)) for p in drawn]
        with figure_output(output):
            sheet = contact_sheet(images, out_dir / "contact-sheet.png",
                                  title=f"Every figure of the {len(found)} datasets in {folder}")
    if not args.quiet:
        for fig in written_files([sheet], output):
            print(f"figure:  {fig}")
    return 0


def _duration(start: str, end: str) -> str:
    try:
        seconds = (_dt.datetime.fromisoformat(end) - _dt.datetime.fromisoformat(start)).total_seconds()
    except ValueError:
        return ""
    return f" ({seconds:.0f} s)"


def _value(v, width: int = 60) -> str:
    text = _text(v) if not hasattr(v, "tolist") else str(v.tolist())
    text = " ".join(text.split())
    return text if len(text) <= width else text[: width - 1] + "…"


def _info(args: argparse.Namespace) -> int:
    import h5py

    with _open(args.dataset) as f:
        lines = [f"{args.dataset}: {_text(f.attrs.get('scenario', '?'))} — {_text(f.attrs.get('title', ''))}"]
        prov = {k: f["provenance"].attrs[k] for k in f["provenance"].attrs} if "provenance" in f else {}
        if prov:
            start, end = _text(prov.get("start_time_utc", "")), _text(prov.get("end_time_utc", ""))
            git = _text(prov.get("git_revision", "")) or "not a git checkout"
            lines.append(f"provenance: seed {prov.get('seed', '?')}, rfsim {_text(prov.get('rfsim_version', '?'))} "
                         f"(git {git[:12]}{'-dirty' if git.endswith('-dirty') else ''}), "
                         f"{start} -> {end}{_duration(start, end)}")
            lines.append(f"            python {_text(prov.get('python', '?'))}, numpy {_text(prov.get('numpy', '?'))}, "
                         f"numba {_text(prov.get('numba', '?'))}, {_text(prov.get('platform', '?'))}")
        for gname, g in f.items():
            if gname == "provenance" or not isinstance(g, h5py.Group):
                continue
            desc = _text(g.attrs.get("description", ""))
            arrays = {k: ds for k, ds in g.items() if isinstance(ds, h5py.Dataset)}
            subgroups = [k for k, sub in g.items() if isinstance(sub, h5py.Group)]
            if "row" in arrays and arrays["row"].is_scale:
                kind = f"table, {arrays['row'].shape[0]} rows"
            elif any(ds.is_scale for ds in arrays.values()):
                coords = [k for k, ds in arrays.items() if ds.is_scale]
                kind = "grid " + " x ".join(f"{c}[{arrays[c].shape[0] if arrays[c].ndim else 1}]" for c in coords)
            else:  # not written by rfsim: a plain group
                kind = "group"
            if subgroups:  # other HDF5 files may nest groups; rfsim's never do
                kind += f", {len(subgroups)} nested group{'s' if len(subgroups) != 1 else ''}: " + ", ".join(subgroups)
            lines.append("")
            lines.append(f"[{gname}] ({kind})" + (f": {desc}" if desc else ""))
            names = [k for k in arrays if k != "row"]
            width = max((len(k) for k in names), default=0)
            for k in names:
                ds = arrays[k]
                dtype = "bool" if ds.attrs.get("rfsim_dtype") == "bool" else (
                    "str" if h5py.check_string_dtype(ds.dtype) else str(ds.dtype))
                dims = "" if ds.ndim <= 1 else "(" + ", ".join(
                    ds.dims[i][0].name.rsplit("/", 1)[-1] if len(ds.dims[i]) else "?" for i in range(ds.ndim)) + ") "
                units = _text(ds.attrs.get("units", "")) or "-"
                text = dims + _text(ds.attrs.get("description", ""))
                if not args.verbose:
                    text = _value(text, 90)
                lines.append(f"  {k:<{width}}  {dtype:<7} {units:<8} {text}")
        attrs = {k: v for k, v in f.attrs.items() if k not in ("title", "scenario", "rfsim_version")}
        if attrs:
            lines.append("")
            lines.append("attributes:")
            for k, v in attrs.items():
                lines.append(f"  {k} = {_value(v, 10**6 if args.verbose else 70)}")
        if args.verbose and prov:
            lines.append("")
            lines.append("provenance attributes:")
            for k, v in prov.items():
                if k != "config_toml":
                    lines.append(f"  {k} = {_text(v)}")
            lines.append("")
            lines.append("resolved config (provenance/config_toml):")
            lines.append(textwrap.indent(_text(prov.get("config_toml", "")).rstrip(), "  "))
    _print_lines(lines)
    return 0


def _print_lines(lines: list[str]) -> None:
    """Print ``lines``; a reader that closed the pipe (``| head``) ends the output quietly."""
    try:
        print("\n".join(lines))
        sys.stdout.flush()
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # the interpreter's final flush must not fail again


__all__ = ["add_parser"]

"""``--format`` and ``--dpi``: one way for ``rfsim run`` and ``rfsim plot`` to choose the files
a figure is written to (PNG by default; PDF, SVG or EPS for papers)."""

from __future__ import annotations

import argparse
from pathlib import Path

from rfsim.core.plots import FIGURE_FORMATS, FigureOutput


def add_figure_args(p: argparse.ArgumentParser) -> None:
    """Add ``--format FMT[,FMT...]`` and ``--dpi N`` to a parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser; changed in place. The values are stored as ``figure_format``
        (default ``"png"``) and ``figure_dpi`` (default None: the figure's own, 120).
    """
    p.add_argument("--format", dest="figure_format", default="png", metavar="FMT[,FMT...]",
                   help="figure file formats, comma-separated, of " + ", ".join(FIGURE_FORMATS)
                        + " (default png), e.g. --format png,pdf,svg")
    p.add_argument("--dpi", dest="figure_dpi", type=int, default=None, metavar="N",
                   help="resolution of raster figures [dots per inch] (default: the figure's, 120)")


def figure_output_of(args: argparse.Namespace) -> FigureOutput:
    """Figure formats and resolution that parsed command-line arguments ask for.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments with ``figure_format`` (comma-separated formats) and ``figure_dpi``
        (dots per inch, or None), as added by :func:`add_figure_args`.

    Returns
    -------
    rfsim.core.plots.FigureOutput
        The formats and resolution.

    Raises
    ------
    rfsim.core.errors.UserError
        For an unknown format or an out-of-range resolution (a one-line user error).
    """
    return FigureOutput.parse(args.figure_format, args.figure_dpi)


def written_files(figures, output: FigureOutput) -> list[Path]:
    """List every file written for a set of figures: one per format of ``output``, in figure order.

    Parameters
    ----------
    figures : iterable of path-like
        The figure paths that ``plot`` returned, one per figure (any suffix).
    output : rfsim.core.plots.FigureOutput
        The formats the figures were written in.

    Returns
    -------
    list of pathlib.Path
        For each figure, its path with each format's suffix, in the order of ``output``'s formats.
    """
    return [p for fig in figures for p in output.paths(fig)]


__all__ = ["add_figure_args", "figure_output_of", "written_files"]

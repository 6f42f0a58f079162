"""``--format`` and ``--dpi``: one way for ``rfsim run`` and ``rfsim plot`` to choose the files
a figure is written to (PNG by default; PDF, SVG or EPS for papers)."""

from __future__ import annotations

import argparse
from pathlib import Path

from rfsim.core.plots import FIGURE_FORMATS, FigureOutput


def add_figure_args(p: argparse.ArgumentParser) -> None:
    """Add ``--format FMT[,FMT...]`` and ``--dpi N`` to ``p``."""
    p.add_argument("--format", dest="figure_format", default="png", metavar="FMT[,FMT...]",
                   help="figure file formats, comma-separated, of " + ", ".join(FIGURE_FORMATS)
                        + " (default png), e.g. --format png,pdf,svg")
    p.add_argument("--dpi", dest="figure_dpi", type=int, default=None, metavar="N",
                   help="resolution of raster figures [dots per inch] (default: the figure's, 120)")


def figure_output_of(args: argparse.Namespace) -> FigureOutput:
    """The :class:`~rfsim.core.plots.FigureOutput` the parsed ``args`` ask for (unknown
    formats and out-of-range resolutions are one-line user errors)."""
    return FigureOutput.parse(args.figure_format, args.figure_dpi)


def written_files(figures, output: FigureOutput) -> list[Path]:
    """Every file written for the figures ``figures`` (the paths ``plot`` returned, one per
    figure): one per format of ``output``, in figure order."""
    return [p for fig in figures for p in output.paths(fig)]


__all__ = ["add_figure_args", "figure_output_of", "written_files"]

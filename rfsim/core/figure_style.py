"""The project's figure style: paper sizes, a colour-blind-safe series cycle, published values.

Every scenario draws its figures inside :func:`paper_style` on a figure made by :func:`figure`::

    with paper_style():
        fig, ax = figure(columns=1)
        for i, (label, x, y) in enumerate(series):
            ax.plot(x, y, label=label, **series_style(i))
        ax.plot(x_pub, y_pub, label=published_label("AURIS Fig. 3.8"), **PUBLISHED)
        ax.set(xlabel="distance $d$ [m]", ylabel="$P_\\mathrm{det}$ [%]")
        legend_outside(ax)
        source_note(ax, "AURIS Fig. 3.8; reduced default run: 200 trials per point")
        save_figure(fig, path)

- **Sizes** are those of a two-column paper: 3.5 in (one column) or 7.16 in (both columns)
  wide, laid out by matplotlib's constrained layout, so titles, labels and legends placed
  outside the axes stay on the canvas.
- **Series** differ by colour (Okabe & Ito's colour-blind-safe palette, without black),
  line style *and* marker (:func:`series_style`), so a figure printed in grey or seen by a
  colour-blind reader still tells them apart.
- **Published values** (a reference document's curve or table) are black, dashed, with
  hollow markers (:data:`PUBLISHED`) and labelled ``published (<source>)``
  (:func:`published_label`); this run's values never use black.
- **Text** uses mathtext for Greek letters, subscripts and units:
  ``"$\\theta$ [°]"``, ``"$d_\\mathrm{tt}$ [m]"``, ``"$\\Delta t$ [$\\mu$s]"``.
- **Probabilities and rates** are drawn with their confidence interval (:func:`ci_errorbar`,
  e.g. a Wilson interval from :func:`rfsim.detection.wilson_interval`); cells or points
  without data (e.g. the tag not powered) are masked and marked (:func:`mask_no_data`,
  :func:`shade_no_data`), never drawn as zero.

matplotlib is imported lazily (through :func:`rfsim.core.plots.pyplot`), so importing this
module costs nothing until a figure is drawn.

Reference: M. Okabe and K. Ito, "Color Universal Design (CUD): how to make figures and
presentations that are friendly to colorblind people", 2008 (the palette below).
"""

from __future__ import annotations

import contextlib
import textwrap
from collections.abc import Iterator

import numpy as np

from rfsim.core.plots import pyplot

#: Figure widths [in] of a two-column paper (IEEE: 3.5 in one column, 7.16 in both).
COLUMN_WIDTH_IN = {1: 3.5, 2: 7.16}
#: Default height [in] of one row of axes, per figure width in columns.
ROW_HEIGHT_IN = {1: 2.4, 2: 2.6}

#: Okabe & Ito's colour-blind-safe palette without black (reserved for published values),
#: yellow last (low contrast on white).
OKABE_ITO = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#56B4E9", "#E69F00", "#F0E442")
#: Line styles combined with the colours (7 distinct patterns).
LINE_STYLES = ("-", "--", ":", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 1)), (0, (6, 2)))
#: Markers combined with the colours (filled; published values use hollow ones).
MARKERS = ("o", "s", "^", "D", "v", "P", "X")

#: Keyword arguments of ``ax.plot``/``ax.errorbar`` for published (reference) values: black,
#: dashed, hollow markers, so they never look like a series of this run.
PUBLISHED = dict(color="black", linestyle="--", linewidth=1.0, marker="o", markersize=4.5,
                 markerfacecolor="none", markeredgecolor="black", markeredgewidth=1.0, zorder=3)
#: The same for ``ax.scatter`` (published points without a line).
PUBLISHED_SCATTER = dict(marker="o", s=22, facecolors="none", edgecolors="black", linewidths=1.0,
                         zorder=3)
#: Hatch and colour of cells or intervals without data (e.g. tag not powered).
NO_DATA = dict(hatch="////", facecolor="0.92", edgecolor="0.55", linewidth=0.0)


def _rc() -> dict:
    """The rcParams of the project style (see :func:`paper_style`)."""
    from cycler import cycler

    return {
        "font.family": "sans-serif",
        "font.sans-serif": ["DejaVu Sans", "Arial", "Helvetica", "Liberation Sans"],
        "font.size": 8.0,
        "axes.titlesize": 8.5,
        "axes.labelsize": 8.0,
        "xtick.labelsize": 7.0,
        "ytick.labelsize": 7.0,
        "legend.fontsize": 7.0,
        "legend.title_fontsize": 7.0,
        "figure.titlesize": 9.0,
        "mathtext.fontset": "dejavusans",
        "mathtext.default": "it",
        "axes.grid": True,
        "grid.linewidth": 0.5,
        "grid.alpha": 0.35,
        "axes.axisbelow": True,
        "axes.linewidth": 0.7,
        "axes.prop_cycle": cycler(color=OKABE_ITO) + cycler(linestyle=LINE_STYLES),
        "lines.linewidth": 1.3,
        "lines.markersize": 4.0,
        "errorbar.capsize": 2.0,
        "legend.frameon": True,
        "legend.framealpha": 0.92,
        "legend.edgecolor": "0.7",
        "legend.fancybox": False,
        "legend.borderaxespad": 0.3,
        "legend.handlelength": 2.6,
        "figure.constrained_layout.use": True,
        "figure.dpi": 100,
        "savefig.bbox": "tight",
        "savefig.pad_inches": 0.03,
        "image.cmap": "viridis",
        "pdf.fonttype": 42,  # TrueType in PDF: text stays text, editable and searchable
        "ps.fonttype": 42,
        "svg.fonttype": "path",  # the SVG looks the same without the fonts installed
    }


@contextlib.contextmanager
def paper_style() -> Iterator[None]:
    """Context in which figures are drawn in the project style (an rcParams context).

    Sans-serif fonts at paper sizes (8 pt text, 7 pt ticks and legends), mathtext in the same
    font, a light grid, constrained layout, framed legends, ``savefig`` with a tight bounding
    box, TrueType fonts in PDF. Create, draw and save the figure inside the context.

    Yields
    ------
    None
        The block runs with the style's rcParams.
    """
    plt = pyplot()
    with plt.rc_context(_rc()):
        yield


def figure(columns: int = 1, nrows: int = 1, ncols: int = 1, height_in: float | None = None, **kw):
    """A new figure ``columns`` paper columns wide (1: 3.5 in, 2: 7.16 in) and its axes.

    Parameters
    ----------
    columns : 1 or 2
        Width of the figure in paper columns.
    nrows, ncols : int
        Grid of axes (as :func:`matplotlib.pyplot.subplots`).
    height_in : float, optional
        Height [in]; default ``nrows`` times 2.4 in (one column) or 2.6 in (two columns).
    **kw
        Passed to :func:`matplotlib.pyplot.subplots` (``sharex``, ``gridspec_kw``, ...).

    Returns
    -------
    fig : matplotlib.figure.Figure
        The figure, laid out by the constrained layout engine.
    axes : matplotlib.axes.Axes or ndarray of Axes
        As :func:`matplotlib.pyplot.subplots` returns them (one Axes or an array of them).

    Raises
    ------
    ValueError
        If ``columns`` is not 1 or 2.
    """
    if columns not in COLUMN_WIDTH_IN:
        raise ValueError(f"columns must be 1 or 2, not {columns!r}")
    width = COLUMN_WIDTH_IN[columns]
    height = nrows * ROW_HEIGHT_IN[columns] if height_in is None else float(height_in)
    kw.setdefault("layout", "constrained")
    return pyplot().subplots(nrows, ncols, figsize=(width, height), **kw)


def series_style(i: int) -> dict:
    """Keyword arguments of ``ax.plot``/``ax.errorbar`` for the ``i``-th series of a figure.

    A colour of the colour-blind-safe cycle, a line style and a marker, all three changing
    from one series to the next (7 distinct combinations, then the cycle repeats with the
    line styles and markers shifted, so the first 49 series are all distinct).

    Parameters
    ----------
    i : int
        Index of the series.

    Returns
    -------
    dict
        ``color``, ``linestyle``, ``marker``.
    """
    n = len(OKABE_ITO)
    shift = (i // n) % n
    return dict(color=OKABE_ITO[i % n], linestyle=LINE_STYLES[(i + shift) % len(LINE_STYLES)],
                marker=MARKERS[(i + 2 * shift) % len(MARKERS)])


def published_label(source: str) -> str:
    """Legend label of published values: ``published (<source>)``.

    Parameters
    ----------
    source : str
        The source, e.g. ``"AURIS Fig. 3.8"``.

    Returns
    -------
    str
        E.g. ``"published (AURIS Fig. 3.8)"``.
    """
    return f"published ({source})"


def source_note(ax_or_fig, text: str, *, fontsize: float = 6.5):
    """A small caption line naming what the figure reproduces and the run's size.

    E.g. ``"after AURIS Fig. 3.16 · reduced default run: 64 trials per cell"``. Under an axes
    the line sits below its x label; under a figure it is the figure's bottom line (placed by
    the constrained layout, so it stays on the canvas).

    Parameters
    ----------
    ax_or_fig : matplotlib.axes.Axes or matplotlib.figure.Figure
        Where the line goes (a figure or subfigure: its bottom line).
    text : str
        The caption (wrapped to the width).
    fontsize : float
        Font size [pt].

    Returns
    -------
    matplotlib.text.Text
        The text artist.
    """
    from matplotlib.figure import Figure, SubFigure

    fig = ax_or_fig if isinstance(ax_or_fig, (Figure, SubFigure)) else ax_or_fig.figure
    # wrapped to the figure's width (a character is about 0.6 font sizes wide); under an
    # axes, to its share of the width at creation
    share = 1.0 if fig is ax_or_fig else max(0.3, ax_or_fig.get_position().width)
    width_chars = max(20, int(share * fig.get_figwidth() * 72 / (0.6 * fontsize)) - 4)
    text = textwrap.fill(text, width_chars)
    if fig is ax_or_fig:
        existing = fig.get_supxlabel() if hasattr(fig, "get_supxlabel") else ""
        label = f"{existing}\n{text}" if existing else text
        return fig.supxlabel(label, fontsize=fontsize, color="0.3", x=0.01, ha="left",
                             fontstyle="italic")
    ax = ax_or_fig
    return ax.annotate(text, xy=(0.0, 0.0), xycoords=_below_xlabel(ax), xytext=(0, -2),
                       textcoords="offset points", ha="left", va="top", fontsize=fontsize,
                       color="0.3", fontstyle="italic", annotation_clip=False)


def _below_xlabel(ax):
    """A coordinate function for annotations: x in axes fraction, y at the bottom of the
    axes' x label and tick labels (in display pixels), evaluated at draw time."""

    def where(renderer):
        from matplotlib.transforms import Bbox

        box = ax.get_window_extent(renderer)
        bottom = box.y0
        for artist in (ax.xaxis,):
            ext = artist.get_tightbbox(renderer)
            if ext is not None and np.isfinite(ext.y0):
                bottom = min(bottom, ext.y0)
        return Bbox.from_extents(box.x0, bottom, box.x1, bottom)

    return where


def legend_outside(ax, where: str = "right", **kw):
    """A legend off the data.

    To the right of ``ax`` (``where="right"``, the default), under ``ax`` below its x label
    (``where="below"``, entries in columns), or one legend for the whole figure to the right of
    all its axes (``where="figure"``; the bottom of the figure is kept for its
    :func:`source_note`). The figure's constrained layout makes room for it.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    where : {"right", "below", "figure"}
        Placement.
    **kw
        Passed to :meth:`~matplotlib.axes.Axes.legend` (``handles``, ``labels``, ``ncols``,
        ``title``...).

    Returns
    -------
    matplotlib.legend.Legend
        The legend.
    """
    if where == "right":
        kw.setdefault("loc", "upper left")
        kw.setdefault("bbox_to_anchor", (1.02, 1.0))
        kw.setdefault("borderaxespad", 0.0)
        return ax.legend(*_handles_labels(ax, kw), **kw)
    if where == "below":
        from matplotlib.transforms import ScaledTranslation

        fig = ax.figure
        # the x axis' tick labels and label have a height independent of the axes' size:
        # measured now, the offset holds after the layout engine resizes the axes
        renderer = fig.canvas.get_renderer()
        axis_box = ax.xaxis.get_tightbbox(renderer)
        depth_in = 0.0 if axis_box is None else max(0.0, ax.bbox.y0 - axis_box.y0) / fig.dpi
        kw.setdefault("loc", "upper center")
        kw.setdefault("bbox_to_anchor", (0.5, 0.0))
        kw.setdefault("bbox_transform", ax.transAxes + ScaledTranslation(0, -depth_in - 0.04,
                                                                         fig.dpi_scale_trans))
        kw.setdefault("borderaxespad", 0.0)
        handles, labels = _handles_labels(ax, kw)
        kw.setdefault("ncols", min(3, max(1, len(handles))))
        return ax.legend(handles, labels, **kw)
    if where == "figure":
        handles, labels = _handles_labels(ax, kw)
        kw.setdefault("loc", "outside right center")
        return ax.figure.legend(handles, labels, **kw)
    raise ValueError(f"where must be 'right', 'below' or 'figure', not {where!r}")


def _handles_labels(ax, kw: dict) -> tuple[list, list]:
    """The ``handles`` and ``labels`` popped from ``kw``, by default those of ``ax``."""
    handles, labels = kw.pop("handles", None), kw.pop("labels", None)
    if handles is None:
        return ax.get_legend_handles_labels()
    return list(handles), [h.get_label() for h in handles] if labels is None else list(labels)


def _edges(centres) -> np.ndarray:
    """Cell edges of cells centred at ``centres`` (1-D, sorted): midpoints between centres,
    the outer edges half a spacing beyond the first and last centre."""
    c = np.asarray(centres, dtype=float)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = (c[1:] + c[:-1]) / 2
    return np.concatenate(([c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]))


def mask_no_data(ax, x, y, mask, *, label: str = "no data", **style):
    """Cover the cells of a heat map that have no data with a hatched grey patch.

    Parameters
    ----------
    ax : Axes
        The heat map's axes.
    x, y : (nx,), (ny,) array
        Cell centres along the x and y axes (regularly or irregularly spaced, sorted).
    mask : (ny, nx) bool array
        True where the cell has no data (e.g. tag not powered). Draw the heat map itself
        with these cells set to NaN (``np.where(mask, np.nan, z)``), so they are not given a
        colour.
    label : str
        Legend label of the hatched patch (e.g. ``"tag not powered"``).
    **style
        Overrides of :data:`NO_DATA` (``hatch``, ``facecolor``, ``edgecolor``).

    Returns
    -------
    matplotlib.patches.Patch or None
        A patch for the legend (label ``label``), or None when no cell is masked.

    Raises
    ------
    ValueError
        If ``mask`` is not of shape (len(y), len(x)).
    """
    from matplotlib.patches import Patch, Rectangle

    mask = np.asarray(mask, dtype=bool)
    xe, ye = _edges(x), _edges(y)
    if mask.shape != (ye.size - 1, xe.size - 1):
        raise ValueError(f"mask shape {mask.shape} is not (len(y), len(x)) = {(ye.size - 1, xe.size - 1)}")
    st = {**NO_DATA, **style}
    for j, i in zip(*np.nonzero(mask)):
        ax.add_patch(Rectangle((xe[i], ye[j]), xe[i + 1] - xe[i], ye[j + 1] - ye[j], zorder=2,
                               **st))
    if not mask.any():
        return None
    return Patch(label=label, **st)


def shade_no_data(ax, x, mask, *, label: str = "no data", log: bool = False, **style):
    """Hatch the x intervals of a curve where there is no data.

    Each masked point's interval reaches half-way to the neighbouring points (geometric
    half-way when ``log``).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    x : array_like
        Sorted x values of the curve.
    mask : array_like of bool
        True where there is no data.
    label : str
        Legend label of the patch.
    log : bool
        The x axis is logarithmic.
    **style
        Patch style, over :data:`NO_DATA`.

    Returns
    -------
    matplotlib.patches.Patch or None
        A legend patch, or None when nothing is masked.
    """
    from matplotlib.patches import Patch

    x = np.asarray(x, dtype=float)
    mask = np.asarray(mask, dtype=bool)
    edges = np.exp(_edges(np.log(x))) if log else _edges(x)
    st = {**NO_DATA, **style}
    for i in np.flatnonzero(mask):
        ax.axvspan(edges[i], edges[i + 1], zorder=0, **st)
    return Patch(label=label, **st) if mask.any() else None


def ci_errorbar(ax, x, p, lo, hi, *, scale: float = 1.0, **style):
    """Estimated probabilities (or rates) with their confidence interval as asymmetric error bars.

    Points where ``p`` is NaN (no trials) are not drawn.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    x : array_like
        Abscissae.
    p : array_like
        Estimates [1].
    lo, hi : array_like
        Confidence interval [1].
    scale : float
        Factor applied to p, lo, hi (100 for percent).
    **style
        Passed to :meth:`~matplotlib.axes.Axes.errorbar` (e.g. ``**series_style(i)``,
        ``label``).

    Returns
    -------
    matplotlib.container.ErrorbarContainer
        The error bars.
    """
    x = np.asarray(x, dtype=float)
    p, lo, hi = (scale * np.asarray(v, dtype=float) for v in (p, lo, hi))
    ok = np.isfinite(p)
    err = np.vstack([np.clip(p - lo, 0, None), np.clip(hi - p, 0, None)])
    err[:, ~ok] = 0.0
    style.setdefault("capsize", 2.0)
    style.setdefault("elinewidth", 0.8)
    return ax.errorbar(x[ok], p[ok], yerr=err[:, ok], **style)


def dodge(x, i: int, n: int, *, width: float, log: bool = False) -> np.ndarray:
    """``x`` shifted for the ``i``-th of ``n`` series drawn at the same x values, so their error bars do not overlap.

    Offsets spread over ``width`` centred on ``x``.

    Parameters
    ----------
    x : array_like
        Abscissae.
    i : int
        Index of the series.
    n : int
        Number of series.
    width : float
        Spread (data units; a factor when ``log``).
    log : bool
        Multiplicative offsets for a log axis.

    Returns
    -------
    numpy.ndarray
        Shifted abscissae.
    """
    x = np.asarray(x, dtype=float)
    off = 0.0 if n <= 1 else (i - (n - 1) / 2) * width / n
    return x * np.exp(off) if log else x + off


__all__ = ["COLUMN_WIDTH_IN", "OKABE_ITO", "LINE_STYLES", "MARKERS", "PUBLISHED",
           "PUBLISHED_SCATTER", "NO_DATA", "paper_style", "figure", "series_style",
           "published_label", "source_note", "legend_outside", "mask_no_data", "shade_no_data",
           "ci_errorbar", "dodge"]

"""Figure helpers shared by the scenarios: headless matplotlib, one way to save.

matplotlib is imported lazily (only when a figure is drawn) with the non-interactive Agg
backend, so the core and the tests stay headless.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path

from rfsim.core.errors import UserError
from rfsim.core.outputs import atomic_path


def pyplot():
    """Import ``matplotlib.pyplot`` on the non-interactive Agg backend.

    Returns
    -------
    module
        ``matplotlib.pyplot``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure_path(dataset_path: str | Path, out_dir: str | Path, what: str) -> Path:
    """Path of figure ``what`` of a dataset: ``<out_dir>/<dataset stem>-<what>.png``.

    Figures are named after the dataset, so ``rfsim run … -o x.h5`` writes ``x-*.png`` and
    never overwrites the figures of another run in the same folder.

    Parameters
    ----------
    dataset_path : str or pathlib.Path
        The dataset file; only its stem is used.
    out_dir : str or pathlib.Path
        Folder of the figures.
    what : str
        Name of the figure, e.g. ``"cdf"``.

    Returns
    -------
    pathlib.Path
        The figure's path (``.png``; :func:`save_figure` replaces the suffix by each format).
    """
    return Path(out_dir) / f"{Path(dataset_path).stem}-{what}.png"


#: Formats ``--format`` accepts (matplotlib writers that need nothing beyond matplotlib).
FIGURE_FORMATS = ("png", "pdf", "svg", "eps")
#: Resolution [dots per inch] of raster figures when neither the user nor the figure sets one.
DEFAULT_DPI = 120


@dataclass(frozen=True)
class FigureOutput:
    """What :func:`save_figure` writes: one file per format, at a resolution for raster formats.

    Parameters
    ----------
    formats : tuple of str, default ("png",)
        Formats among :data:`FIGURE_FORMATS`, one file each; the first is the path
        :func:`save_figure` returns.
    dpi : int or None, default None
        Resolution of raster formats [dots per inch], in [20, 2400]; None: the figure's own
        choice, else :data:`DEFAULT_DPI`.

    Raises
    ------
    rfsim.core.errors.UserError
        If ``formats`` is empty or names an unknown format, or ``dpi`` is out of range.
    """

    formats: tuple[str, ...] = ("png",)
    dpi: int | None = None

    def __post_init__(self):
        if not self.formats:
            raise UserError("--format: give at least one of " + ", ".join(FIGURE_FORMATS))
        bad = [f for f in self.formats if f not in FIGURE_FORMATS]
        if bad:
            raise UserError(f"--format {bad[0]!r}: expected a comma-separated list of "
                            + ", ".join(FIGURE_FORMATS))
        if self.dpi is not None and not 20 <= self.dpi <= 2400:
            raise UserError(f"--dpi {self.dpi}: expected an integer in [20, 2400]")

    @classmethod
    def parse(cls, formats: str = "png", dpi: int | None = None) -> "FigureOutput":
        """Make the output of the command line's ``--format png,pdf,svg`` and ``--dpi N``.

        Parameters
        ----------
        formats : str, default "png"
            Comma-separated formats (case-insensitive, a leading dot allowed, repeats dropped).
        dpi : int or None, default None
            Resolution of raster formats [dots per inch], or None.

        Returns
        -------
        FigureOutput
            The output.

        Raises
        ------
        rfsim.core.errors.UserError
            For an unknown format, no format, or a resolution outside [20, 2400].
        """
        names = [f.strip().lower().lstrip(".") for f in formats.split(",") if f.strip()]
        return cls(tuple(dict.fromkeys(names)), dpi)

    def paths(self, path: str | Path) -> list[Path]:
        """Files a figure meant for ``path`` is written to, one per format.

        Parameters
        ----------
        path : str or pathlib.Path
            The figure's path; its suffix is replaced.

        Returns
        -------
        list of pathlib.Path
            ``path`` with each format's suffix, in the order of ``formats``.
        """
        path = Path(path)
        return [path.with_suffix(f".{fmt}") for fmt in self.formats]


_OUTPUT: ContextVar[FigureOutput] = ContextVar("figure_output", default=FigureOutput())


@contextlib.contextmanager
def figure_output(output: FigureOutput) -> Iterator[FigureOutput]:
    """Make :func:`save_figure` write the formats and resolution of ``output`` within the block.

    E.g. ``rfsim run … --format png,pdf --dpi 300``: a scenario's ``plot`` needs no argument
    for it.

    Parameters
    ----------
    output : FigureOutput
        The formats and resolution in effect in the block.

    Yields
    ------
    FigureOutput
        ``output``; the previous output is restored when the block ends.
    """
    token = _OUTPUT.set(output)
    try:
        yield output
    finally:
        _OUTPUT.reset(token)


def current_figure_output() -> FigureOutput:
    """The :class:`FigureOutput` in effect.

    Returns
    -------
    FigureOutput
        The one set by the innermost :func:`figure_output` block, else the default (PNG only,
        the figure's own resolution).
    """
    return _OUTPUT.get()


def save_figure(fig, path: Path, *, dpi: int | None = None, tight: bool = True) -> Path:
    """Lay out a figure, write it in every format in effect and close it.

    The figure is laid out with ``tight_layout`` unless ``tight`` is False (e.g. with a shared
    colorbar) or it has a layout engine of its own. ``path``'s suffix is replaced by each
    format of the :func:`figure_output` in effect (default PNG only), one file each, and the
    folder is created. The resolution is the output's ``dpi`` if the user set one, else
    ``dpi``, else :data:`DEFAULT_DPI`.

    Each file is written under a hidden temporary name and renamed over its path, so a failed
    write leaves the previous figure, if any, intact.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; closed in any case.
    path : pathlib.Path
        Where the figure goes (the suffix is replaced by each format's).
    dpi : int or None, default None
        The figure's own resolution [dots per inch], used when the user set none.
    tight : bool, default True
        Whether to call ``tight_layout`` first.

    Returns
    -------
    pathlib.Path
        The file of the first format.

    Raises
    ------
    rfsim.core.errors.ResourceError
        If a file cannot be written (e.g. disk full), in one line.
    """
    output = _OUTPUT.get()
    if tight and not _has_layout_engine(fig):
        fig.tight_layout()
    resolution = output.dpi or dpi or DEFAULT_DPI
    paths = output.paths(path)
    paths[0].parent.mkdir(parents=True, exist_ok=True)
    try:
        for target, fmt in zip(paths, output.formats):
            with atomic_path(target, f"the figure {str(target)!r}") as tmp:
                fig.savefig(tmp, dpi=resolution, format=fmt)
    finally:
        pyplot().close(fig)
    return paths[0]


def _has_layout_engine(fig) -> bool:
    """Whether ``fig`` is laid out by an engine of its own (e.g. the constrained layout of
    :func:`rfsim.core.figure_style.figure`), which ``tight_layout`` must not override."""
    get = getattr(fig, "get_layout_engine", None)
    return get is not None and get() is not None


__all__ = ["pyplot", "save_figure", "figure_path", "FigureOutput", "FIGURE_FORMATS", "DEFAULT_DPI",
           "figure_output", "current_figure_output"]


# --- generic figure pieces ------------------------------------------------------------------


def step_cdf(ax, values, *, label: str | None = None) -> None:
    """Draw the empirical CDF of ``values`` on ``ax`` as a step.

    The CDF is k/n at the k-th smallest value (steps ``where="post"``); nothing is drawn when
    ``values`` is empty.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on.
    values : iterable of float
        The samples (any order).
    label : str or None, default None
        Legend label of the step.
    """
    v = sorted(float(x) for x in values)
    if v:
        ax.step(v, [(k + 1) / len(v) for k in range(len(v))], where="post", label=label)


def grouped_bars(ax, categories, groups, *, mark_label: str | None = None) -> None:
    """Draw bars of several groups side by side per category, each with a reference mark.

    Each bar gets a black mark at a reference value (e.g. a published one; NaN draws no mark).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on.
    categories : sequence of str
        Tick labels of the categories, in order along x.
    groups : sequence of (str, sequence of float, sequence of float)
        Per group: its label, its values and its reference values, both in the order of
        ``categories``.
    mark_label : str or None, default None
        Legend label of the marks (given once).
    """
    n, width = len(groups), 0.8 / len(groups)
    x = list(range(len(categories)))
    for i, (label, values, marks) in enumerate(groups):
        at = [c + (i - (n - 1) / 2) * width for c in x]
        ax.bar(at, values, width * 0.9, label=label)
        ax.plot(at, marks, "_", ms=16, mew=3, color="k", label=mark_label if i == 0 else None)
    ax.set_xticks(x, categories)


__all__ += ["step_cdf", "grouped_bars"]


def draw_floor_plan(ax, bounds, *, walls=(), cells=(), readers=(), reference=()) -> None:
    """Draw a localization floor plan on ``ax``.

    The area's outline in black, walls in brown, grid cells as grey dots, readers as red
    squares and reference tags as purple triangles; an empty point set is not drawn.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on.
    bounds : sequence of float, length 4
        The area ``(xmin, ymin, xmax, ymax)`` [m].
    walls : array_like, shape (n_walls, 4), default ()
        Wall segments ``(x0, y0, x1, y1)`` [m].
    cells : ndarray, shape (n_cells, 2), default ()
        Grid cell centres [m].
    readers : ndarray, shape (n_readers, 2), default ()
        Reader positions [m].
    reference : ndarray, shape (n_reference, 2), default ()
        Reference tag positions [m].
    """
    x0, y0, x1, y1 = bounds
    ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], "k-", lw=2)
    for w in walls:
        ax.plot([w[0], w[2]], [w[1], w[3]], color="brown", lw=4, label="wall")
    for pts, style, kw in ((cells, ".", dict(color="0.6", label="grid cells")),
                           (readers, "s", dict(ms=10, color="tab:red", label="readers")),
                           (reference, "^", dict(ms=9, color="tab:purple", label="reference tags"))):
        if len(pts):
            ax.plot(pts[:, 0], pts[:, 1], style, **kw)


__all__ += ["draw_floor_plan"]


def grid_arrays(dataset, name: str) -> tuple[dict, dict]:
    """Coordinates and variables of a grid of a read dataset as NumPy arrays.

    Parameters
    ----------
    dataset : rfsim.core.dataset.Dataset
        A dataset read by :func:`rfsim.core.dataset.read_dataset`.
    name : str
        Name of the grid.

    Returns
    -------
    coords : dict of str to ndarray
        Coordinate name → values.
    variables : dict of str to ndarray
        Variable name → values.
    """
    coords, variables = dataset.grids[name]
    return {k: c.data for k, c in coords.items()}, {k: v.data for k, v in variables.items()}


def probability_errorbars(ax, x, table, names, labels=None) -> None:
    """Plot probabilities [%] with their confidence intervals as error bars.

    For each name with a column ``p_<name>`` in ``table``: 100·p against ``x``, with the
    interval ``[ci_lo_<name>, ci_hi_<name>]`` as error bars; names without the column are
    skipped.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on.
    x : array_like, shape (n,)
        Abscissae.
    table : mapping of str to ndarray
        Columns ``p_<name>``, ``ci_lo_<name>``, ``ci_hi_<name>`` (probabilities in [0, 1],
        shape (n,)).
    names : iterable of str
        The names to plot, in legend order.
    labels : mapping of str to str or None, default None
        Legend label per name (None: the name itself).
    """
    for name in names:
        if f"p_{name}" not in table:
            continue
        p = table[f"p_{name}"]
        err = [p - table[f"ci_lo_{name}"], table[f"ci_hi_{name}"] - p]
        ax.errorbar(x, 100 * p, yerr=[100 * e for e in err], marker="o", capsize=3,
                    label=name if labels is None else labels[name])


def run_config(dataset_path) -> dict:
    """Resolved config a dataset was written with, as nested dicts.

    Read from the ``config_toml`` attribute of the file's ``provenance`` group, e.g. to say on
    a figure that a run is a reduced default.

    Parameters
    ----------
    dataset_path : str or pathlib.Path
        The HDF5 dataset file.

    Returns
    -------
    dict
        The parsed TOML; ``{}`` when the file has no config.
    """
    import tomllib

    import h5py

    with h5py.File(dataset_path, "r") as f:
        text = f["provenance"].attrs.get("config_toml", "") if "provenance" in f else ""
    text = text.decode() if isinstance(text, bytes) else str(text)
    return tomllib.loads(text) if text else {}


__all__ += ["grid_arrays", "probability_errorbars", "run_config"]


def contact_sheet(images, path: Path, *, ncols: int = 4, title: str = "", cell_width_in: float = 4.2) -> Path:
    """Put figure images side by side on one page, so a reviewer sees every figure at once.

    ``ncols`` images per row in the given order, each under its caption, each keeping its
    aspect ratio inside a cell ``cell_width_in`` inches wide (a row is as tall as its tallest
    image). The page is written by :func:`save_figure` (the formats of the
    :func:`figure_output` in effect) at 150 dots per inch.

    Parameters
    ----------
    images : iterable of (str, path-like)
        (caption, PNG path) pairs.
    path : pathlib.Path
        Where the page goes.
    ncols : int, default 4
        Images per row (at most the number of images).
    title : str, default ""
        Title of the page ("" for none).
    cell_width_in : float, default 4.2
        Width of a cell [inch].

    Returns
    -------
    pathlib.Path
        The file of the first format.

    Raises
    ------
    rfsim.core.errors.UserError
        If ``images`` is empty.
    """
    plt = pyplot()
    import matplotlib.image as mpimg

    loaded = [(caption, mpimg.imread(str(p))) for caption, p in images]
    if not loaded:
        raise UserError("no figures to put on a contact sheet")
    ncols = max(1, min(ncols, len(loaded)))
    rows = [loaded[i:i + ncols] for i in range(0, len(loaded), ncols)]
    heights = [max(img.shape[0] / img.shape[1] for _, img in row) * cell_width_in + 0.3 for row in rows]
    fig = plt.figure(figsize=(ncols * cell_width_in, sum(heights) + (0.5 if title else 0.1)), layout="constrained")
    grid = fig.add_gridspec(len(rows), ncols, height_ratios=heights)
    for r, row in enumerate(rows):
        for c, (caption, img) in enumerate(row):
            ax = fig.add_subplot(grid[r, c])
            ax.imshow(img, interpolation="antialiased")
            ax.set_axis_off()
            ax.set_title(caption, fontsize=9, loc="left")
    if title:
        fig.suptitle(title, fontsize=12)
    return save_figure(fig, path, dpi=150)


__all__ += ["contact_sheet"]

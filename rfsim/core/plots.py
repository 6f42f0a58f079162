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
    """``matplotlib.pyplot`` on the Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure_path(dataset_path: str | Path, out_dir: str | Path, what: str) -> Path:
    """Where figure ``what`` of a dataset goes: ``<out_dir>/<dataset stem>-<what>.png``.

    Figures are named after the dataset, so ``rfsim run … -o x.h5`` writes ``x-*.png`` and
    never overwrites the figures of another run in the same folder.
    """
    return Path(out_dir) / f"{Path(dataset_path).stem}-{what}.png"


#: Formats ``--format`` accepts (matplotlib writers that need nothing beyond matplotlib).
FIGURE_FORMATS = ("png", "pdf", "svg", "eps")
#: Resolution [dots per inch] of raster figures when neither the user nor the figure sets one.
DEFAULT_DPI = 120


@dataclass(frozen=True)
class FigureOutput:
    """What :func:`save_figure` writes: one file per format in ``formats`` (first = the
    path returned), at ``dpi`` dots per inch for raster formats (None: the figure's own
    choice, else :data:`DEFAULT_DPI`)."""

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
        """From the command line's ``--format png,pdf,svg`` (case-insensitive, repeats
        dropped) and ``--dpi N``; unknown formats are a one-line :class:`UserError`."""
        names = [f.strip().lower().lstrip(".") for f in formats.split(",") if f.strip()]
        return cls(tuple(dict.fromkeys(names)), dpi)

    def paths(self, path: str | Path) -> list[Path]:
        """The files a figure meant for ``path`` is written to, one per format (suffix
        replaced), in the order of ``formats``."""
        path = Path(path)
        return [path.with_suffix(f".{fmt}") for fmt in self.formats]


_OUTPUT: ContextVar[FigureOutput] = ContextVar("figure_output", default=FigureOutput())


@contextlib.contextmanager
def figure_output(output: FigureOutput) -> Iterator[FigureOutput]:
    """Within the block, :func:`save_figure` writes the formats and resolution of ``output``
    (e.g. ``rfsim run … --format png,pdf --dpi 300``); a scenario's ``plot`` needs no
    argument for it."""
    token = _OUTPUT.set(output)
    try:
        yield output
    finally:
        _OUTPUT.reset(token)


def current_figure_output() -> FigureOutput:
    """The :class:`FigureOutput` in effect (the default: PNG only)."""
    return _OUTPUT.get()


def save_figure(fig, path: Path, *, dpi: int | None = None, tight: bool = True) -> Path:
    """Lay out (unless ``tight`` is False, e.g. with a shared colorbar, or the figure has a
    layout engine of its own), write ``fig`` to ``path`` (creating its folder) and close it.

    ``path``'s suffix is replaced by each format of the :func:`figure_output` in effect
    (default PNG only), one file each; the first is returned. The resolution is the
    output's ``dpi`` if the user set one, else ``dpi``, else :data:`DEFAULT_DPI`.

    Each file is written under a hidden temporary name and renamed over its path, so a
    failed write (disk full: a one-line :class:`~rfsim.core.errors.ResourceError`) leaves
    the previous figure, if any, intact."""
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
    """Draw the empirical CDF of ``values`` on ``ax`` as a step (k/n at the k-th smallest value);
    nothing when ``values`` is empty."""
    v = sorted(float(x) for x in values)
    if v:
        ax.step(v, [(k + 1) / len(v) for k in range(len(v))], where="post", label=label)


def grouped_bars(ax, categories, groups, *, mark_label: str | None = None) -> None:
    """Bars of several groups side by side per category, each bar with a black mark at a
    reference value (e.g. a published one; NaN draws no mark).

    ``groups``: (label, values, reference values) per group, values in the order of
    ``categories``; ``mark_label`` labels the marks once in the legend.
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
    """A localization floor plan on ``ax``: the area's outline ``bounds`` (xmin, ymin, xmax, ymax)
    [m], walls (n, 4) (x0, y0, x1, y1) [m] in brown, grid cells as grey dots, readers as red
    squares, reference tags as purple triangles (point sets (n, 2) arrays [m]; empty: not drawn)."""
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
    """Coordinates and variables of grid ``name`` of a read dataset (:func:`rfsim.core.dataset.read_dataset`)
    as two dicts of NumPy arrays."""
    coords, variables = dataset.grids[name]
    return {k: c.data for k, c in coords.items()}, {k: v.data for k, v in variables.items()}


def probability_errorbars(ax, x, table, names, labels=None) -> None:
    """For each name with a column ``p_<name>`` in ``table``: 100·p against ``x`` with the interval
    ``[ci_lo_<name>, ci_hi_<name>]`` as error bars [%], labelled ``labels[name]`` (default the name)."""
    for name in names:
        if f"p_{name}" not in table:
            continue
        p = table[f"p_{name}"]
        err = [p - table[f"ci_lo_{name}"], table[f"ci_hi_{name}"] - p]
        ax.errorbar(x, 100 * p, yerr=[100 * e for e in err], marker="o", capsize=3,
                    label=name if labels is None else labels[name])


def run_config(dataset_path) -> dict:
    """The resolved config a dataset was written with (its ``provenance`` group's
    ``config_toml``) as nested dicts, e.g. to say on a figure that a run is a reduced
    default; ``{}`` when the file has none."""
    import tomllib

    import h5py

    with h5py.File(dataset_path, "r") as f:
        text = f["provenance"].attrs.get("config_toml", "") if "provenance" in f else ""
    text = text.decode() if isinstance(text, bytes) else str(text)
    return tomllib.loads(text) if text else {}


__all__ += ["grid_arrays", "probability_errorbars", "run_config"]


def contact_sheet(images, path: Path, *, ncols: int = 4, title: str = "", cell_width_in: float = 4.2) -> Path:
    """One page with the figure images ``images`` ((caption, PNG path) pairs) side by side,
    ``ncols`` per row in the given order, each under its caption, so a reviewer sees every
    figure at once; written by :func:`save_figure` (the formats of the
    :func:`figure_output` in effect) to ``path`` and returned.

    Each image keeps its aspect ratio inside a cell ``cell_width_in`` inches wide; a row is as
    tall as its tallest image.
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

"""Figures of the ``exciter-link`` scenario (:mod:`rfsim.scenarios.exciter_link`), drawn from its dataset alone.

The scenario module composes and runs; this module only draws (``plot`` is called through
the scenario's ``plot``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rfsim.core.lazy import lazy_import
from rfsim.core.figure_style import (OKABE_ITO, ci_errorbar, figure, legend_outside, mask_no_data,
                                     paper_style, series_style, source_note)
from rfsim.core.plots import figure_path, save_figure
from rfsim.core.references import cite

sa = lazy_import("rfsim.devices.st_analytic")


# ----------------------------------------------------------------------------- plot


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Draw the figures; see :func:`rfsim.scenarios.exciter_link.plot`."""
    from matplotlib.lines import Line2D

    from rfsim.core.dataset import read_dataset, read_table

    ds = read_dataset(dataset_path)
    coords, vars_ = ds.grids["points"]
    d_e, d_tt = coords["exciter_distance_m"].data, coords["tag_distance_m"].data
    p = vars_["p_decoded"].data
    lo, hi = vars_["ci_lo"].data, vars_["ci_hi"].data
    draws = vars_["draws"].data
    unpowered = vars_["tag_replied_fraction"].data == 0
    rows = read_table(dataset_path, "eq65_rows")
    a = ds.attrs
    with paper_style():
        fig, (ax, ax2) = figure(columns=2, ncols=2, height_in=3.0, width_ratios=(1.25, 1.0))
        im = ax.pcolormesh(d_e, d_tt, 100 * np.where(unpowered, np.nan, p).T, shading="nearest",
                           cmap="viridis", vmin=0.0, vmax=100.0)
        fig.colorbar(im, ax=ax, label=r"decode probability $P_\mathrm{dec}$ [%]")
        hatch = mask_no_data(ax, d_e, d_tt, unpowered.T, label="tag not powered (no reply)")
        ok = rows["d50_in_range"]
        if ok.any():
            ax.errorbar(rows["exciter_distance_m"][ok], rows["d50_m"][ok], yerr=rows["d50_stderr_m"][ok],
                        color="white", marker="o", ms=3.5, mec="black", mew=0.6, capsize=2, lw=1.2,
                        ecolor="white", label=r"50 % point of Eq. (6.5) per $d_\mathrm{e}$ ($\pm$1 s.e.)")
        if a.get("eq65_extended_status") == "ok":
            x = d_e[rows["tag_runs"]]
            line = -(a["eq65_extended_a1"] + a["eq65_extended_a3"] * x) / a["eq65_extended_a2"]
            ax.plot(x, line, color=OKABE_ITO[1], ls="--", lw=1.4,
                    label=r"50 % line of Eq. (6.5) + $a_3 d_\mathrm{e}$ (pooled)")
        ax.set(xlabel=r"exciter–tag distance $d_\mathrm{e}$ [m]",
               ylabel=r"tag–listener distance $d_\mathrm{tt}$ [m]",
               xticks=d_e[::2], yticks=_spaced(d_tt, 0.1 * np.ptp(d_tt)),
               title="decode probability over the grid")
        ax.grid(False)
        picks = _curve_rows(d_e, unpowered)
        for i, k in enumerate(picks):
            ci_errorbar(ax2, d_tt, p[k], lo[k], hi[k], scale=100.0, ms=3.5,
                        label=rf"$d_\mathrm{{e}}$ = {d_e[k]:g} m", **series_style(i))
            r = np.flatnonzero(np.isclose(rows["exciter_distance_m"], d_e[k]))
            if r.size and np.isfinite(rows["a1"][r[0]]):
                x = np.linspace(d_tt.min(), d_tt.max(), 100)
                fit = 100 / (1 + np.exp(rows["a1"][r[0]] + rows["a2"][r[0]] * x))
                ax2.plot(x, fit, color=series_style(i)["color"], lw=0.8, alpha=0.8)
        ax2.set(xlabel=r"tag–listener distance $d_\mathrm{tt}$ [m]",
                ylabel=r"$P_\mathrm{dec}$ [%] (Clopper-Pearson 95 %)", ylim=(-3, 103),
                title=r"$P_\mathrm{dec}$ at three $d_\mathrm{e}$")
        handles, labels = ax.get_legend_handles_labels()
        legend_outside(ax, where="below", handles=handles + ([hatch] if hatch is not None else []),
                       ncols=1)
        handles, labels = ax2.get_legend_handles_labels()
        legend_outside(ax2, handles=handles + [Line2D([], [], color="0.4", lw=0.8, label="Eq. (6.5) fit of the row")])
        fig.suptitle(f"Exciter-powered tag-to-tag link, Eq. (6.5) fit — {cite('geng', 'Ch. 6')}")
        source_note(fig, f"{int(np.median(draws))} channel draws per (" + r"$d_\mathrm{e}$, $d_\mathrm{tt}$) point, "
                         f"{d_e.size} × {d_tt.size} points")
        return [save_figure(fig, figure_path(dataset_path, out_dir, "heatmap"))]


def _spaced(values, gap: float) -> list[float]:
    """Ticks at the cell centres ``values`` (sorted) with at least ``gap`` between neighbours
    (the first kept), so tick labels of close cells do not overlap."""
    kept = [values[0]]
    for v in values[1:]:
        if v - kept[-1] >= gap:
            kept.append(v)
    return kept


def _curve_rows(d_e, unpowered) -> list[int]:
    """Indices of up to three exciter distances for the curves: the nearest, the farthest at
    which the tag is powered somewhere, and one half-way (in index) between."""
    powered = np.flatnonzero(~unpowered.all(axis=1))
    if powered.size == 0:
        return [0]
    first, last = int(powered[0]), int(powered[-1])
    return sorted({first, (first + last) // 2, last})


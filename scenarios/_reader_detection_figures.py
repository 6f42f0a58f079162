"""Figures of the ``reader-detection`` scenario (:mod:`rfsim.scenarios.reader_detection`), drawn from its dataset alone.

The scenario module composes and runs; this module only draws (``plot`` is called through
the scenario's ``plot``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rfsim.core.figure_style import (PUBLISHED, ci_errorbar, figure, legend_outside, mask_no_data, paper_style,
                                     published_label, series_style, source_note)
from rfsim.core.plots import figure_path, run_config, save_figure
from rfsim.core.references import cite


def plot(dataset_path: Path, out_dir: Path, *, d50_angles_deg: tuple[float, ...],
         room_names: tuple[str, ...]) -> list[Path]:
    """Draw the figures (d50 at ``d50_angles_deg`` [°], rooms named ``room_names``); see
    :func:`rfsim.scenarios.reader_detection.plot`."""
    from matplotlib.lines import Line2D
    from scipy import stats

    from rfsim.core.dataset import read_dataset, read_table
    from rfsim.detection import ReaderDetectionModel

    ds = read_dataset(dataset_path)
    coords, vars_ = ds.grids["cells"]
    d, a = coords["distance_m"].data, coords["theta_deg"].data
    trials = read_table(dataset_path, "trials")
    camp = run_config(dataset_path).get("campaign", {})
    reps, queries = int(np.max(trials["repetition"]) + 1), int(np.median(trials["n_queries"]))
    size = f"{d.size} distances × {a.size} angles × {reps} repetitions × {queries} queries per room"
    if not camp.get("full", True):
        size = f"reduced default campaign: {size} (the source's size: campaign.full = true)"
    with paper_style():
        fig, axs = figure(columns=2, ncols=2, sharey=True, height_in=3.0)
        for k, ax in enumerate(axs):
            p = 100 * vars_["p_mean"].data[k]
            im = ax.pcolormesh(a, d, np.where(np.isfinite(p), p, np.nan), shading="nearest", vmin=0, vmax=100,
                               cmap="viridis")
            hatch = mask_no_data(ax, a, d, ~np.isfinite(p), label="no trials")
            ax.set(xlabel=r"angle off boresight $\theta$ [°]", title=f"room {k} ({room_names[k]})",
                   xticks=a, yticks=d)
            ax.grid(False)
            if hatch is not None:
                legend_outside(ax, where="below", handles=[hatch])
        axs[0].set_ylabel("distance $d$ [m]")
        fig.colorbar(im, ax=axs, label=r"mean detection probability $\bar{p}$ [%]", shrink=0.95)
        fig.suptitle(f"Reader detection probability per cell, replica of {cite('geng', 'campaign A')}")
        source_note(fig, f"cell = mean of p̂ = reads/queries over the repetitions; {size}")
        p1 = save_figure(fig, figure_path(dataset_path, out_dir, "heatmap"))

        fits = read_table(dataset_path, "fits") if "fits" in ds.tables else None
        fig, ax = figure(columns=2, height_in=3.4)
        x = np.linspace(0.0, max(10.0, float(d.max())), 200)
        handles, drawn = [], set()
        for j, ang in enumerate(d50_angles_deg):
            style = series_style(j)
            sel = np.abs(np.abs(trials["theta_deg"]) - ang) < 1e-9
            handles.append(Line2D([], [], **style, label=f"|θ| = {ang:g}°"))
            if sel.any():
                ds_ = np.unique(trials["distance_m"][sel])
                groups = [trials["p_hat"][sel & (trials["distance_m"] == v)] for v in ds_]
                mean = np.array([g.mean() for g in groups])
                half = np.array([stats.t.ppf(0.975, g.size - 1) * g.std(ddof=1) / np.sqrt(g.size) if g.size > 1
                                 else np.nan for g in groups])
                ci_errorbar(ax, ds_, mean, np.clip(mean - half, 0, 1), np.clip(mean + half, 0, 1), scale=100.0,
                            **{**style, "linestyle": "none"})
                drawn.add("trials")
            if fits is None:
                continue
            for i, m in enumerate(fits["method"]):
                if not np.isfinite(fits["a1"][i]) or m == "moments":
                    continue
                model = ReaderDetectionModel(mean_coefficients=(fits["a1"][i], fits["a2"][i], fits["a3"][i]))
                if m == "published":
                    ax.plot(x, 100 * model.mean(x, ang), markevery=20, **{**PUBLISHED, "marker": style["marker"]})
                else:
                    ax.plot(x, 100 * model.mean(x, ang), color=style["color"], ls=style["linestyle"], lw=1.2)
                drawn.add(m)
        if "trials" in drawn:
            handles.append(Line2D([], [], ls="none", marker="o", color="0.3",
                                  label="mean p̂ of the trials,\nboth rooms (t 95 %)"))
        handles += [Line2D([], [], color="0.3", lw=1.2, label=f"{m.upper()} mean model fit")
                    for m in sorted(drawn - {"trials", "published"})]
        if "published" in drawn:
            handles.append(Line2D([], [], **PUBLISHED, label=published_label("Geng 2015") + ",\nmean model"))
        ax.set(xlabel="distance $d$ [m]", ylabel="detection probability [%]", ylim=(-2, 102))
        legend_outside(ax, handles=handles)
        ax.set_title(f"Reader detection vs distance, rooms pooled ({cite('geng', 'campaign A')})")
        source_note(ax, "The mean model is linear in |θ|: at 60° the cells fall faster than it can follow (the "
                        "assumed 70° patch beam gives −10.2 dB at 60°; the published d50 of 1.30 m implies a "
                        f"58.6° beam). {size}.")
        return [p1, save_figure(fig, figure_path(dataset_path, out_dir, "mean"))]

"""Figures of the ``st-to-st`` scenario (:mod:`rfsim.scenarios.st_to_st`), drawn from its dataset alone.

The scenario module composes and runs; this module only draws (``plot`` is called through
the scenario's ``plot``).
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from rfsim.core.references import cite
from rfsim.core.figure_style import ci_errorbar, dodge, figure, legend_outside, paper_style, series_style
from rfsim.core.plots import figure_path, save_figure
from rfsim.scenarios._captions import caption
from rfsim.core.lazy import lazy_import

sa = lazy_import("rfsim.devices.st_analytic")



# ----------------------------------------------------------------------------- plot


def plot(dataset_path: Path, out_dir: Path, *, techniques: tuple[str, ...]) -> list[Path]:
    """Draw the figures of ``techniques`` (in legend order); see :func:`rfsim.scenarios.st_to_st.plot`."""
    from rfsim.core.dataset import read_dataset, read_provenance, read_table

    cells = read_table(dataset_path, "cells")
    attrs = read_dataset(dataset_path).attrs
    mc = tomllib.loads(read_provenance(dataset_path).get("config_toml", "")).get("mc", {})
    x = cells["tx_x_m"]
    step = float(np.min(np.diff(np.unique(x)))) if np.unique(x).size > 1 else 1.0
    with paper_style():
        fig, ax = figure(columns=1, height_in=3.3)
        for i, t in enumerate(techniques):
            if f"p_{t}" not in cells:
                continue
            lo, hi = attrs.get(f"overall_ci_{t}", (np.nan, np.nan))
            ci_errorbar(ax, dodge(x, i, len(techniques), width=0.6 * step), cells[f"p_{t}"], cells[f"ci_lo_{t}"],
                        cells[f"ci_hi_{t}"], scale=100.0, markersize=3.5, linewidth=1.0, **series_style(i),
                        label=f"{t} {100 * attrs[f'overall_p_{t}']:.1f} [{100 * lo:.1f}, {100 * hi:.1f}]")
        ax.set(xlabel="transmitting ST position $x$ [m] (exciter at the origin)",
               ylabel="$P_\\mathrm{cancel}$ [%]", title="Phase cancellation on the ST-to-ST link")
        ax.set_ylim(bottom=-1.0)
        legend_outside(ax, where="below", ncols=2, title="technique, overall $P_\\mathrm{cancel}$ [%] (95 % CI)",
                       columnspacing=1.0)
        n = int(np.median(cells["n_samples"]))
        size = (f"{n} receiving positions per distance, {int(cells['n_samples'].sum())} in all"
                + ("" if mc.get("full", True) else " (reduced default run; mc.full = true runs the full size)"))
        caption(fig, f"After {cite('auris', 'Fig. 5.8')}.", f"{size}.",
                "Bars: Clopper-Pearson 95 % intervals, techniques side by side at each distance.")
        return [save_figure(fig, figure_path(dataset_path, out_dir, "pcancel"))]



"""Figures of the ``access`` scenario (:mod:`rfsim.scenarios.access`), drawn from its dataset alone.

The scenario module composes and runs; this module only draws (``plot`` is called through the
scenario's ``plot``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rfsim.core.figure_style import OKABE_ITO, ci_errorbar, figure, legend_outside, paper_style, series_style
from rfsim.core.plots import figure_path, save_figure
from rfsim.scenarios._captions import caption

#: (rate column, legend label) of the curves, in drawing order.
CURVES = (("read", "EPC read (singulation)"), ("tid", "TID read (Read after Req_RN)"),
          ("write", "Write (success reply)"))


def plot_ranges(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Draw the rates against distance with the read and write ranges; see
    :func:`rfsim.scenarios.access.plot`."""
    from matplotlib.ticker import FixedLocator, NullFormatter

    from rfsim.core.dataset import read_dataset, read_table

    a = read_dataset(dataset_path).attrs
    t = read_table(dataset_path, "rates")
    acc = read_table(dataset_path, "accesses")
    d = t["distance_m"]
    with paper_style():
        fig, (ax, ax2) = figure(columns=2, ncols=2, height_in=3.9, width_ratios=(1.5, 1.0))
        for i, (name, label) in enumerate(CURVES):
            if np.all(t[f"{name}_successes"] == 0) and name != "read" and math.isnan(a[f"{name}_range_m"]):
                label += " (none)"
            ci_errorbar(ax, d, t[f"{name}_rate"], t[f"{name}_rate_lo"], t[f"{name}_rate_hi"], scale=100.0,
                        label=label, **series_style(i))
        for name, text, color in (("read_range_m", "read range", OKABE_ITO[0]),
                                  ("write_range_m", "write range", OKABE_ITO[2])):
            if math.isfinite(a[name]):
                ax.axvline(a[name], color=color, ls=":", lw=1.0, label=f"{text} {a[name]:.2f} m (rate 50 %)")
        if math.isfinite(a["read_range_m"]):
            friis = a["read_range_m"] * a["friis_ratio"]
            ax.axvline(friis, color="0.4", ls="--", lw=0.8,
                       label=f"Friis: read range × $10^{{-\\Delta/20}}$ = {friis:.2f} m")
            if math.isfinite(a["write_range_m"]):
                ax.axvspan(a["write_range_m"], a["read_range_m"], color=OKABE_ITO[2], alpha=0.12, lw=0,
                           label=f"read/write gap {a['range_gap_m']:.2f} m")
        ax.set(xlabel="reader–tag distance $d$ [m]", ylabel="success rate [%]", ylim=(-3, 103),
               title="success rates, Wilson 95 % intervals")
        legend_outside(ax, where="below", ncols=2)
        reads = read_table(dataset_path, "reads")
        dd, p_inc = reads["true_distance_m"], reads["true_incident_power_dbm"]
        mean = np.array([np.mean(p_inc[dd == x]) for x in d])
        ax2.plot(dd, p_inc, ls="none", marker="o", ms=3, mfc="none", mew=0.6, color=OKABE_ITO[4],
                 label="one trial (Query)")
        levels = [(a[k], text, c) for k, text, c in (("read_range_m", "read", OKABE_ITO[0]),
                                                     ("write_range_m", "write", OKABE_ITO[2])) if math.isfinite(a[k])]
        for x, text, color in levels:  # the power at a range: the mean curve, straight in log d
            p = float(np.interp(np.log(x), np.log(d), mean))
            ax2.axhline(p, color=color, ls=":", lw=1.0, label=f"at the {text} range: {p:.1f} dBm")
        ax2.set(xscale="log", xlabel="reader–tag distance $d$ [m] (log)", ylabel="$P_\\mathrm{inc}$ [dBm]",
                title="CW power incident at the tag")
        ax2.xaxis.set_major_locator(FixedLocator([x for x in (0.5, 1, 2, 4, 8, 16, 32) if d[0] <= x <= d[-1]]))
        ax2.xaxis.set_major_formatter(lambda x, pos: f"{x:g}")
        ax2.xaxis.set_minor_formatter(NullFormatter())
        legend_outside(ax2, where="below", ncols=1)
        fig.suptitle("Read range and write range of one tag")
        n = int(np.median(t["trials"]))
        errs = int(np.sum(t["write_power_errors"]))
        caption(fig, f"Program: {a['program']}. {n} trials per distance; a trial reads the EPC, then runs the "
                     f"program with T2 = {a.get('t2_tpri', 10):g} Tpri between a reply and the next command.",
                f"Write threshold Δ = {a['write_threshold_db']:.1f} dB above the read sensitivity (chip model); "
                f"{errs} Writes answered 'insufficient power' (0Bh); ranges where a rate crosses 50 %, "
                f"interpolated; measured write/read ratio {a['range_ratio']:.3f}, Friis {a['friis_ratio']:.3f}.")
        return [save_figure(fig, figure_path(dataset_path, out_dir, "ranges"))]

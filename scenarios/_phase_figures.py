"""Figures of the ``phase-tracking`` dataset, drawn from the file alone.

* ``-phase``: reported phase (first seconds) and unwrapped pseudo-range minus its first value
  vs time, per antenna (Särkkä et al. Fig. 4: smooth, no λ/2 jumps);
* ``-track``: floor plan with the antennas, the intended and true paths and the EKF / RTS /
  RSSI-only tracks (Figs. 6–8);
* ``-cdf``: CDF of the position error against the intended path per estimator and pass, and
  the RMSE per pass beside the published RMSEs.

Drawn in the project's figure style (:mod:`rfsim.core.figure_style`): an estimator keeps its
colour and marker, a pass its line style.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rfsim.core.dataset import read_table
from rfsim.core.figure_style import (OKABE_ITO, PUBLISHED, figure, legend_outside, paper_style, published_label,
                                     series_style)
from rfsim.core.lazy import lazy_import
from rfsim.core.plots import figure_path, save_figure
from rfsim.core.references import cite
from rfsim.scenarios._captions import caption

h5py = lazy_import("h5py")
_mlines = lazy_import("matplotlib.lines")

PHASE_WINDOW_S = 3.0


#: Colour and marker per estimator, line style per pass: no series told apart by colour alone.
_KIND = {"EKF": (OKABE_ITO[0], "o"), "RTS": (OKABE_ITO[1], "s"), "RSSI": (OKABE_ITO[2], "^")}
_PASS_LINE = {0: "-.", 1: "-", 2: "--", 3: ":"}
#: The source in legend entries (the captions cite it in full).
SHORT = "Särkkä et al. 2012"


def _style(name: str, k: int) -> dict:
    colour, marker = _KIND.get(name.split()[0], (OKABE_ITO[3], "D"))
    return dict(color=colour, marker=marker, linestyle=_PASS_LINE.get(int(k), "-"))


def _label(name: str, k: int) -> str:
    return name if name.startswith("RSSI") else f"{name}, pass {int(k)}"


def _key(name: str, k: int) -> str:
    return "rssi" if name.startswith("RSSI") else f"{name.lower()}{int(k)}"


def plot_all(dataset_path: Path, out_dir: Path) -> list[Path]:
    summ = read_table(dataset_path, "summary")
    with h5py.File(dataset_path, "r") as f:  # the numeric columns drawn, not the whole tables
        reads = {k: f["reads"][k][()] for k in ("t_s", "antenna_port", "phase_reported_rad")}
        pr = {k: f["pseudoranges"][k][()] for k in ("t_s", "antenna", "pseudorange_m", "true_range_m")}
        est = {k: f["estimates"][k][()] for k in f["estimates"] if k != "row"}
        anchors = np.asarray(f.attrs["antennas_xyz_m"])[:, :2]
        jumps = int(f.attrs["unwrap_jumps"])
        limit = float(f.attrs["unwrap_limit_mps"])
        rate = float(f.attrs.get("reads_per_s_per_antenna", np.nan))
    duration = float(reads["t_s"].max() - reads["t_s"].min())
    size = (f"{reads['t_s'].size} reads over {duration:.0f} s ({rate:g} reads/s per antenna, "
            f"{np.unique(reads['antenna_port']).size} antennas)")
    out = []
    with paper_style():
        fig, (a1, a2) = figure(columns=2, nrows=2, height_in=4.6)
        ant = reads["antenna_port"]
        for k, i in enumerate(np.unique(ant)):
            st = series_style(k)
            m = (ant == i) & (reads["t_s"] <= reads["t_s"][0] + PHASE_WINDOW_S)
            a1.plot(reads["t_s"][m], reads["phase_reported_rad"][m], linestyle="none", marker=st["marker"],
                    markersize=1.8, color=st["color"], label=f"antenna {i}")
            mp = (pr["antenna"] == i) & np.isfinite(pr["pseudorange_m"])
            z, r = pr["pseudorange_m"][mp], pr["true_range_m"][mp]
            a2.plot(pr["t_s"][mp], r - r[0], color="0.6", linestyle="-", linewidth=3.0, alpha=0.6, zorder=1,
                    label="true range change" if k == 0 else None)
            a2.plot(pr["t_s"][mp], z - z[0], linewidth=0.9, markevery=max(1, z.size // 12), markersize=3,
                    label=f"antenna {i}", zorder=2, **st)
        a1.set(xlabel="time $t$ [s]", ylabel="reported phase $\\theta$ [rad]",
               title=f"Reported phase (12 bit, with port offsets), first {PHASE_WINDOW_S:g} s")
        a2.set(xlabel="time $t$ [s]", ylabel="$r - r_0$ [m]",
               title=f"Unwrapped pseudo-range minus its first value ({jumps} λ/2 jumps)")
        legend_outside(a1, markerscale=2.5)
        legend_outside(a2)
        caption(fig, f"After {cite('sarkka', 'Fig. 4')} (smooth pseudo-ranges, no λ/2 jumps); this run: {jumps} jumps.",
                f"{size}; unwrapping holds below {limit:.3g} m/s radial speed.")
        out.append(save_figure(fig, figure_path(dataset_path, out_dir, "phase")))

        fig, ax = figure(columns=1, height_in=4.3)
        ax.plot(anchors[:, 0], anchors[:, 1], linestyle="none", marker="^", markersize=7, color="black",
                label="reader antennas")
        ax.plot(est["intended_x_m"], est["intended_y_m"], color="0.6", linestyle="-", linewidth=3.0, alpha=0.6,
                label="intended path")
        ax.plot(est["x_m"], est["y_m"], color="0.2", linestyle="-", linewidth=0.6, label="true path (jitter)")
        ax.plot(est["rssi_x_m"], est["rssi_y_m"], linestyle="none", marker=".", color=_KIND["RSSI"][0], markersize=1.2,
                alpha=0.5, label="RSSI only, eq. 13")
        n_pass = int(summ["pass"].max())
        for name, k in (("EKF", 1), ("RTS", n_pass)):
            ax.plot(est[f"{_key(name, k)}_x_m"], est[f"{_key(name, k)}_y_m"], linewidth=0.8,
                    markevery=max(1, est["x_m"].size // 12), markersize=2.5, label=_label(name, k), **_style(name, k))
        ax.set_aspect("equal", adjustable="datalim")
        ax.set(xlabel="$x$ [m]", ylabel="$y$ [m]", title="True and estimated tracks")
        leg = legend_outside(ax, where="below", ncols=2)
        for h in leg.legend_handles:  # the RSSI dots, visible in the legend
            if h.get_markersize() < 3:
                h.set_markersize(5)
                h.set_alpha(1.0)
        rm = {(e, int(k)): r for e, k, r in zip(summ["estimator"].astype(str), summ["pass"], summ["rmse_m"])}
        caption(fig, f"After {cite('sarkka', 'Figs. 6-8')}; {size}.",
                f"RMSE vs the intended path: EKF pass 1 {100 * rm[('EKF', 1)]:.1f} cm, RTS pass {n_pass} "
                f"{100 * rm[('RTS', n_pass)]:.1f} cm, RSSI {100 * rm[('RSSI eq. 13', 0)]:.0f} cm.")
        out.append(save_figure(fig, figure_path(dataset_path, out_dir, "track")))

        fig, (a1, a2) = figure(columns=2, ncols=2, height_in=3.3, width_ratios=(1.7, 1.0))
        intended = np.column_stack([est["intended_x_m"], est["intended_y_m"]])
        for j, (name, k) in enumerate(zip(summ["estimator"].astype(str), summ["pass"])):
            xy = np.column_stack([est[f"{_key(name, k)}_x_m"], est[f"{_key(name, k)}_y_m"]])
            e = np.sort(np.linalg.norm(xy - intended, axis=1))
            e = e[np.isfinite(e)]
            n = max(1, e.size // 8)
            a1.plot(np.maximum(e, 1e-5), np.arange(1, e.size + 1) / e.size, linewidth=1.0, markersize=3.5,
                    markevery=((j * n) // 7, n), label=_label(name, k), **_style(name, k))
        a1.set(xscale="log", xlabel="position error vs intended path [m]", ylabel="CDF [–]",
               title="Error CDF per estimator and pass")
        legend_outside(a1, where="below", ncols=4)
        for name in ("EKF", "RTS", "RSSI"):
            m = np.char.startswith(summ["estimator"].astype(str), name)
            if not m.any():
                continue
            k = np.maximum(summ["pass"][m], 1)
            colour, marker = _KIND[name]
            a2.plot(k, 100 * summ["rmse_m"][m], color=colour, marker=marker, linestyle="-", label="this run")
            pub = summ["published_rmse_m"][m]
            if np.isfinite(pub).any():
                a2.plot(k, 100 * pub, **{**PUBLISHED, "marker": marker}, label=published_label(SHORT))
        passes = np.unique(np.maximum(summ["pass"], 1))
        a2.set(yscale="log", xlabel="pass", ylabel="RMSE [cm]", title="RMSE vs intended path", xticks=passes,
               xlim=(passes.min() - 0.3, passes.max() + 0.3))
        a2.set_yticks([1, 2, 5, 10, 20, 50], ["1", "2", "5", "10", "20", "50"])
        a2.minorticks_off()
        proxies = [_mlines.Line2D([], [], color="0.3", marker="o", linestyle="-", label="this run (estimator's colour)"),
                   _mlines.Line2D([], [], **PUBLISHED, label=published_label(SHORT))]
        legend_outside(a2, where="below", handles=proxies, ncols=1)
        caption(fig, f"Setup of {cite('sarkka', 'experiment 1')}; published RMSEs: black hollow markers in the "
                     "estimator's marker shape (RSSI drawn at pass 1; EKF pass 3 not published).", f"{size}.")
        out.append(save_figure(fig, figure_path(dataset_path, out_dir, "cdf")))
    return out

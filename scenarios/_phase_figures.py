"""Figures of the ``phase-tracking`` dataset, drawn from the file alone.

* ``-phase``: reported phase (first seconds) and unwrapped pseudo-range minus its first value
  vs time, per antenna (Särkkä et al. Fig. 4: smooth, no λ/2 jumps);
* ``-track``: floor plan with the antennas, the intended and true paths and the EKF / RTS /
  RSSI-only tracks (Figs. 6–8);
* ``-cdf``: CDF of the position error against the intended path per estimator and pass, with
  the published RMSEs marked.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rfsim.core.dataset import read_table
from rfsim.core.lazy import lazy_import
from rfsim.core.plots import figure_path, pyplot, save_figure
from rfsim.core.references import cite

h5py = lazy_import("h5py")

PHASE_WINDOW_S = 3.0


def plot_all(dataset_path: Path, out_dir: Path) -> list[Path]:
    plt = pyplot()
    summ = read_table(dataset_path, "summary")
    with h5py.File(dataset_path, "r") as f:  # the numeric columns drawn, not the whole tables
        reads = {k: f["reads"][k][()] for k in ("t_s", "antenna_port", "phase_reported_rad")}
        pr = {k: f["pseudoranges"][k][()] for k in ("t_s", "antenna", "pseudorange_m", "true_range_m")}
        est = {k: f["estimates"][k][()] for k in f["estimates"] if k != "row"}
        anchors = np.asarray(f.attrs["antennas_xyz_m"])[:, :2]
        jumps = int(f.attrs["unwrap_jumps"])
        limit = float(f.attrs["unwrap_limit_mps"])
    out = []

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6.4))
    ant = reads["antenna_port"]
    for i in np.unique(ant):
        m = (ant == i) & (reads["t_s"] <= reads["t_s"][0] + PHASE_WINDOW_S)
        a1.plot(reads["t_s"][m], reads["phase_reported_rad"][m], ".", ms=1.5, label=f"antenna {i}")
        mp = (pr["antenna"] == i) & np.isfinite(pr["pseudorange_m"])
        z = pr["pseudorange_m"][mp]
        a2.plot(pr["t_s"][mp], z - z[0], lw=1.0, label=f"antenna {i}")
        a2.plot(pr["t_s"][mp], pr["true_range_m"][mp] - pr["true_range_m"][mp][0], "k:", lw=0.6)
    for a, ylabel, title in ((a1, "reported phase [rad]", f"reported phase (12-bit, with port offsets), first "
                              f"{PHASE_WINDOW_S:g} s"),
                             (a2, "pseudo-range − first value [m]", f"unwrapped pseudo-ranges (dotted: true range "
                              f"change); λ/2 jumps: {jumps} (limit {limit:.3g} m/s radial)")):
        a.set(xlabel="time [s]", ylabel=ylabel)
        a.set_title(title, fontsize=9)
        a.grid(True, alpha=0.3)
    a1.legend(fontsize=7, markerscale=6, loc="upper right", ncol=4)
    fig.suptitle(f"Phase and pseudo-range per antenna ({cite('sarkka', 'Fig. 4')})")
    out.append(save_figure(fig, figure_path(dataset_path, out_dir, "phase")))

    fig, ax = plt.subplots(figsize=(7, 7.8))
    ax.plot(anchors[:, 0], anchors[:, 1], "k^", ms=10, label="reader antennas")
    ax.plot(est["intended_x_m"], est["intended_y_m"], "k-", lw=2.5, alpha=0.25, label="intended path")
    ax.plot(est["x_m"], est["y_m"], "k-", lw=0.6, label="true path (jitter)")
    ax.plot(est["rssi_x_m"], est["rssi_y_m"], ".", color="tab:gray", ms=0.8, alpha=0.4, label="RSSI only, eq. 13")
    n_pass = int(summ["pass"].max())
    ax.plot(est["ekf1_x_m"], est["ekf1_y_m"], "-", color="tab:orange", lw=0.8, label="EKF, pass 1")
    ax.plot(est[f"rts{n_pass}_x_m"], est[f"rts{n_pass}_y_m"], "-", color="tab:blue", lw=0.8,
            label=f"RTS, pass {n_pass}")
    ax.set(aspect="equal", xlabel="x [m]", ylabel="y [m]")
    ax.grid(True, alpha=0.3)
    leg = ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=3)  # below the room
    for h in leg.legend_handles:  # the RSSI dots, visible in the legend
        if h.get_markersize() < 3:
            h.set_markersize(4)
            h.set_alpha(1.0)
    rm = {(e, int(k)): r for e, k, r in zip(summ["estimator"].astype(str), summ["pass"], summ["rmse_m"])}
    ax.set_title(f"EKF pass 1 {100 * rm[('EKF', 1)]:.1f} cm, RTS pass {n_pass} {100 * rm[('RTS', n_pass)]:.1f} cm, "
                 f"RSSI {100 * rm[('RSSI eq. 13', 0)]:.0f} cm RMSE (vs intended path)", fontsize=9)
    fig.suptitle(f"True and estimated tracks ({cite('sarkka', 'Figs. 6-8')})")
    out.append(save_figure(fig, figure_path(dataset_path, out_dir, "track")))

    fig, ax = plt.subplots(figsize=(7.5, 5))
    intended = np.column_stack([est["intended_x_m"], est["intended_y_m"]])
    for name, k, pub in zip(summ["estimator"].astype(str), summ["pass"], summ["published_rmse_m"]):
        key = "rssi" if name.startswith("RSSI") else f"{name.lower()}{int(k)}"
        xy = np.column_stack([est[f"{key}_x_m"], est[f"{key}_y_m"]])
        e = np.sort(np.linalg.norm(xy - intended, axis=1))
        e = e[np.isfinite(e)]
        label = name if name.startswith("RSSI") else f"{name} pass {int(k)}"
        line, = ax.plot(np.maximum(e, 1e-5), np.arange(1, e.size + 1) / e.size, label=label)
        if np.isfinite(pub):
            ax.axvline(pub, color=line.get_color(), ls=":", lw=1.0)
    ax.set(xscale="log", xlabel="position error vs intended path [m] (dotted: published RMSE)",
           ylabel="fraction of reads")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")  # a fixed place: "best" tests every one of the 7 × 24,000 vertices
    fig.suptitle(f"CDF of the localization error per estimator ({cite('sarkka', 'experiment 1 setup')})")
    out.append(save_figure(fig, figure_path(dataset_path, out_dir, "cdf")))
    return out

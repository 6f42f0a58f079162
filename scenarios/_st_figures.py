"""Figures of ``st-localization``: the room with landmarks, antennas and true/estimated tracks
(Fig. 4.10), error vs time and error CDF per tracker (Figs. 4.12-4.15), RMSE vs speed with and
without bias compensation (Fig. 4.11), and RMSE per case beside the published values."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rfsim.core.dataset import read_table
from rfsim.core.lazy import lazy_import
from rfsim.core.plots import figure_path, pyplot, save_figure
from rfsim.core.references import cite
from rfsim.estimators.track_errors import rms_per_step

h5py = lazy_import("h5py")


def plot_all(path: Path, out_dir: Path) -> list[Path]:
    """The figures of the dataset at ``path`` (module docstring); the room, error and CDF figures
    show the first case that is not part of the speed sweep (else case 0)."""
    plt, out = pyplot(), []
    est, cases, s, per = (read_table(path, t) for t in ("estimates", "cases", "summary", "periods"))
    with h5py.File(path, "r") as f:
        a = {k: f.attrs[k] for k in f.attrs}
    idx = np.flatnonzero(cases["experiment"] != "speed-sweep")
    c = int(cases["case"][idx[0]] if idx.size else cases["case"][0])
    fig, ax = plt.subplots(figsize=(7, 5.5))
    (x0, y0, x1, y1), lm, ant = a["bounds_m"], np.atleast_2d(a["landmarks_xy_m"]), np.atleast_2d(a["antennas_xyz_m"])
    ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], "k-", lw=2)
    ax.plot(lm[:, 0], lm[:, 1], "s", ms=4, color="0.55", label="landmark tags")
    ax.plot(ant[:, 0], ant[:, 1], "x", ms=12, mew=3, color="tab:red", label="reader antennas (2 m, facing down)")
    ps = (per["case"] == c) & (per["realization"] == 0) & (per["period"] < 200)
    ax.plot(per["x_true_m"][ps], per["y_true_m"][ps], "k-", lw=2, label="true track")
    first = (est["case"] == c) & (est["realization"] == 0) & (est["period"] < 200)
    for label in dict.fromkeys(est["tracker"][first]):
        m = first & (est["tracker"] == label)
        ax.plot(est["x_est_m"][m], est["y_est_m"][m], ".-", ms=2, lw=0.7, label=label)
    ax.set_aspect("equal")
    row = np.flatnonzero(cases["case"] == c)[0]
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"{a['preset']}: {cases['experiment'][row]} (trajectory "
           f"{cases['trajectory'][row]}), first 60 s\nafter {cite('auris', 'Fig. 4.10')}")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    out.append(save_figure(fig, figure_path(path, out_dir, "room")))
    sel = est["case"] == c
    for name, size, cdf in (("error-time", (7, 4), False), ("cdf", (6.5, 4.5), True)):
        fig, ax = plt.subplots(figsize=size)
        for label in dict.fromkeys(est["tracker"][sel]):
            m = sel & (est["tracker"] == label)
            if cdf:
                v = np.sort(est["error_m"][m])
                ax.step(v, np.arange(1, v.size + 1) / v.size, where="post", label=label)
            else:
                rmse = rms_per_step(est["period"][m], est["error_m"][m])
                k = max(1, rmse.size // 300)
                ax.plot(((np.arange(rmse.size) + 1) * a["detection_period_s"])[::k], rmse[::k], lw=0.8, label=label)
        ax.set(**({"xlabel": "position error [m]", "ylabel": "CDF", "title": f"Error CDF — {cite('auris', 'Fig. 4.14')}"}
                  if cdf else {"xlabel": "time [s]", "ylabel": "RMSE over realizations [m]",
                               "title": f"Error vs time — {cite('auris', 'Fig. 4.12')}"}))
        if cdf:
            ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        out.append(save_figure(fig, figure_path(path, out_dir, name)))
    keep = (s["experiment"] != "speed-sweep") | np.all(s["experiment"] == "speed-sweep")  # all if only the sweep
    x = np.arange(int(keep.sum()))
    fig, ax = plt.subplots(figsize=(max(6, 0.7 * x.size), 4.5))
    ax.bar(x, s["mean_error_m"][keep], 0.6, label="this run")
    ax.plot(x, s["published_rmse_m"][keep], "k_", ms=20, mew=3, label="published")
    ax.set_xticks(x, [f"{e} {'' if not np.isfinite(v) else f'{v:g} m/s '}{t}" for e, v, t in zip(
        s["experiment"][keep], s["speed_mps"][keep], s["tracker"][keep])], rotation=40, ha="right", fontsize=7)
    ax.set(ylabel="average RMSE (mean l2 error) [m]", title=f"RMSE per case and tracker beside {cite('auris', 'ch. 4')}")
    ax.legend(fontsize=8)
    out.append(save_figure(fig, figure_path(path, out_dir, "rmse")))
    if np.any(s["experiment"] == "speed-sweep"):
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        for label in ("pfaa-never", "pfaa-always"):
            m = (s["experiment"] == "speed-sweep") & (s["tracker"] == label)
            ax.plot(s["speed_mps"][m], s["mean_error_m"][m], "o-", label=label)
        ax.axvline(a["published_crossover_mps"], color="k", ls="--", label="published crossover 1.2 m/s")
        if np.isfinite(a.get("crossover_mps", np.nan)):
            ax.axvline(a["crossover_mps"], color="tab:red", ls=":", label=f"this run {a['crossover_mps']:.2f} m/s")
        ax.set(xlabel="speed [m/s]", ylabel="average RMSE (mean l2 error) [m]",
               title=f"Bias compensation never / always — {cite('auris', 'Fig. 4.11')}")
        ax.legend(fontsize=8)
        out.append(save_figure(fig, figure_path(path, out_dir, "speed")))
    return out


__all__ = ["plot_all"]

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

h5py = lazy_import("h5py")


def _attrs(path: Path) -> dict:
    with h5py.File(path, "r") as f:
        return {k: f.attrs[k] for k in f.attrs}


def _shown_case(cases) -> int:
    """The first case that is not part of the speed sweep (else case 0)."""
    idx = np.flatnonzero(cases["experiment"] != "speed-sweep")
    return int(cases["case"][idx[0]] if idx.size else cases["case"][0])


def plot_room(path, out, est, cases) -> Path:
    plt = pyplot()
    a = _attrs(path)
    c = _shown_case(cases)
    fig, ax = plt.subplots(figsize=(7, 5.5))
    x0, y0, x1, y1 = a["bounds_m"]
    ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], "k-", lw=2)
    lm = np.atleast_2d(a["landmarks_xy_m"])
    ax.plot(lm[:, 0], lm[:, 1], "s", ms=4, color="0.55", label="landmark tags")
    ant = np.atleast_2d(a["antennas_xyz_m"])
    ax.plot(ant[:, 0], ant[:, 1], "x", ms=12, mew=3, color="tab:red", label="reader antennas (2 m, facing down)")
    sel = (est["case"] == c) & (est["realization"] == 0) & (est["period"] < 200)
    per = read_table(path, "periods")
    ps = (per["case"] == c) & (per["realization"] == 0) & (per["period"] < 200)
    ax.plot(per["x_true_m"][ps], per["y_true_m"][ps], "k-", lw=2, label="true track")
    for label in dict.fromkeys(est["tracker"][sel]):
        m = sel & (est["tracker"] == label)
        ax.plot(est["x_est_m"][m], est["y_est_m"][m], ".-", ms=2, lw=0.7, label=label)
    ax.set_aspect("equal")
    row = np.flatnonzero(cases["case"] == c)[0]
    ax.set(xlabel="x [m]", ylabel="y [m]",
           title=f"{a['preset']}: {cases['experiment'][row]} (trajectory {cases['trajectory'][row]}), first 60 s\n"
                 f"after {cite('auris', 'Fig. 4.10')}")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return save_figure(fig, out)


def plot_error_time(path, out, est, cases) -> Path:
    plt = pyplot()
    c = _shown_case(cases)
    a = _attrs(path)
    fig, ax = plt.subplots(figsize=(7, 4))
    sel = est["case"] == c
    for label in dict.fromkeys(est["tracker"][sel]):
        m = sel & (est["tracker"] == label)
        T = int(est["period"][m].max()) + 1
        e2, n = np.zeros(T), np.zeros(T)
        np.add.at(e2, est["period"][m], est["error_m"][m] ** 2)
        np.add.at(n, est["period"][m], 1)
        rmse = np.sqrt(e2 / n)
        k = max(1, T // 300)
        t = (np.arange(T) + 1) * a["detection_period_s"]
        ax.plot(t[::k], rmse[::k], lw=0.8, label=label)
    ax.set(xlabel="time [s]", ylabel="RMSE over realizations [m]", title=f"Error vs time — {cite('auris', 'Fig. 4.12')}")
    ax.legend(fontsize=8)
    return save_figure(fig, out)


def plot_cdf(path, out, est, cases) -> Path:
    plt = pyplot()
    c = _shown_case(cases)
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    sel = est["case"] == c
    for label in dict.fromkeys(est["tracker"][sel]):
        v = np.sort(est["error_m"][sel & (est["tracker"] == label)])
        ax.step(v, np.arange(1, v.size + 1) / v.size, where="post", label=label)
    ax.set(xlabel="position error [m]", ylabel="CDF", title=f"Error CDF — {cite('auris', 'Fig. 4.14')}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out)


def plot_speed(path, out, summary) -> Path:
    plt = pyplot()
    a = _attrs(path)
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for label in ("pfaa-never", "pfaa-always"):
        m = (summary["experiment"] == "speed-sweep") & (summary["tracker"] == label)
        ax.plot(summary["speed_mps"][m], summary["mean_error_m"][m], "o-", label=label)
    ax.axvline(a["published_crossover_mps"], color="k", ls="--", label="published crossover 1.2 m/s")
    if np.isfinite(a.get("crossover_mps", np.nan)):
        ax.axvline(a["crossover_mps"], color="tab:red", ls=":", label=f"this run {a['crossover_mps']:.2f} m/s")
    ax.set(xlabel="speed [m/s]", ylabel="average RMSE (mean l2 error) [m]",
           title=f"Bias compensation never / always — {cite('auris', 'Fig. 4.11')}")
    ax.legend(fontsize=8)
    return save_figure(fig, out)


def plot_summary(path, out, summary) -> Path:
    plt = pyplot()
    keep = summary["experiment"] != "speed-sweep"
    if not keep.any():
        keep = np.ones_like(keep)
    labels = [f"{e} {'' if not np.isfinite(v) else f'{v:g} m/s '}{t}" for e, v, t in
              zip(summary["experiment"][keep], summary["speed_mps"][keep], summary["tracker"][keep])]
    x = np.arange(len(labels))
    fig, ax = plt.subplots(figsize=(max(6, 0.7 * len(labels)), 4.5))
    ax.bar(x, summary["mean_error_m"][keep], 0.6, label="this run")
    ax.plot(x, summary["published_rmse_m"][keep], "k_", ms=20, mew=3, label="published")
    ax.set_xticks(x, labels, rotation=40, ha="right", fontsize=7)
    ax.set(ylabel="average RMSE (mean l2 error) [m]", title=f"RMSE per case and tracker beside {cite('auris', 'ch. 4')}")
    ax.legend(fontsize=8)
    return save_figure(fig, out)


def plot_all(path: Path, out_dir: Path) -> list[Path]:
    est, cases, summary = read_table(path, "estimates"), read_table(path, "cases"), read_table(path, "summary")
    out = [plot_room(path, figure_path(path, out_dir, "room"), est, cases),
           plot_error_time(path, figure_path(path, out_dir, "error-time"), est, cases),
           plot_cdf(path, figure_path(path, out_dir, "cdf"), est, cases),
           plot_summary(path, figure_path(path, out_dir, "rmse"), summary)]
    if np.any(summary["experiment"] == "speed-sweep"):
        out.append(plot_speed(path, figure_path(path, out_dir, "speed"), summary))
    return out


__all__ = ["plot_all"]

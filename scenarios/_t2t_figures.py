"""Figures of ``tag-to-tag-tracking``: the aisle with reference tags and true/estimated tracks
(after Fig. 6.3), error vs time, the RMSE CDF per tracker (Fig. 6.4) and the average RMSE per
tracker and range beside Table 6.2."""

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


def _pick_range(values) -> float:
    """r = 2 m when present (Fig. 6.3/6.4 use it), else the first range."""
    u = np.unique(values)
    return 2.0 if np.any(u == 2.0) else float(u[0])


def plot_tracks(path: Path, out: Path) -> Path:
    plt = pyplot()
    a = _attrs(path)
    est, truth = read_table(path, "estimates"), read_table(path, "truth")
    r = _pick_range(est["range_m"])
    tags = np.atleast_2d(a["tags_xy_m"])
    fig, ax = plt.subplots(figsize=(9, 3.8))
    w = float(a["aisle_width_m"])
    for s in (-1, 1):
        ax.axhline(s * w / 2, color="0.5", lw=6, alpha=0.4)
    ax.plot(tags[:, 0], tags[:, 1], "^", ms=10, color="tab:purple", label="reference tags")
    ex = np.asarray(a["exciter_xyz_m"])
    ax.plot(ex[0], ex[1], "*", ms=14, color="tab:orange", label="exciter")
    tr = truth["trajectory"] == 0
    ax.plot(truth["x_m"][tr], truth["y_m"][tr], "k-", lw=2, label="true track")
    for label in dict.fromkeys(est["tracker"]):
        m = (est["trajectory"] == 0) & (est["range_m"] == r) & (est["tracker"] == label)
        if m.any():
            ax.plot(est["x_est_m"][m], est["y_est_m"][m], "o" if label == "nn" else ".-", lw=0.8,
                    ms=6 if label == "nn" else 3, mfc="none" if label == "nn" else None, label=label)
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"Aisle, trajectory 0, r = {r:g} m — after {cite('geng', 'Fig. 6.3')}")
    ax.set_aspect("equal")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return save_figure(fig, out)


def plot_error_vs_time(path: Path, out: Path) -> Path:
    plt = pyplot()
    est = read_table(path, "estimates")
    r = _pick_range(est["range_m"])
    fig, ax = plt.subplots(figsize=(7, 4))
    bins = np.linspace(0.0, float(est["t_s"].max()) + 1e-9, 25)
    for label in dict.fromkeys(est["tracker"]):
        m = (est["range_m"] == r) & (est["tracker"] == label)
        idx = np.digitize(est["t_s"][m], bins) - 1
        e2 = est["error_m"][m] ** 2
        rms = np.array([np.sqrt(e2[idx == b].mean()) if np.any(idx == b) else np.nan for b in range(bins.size - 1)])
        ax.plot(0.5 * (bins[1:] + bins[:-1]), rms, "-o", ms=3, label=label)
    ax.set(xlabel="time [s]", ylabel="RMS position error over trajectories [m]",
           title=f"Error vs time, r = {r:g} m (filter run 0)")
    ax.legend(fontsize=8)
    return save_figure(fig, out)


def plot_cdf(path: Path, out: Path) -> Path:
    plt = pyplot()
    runs = read_table(path, "runs")
    r = _pick_range(runs["range_m"])
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for label in dict.fromkeys(runs["tracker"]):
        v = np.sort(runs["rmse_m"][(runs["range_m"] == r) & (runs["tracker"] == label)])
        if v.size:
            ax.step(v, np.arange(1, v.size + 1) / v.size, where="post", label=label)
    ax.set(xlabel="RMSE [m]", ylabel="CDF", title=f"CDF of RMSEs, r = {r:g} m — {cite('geng', 'Fig. 6.4')}")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return save_figure(fig, out)


def plot_table(path: Path, out: Path) -> Path:
    plt = pyplot()
    s = read_table(path, "summary")
    names = [k[:-7] for k in s if k.endswith("_rmse_m") and not k.endswith("_published_rmse_m")]
    order = {"nn": 0, "kf": 1, "pf": 2, "rb": 3}
    labels = sorted(names, key=lambda n: (order.get(n[:2], 4), int("".join(c for c in n if c.isdigit()) or 0)))
    fig, ax = plt.subplots(figsize=(8, 4.5))
    n_r = s["range_m"].size
    width = 0.8 / n_r
    x = np.arange(len(labels))
    for i, r in enumerate(s["range_m"]):
        got = [s[f"{lab}_rmse_m"][i] for lab in labels]
        pub = [s[f"{lab}_published_rmse_m"][i] for lab in labels]
        ax.bar(x + (i - (n_r - 1) / 2) * width, got, width * 0.9, label=f"r = {r:g} m (this run)")
        ax.plot(x + (i - (n_r - 1) / 2) * width, pub, "_", ms=16, mew=3, color="k",
                label="published (Table 6.2)" if i == 0 else None)
    ax.set_xticks(x, labels)
    ax.set(ylabel="average RMSE [m]", title=f"Average RMSE per tracker and sensing range r\nbeside {cite('geng', 'Table 6.2')} (black marks)")
    ax.legend(fontsize=8)
    return save_figure(fig, out)


def plot_all(path: Path, out_dir: Path) -> list[Path]:
    out = [plot_table(path, figure_path(path, out_dir, "table6_2"))]
    if "runs" in _groups(path):
        out.append(plot_cdf(path, figure_path(path, out_dir, "cdf")))
    if "estimates" in _groups(path):
        out.append(plot_tracks(path, figure_path(path, out_dir, "tracks")))
        out.append(plot_error_vs_time(path, figure_path(path, out_dir, "error-time")))
    return out


def _groups(path: Path) -> set[str]:
    with h5py.File(path, "r") as f:
        return set(f)


__all__ = ["plot_all"]

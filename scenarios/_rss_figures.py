"""Figures of the ``rss-localization`` scenario: floor plan with readers, walls, reference tags
and true/estimated tracks; error CDF per estimator; RMSE vs σ0 beside the thesis's values."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rfsim.core.dataset import read_table
from rfsim.core.lazy import lazy_import
from rfsim.core.plots import draw_floor_plan, pyplot, save_figure
from rfsim.core.rows import read_block

h5py = lazy_import("h5py")


def _cases(path: Path) -> dict[str, np.ndarray]:
    """Case index, motion and σ0 of every case (from the small summary table)."""
    sm = read_table(path, "summary")
    keep = np.unique(sm["case"], return_index=True)[1]
    return {k: sm[k][keep] for k in ("case", "motion", "sigma0_db")}


def plot_floor_plan(path: Path, out: Path, *, n_tracks: int = 2) -> Path:
    """Readers, walls, cells, reference tags and the first tracks of the first mobile case."""
    plt = pyplot()
    with h5py.File(path, "r") as f:
        a = {k: f.attrs[k] for k in f.attrs}
    cases = _cases(path)
    mobile = cases["motion"] == "mobile"
    case = int(cases["case"][np.flatnonzero(mobile)[0] if mobile.any() else 0])
    est = read_block(path, "estimates", "case", case, ("estimator", "trial", "x_true_m", "y_true_m", "x_est_m", "y_est_m"))
    fig, ax = plt.subplots(figsize=(8, 6))
    draw_floor_plan(ax, a["bounds_m"], walls=np.atleast_2d(a["walls_xy"]).reshape(-1, 4),
                    cells=np.atleast_2d(a["cells_xy"]), readers=np.atleast_2d(a["readers_xy"]),
                    reference=np.atleast_2d(a["reference_xy"]).reshape(-1, 2))
    names = list(dict.fromkeys(est["estimator"]))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for tr in range(n_tracks):
        m = est["trial"] == tr
        first = m & (est["estimator"] == names[0])
        ax.plot(est["x_true_m"][first], est["y_true_m"][first], "k-o", ms=3, lw=1.5, label="true track" if tr == 0 else None)
        for i, name in enumerate(names[::max(1, len(names) // 4)][:4]):
            mm = m & (est["estimator"] == name) & np.isfinite(est["x_est_m"])
            ax.plot(est["x_est_m"][mm], est["y_est_m"][mm], "--.", color=colors[(i + 1) % len(colors)],
                    lw=1, label=name if tr == 0 else None)
    ax.set(aspect="equal", xlabel="x [m]", ylabel="y [m]", title=f"{a['preset']}: readers, walls, true and estimated tracks")
    uniq = dict(zip(*ax.get_legend_handles_labels()[::-1]))
    ax.legend(uniq.values(), uniq.keys(), fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return save_figure(fig, out)


def plot_error_cdf(path: Path, out: Path) -> Path:
    """Empirical CDF of the scored errors per estimator and motion (σ0 closest to 5.2 dB)."""
    plt = pyplot()
    cases = _cases(path)
    s = cases["sigma0_db"]
    target = s[np.isfinite(s)][np.argmin(np.abs(s[np.isfinite(s)] - 5.2))] if np.isfinite(s).any() else np.nan
    motions = list(dict.fromkeys(cases["motion"]))
    fig, axes = plt.subplots(1, len(motions), figsize=(5 * len(motions), 4), squeeze=False)
    for ax, motion in zip(axes[0], motions):
        for case in cases["case"][(cases["motion"] == motion) & ((s == target) | ~np.isfinite(s))]:
            est = read_block(path, "estimates", "case", int(case), ("estimator", "error_m", "scored"))
            m = est["scored"]
            for name in dict.fromkeys(est["estimator"][m]):
                e = np.sort(est["error_m"][m & (est["estimator"] == name)])
                ax.plot(e, np.arange(1, e.size + 1) / e.size, label=name)
        ax.set(xlabel="localization error [m]", ylabel="CDF",
               title=f"{motion} target" + (f", σ0 = {target:g} dB" if np.isfinite(target) else ""))
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    return save_figure(fig, out)


def plot_rmse_vs_sigma(path: Path, out: Path) -> Path:
    """RMSE vs σ0 per estimator and motion (lines) beside the thesis's values (crosses), with the
    corrected CRLB; for the home replica, a bar chart of RMSE beside the published RMSE."""
    plt = pyplot()
    sm = read_table(path, "summary")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    if np.isfinite(sm["sigma0_db"]).any():
        colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        keys = list(dict.fromkeys(zip(sm["estimator"], sm["motion"])))
        for i, (name, motion) in enumerate(keys):
            m = (sm["estimator"] == name) & (sm["motion"] == motion)
            c = colors[i % len(colors)]
            ax.plot(sm["sigma0_db"][m], sm["rmse_m"][m], "-o", color=c, label=f"{name} ({motion})")
            ax.plot(sm["sigma0_db"][m], sm["published_rmse_m"][m], "x", ms=9, mew=2, color=c)
        ax.set(xlabel="σ0 [dB]", ylabel="RMSE [m]", title="RMSE vs σ0: simulated (lines) and thesis (crosses)")
    else:
        labels = [f"{n}\n({m})" for n, m in zip(sm["estimator"], sm["motion"])]
        x = np.arange(len(labels))
        ax.bar(x - 0.2, sm["rmse_m"], 0.4, label="simulated")
        ax.bar(x + 0.2, sm["published_rmse_m"], 0.4, label="thesis")
        ax.set_xticks(x, labels, rotation=60, fontsize=6)
        ax.set(ylabel="RMSE [m]", title="home replica: RMSE beside the thesis")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    return save_figure(fig, out)

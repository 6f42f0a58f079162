"""Figures of the ``rss-localization`` scenario, in the project's figure style: floor plan with
readers, walls, reference tags and true/estimated tracks; error CDF per estimator; RMSE vs σ0,
fixed and mobile target side by side, beside the thesis's values and the corrected CRLB."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rfsim.core.dataset import read_table
from rfsim.core.lazy import lazy_import
from rfsim.core.figure_style import PUBLISHED, figure, legend_outside, paper_style, published_label, series_style
from rfsim.core.plots import draw_floor_plan, save_figure
from rfsim.core.references import cite
from rfsim.core.rows import read_block
from rfsim.scenarios._captions import caption, unique_handles

h5py = lazy_import("h5py")


def _cases(path: Path) -> dict[str, np.ndarray]:
    """Case index, motion and σ0 of every case (from the small summary table)."""
    sm = read_table(path, "summary")
    keep = np.unique(sm["case"], return_index=True)[1]
    return {k: sm[k][keep] for k in ("case", "motion", "sigma0_db")}


#: The source in legend entries (the captions cite it in full).
SHORT = "Özkaya 2011"
#: Where the thesis prints the values the figures compare with.
TABLES = "Tables 7.2, 7.3, 7.6, 7.7, 7.9-7.11, 7.14-7.16"


def _room_source(preset: str) -> str:
    return (cite("ozkaya", "ch. 6 and Tables 7.41-7.42 (home)") if preset == "home-2room"
            else cite("ozkaya", "Sec. 7.2 (room of Fig. 7.2)")) if preset else cite("ozkaya")


def _estimator_styles(names) -> dict[str, dict]:
    """One series style per estimator, the same in every figure of the scenario."""
    return {n: series_style(i) for i, n in enumerate(dict.fromkeys(names))}


def plot_floor_plan(path: Path, out: Path, *, n_tracks: int = 2) -> Path:
    """Readers, walls, cells, reference tags and the first tracks of the first mobile case."""
    with h5py.File(path, "r") as f:
        a = {k: f.attrs[k] for k in f.attrs}
    cases = _cases(path)
    mobile = cases["motion"] == "mobile"
    k0 = np.flatnonzero(mobile)[0] if mobile.any() else 0
    case = int(cases["case"][k0])
    est = read_block(path, "estimates", "case", case, ("estimator", "trial", "x_true_m", "y_true_m", "x_est_m", "y_est_m"))
    walls = np.atleast_2d(a["walls_xy"]).reshape(-1, 4)
    names = list(dict.fromkeys(est["estimator"]))
    styles = _estimator_styles(names)
    shown = [n for n in names if n in ("nn", "grid-mmse", "pf-mmse")] or names[:3]
    x0, y0, x1, y1 = a["bounds_m"]
    with paper_style():
        fig, ax = figure(columns=1, height_in=max(2.6, min(4.2, 2.2 * (y1 - y0) / (x1 - x0))))
        draw_floor_plan(ax, a["bounds_m"], walls=walls, cells=np.atleast_2d(a["cells_xy"]),
                        readers=np.atleast_2d(a["readers_xy"]), reference=np.atleast_2d(a["reference_xy"]).reshape(-1, 2))
        trials = np.unique(est["trial"])[:n_tracks]
        for tr in trials:
            m = est["trial"] == tr
            first = m & (est["estimator"] == names[0])
            ax.plot(est["x_true_m"][first], est["y_true_m"][first], color="0.25", linestyle="-", linewidth=1.6, marker="o", markersize=2.5,
                    label="true track" if tr == trials[0] else None, zorder=3)
            ax.plot(est["x_true_m"][first][:1], est["y_true_m"][first][:1], linestyle="none", marker="o", markersize=6,
                    markerfacecolor="white", markeredgecolor="0.25", label="start" if tr == trials[0] else None, zorder=4)
            for name in shown:
                mm = m & (est["estimator"] == name) & np.isfinite(est["x_est_m"])
                ax.plot(est["x_est_m"][mm], est["y_est_m"][mm], linewidth=0.9, markersize=2.5,
                        label=name if tr == trials[0] else None, **styles[name])
        ax.set_aspect("equal", adjustable="datalim")
        what = "readers, walls, tracks" if walls.size else "readers, cells, tracks"
        ax.set(xlabel="$x$ [m]", ylabel="$y$ [m]", title=f"{a['preset']}: {what}")
        legend_outside(ax, handles=unique_handles(ax), fontsize=6)
        sigma = cases["sigma0_db"][k0]
        caption(fig, f"{_room_source(str(a['preset']))}.",
                f"Mobile target{f', σ0 = {sigma:g} dB' if np.isfinite(sigma) else ''}: the first {trials.size} "
                f"of {np.unique(est['trial']).size} trials; estimators of the thesis (all in the CDF figure).")
        return save_figure(fig, out)


def plot_error_cdf(path: Path, out: Path) -> Path:
    """Empirical CDF of the scored errors per estimator and motion (σ0 closest to 5.2 dB)."""
    cases = _cases(path)
    s = cases["sigma0_db"]
    target = s[np.isfinite(s)][np.argmin(np.abs(s[np.isfinite(s)] - 5.2))] if np.isfinite(s).any() else np.nan
    motions = list(dict.fromkeys(cases["motion"]))
    with h5py.File(path, "r") as f:
        preset = str(f.attrs.get("preset", ""))
    with paper_style():
        fig, axes = figure(columns=2 if len(motions) > 1 else 1, ncols=len(motions), height_in=2.9, sharey=True,
                           squeeze=False)
        counts, styles = [], {}
        for ax, motion in zip(axes[0], motions):
            for case in cases["case"][(cases["motion"] == motion) & ((s == target) | ~np.isfinite(s))]:
                est = read_block(path, "estimates", "case", int(case), ("estimator", "error_m", "scored"))
                m = est["scored"].astype(bool)
                styles = styles or _estimator_styles(est["estimator"])
                for name in dict.fromkeys(est["estimator"][m]):
                    e = np.sort(est["error_m"][m & (est["estimator"] == name)])
                    st = styles.get(name, series_style(len(styles)))
                    ax.plot(e, np.arange(1, e.size + 1) / e.size, markevery=max(1, e.size // 9), label=name, **st)
                    counts.append(e.size)
            ax.set(xlabel="localization error [m]",
                   title=f"{motion} target" + (f", $\\sigma_0$ = {target:g} dB" if np.isfinite(target) else ""))
        axes[0][0].set_ylabel("CDF [–]")
        legend_outside(axes[0][-1], handles=unique_handles(axes[0][0]), title="estimator")
        n = f"{min(counts)}" if counts and min(counts) == max(counts) else (f"{min(counts)}-{max(counts)}" if counts else "0")
        caption(fig, f"Estimators and setup of {_room_source(preset)}; the thesis prints the statistics, not the CDFs "
                     f"({TABLES}).", f"{n} scored estimates per estimator and motion.")
        return save_figure(fig, out)


def plot_rmse_vs_sigma(path: Path, out: Path) -> Path:
    """RMSE vs σ0 per estimator, fixed and mobile target side by side, beside the thesis's values
    (black hollow markers, the estimator's marker shape) and the corrected CRLB; for the home
    replica, bars of the RMSE beside the published RMSE."""
    sm = read_table(path, "summary")
    styles = _estimator_styles(sm["estimator"])
    with paper_style():
        if np.isfinite(sm["sigma0_db"]).any():
            motions = list(dict.fromkeys(sm["motion"]))
            fig, axes = figure(columns=2 if len(motions) > 1 else 1, ncols=len(motions), height_in=2.9, sharey=True,
                               squeeze=False)
            crlb_note = []
            for ax, motion in zip(axes[0], motions):
                mo = sm["motion"] == motion
                sig = np.unique(sm["sigma0_db"][mo])
                crlb = np.array([sm["crlb_m"][mo & (sm["sigma0_db"] == v)][0] for v in sig])
                if np.nanmax(crlb) <= 1.3 * np.nanmax(sm["rmse_m"]):
                    ax.plot(sig, crlb, color="0.55", linestyle="-", linewidth=2.2, alpha=0.7, label="corrected CRLB")
                else:
                    crlb_note.append(f"{motion} {np.nanmin(crlb):.2f}-{np.nanmax(crlb):.2f} m")
                for name, st in styles.items():
                    m = mo & (sm["estimator"] == name)
                    if not m.any():
                        continue
                    ax.plot(sm["sigma0_db"][m], sm["rmse_m"][m], label=name, **st)
                    pub = sm["published_rmse_m"][m]
                    if np.isfinite(pub).any():
                        ax.plot(sm["sigma0_db"][m], pub, **{**PUBLISHED, "marker": st["marker"], "linewidth": 0.7},
                                label=f"{name}, {published_label(SHORT)}")
                ax.set(xlabel="RSSI noise $\\sigma_0$ [dB]", title=f"{motion} target")
            axes[0][0].set_ylabel("RMSE [m]")
            by_label = {h.get_label(): h for ax in axes[0] for h in unique_handles(ax)}
            order = ["corrected CRLB"] + [k for n in styles for k in (n, f"{n}, {published_label(SHORT)}")]
            legend_outside(axes[0][-1], handles=[by_label[k] for k in order if k in by_label], fontsize=6)
            n = sm["n_scored"]
            caption(fig, f"After {cite('ozkaya', TABLES)} (black hollow markers: the thesis, the estimator's marker).",
                    f"{int(n.min())}-{int(n.max())} scored estimates per point."
                    + (f" The corrected CRLB ({', '.join(crlb_note)}) lies above every estimator's RMSE, off the axes."
                       if crlb_note else ""))
        else:
            fig, ax = figure(columns=2, height_in=3.0)
            labels = [f"{n}\n({m})" for n, m in zip(sm["estimator"], sm["motion"])]
            x = np.arange(len(labels))
            ax.bar(x, sm["rmse_m"], 0.6, color=series_style(0)["color"], label="this run")
            ax.plot(x, sm["published_rmse_m"], linestyle="none",
                    **{k: v for k, v in PUBLISHED.items() if k not in ("linestyle", "linewidth")},
                    label=published_label(f"{SHORT}, Tables 7.41-7.42"))
            ax.set_xticks(x, labels, rotation=60, fontsize=6)
            ax.set(xlabel="estimator (motion)", ylabel="RMSE [m]", title="home replica: RMSE beside the thesis")
            legend_outside(ax)
            caption(fig, f"After {cite('ozkaya', 'Tables 7.41-7.42')}.",
                    f"{int(sm['n_scored'].min())}-{int(sm['n_scored'].max())} scored estimates per bar.")
        return save_figure(fig, out)

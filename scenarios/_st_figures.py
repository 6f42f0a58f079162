"""Figures of ``st-localization``: the room with landmarks, antennas and true/estimated tracks
(Fig. 4.10), error vs time and error CDF per tracker (Figs. 4.12-4.15), RMSE vs speed with and
without bias compensation (Fig. 4.11), and RMSE per case beside the published values."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from rfsim.core.dataset import read_provenance, read_table
from rfsim.core.figure_style import PUBLISHED, figure, legend_outside, paper_style, published_label, series_style
from rfsim.core.lazy import lazy_import
from rfsim.core.plots import figure_path, save_figure
from rfsim.core.references import cite
from rfsim.scenarios._captions import caption, unique_handles
from rfsim.estimators.track_errors import rms_per_step

h5py = lazy_import("h5py")


#: Legend names of the trackers.
TRACKER_NAMES = {"pfbin": "PF-BIN", "pfaa": "PF-AA", "wcl": "WCL", "sqlam": "SQLAM", "pfaa-never": "PF-AA, never",
                 "pfaa-always": "PF-AA, always"}
#: The source in legend entries (the captions cite it in full).
SHORT = "AURIS"


def _name(label: str) -> str:
    return TRACKER_NAMES.get(label, label)


def _styles(labels) -> dict[str, dict]:
    """One series style per tracker, the same in every figure of the scenario."""
    return {t: series_style(i) for i, t in enumerate(dict.fromkeys(labels))}


def _every(n: int, i: int, per_line: int = 10) -> tuple[int, int]:
    """``markevery`` of series ``i``: about ``per_line`` markers, staggered between series."""
    step = max(1, n // per_line)
    return ((i * step) // 5 % step, step)


def _realizations(cases, c: int, full: bool, source_n: int | None) -> str:
    n = int(cases["realizations"][np.flatnonzero(cases["case"] == c)[0]])
    tail = "" if full or source_n is None else f" (reduced default; the source and full = true: {source_n})"
    return f"{n} realization{'s' if n != 1 else ''}{tail}"


def _loop_periods(a, cases, row: int) -> int:
    """Query periods of one loop of the case's closed trajectory (at least 20)."""
    key = f"trajectory_{cases['trajectory'][row]}_xy_m"
    v = float(cases["speed_mps"][row])
    if key not in a or not np.isfinite(v) or v <= 0:
        return 200
    xy = np.atleast_2d(a[key])
    length = float(np.sum(np.hypot(*np.diff(xy, axis=0).T)))
    return max(20, int(np.ceil(length / v / float(a["detection_period_s"]))))


def plot_all(path: Path, out_dir: Path) -> list[Path]:
    """The figures of the dataset at ``path`` (module docstring); the room and error figures show the
    first case that is not part of the speed sweep (else case 0), the CDF every trajectory-2 speed."""
    out = []
    est, cases, s, per = (read_table(path, t) for t in ("estimates", "cases", "summary", "periods"))
    with h5py.File(path, "r") as f:
        a = {k: f.attrs[k] for k in f.attrs}
    text = read_provenance(path).get("config_toml", "")
    full = bool(tomllib.loads(text).get("full", False)) if text else False
    idx = np.flatnonzero(cases["experiment"] != "speed-sweep")
    c = int(cases["case"][idx[0]] if idx.size else cases["case"][0])
    row = np.flatnonzero(cases["case"] == c)[0]
    styles = _styles(est["tracker"])
    v_txt = "" if not np.isfinite(cases["speed_mps"][row]) else f" at {cases['speed_mps'][row]:g} m/s"
    with paper_style():
        fig, ax = figure(columns=1, height_in=3.6)
        (x0, y0, x1, y1), lm, ant = a["bounds_m"], np.atleast_2d(a["landmarks_xy_m"]), np.atleast_2d(a["antennas_xyz_m"])
        ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], color="0.2", linestyle="-", linewidth=1.5)
        ax.plot(lm[:, 0], lm[:, 1], linestyle="none", marker="s", markersize=3, color="0.6", label="landmark tags")
        n_per = _loop_periods(a, cases, row)
        ps = (per["case"] == c) & (per["realization"] == 0) & (per["period"] < n_per)
        ax.plot(per["x_true_m"][ps], per["y_true_m"][ps], color="0.55", linestyle="-", linewidth=3.0, alpha=0.6,
                label="true track", zorder=2)
        first = (est["case"] == c) & (est["realization"] == 0) & (est["period"] < n_per)
        for label in dict.fromkeys(est["tracker"][first]):
            m = first & (est["tracker"] == label)
            ax.plot(est["x_est_m"][m], est["y_est_m"][m], linewidth=0.8, markersize=2.5, label=_name(label),
                    markevery=_every(int(m.sum()), list(styles).index(label), 15), zorder=3, **styles[label])
        ax.plot(ant[:, 0], ant[:, 1], linestyle="none", marker="X", markersize=9, color="black",
                markeredgecolor="white", markeredgewidth=1.0, zorder=6, label=f"reader antenna ({ant[0, 2]:g} m above)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set(xlabel="$x$ [m]", ylabel="$y$ [m]", title=f"Trajectory {cases['trajectory'][row]}{v_txt}: one loop")
        legend_outside(ax, where="below", ncols=2)
        t_loop = n_per * float(a["detection_period_s"])
        caption(fig, f"After {cite('auris', 'Fig. 4.10')}; preset {a['preset']}.",
                f"Realization 0, the first {t_loop:.0f} s ({n_per} query periods of {a['detection_period_s']:g} s).")
        out.append(save_figure(fig, figure_path(path, out_dir, "room")))

        sel = est["case"] == c
        fig, ax = figure(columns=1, height_in=2.9)
        for label in dict.fromkeys(est["tracker"][sel]):
            m = sel & (est["tracker"] == label)
            rmse = rms_per_step(est["period"][m], est["error_m"][m])
            k = max(1, rmse.size // 300)
            t = ((np.arange(rmse.size) + 1) * a["detection_period_s"])[::k]
            ax.plot(t, rmse[::k], linewidth=0.8, markersize=3, markevery=_every(t.size, list(styles).index(label)),
                    label=_name(label), **styles[label])
        ax.set(xlabel="time $t$ [s]", ylabel="RMSE over realizations [m]", title=f"Error vs time{v_txt}")
        legend_outside(ax, where="below", ncols=3)
        caption(fig, f"After {cite('auris', 'Fig. 4.12')}; trajectory {cases['trajectory'][row]}.",
                f"{_realizations(cases, c, full, 100)}.")
        out.append(save_figure(fig, figure_path(path, out_dir, "error-time")))

        tr2 = [int(k) for k in cases["case"][cases["experiment"] == cases["experiment"][row]]]
        fig, axes = figure(columns=2 if len(tr2) > 1 else 1, ncols=len(tr2), height_in=2.9, sharey=True, squeeze=False)
        for ax, cc in zip(axes[0], tr2):
            r = np.flatnonzero(cases["case"] == cc)[0]
            sel = est["case"] == cc
            for label in dict.fromkeys(est["tracker"][sel]):
                v = np.sort(est["error_m"][sel & (est["tracker"] == label)])
                ax.step(v, np.arange(1, v.size + 1) / v.size, where="post", markersize=3,
                        markevery=_every(v.size, list(styles).index(label)), label=_name(label), **styles[label])
            spd = cases["speed_mps"][r]
            ax.set(xlabel="position error [m]", title=(f"{spd:g} m/s" if np.isfinite(spd) else str(cases["experiment"][r]))
                   + (" (Fig. 4.14)" if np.isfinite(spd) and spd >= 2.5 else ""))
        axes[0][0].set_ylabel("CDF [–]")
        legend_outside(axes[0][-1], handles=unique_handles(*axes[0]))
        caption(fig, f"After {cite('auris', 'Fig. 4.14')} (2.5 m/s); trajectory {cases['trajectory'][row]}; every "
                     "period of every realization.",
                "; ".join(f"{cases['speed_mps'][np.flatnonzero(cases['case'] == cc)[0]]:g} m/s: "
                          f"{_realizations(cases, cc, full, 500 if cases['speed_mps'][np.flatnonzero(cases['case'] == cc)[0]] >= 2.5 else 100)}"
                          for cc in tr2) + ".")
        out.append(save_figure(fig, figure_path(path, out_dir, "cdf")))

        out.append(save_figure(_rmse_bars(s, cases, full), figure_path(path, out_dir, "rmse")))
        if np.any(s["experiment"] == "speed-sweep"):
            out.append(save_figure(_speed(s, cases, a, full), figure_path(path, out_dir, "speed")))
    return out


def _rmse_bars(s, cases, full: bool):
    """Average RMSE per case (groups) and tracker (bars), the published values as black hollow markers;
    a bar beyond the axes is cut and labelled with its value."""
    keep = (s["experiment"] != "speed-sweep") | np.all(s["experiment"] == "speed-sweep")  # all if only the sweep
    groups = _groups(s["experiment"][keep], s["speed_mps"][keep])
    trackers = list(dict.fromkeys(s["tracker"][keep]))
    styles = _styles(trackers)
    fig, ax = figure(columns=1, height_in=3.2)
    w = 0.8 / len(trackers)
    vals = s["mean_error_m"][keep]
    top = 1.6 * float(np.nanpercentile(vals, 75)) if vals.size else 1.0
    top = max(top, 1.15 * float(np.nanmax(np.where(np.isfinite(s["published_rmse_m"]), s["published_rmse_m"], 0))))
    cut = []
    for j, t in enumerate(trackers):
        for g, (exp, v) in enumerate(groups):
            m = keep & (s["tracker"] == t) & (s["experiment"] == exp) & ((s["speed_mps"] == v) | (np.isnan(v) & np.isnan(s["speed_mps"])))
            if not m.any():
                continue
            k = np.flatnonzero(m)[0]
            x = g + (j - (len(trackers) - 1) / 2) * w
            val = s["mean_error_m"][k]
            ax.bar(x, min(val, top), w * 0.9, color=styles[t]["color"], hatch=("", "////", "...", "xx")[j % 4],
                   edgecolor="white", linewidth=0.4, label=_name(t) if _name(t) not in _seen_labels(ax) else None)
            if val > top:
                ax.annotate(f"{val:.2f} m ↑", (x, top), xytext=(0, 2), textcoords="offset points", ha="center",
                            va="bottom", fontsize=6)
                cut.append((t, exp, v, val))
            pub = s["published_rmse_m"][k]
            if np.isfinite(pub):
                ax.plot(x, pub, linestyle="none", **{q: r for q, r in PUBLISHED.items() if q not in ("linestyle", "linewidth")},
                        label=published_label(SHORT) if published_label(SHORT) not in _seen_labels(ax) else None)
    ax.set_xticks(range(len(groups)), [f"{e}\n{v:g} m/s" if np.isfinite(v) else str(e) for e, v in groups])
    ax.set_ylim(0, top * 1.12)
    ax.set(xlabel="experiment", ylabel="average RMSE [m]", title="Average RMSE per experiment and tracker")
    legend_outside(ax, where="below", ncols=2)
    notes = [f"After {cite('auris', 'Figs. 4.12-4.15')}: average RMSE = mean error at the period ends."]
    for t, exp, v, val in cut:
        notes.append(f"{_name(t)} on {exp} at {v:g} m/s ({val:.2f} m, cut) loses the track from the first periods; "
                     "the source says PF-AA is better there and prints no number (Figs. 4.13-4.14).")
    rw = (s["experiment"] == "random-walk") & np.isfinite(s["published_vs_wcl_percent"])
    for k in np.flatnonzero(rw):
        notes.append(f"Random walk: {_name(s['tracker'][k])} vs WCL {s['vs_wcl_percent'][k]:+.1f} % "
                     f"(published {s['published_vs_wcl_percent'][k]:+.1f} %).")
    notes.append("Realizations per case: " + ", ".join(sorted({str(int(n)) for n in cases["realizations"]}))
                 + ("" if full else " (reduced default)") + ".")
    caption(fig, *notes)
    return fig


def _groups(experiments, speeds) -> list[tuple[str, float]]:
    """The distinct (experiment, speed) pairs in order (NaN speeds equal)."""
    seen = {}
    for e, v in zip(experiments, speeds):
        seen.setdefault((str(e), round(float(v), 9) if np.isfinite(v) else None), (str(e), float(v)))
    return list(seen.values())


def _seen_labels(ax) -> set[str]:
    return set(ax.get_legend_handles_labels()[1])


def _speed(s, cases, a, full: bool):
    """Average RMSE vs speed, bias compensation never / always, with both crossovers."""
    fig, ax = figure(columns=1, height_in=3.0)
    for i, label in enumerate(("pfaa-never", "pfaa-always")):
        m = (s["experiment"] == "speed-sweep") & (s["tracker"] == label)
        ax.plot(s["speed_mps"][m], s["mean_error_m"][m], label=f"compensation {label.split('-')[1]}", **series_style(i))
    pub = float(a["published_crossover_mps"])
    ax.axvline(pub, ymin=0.5, ymax=1.0, **{k: v for k, v in PUBLISHED.items() if k not in ("marker", "markersize",
               "markerfacecolor", "markeredgecolor", "markeredgewidth")}, label=f"crossover, {published_label(SHORT)}: {pub:g} m/s")
    if np.isfinite(a.get("crossover_mps", np.nan)):
        ax.axvline(a["crossover_mps"], ymin=0.0, ymax=0.5, color=series_style(2)["color"], linestyle="-", linewidth=1.4,
                   label=f"crossover, this run: {a['crossover_mps']:.2f} m/s")
    ax.set(xlabel="speed $v$ [m/s]", ylabel="average RMSE [m]", title="PF-AA bias compensation never / always")
    legend_outside(ax, where="below", ncols=1)
    sw = cases["experiment"] == "speed-sweep"
    n = int(np.median(cases["realizations"][sw])) if sw.any() else 0
    caption(fig, f"After {cite('auris', 'Fig. 4.11')}; trajectory 1.",
            f"{n} realizations per speed{'' if full else ' (reduced default; the source: 100)'}.")
    return fig


__all__ = ["plot_all"]

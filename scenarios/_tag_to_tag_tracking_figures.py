"""Figures of the ``tag-to-tag-tracking`` scenario (:mod:`rfsim.scenarios.tag_to_tag_tracking`), drawn from its dataset alone.

The scenario module composes and runs; this module only draws (``plot`` is called through
the scenario's ``plot``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rfsim.core.lazy import lazy_import
from rfsim.core.figure_style import PUBLISHED, figure, legend_outside, paper_style, published_label, series_style
from rfsim.core.plots import figure_path, save_figure
from rfsim.core.references import cite
from rfsim.scenarios._captions import caption

_dataset = lazy_import("rfsim.core.dataset")


# ----------------------------------------------------------------------------- figures


def _at_range(table) -> tuple[float, np.ndarray]:
    """r = 2 m when present (Fig. 6.3/6.4 use it), else the first range; and the rows at r."""
    u = np.unique(table["range_m"])
    r = 2.0 if np.any(u == 2.0) else float(u[0])
    return r, table["range_m"] == r


#: Legend names of the trackers.
_TRACKER_NAMES = {"nn": "NN", "kf": "KF", "rbpf": "RBPF", "pf": "PF"}


def _tracker_name(label: str) -> str:
    """``pf30`` → ``PF, M = 30``; ``nn`` → ``NN``."""
    head = label.rstrip("0123456789")
    m = label[len(head):]
    return _TRACKER_NAMES.get(head, head) + (f", $M$ = {m}" if m else "")


def _trackers(labels) -> list[str]:
    """The tracker labels in the order of Table 6.2: NN, KF, PF by M, RBPF."""
    order = {"nn": 0, "kf": 1, "pf": 2, "rb": 3}
    return sorted(dict.fromkeys(labels), key=lambda n: (order.get(n[:2], 4),
                                                        int("".join(c for c in n if c.isdigit()) or 0)))


def _size(t) -> str:
    """The run's size: trajectories and filter runs."""
    runs = t.get("runs")
    n_traj = np.unique((runs or t["estimates"])["trajectory"]).size
    n_run = np.unique(runs["run"]).size if runs is not None else 1
    return f"{n_traj} trajectories × {n_run} filter runs (PF, RBPF; NN and KF are deterministic)"


def _tracks(ax, a, est, truth) -> None:
    r, at_r = _at_range(est)
    half = float(a["aisle_width_m"]) / 2
    for s in (-1, 1):
        ax.axhspan(s * half, s * (half + 0.2), facecolor="0.93", edgecolor="0.6", hatch="////", linewidth=0.0,
                   zorder=0, label="shelves" if s < 0 else None)
    tags, ex = np.atleast_2d(a["tags_xy_m"]), np.asarray(a["exciter_xyz_m"])
    ax.plot(tags[:, 0], tags[:, 1], "^", markersize=5, color="0.2", linestyle="none", label="reference tags", zorder=3)
    ax.plot(ex[0], ex[1], "*", markersize=9, color="0.2", markerfacecolor="white", linestyle="none", label="exciter",
            zorder=3)
    tr = truth["trajectory"] == 0
    ax.plot(truth["x_m"][tr], truth["y_m"][tr], color="0.55", linestyle="-", linewidth=3.2, alpha=0.55, label="true track", zorder=1)
    shown = [lab for lab in _trackers(est["tracker"]) if lab in ("nn", "kf") or lab.startswith("rbpf")
             or lab == max((x for x in dict.fromkeys(est["tracker"]) if x.startswith("pf")),
                           key=lambda x: int(x[2:] or 0), default="")]
    for i, label in enumerate(_trackers(est["tracker"])):
        m = (est["trajectory"] == 0) & at_r & (est["tracker"] == label)
        if label not in shown or not m.any():
            continue
        st = series_style(i)
        if label == "nn":  # NN estimates are the decoded tags themselves: rings around the tags
            ax.plot(est["x_est_m"][m], est["y_est_m"][m], linestyle="none", marker="o", markersize=10,
                    markerfacecolor="none", markeredgewidth=1.2, color=st["color"],
                    label=f"{_tracker_name(label)} (the decoded tag)", zorder=4)
        else:
            ax.plot(est["x_est_m"][m], est["y_est_m"][m], linewidth=0.9, markersize=2.5, label=_tracker_name(label),
                    **st)
    ax.set(xlabel="$x$ [m] (along the aisle)", ylabel="$y$ [m]", title=f"Aisle and tracks, trajectory 0, $r$ = {r:g} m")
    ax.set_aspect("equal", adjustable="datalim")


def _error_vs_time(ax, est) -> None:
    r, at_r = _at_range(est)
    bins = np.linspace(0.0, float(est["t_s"].max()) + 1e-9, 25)
    for i, label in enumerate(_trackers(est["tracker"])):
        m = at_r & (est["tracker"] == label)
        idx, e2 = np.digitize(est["t_s"][m], bins) - 1, est["error_m"][m] ** 2
        rms = [np.sqrt(e2[idx == b].mean()) if np.any(idx == b) else np.nan for b in range(bins.size - 1)]
        ax.plot(0.5 * (bins[1:] + bins[:-1]), rms, markersize=3, label=_tracker_name(label), **series_style(i))
    ax.set(xlabel="time $t$ [s]", ylabel="RMS position error [m]", title=f"Error vs time, $r$ = {r:g} m")


def _cdf(ax, runs) -> None:
    r, at_r = _at_range(runs)
    for i, label in enumerate(_trackers(runs["tracker"])):
        v = np.sort(runs["rmse_m"][at_r & (runs["tracker"] == label)])
        if v.size:
            ax.step(v, np.arange(1, v.size + 1) / v.size, where="post", markevery=_every(v.size, i),
                    label=_tracker_name(label), **series_style(i))
    ax.set(xlabel="RMSE of a run [m]", ylabel="CDF [–]", title=f"CDF of the RMSEs, $r$ = {r:g} m")


def _every(n: int, i: int, per_line: int = 10) -> tuple[int, int]:
    """``markevery`` of series ``i``: about ``per_line`` markers, staggered between series."""
    step = max(1, n // per_line)
    return ((i * step) // 6 % step, step)


def _table(ax, s) -> str:
    """Grouped bars of Table 6.2; returns a note on the trackers the run does not reproduce."""
    names = _trackers(k[:-7] for k in s if k.endswith("_rmse_m") and not k.endswith("_published_rmse_m"))
    x = np.arange(len(names))
    n = s["range_m"].size
    w = 0.8 / n
    hatches = ("", "////", "...", "xx")
    for i, r in enumerate(s["range_m"]):
        at = x + (i - (n - 1) / 2) * w
        ax.bar(at, [s[f"{lab}_rmse_m"][i] for lab in names], w * 0.92, color=series_style(i)["color"],
               hatch=hatches[i % len(hatches)], edgecolor="white", linewidth=0.4, label=f"this run, $r$ = {r:g} m")
        pub = np.array([s[f"{lab}_published_rmse_m"][i] for lab in names])
        ax.plot(at, pub, linestyle="none", **{k: v for k, v in PUBLISHED.items() if k not in ("linestyle", "linewidth")},
                label=published_label("Geng 2015, Table 6.2") if i == 0 else None)
    ax.set_xticks(x, [_tracker_name(lab).replace(", ", "\n") for lab in names])
    ax.set(xlabel="tracker", ylabel="average RMSE [m]", title="Average RMSE per tracker and sensing range $r$")
    flagged = []
    for k, lab in enumerate(names):
        ratio = np.array([s[f"{lab}_published_rmse_m"][i] / s[f"{lab}_rmse_m"][i] for i in range(n)])
        if np.all(np.isfinite(ratio)) and (ratio.min() > 1.5 or ratio.max() < 1 / 1.5):
            top = max(np.nanmax([s[f"{lab}_rmse_m"][i] for i in range(n)]),
                      np.nanmax([s[f"{lab}_published_rmse_m"][i] for i in range(n)]))
            ax.annotate("not\nreproduced", (x[k], top), xytext=(0, 4), textcoords="offset points", ha="center",
                        va="bottom", fontsize=6, color="0.2")
            flagged.append(f"{_tracker_name(lab)} {ratio.min():.1f}-{ratio.max():.1f}× below the published values")
    ax.set_ylim(top=ax.get_ylim()[1] * 1.08)
    return "; ".join(flagged)


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Draw the figures; see :func:`rfsim.scenarios.tag_to_tag_tracking.plot`."""
    path, ds = Path(dataset_path), _dataset.read_dataset(dataset_path)
    t = {name: {k: c.data for k, c in cols.items()} for name, cols in ds.tables.items()}
    size = _size(t)
    out = []
    with paper_style():
        fig, ax = figure(columns=1, height_in=3.4)
        flagged = _table(ax, t["summary"])
        legend_outside(ax, where="below", ncols=2)
        caption(fig, f"After {cite('geng', 'Table 6.2')}.", f"{size}.",
                f"Not reproduced: {flagged} (KF readings: {cite('geng', 'L1115-L1119')})." if flagged else "")
        out.append(save_figure(fig, figure_path(path, Path(out_dir), "table6_2")))
        if "runs" in t:
            fig, ax = figure(columns=1, height_in=3.2)
            _cdf(ax, t["runs"])
            legend_outside(ax, where="below", ncols=3)
            caption(fig, f"After {cite('geng', 'Fig. 6.4')}.", f"{size}; one RMSE per (trajectory, filter run).")
            out.append(save_figure(fig, figure_path(path, Path(out_dir), "cdf")))
        if "estimates" in t:
            fig, ax = figure(columns=2, height_in=2.7)
            _tracks(ax, ds.attrs, t["estimates"], t["truth"])
            legend_outside(ax, where="below", ncols=4)
            caption(fig, f"After {cite('geng', 'Fig. 6.3')} (the layout of the figure is not in the text: 5 tags per "
                         "shelf, recorded in the dataset). PF with the largest M and RBPF: first filter run.")
            out.append(save_figure(fig, figure_path(path, Path(out_dir), "tracks")))
            fig, ax = figure(columns=1, height_in=3.0)
            _error_vs_time(ax, t["estimates"])
            legend_outside(ax, where="below", ncols=3)
            caption(fig, f"Setup of {cite('geng', 'ch. 6')} (no figure of the source).",
                    f"RMS over {np.unique(t['estimates']['trajectory']).size} trajectories in 0.5 s bins; PF and "
                    "RBPF: the first of the filter runs of each trajectory (the dataset keeps its estimates).")
            out.append(save_figure(fig, figure_path(path, Path(out_dir), "error-time")))
    return out



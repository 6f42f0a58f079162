"""Figures of the HIMR scenarios (``himr-1d``, ``himr-2d``), drawn from the dataset alone in the
project's figure style (:mod:`rfsim.core.figure_style`).

* ``-trajectory``: true vs estimated distance (1-D) or track (2-D);
* ``-errors``: position error vs time per estimator (1-D, beside the source's 1 mm, 9 mm and
  2.5 cm) or per case and observer variant (2-D, the outage shaded);
* ``-rss-phase``: RSS and the phase-derived radial velocity per pylon, the aliasing limit and
  the aliased packets marked (the measured curves of the source's Fig. 15);
* ``-eigenvalues``: stability of the 1-D observer's Euler step vs packet rate; the 2-D
  observers' frozen-time eigenvalues along the trajectory with the heading (Fig. 82).

The per-packet and IMU tables are :mod:`rfsim.scenes.himr_air`'s, the measurement stream and
the cases :mod:`rfsim.estimators.himr_cases`'.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from rfsim.core.dataset import read_dataset, read_provenance, read_table
from rfsim.core.figure_style import PUBLISHED, figure, legend_outside, paper_style, published_label, series_style
from rfsim.core.plots import figure_path, save_figure
from rfsim.core.references import cite
from rfsim.scenarios._captions import caption, unique_handles
from rfsim.estimators.himr_cases import OUTAGE_S

#: Grey of the true track or distance, drawn wide under the estimates so they stay visible.
TRUE_STYLE = dict(color="0.55", linestyle="-", linewidth=3.2, alpha=0.55, solid_capstyle="round", zorder=1)
#: The source in legend entries (the caption cites it in full).
SHORT = "Akbar 2016"
#: What the 2-D figures call an observer run (variant, dealias) in the legend.
VARIANT_NAMES = {"literal": "literal observer", "prerotated": "prerotated observer", "ekf": "EKF"}


def _config(dataset_path) -> dict:
    """The resolved config of the run (provenance), {} if the file has none."""
    text = read_provenance(dataset_path).get("config_toml", "")
    return tomllib.loads(text) if text else {}


def _every(n_points: int, i: int, per_line: int = 14) -> tuple[int, int]:
    """``markevery`` of the ``i``-th series: about ``per_line`` markers, staggered between series
    so that coinciding curves still show each one's markers."""
    step = max(1, n_points // per_line)
    return ((i * step) // 4 % step, step)


# ----------------------------------------------------------------------------- RSS and radial velocity


def plot_rss_phase(packets: dict, source: str, *, size_note: str):
    """RSS and phase-derived radial velocity per pylon vs time (one velocity panel per pylon):
    the measured values as markers, the true radial velocity as a grey line, the aliasing
    limit ±λ/(4Δt) dashed and the packets whose phase step aliased as hollow markers."""
    pylons = np.unique(packets["pylon"])
    n = pylons.size
    if n == 1:
        fig, axes = figure(columns=1, nrows=2, height_in=4.3, sharex=True)
        a_rss, a_vel = axes[0], list(axes[1:])
    else:
        fig, axes = figure(columns=2, nrows=(n + 2) // 2, ncols=2, height_in=2.0 * ((n + 2) // 2) + 1.0,
                           sharex=True)
        axes = axes.ravel()
        a_rss, a_vel = axes[0], list(axes[1:n + 1])
        for ax in axes[n + 1:]:
            ax.remove()
    t = packets["t_s"]
    limits = []
    for i, u in enumerate(pylons):
        s = packets["pylon"] == u
        st = series_style(i)
        f_ghz = packets["carrier_hz"][s][0] / 1e9
        a_rss.plot(t[s], packets["rss_dbm"][s], color=st["color"], linestyle=st["linestyle"], marker=st["marker"],
                   markevery=_every(int(s.sum()), i), label=f"pylon {u} ({f_ghz:.2f} GHz)")
        ax = a_vel[i]
        ax.plot(t[s], packets["true_radial_velocity_mps"][s], **{**TRUE_STYLE, "linewidth": 2.4},
                label="true $\\dot r$")
        ok = s & (packets["aliased"] == 0)
        al = s & (packets["aliased"] > 0)
        ax.plot(t[ok], packets["radial_velocity_mps"][ok], linestyle="none", marker=st["marker"], markersize=2.2,
                color=st["color"], label="measured (the pylon's marker)")
        if al.any():
            ax.plot(t[al], packets["radial_velocity_mps"][al], linestyle="none", marker=st["marker"], markersize=3.2,
                    markerfacecolor="none", markeredgewidth=0.7, color=st["color"], label="measured, aliased (hollow)")
        lim = np.nanmedian(packets["aliasing_limit_mps"][s])
        if np.isfinite(lim):
            limits.append(f"{lim:.2f}")
            for sign in (1, -1):
                ax.axhline(sign * lim, color="0.3", linestyle=(0, (4, 2)), linewidth=0.8,
                           label="aliasing limit $\\pm\\lambda/(4\\Delta t)$" if sign > 0 else None)
        ax.set_ylabel(f"$\\dot r$ [m/s]")
        ax.set_title(f"pylon {u}: $\\dot r$, {int(al.sum())} of {int(s.sum())} aliased")
        top = max(np.nanmax(np.abs(packets["true_radial_velocity_mps"][s])), lim if np.isfinite(lim) else 0.0)
        ax.set_ylim(-1.25 * top, 1.25 * top)
    a_rss.set_ylabel("RSS [dBm]")
    a_rss.set_title("RSS of the modulated part")
    for ax in [a_rss, *a_vel][-2 if n > 1 else -1:]:
        ax.set_xlabel("time $t$ [s]")
    legend_outside(a_vel[-1], where="below", handles=unique_handles(*([a_rss] if n > 1 else []), *a_vel), ncols=2)
    caption(fig, f"After {source}; radial velocity from the packet-to-packet phase step (eq. 23), aliasing "
                 f"limit ±{'/'.join(limits)} m/s.", f"{size_note.capitalize()}.")
    return fig


# ----------------------------------------------------------------------------- 1-D


def plot_1d(dataset_path: Path, out_dir: Path, estimators) -> list[Path]:
    """The four figures of ``himr-1d`` (module docstring)."""
    est, truth, pk, dg = (read_table(dataset_path, k) for k in ("estimates", "truth", "packets", "diagnostics"))
    gains = {k: c.data for k, c in read_dataset(dataset_path).grids["gains"][1].items()}
    n_pk, rate = pk["t_s"].size, 1.0 / np.median(dg["step_s"])
    size = f"one run: {n_pk} packets at {rate:.0f} packets/s"
    names = {"himr": "HIMR observer", "rss": "RSS range alone", "double-integration": "double integration"}
    out = []
    with paper_style():
        fig, ax = figure(columns=1, height_in=3.0)
        ax.plot(truth["t_s"], truth["z_m"], **TRUE_STYLE, label="true")
        for i, name in enumerate(estimators):
            s = est["estimator"] == name
            ax.plot(est["t_s"][s], est["z_hat_m"][s], linewidth=0.9, markevery=_every(int(s.sum()), i, 12),
                    label=names.get(name, name), **series_style(i))
        ax.set(xlabel="time $t$ [s]", ylabel="distance $z$ [m]", title="True and estimated distance to the pylon")
        legend_outside(ax, where="below", ncols=2)
        caption(fig, f"After {cite('himr', 'Figs. 12-16')}.", f"{size.capitalize()}.",
                "HIMR and RSS lie within 5 mm of the true distance (error figure).")
        out.append(save_figure(fig, figure_path(dataset_path, out_dir, "trajectory")))

        fig, (a1, a2) = figure(columns=1, nrows=2, height_in=4.2, sharex=True,
                               gridspec_kw={"height_ratios": (2.2, 1.0)})
        for i, name in enumerate(estimators):
            s = est["estimator"] == name
            a1.plot(est["t_s"][s], 1e3 * np.abs(est["error_m"][s]), linewidth=0.9,
                    markevery=_every(int(s.sum()), i, 12), label=names.get(name, name), **series_style(i))
        pub = {1.0: "Fig. 12: HIMR,\nsimulation", 9.0: "Fig. 16: HIMR\npeak, experiment",
               25.0: "Fig. 13: double-\nintegration drift"}
        for k, v in enumerate(pub):
            a1.axhline(v, color=PUBLISHED["color"], linestyle=PUBLISHED["linestyle"], linewidth=0.8, zorder=3,
                       label=published_label(SHORT) if k == 0 else None)
        right = a1.secondary_yaxis("right")
        right.set_yticks(list(pub), list(pub.values()), fontsize=5.5)
        a1.set(ylim=(0, 30), ylabel="$|z - \\hat z|$ [mm]", title="Distance error per estimator")
        h, r = (est["estimator"] == "himr"), (est["estimator"] == "rss")
        if h.any() and r.any():
            a2.plot(est["t_s"][h], 1e3 * (est["z_hat_m"][h] - est["z_hat_m"][r]), **series_style(0),
                    markevery=_every(int(h.sum()), 0, 12), linewidth=0.9)
        a2.set(xlabel="time $t$ [s]", ylabel="HIMR − RSS [mm]")
        legend_outside(a2, where="below", handles=a1.get_legend_handles_labels()[0], ncols=2)
        caption(fig, f"{size.capitalize()}.", f"Published: {cite('himr', 'Sec. 2.5-2.7')}.")
        out.append(save_figure(fig, figure_path(dataset_path, out_dir, "errors")))

        out.append(save_figure(plot_rss_phase(pk, cite("himr", "Fig. 15"), size_note=size),
                               figure_path(dataset_path, out_dir, "rss-phase")))

        fig, ax = figure(columns=1, height_in=2.6)
        lam = gains["eig_real"] + 1j * gains["eig_imag"]
        f = np.linspace(100.0, max(600.0, 1.5 * rate), 400)
        rho = np.abs(1.0 + np.outer(1.0 / f, lam)).max(axis=1)
        f_min = 2.0 / np.abs(lam.real).max() if lam.real.max() < 0 else np.nan
        ax.plot(f, rho, **series_style(0), markevery=40, label="$\\rho(I + T(A - LC))$, $T = 1/f$")
        ax.plot(1.0 / dg["step_s"], dg["euler_spectral_radius"], linestyle="none", marker="D", markersize=5,
                color=series_style(1)["color"], label=f"this run ({rate:.0f} /s)")
        ax.axhline(1.0, color="0.3", linewidth=0.8, linestyle=(0, (4, 2)), label="limit $\\rho = 1$")
        if np.isfinite(f_min):
            ax.axvspan(f[0], 1.0 / f_min, color="0.85", zorder=0, label=f"unstable: $f$ < {1 / f_min:.1f} /s")
        ax.set(xlabel="packet rate $f$ [packets/s]", ylabel="spectral radius $\\rho$ [–]", xlim=(f[0], f[-1]),
               title="Stability of the observer's Euler step")
        legend_outside(ax, where="below", ncols=2)
        eig = ", ".join(f"{v.real:.0f}" + (f"{v.imag:+.1f}j" if v.imag else "") for v in lam)
        caption(fig, f"Forward Euler at the packet epochs: eigenvalues 1 + T·eig(A - LC), eig(A - LC) = {eig} 1/s "
                     f"(W, V of {cite('himr', 'L571')}).")
        out.append(save_figure(fig, figure_path(dataset_path, out_dir, "eigenvalues")))
    return out


# ----------------------------------------------------------------------------- 2-D


def _runs_of_case_1(est) -> list[tuple[str, str, np.ndarray]]:
    """(variant, dealias, row mask) of every case-1 run."""
    s = est["case"] == 1
    runs = sorted(set(zip(est["variant"][s].tolist(), est["dealias"][s].tolist())))
    return [(v, d, s & (est["variant"] == v) & (est["dealias"] == d)) for v, d in runs]


def _metres(v: float) -> str:
    """A length for a legend: mm, cm, m or km, three digits."""
    for unit, f in (("km", 1e3), ("m", 1.0), ("cm", 1e-2)):
        if abs(v) >= f:
            return f"{v / f:.3g} {unit}"
    return f"{v * 1e3:.3g} mm"


def _run_label(variant: str, dealias: str) -> str:
    return f"{VARIANT_NAMES.get(variant, variant)}, {dealias} dealiasing"


def plot_2d(dataset_path: Path, out_dir: Path) -> list[Path]:
    """The four figures of ``himr-2d`` (module docstring)."""
    ds = read_dataset(dataset_path)
    est, truth, pk, dg, sm = (read_table(dataset_path, k) for k in ("estimates", "truth", "packets", "diagnostics",
                                                                      "summary"))
    cfg = _config(dataset_path)
    outage = tuple(cfg.get("observer", {}).get("outage_s", OUTAGE_S))
    n_pk = int(ds.attrs.get("n_packets", truth["t_s"].size))
    size = f"one run: {n_pk} packets at {1.0 / np.median(np.diff(truth['t_s'])):.0f} packets/s"
    path = lambda what: figure_path(dataset_path, out_dir, what)  # noqa: E731
    out = []
    with paper_style():
        fig, ax = figure(columns=1, height_in=4.4)
        ax.plot(truth["x"], truth["y"], **TRUE_STYLE, label="true track")
        span = [truth["x"].min() - 0.45, truth["x"].max() + 0.45, truth["y"].min() - 0.45, truth["y"].max() + 0.45]
        for i, (v, d, s) in enumerate(_runs_of_case_1(est)):
            x, y = est["x_hat"][s], est["y_hat"][s]
            inside = (x >= span[0]) & (x <= span[1]) & (y >= span[2]) & (y <= span[3])
            label, st = _run_label(v, d), series_style(i)
            if not inside.all():
                k = int(np.flatnonzero(~inside)[0])
                label += (f"\n(leaves the frame at {est['t_s'][s][k]:.2f} s, marked ✕;"
                          f" max error {_metres(np.nanmax(est['error_m'][s]))})")
                ax.plot(np.clip(x[k], *span[:2]), np.clip(y[k], *span[2:]), marker="X", markersize=7,
                        color=st["color"], markeredgecolor="white", linestyle="none", zorder=4)
            ax.plot(np.where(inside, x, np.nan), np.where(inside, y, np.nan), linewidth=0.9, markersize=2.8,
                    markevery=_every(int(s.sum()), i, 20), label=label, **st)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set(xlabel="$x$ [m]", ylabel="$y$ [m]",
               title="True and estimated track, case 1")
        legend_outside(ax, where="below", ncols=1)
        caption(fig, f"After {cite('himr', 'Figs. 68-71')}.", f"{size.capitalize()}.")
        out.append(save_figure(fig, path("trajectory")))

        fig, (a1, a2) = figure(columns=2, nrows=2, height_in=5.0, sharex=True)
        main = ds.attrs.get("dealias", "gated")
        pre = (est["variant"] == "prerotated") & (est["dealias"] == main)
        case_names = {int(c): str(n) for c, n in zip(sm["case"], sm["case_name"])}
        a1.axvspan(*outage, color="0.88", zorder=0, label=f"outage of cases 2-5 ({outage[0]:g}-{outage[1]:g} s)")
        for i, c in enumerate(np.unique(est["case"])):
            s = pre & (est["case"] == c)
            if s.any():
                a1.plot(est["t_s"][s], np.maximum(est["error_m"][s], 1e-4), linewidth=0.9,
                        markevery=_every(int(s.sum()), i, 16), label=f"case {c}: {case_names.get(int(c), '')}",
                        **series_style(i))
        top = 10.0
        for i, (v, d, s) in enumerate(_runs_of_case_1(est)):
            e = np.maximum(est["error_m"][s], 1e-4)
            a2.plot(est["t_s"][s], np.where(e > top, np.nan, e), linewidth=0.9, markevery=_every(int(s.sum()), i, 16),
                    label=_run_label(v, d), **series_style(i))
            if e.max() > top:
                k = int(np.argmax(e > top))
                a2.annotate(f"leaves the axes at {est['t_s'][s][k]:.2f} s,\n{_metres(e[-1])} at {est['t_s'][s][-1]:.1f} s",
                            (est["t_s"][s][k], top), xytext=(0.3, 0.93), textcoords="axes fraction", va="top",
                            fontsize=6,
                            color=series_style(i)["color"], arrowprops=dict(arrowstyle="->", color=series_style(i)["color"],
                                                                            linewidth=0.7))
        a1.set(yscale="log", ylabel="position error [m]", title=f"prerotated observer, {main} dealiasing: cases 1-7")
        a2.set(yscale="log", ylim=(1e-4, 2 * top), xlabel="time $t$ [s]", ylabel="position error [m]",
               title="case 1 (all measurements): every observer variant")
        legend_outside(a1)
        legend_outside(a2)
        caption(fig, f"After {cite('himr', 'Figs. 68-96')} (cases: L1050-L1072).", f"{size.capitalize()}.")
        out.append(save_figure(fig, path("errors")))

        out.append(save_figure(plot_rss_phase(pk, cite("himr", "Ch. IV"), size_note=size),
                               path("rss-phase")))

        fig, (a1, a2) = figure(columns=1, nrows=2, height_in=4.0, sharex=True, gridspec_kw={"height_ratios": (2, 1)})
        lo, hi = ds.attrs.get("literal_unstable_from_s", np.nan), ds.attrs.get("literal_unstable_to_s", np.nan)
        for ax in (a1, a2):
            if np.isfinite(lo) and np.isfinite(hi):
                ax.axvspan(lo, hi, color="0.88", zorder=0, label=f"literal unstable ({lo:.2f}-{hi:.2f} s)")
        a1.plot(dg["t_s"], dg["max_real_eig_literal"], markevery=16, label="literal (heading in $C$)", **series_style(0))
        a1.plot(dg["t_s"], dg["max_real_eig_prerotated"], markevery=(8, 16), label="prerotated accelerations",
                **series_style(1))
        a1.axhline(0.0, color="0.3", linewidth=0.8, linestyle=(0, (4, 2)))
        a1.set(ylabel="max Re eig$(A - LC(x(t)))$ [1/s]", title="Observer error dynamics along the true track")
        a2.plot(truth["t_s"], np.degrees(truth["psi"]), color="0.25", linestyle="-", linewidth=1.2, label="true heading $\\psi$")
        psi_deg = np.degrees(truth["psi"])
        lo_d, hi_d = np.nanmin(psi_deg), np.nanmax(psi_deg)
        bounds = np.arange(90.0 + 180.0 * np.ceil((lo_d - 180.0) / 180.0), hi_d + 90.0 + 1e-9, 180.0)
        bounds = bounds[bounds >= lo_d - 90.0]
        for k, b in enumerate(bounds):
            a2.axhline(b, color="0.3", linewidth=0.8, linestyle=(0, (4, 2)),
                       label="$\\psi = \\pi \\pm 90°$ (mod 360°)" if k == 0 else None)
        y0, y1 = min(lo_d, bounds.min()) - 30.0, max(hi_d, bounds.max()) + 30.0
        a2.set(xlabel="time $t$ [s]", ylabel="heading $\\psi$ [°]", ylim=(y0, y1),
               yticks=np.arange(90.0 * np.ceil(y0 / 90.0), y1, 90.0))
        legend_outside(a2, where="below", handles=unique_handles(a1, a2), ncols=2)
        caption(fig, f"After {cite('himr', 'Fig. 82')}, here along the actual track (positive: locally unstable).")
        out.append(save_figure(fig, path("eigenvalues")))
    return out


__all__ = ["plot_rss_phase", "plot_1d", "plot_2d"]

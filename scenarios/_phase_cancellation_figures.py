"""Figures of the ``phase-cancellation`` scenario (:mod:`rfsim.scenarios.phase_cancellation`), drawn from its dataset alone.

The scenario module composes and runs; this module only draws (``plot`` is called through
the scenario's ``plot``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rfsim.core.lazy import lazy_import
from rfsim.core.figure_style import (OKABE_ITO, PUBLISHED, ci_errorbar, dodge, figure, legend_outside, paper_style,
                                     published_label, series_style, shade_no_data, source_note)
from rfsim.core.plots import figure_path, grid_arrays, run_config, save_figure
from rfsim.core.references import cite

sa = lazy_import("rfsim.devices.st_analytic")
_sat = lazy_import("rfsim.devices.sense_a_tag")
_dataset = lazy_import("rfsim.core.dataset")


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Draw the figures; see :func:`rfsim.scenarios.phase_cancellation.plot`."""
    ds = _dataset.read_dataset(dataset_path)
    paths = []
    with paper_style():
        paths.append(_plot_fig3_3_3_5(ds, figure_path(dataset_path, out_dir, "fig3_3_3_5")))
        paths.append(_plot_fig3_8(ds, figure_path(dataset_path, out_dir, "fig3_8")))
        paths.append(_plot_fig3_15(ds, figure_path(dataset_path, out_dir, "fig3_15")))
        paths.append(_plot_fig3_16(ds, dataset_path, figure_path(dataset_path, out_dir, "fig3_16")))
    return paths


def _phase_axis(ax) -> None:
    """x axis of a relative phase θ in [−π, π] with ticks at multiples of π/2."""
    ax.set_xticks(np.linspace(-np.pi, np.pi, 5), [r"$-\pi$", r"$-\pi/2$", "0", r"$\pi/2$", r"$\pi$"])
    ax.set_xlabel(r"relative phase $\theta$ [rad]")


def _plot_fig3_3_3_5(ds, path: Path) -> Path:
    fig, axs = figure(columns=2, ncols=2, height_in=3.0)
    (c3, v3), (c5, v5) = grid_arrays(ds, "fig3_3"), grid_arrays(ds, "fig3_5")
    labels = ([f"$A_{{T1}}$ = {v3['a_t1'][i]:g}, $A_{{T2}}$ = {v3['a_t2'][i]:g}" for i in range(v3["diff"].shape[0])],
              [rf"$\psi = \pi/{np.pi / p:.0f}$" for p in c5["psi_rad"]])
    titles = ("ASK, $A_R$ = 1 (Eq. 3.4, Fig. 3.3)", "PSK, $A_R$ = 1, $A_T$ = 0.4 (Eq. 3.9, Fig. 3.5)")
    for a, (c, v), names, title in zip(axs, ((c3, v3), (c5, v5)), labels, titles):
        for i, label in enumerate(names):
            a.plot(c["theta_rad"], v["diff"][i], label=label, markevery=25, ms=3.5, **series_style(i))
        a.set_title(title)
        _phase_axis(a)
        a.set_ylabel(r"$|A_1 - A_2|$ [units of $A_R$]")
        legend_outside(a, where="below", ncols=2)
    fig.suptitle("Envelope difference against the relative phase of backscatter and CW\n"
                 f"(closed forms; {cite('auris', 'Figs. 3.3 and 3.5')})")
    return save_figure(fig, path)


def _plot_fig3_8(ds, path: Path) -> Path:
    c, v = grid_arrays(ds, "fig3_8")
    fig, ax = figure(columns=1, height_in=4.4)
    im = ax.pcolormesh(c["x_m"], c["y_m"], 1e3 * v["diff_v"], shading="auto", cmap="gray", vmax=20.0)
    fig.colorbar(im, ax=ax, extend="max", label=r"$|A_1 - A_2|$ [mV] (white: $\geq$ 20 mV)")
    ax.plot([0], [0], "^", color=OKABE_ITO[0], mec="white", ms=8, clip_on=False, zorder=5, label="reader (0, 0) m")
    ax.plot([0], [2], "s", color=OKABE_ITO[1], mec="white", ms=6, zorder=5, label="tag (0, 2) m")
    ax.set(xlim=(c["x_m"].min(), c["x_m"].max()), xticks=np.linspace(-1.0, 1.0, 5),
           ylim=(min(0.0, c["y_m"].min()), c["y_m"].max()), xlabel="$x$ [m]", ylabel="$y$ [m]", aspect="equal")
    ax.grid(False)
    legend_outside(ax, where="below", ncols=2)
    fig.suptitle(f"Null map of Eq. 3.4 with Eq. 3.23, dark: cancellation\n({cite('auris', 'Fig. 3.8')})")
    return save_figure(fig, path)


def _plot_fig3_15(ds, path: Path) -> Path:
    c, v = grid_arrays(ds, "tracks")
    n = len(c["angle_deg"])
    ncols = 2 if n > 1 else 1
    fig, axs = figure(columns=2, nrows=(n + ncols - 1) // ncols, ncols=ncols, sharex=True, sharey=True,
                      squeeze=False, height_in=1.9 * ((n + ncols - 1) // ncols) + 0.6)
    worst = 0.0
    for i, a in enumerate(axs.flat):
        if i >= n:
            a.remove()
            continue
        a.plot(c["distance_m"], 1e3 * v["closed_diff_v"][i], label="Eq. 3.4 from the measured amplitudes",
               **{**series_style(0), "marker": None})
        a.plot(c["distance_m"], 1e3 * v["diff_v"][i], ls="none", marker="o", ms=3.2, mfc="none", mew=0.7,
               color=OKABE_ITO[1], label="sample level (detector output)")
        worst = max(worst, float(np.nanmax(np.abs(v["diff_v"][i] - v["closed_diff_v"][i]))))
        a.set_title(f"track at {c['angle_deg'][i]:g}°")
        a.set(xlabel="ST distance from the tag [m]", ylabel=r"$|A_1 - A_2|$ [mV]")
        a.label_outer()
    legend_outside(axs.flat[0], where="figure")
    fig.suptitle(f"Radial tracks around the tag at angles from the tag–reader direction\n"
                 f"({cite('auris', 'Fig. 3.15')}; one y scale)")
    source_note(fig, f"sample level and closed form differ by at most {1e3 * worst:.2g} mV on these tracks")
    return save_figure(fig, path)


def _plot_fig3_16(ds, dataset_path: Path, path: Path) -> Path:
    cells = _dataset.read_table(dataset_path, "cells")
    x = cells["tag_x_m"]
    silent = cells["tag_replied_fraction"] == 0
    fig, ax = figure(columns=2, height_in=3.0)
    spacing = float(np.min(np.diff(x))) if x.size > 1 else 1.0
    for i, name in enumerate(_sat.TECHNIQUES):
        if f"p_{name}" not in cells:
            continue
        p = np.where(silent, np.nan, cells[f"p_{name}"])
        ci_errorbar(ax, dodge(x, i, len(_sat.TECHNIQUES), width=0.5 * spacing), p, cells[f"ci_lo_{name}"],
                    cells[f"ci_hi_{name}"], scale=100.0, label=_TECHNIQUE_LABELS.get(name, name), **series_style(i))
    ax.axhline(1.0, **{**PUBLISHED, "marker": None},
               label=published_label("AURIS Fig. 3.16") + ": path selection < 1 %")
    hatch = shade_no_data(ax, x, silent, label="tag not powered: no trials")
    ax.set(xlabel="tag position $x$ [m] (cell)", ylabel="P(phase cancellation) [%]", ylim=(-2, None),
           xticks=x[::2] if x.size > 8 else x)
    handles = ax.get_legend_handles_labels()[0] + ([hatch] if hatch is not None else [])
    legend_outside(ax, where="below", handles=handles, ncols=3, title="technique (Clopper-Pearson 95 %)")
    antennas = ("tag: " + ("PASS's 6.02 dBi file" if "PASS" in str(ds.attrs.get("tag_antenna", "")) else "half-wave dipole")
                + ", ST: " + ("PASS's file" if "PASS" in str(ds.attrs.get("st_antenna", "")) else "half-wave dipoles"))
    ax.set_title("Probability of phase cancellation per technique, this model\n"
                 f"to compare with {cite('auris', 'Fig. 3.16 and 5.8')}")
    mc = run_config(dataset_path).get("mc", {})
    size = (f"{int(np.median(cells['n_samples']))} ST samples per cell "
            f"({mc.get('positions_per_cell', '?')} positions × {mc.get('repetitions', '?')} repetitions)")
    if not mc.get("full", True):
        size = "reduced default Monte Carlo: " + size + "; the source's size: mc.full = true (300 × 3)"
    source_note(fig, f"{size}; {antennas}")
    return save_figure(fig, path)


#: Legend names of the sense-a-tag techniques.
_TECHNIQUE_LABELS = {"single": "single antenna", "combination": "simple combination",
                     "selection": "path selection (Alg. 1)", "stamp": "ASK-PSK stamp"}

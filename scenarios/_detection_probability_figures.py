"""Figures of the ``detection-probability`` scenario (:mod:`rfsim.scenarios.detection_probability`), drawn from its dataset alone.

The scenario module composes and runs; this module only draws (``plot`` is called through
the scenario's ``plot``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rfsim.core.errors import UserError
from rfsim.core.figure_style import (OKABE_ITO, PUBLISHED, ci_errorbar, figure, legend_outside, paper_style,
                                     published_label, source_note)
from rfsim.core.plots import figure_path, save_figure
from rfsim.core.references import cite
from rfsim.core.lazy import lazy_import

_dataset = lazy_import("rfsim.core.dataset")
_detection = lazy_import("rfsim.detection")



# ----------------------------------------------------------------------------- plots


def plot(dataset_path: Path, out_dir: Path, *, fit_file) -> list[Path]:
    """Draw the figures, the models fitted by ``fit_file(dataset_path)``; see
    :func:`rfsim.scenarios.detection_probability.plot`."""
    from matplotlib.lines import Line2D

    det = _detection
    s = _dataset.read_table(dataset_path, "samples")
    try:
        fits = fit_file(dataset_path)
    except UserError:
        fits = None
    coefs = [] if fits is None else [
        (fits["model"][i], fits["source"][i], np.array([fits[f"a{j}"][i] for j in range(5)]))
        for i in range(fits["model"].size)]
    coefs = [(m, src, c[np.isfinite(c)]) for m, src, c in coefs]
    y = s["st_detected"].astype(float)
    colour = {"RTS": OKABE_ITO[0], "TS": OKABE_ITO[1]}
    published = {"RTS": dict(PUBLISHED), "TS": {**PUBLISHED, "linestyle": ":", "marker": "s"}}
    with paper_style():
        fig, axes = figure(columns=2, ncols=2, height_in=3.2, sharey=True)
        for ax, var, sel, edges, xlab, fixed in (
                (axes[0], "D_m", (s["d_m"] >= 0.4) & (s["d_m"] <= 1.0), np.arange(1.0, 10.01, 0.3),
                 "reader antenna–tag distance $D$ [m]", 0.6),
                (axes[1], "d_m", (s["D_m"] >= 2.0) & (s["D_m"] <= 4.0), np.arange(0.0, 2.01, 0.2),
                 "ST–tag distance $d$ [m]", 3.0)):
            edges = _merged_edges(s[var][sel], edges, MIN_BIN_SAMPLES)
            b = det.binned_probability(s[var][sel], y[sel], edges)
            ok = b.trials > 0
            ci_errorbar(ax, b.centers[ok], b.p_hat[ok], b.lower[ok], b.upper[ok], scale=100.0,
                        xerr=0.5 * np.diff(edges)[ok], color="0.15", marker="o", ms=3.5, linestyle="none",
                        elinewidth=0.7, zorder=4)
            x = np.linspace(edges[0], edges[-1], 200)
            th, ph = (float(np.median(np.abs(s[k][sel]))) if sel.any() else 0.0 for k in ("theta_rad", "phi_rad"))
            at = rf"$|\theta|$ = {th:.2f}, $|\phi|$ = {ph:.2f} rad (medians)"
            if var == "D_m":
                curves = {"RTS": det.rts_design(x, fixed, th, ph), "TS": det.ts_design(np.full_like(x, fixed))}
                ax.set_title(f"$d$ in [0.4, 1] m ({int(sel.sum())} samples);\ncurves at $d$ = 0.6 m and\n{at}")
            else:
                curves = {"RTS": det.rts_design(fixed, x, th, ph), "TS": det.ts_design(x)}
                ax.set_title(f"$D$ in [2, 4] m ({int(sel.sum())} samples);\ncurves at $D$ = 3 m and\n{at}")
            for model, source, coef in coefs:
                pr = 100 * det.predict_proba(curves[model], coef)
                if source == "fit":
                    ax.plot(x, pr, color=colour[model], ls="-" if model == "RTS" else "--", lw=1.3)
                else:
                    ax.plot(x, pr, markevery=25, **published[model])
            # the fitted models averaged over the samples of each bin (the binned data mix all
            # angles and the other distance, the curves above fix them)
            feats = {"RTS": det.rts_design(s["D_m"][sel], s["d_m"][sel], s["theta_rad"][sel], s["phi_rad"][sel]),
                     "TS": det.ts_design(s["d_m"][sel])}
            k = np.clip(np.searchsorted(edges, s[var][sel], side="right") - 1, 0, edges.size - 2)
            for model, source, coef in coefs:
                if source == "fit":
                    pr = det.predict_proba(feats[model], coef)
                    mean_pr = np.bincount(k, pr, minlength=edges.size - 1) / np.maximum(b.trials, 1)
                    ax.plot(b.centers[ok], 100 * mean_pr[ok], ls="none", marker="D" if model == "RTS" else "v",
                            ms=3.5, mfc="white", mec=colour[model], mew=0.9, zorder=5)
            ax.set(xlabel=xlab, ylim=(-2, 102))
        axes[0].set_ylabel("P(ST decodes the tag's RN16) [%]")
        handles = [Line2D([], [], color="0.15", marker="o", ms=3.5, ls="none",
                          label=f"simulated, binned (≥ {MIN_BIN_SAMPLES}\nsamples/bin; Wilson 95 %)")]
        for model in ("RTS", "TS"):
            if any(m == model and src == "fit" for m, src, _ in coefs):
                handles += [Line2D([], [], color=colour[model], ls="-" if model == "RTS" else "--",
                                   label=f"{model} ML fit of this run"),
                            Line2D([], [], ls="none", marker="D" if model == "RTS" else "v", mfc="white",
                                   mec=colour[model], label=f"{model} fit averaged\nover the bin's samples")]
            if any(m == model and src != "fit" for m, src, _ in coefs):
                handles.append(Line2D([], [], **published[model],
                                      label=published_label(f"AURIS {model}")))
        legend_outside(axes[1], where="figure", handles=handles)
        fig.suptitle(f"ST detection of the tag's reply, {cite('auris', 'Fig. 4.7')} (RTS/TS models, Eqs. 4.6–4.8)")
        source_note(fig, f"{s['D_m'].size} samples in all; D: reader antenna to tag, d: ST centre to tag, "
                         "θ, φ: azimuth and elevation of the tag seen from the antenna")
        return [save_figure(fig, figure_path(dataset_path, out_dir, "fig4_7"))]


#: Fewest samples in a bin of the Fig. 4.7 analogue (narrow bins are merged up to it).
MIN_BIN_SAMPLES = 40


def _merged_edges(x, edges, min_count: int) -> np.ndarray:
    """``edges`` with neighbouring bins merged, left to right, until each bin holds at least
    ``min_count`` of the values ``x`` (a short remainder joins the last bin)."""
    counts, _ = np.histogram(x, bins=edges)
    kept, run = [edges[0]], 0
    for i, c in enumerate(counts):
        run += c
        if run >= min_count:
            kept.append(edges[i + 1])
            run = 0
    if len(kept) == 1:
        return np.array([edges[0], edges[-1]])
    kept[-1] = edges[-1]  # the remainder (fewer than min_count) joins the last bin
    return np.asarray(kept)

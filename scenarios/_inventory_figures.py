"""Figures of the ``inventory`` scenario (:mod:`rfsim.scenarios.inventory`), drawn from its dataset alone.

The scenario module composes and runs; this module only draws (``plot`` is called through
the scenario's ``plot``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rfsim.core.figure_style import (OKABE_ITO, ci_errorbar, figure, legend_outside, paper_style, series_style,
                                     source_note)
from rfsim.core.plots import figure_path, save_figure
from rfsim.core.references import cite


def _count_text(n: np.ndarray) -> str:
    """"20" or "18-20": the trial counts of the plotted points."""
    if not n.size:
        return "0"
    return f"{n.min()}" if n.min() == n.max() else f"{n.min()}-{n.max()}"


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Draw the figures; see :func:`rfsim.scenarios.inventory.plot`."""
    import h5py

    from rfsim.core.dataset import read_table
    from rfsim.detection.fit import wilson_interval
    from rfsim.protocols.inventory import SLOT_TYPES

    s, inv = read_table(dataset_path, "slots"), read_table(dataset_path, "inventories")
    with h5py.File(dataset_path, "r") as f:
        has_capture, has_sweep = "capture" in f, "capture_sweep" in f
    pops = np.unique(inv["population"])
    runs = np.array([np.sum(inv["population"] == n) for n in pops])
    out = []
    with paper_style():
        fig, (a, b, c) = figure(columns=2, ncols=3, height_in=2.8)
        types = np.asarray(s["slot_type"]).astype(str)
        bottom = np.zeros(pops.size)
        at = np.arange(pops.size)
        n_slots = np.array([np.sum(s["population"] == n) for n in pops])
        for i, st in enumerate(SLOT_TYPES):
            k = np.array([np.sum(types[s["population"] == n] == st) for n in pops])
            frac = k / np.maximum(n_slots, 1)
            a.bar(at, 100 * frac, bottom=100 * bottom, color=OKABE_ITO[i % len(OKABE_ITO)],
                  hatch=_HATCHES[i % len(_HATCHES)], edgecolor="white", lw=0.3, label=st.replace("_", " "))
            # the share's Wilson 95 % interval, centred on its segment (its length is the interval's)
            lo, hi = wilson_interval(k, n_slots)
            mid = 100 * (bottom + frac / 2)
            shown = k > 0
            a.errorbar(at[shown] + 0.3 * (i / max(1, len(SLOT_TYPES) - 1) - 0.5), mid[shown],
                       yerr=np.maximum(0.0, [100 * (frac - lo)[shown], 100 * (hi - frac)[shown]]), fmt="none",
                       ecolor="black", elinewidth=0.6, capsize=1.5)
            bottom += frac
        a.set_xticks(at, [f"{n}\n({k} slots)" for n, k in zip(pops, n_slots)])
        a.set(xlabel="tags $N$", ylabel="share of slots [%] (Wilson 95 %)", ylim=(0, 100), title="slot types")
        a.grid(False)
        legend_outside(a, where="below", ncols=3, title="slot type")
        read = np.array([np.sum(inv["tags_read"][inv["population"] == n]) for n in pops])
        lo, hi = wilson_interval(read, pops * runs)
        ci_errorbar(b, pops, read / (pops * runs), lo, hi, scale=100.0, **series_style(0))
        b.set(xlabel="tags $N$", ylabel="tags read [%] (Wilson 95 %)", ylim=(-3, 103), title="read rate")
        good = np.array([np.round(np.sum((inv["efficiency"] * inv["slots"])[inv["population"] == n]))
                         for n in pops])
        total = np.array([np.sum(inv["slots"][inv["population"] == n]) for n in pops])
        lo, hi = wilson_interval(good, total)
        ci_errorbar(c, pops, good / total, lo, hi, scale=100.0, label="this run (Wilson 95 %)",
                    **series_style(0))
        c.axhline(100 / math.e, color="black", ls="--", lw=1.0, label="$1/e$ (ideal framed Aloha)")
        c.set(xlabel="tags $N$", ylabel="successful slots [%]", title="slot efficiency")
        legend_outside(c, where="below", ncols=1)
        fig.suptitle(f"Inventory with the Q algorithm at sample level ({cite('gen2')}, Annex D)")
        source_note(fig, f"{_count_text(runs)} inventory run(s) per population, runs pooled")
        out.append(save_figure(fig, figure_path(dataset_path, out_dir, "summary")))
        if has_capture or has_sweep:
            fig, axes = figure(columns=2, ncols=3, height_in=3.1)
            if has_capture:
                _plot_capture_trials(axes[0], read_table(dataset_path, "capture"), wilson_interval)
            else:
                axes[0].remove()
            if has_sweep:
                _plot_sweep(axes[1], axes[2], dataset_path)
            else:
                axes[1].remove()
                axes[2].remove()
            fig.suptitle(f"Two tags replying in one slot: capture and RN16 acceptance ({cite('gen2')})")
            if has_sweep:
                sw = read_table(dataset_path, "capture_sweep")
                source_note(fig, "sweep profiles " + ", ".join(dict.fromkeys(np.asarray(sw["profile"]).astype(str)))
                            + f"; RN16 accepted at $E_b/(N_0+I)$ ≥ {float(sw['threshold_db'][0]):.1f} dB")
            out.append(save_figure(fig, figure_path(dataset_path, out_dir, "capture")))
    return out


#: Hatches of the slot types (so the stacked bars do not depend on colour alone).
_HATCHES = ("", "////", "", "\\\\\\\\", "xx", "..", "--")


def _plot_capture_trials(a, c, wilson_interval) -> None:
    """The engine's capture trials: P(capture) per simulated ratio (Wilson 95 %) with the
    trials as ticks at 0 and 100 %."""
    ok = np.isfinite(c["ratio_db"]) & (c["n_replies"] >= 2)
    sel = [ok & (c["point"] == i) for i in np.unique(c["point"][ok])]
    # one marker per simulated nominal ratio, at the mean of its trials' measured ratios
    x = np.array([c["ratio_db"][m].mean() for m in sel])
    n = np.array([np.sum(m) for m in sel])
    k = np.array([np.sum(c["captured"][m]) for m in sel])
    lo, hi = wilson_interval(k, n)
    ci_errorbar(a, x, k / np.maximum(n, 1), lo, hi, scale=100.0,
                label=f"{_count_text(n)} trials/ratio,\nWilson 95 %", **series_style(4))
    a.plot(c["ratio_db"][ok], np.where(c["captured"][ok], 104, -4), "|", color="0.45", ms=5,
           label="one trial (top: captured)")
    a.set(ylim=(-9, 109), xlabel="power ratio near/far\nat the reader [dB]",
          ylabel=r"$P_\mathrm{capture}$ [%]", title="engine, lock-step tags\n(sample level)")
    legend_outside(a, where="below", ncols=1)


def _plot_sweep(a, b, path) -> None:
    """P(capture) vs power ratio (Clopper-Pearson 95 %) and the acceptance trade-off
    (false-ACK rate on a log axis; a zero rate is drawn at half of one collision, 1/(2n);
    Wilson 95 % intervals of both rates at every 4th threshold)."""
    from rfsim.core.dataset import read_table
    from rfsim.detection.fit import wilson_interval

    c, acc = read_table(path, "capture_sweep"), read_table(path, "acceptance")
    code = np.asarray(c["line_code"]).astype(str)
    prof_c, prof_a = np.asarray(c["profile"]).astype(str), np.asarray(acc["profile"]).astype(str)
    i = 0
    for name in dict.fromkeys(prof_c):
        for sp in (0, 1):
            how = "own BLF/T1" if sp else "lock-step"
            m, ma = (prof_c == name) & (c["spread"] == sp), (prof_a == name) & (acc["spread"] == sp)
            if not m.any() and not ma.any():
                continue
            style = series_style(i)
            i += 1
            if m.any():
                ci_errorbar(a, c["ratio_db"][m], c["p_capture"][m], c["ci_lo"][m], c["ci_hi"][m], scale=100.0,
                            ms=3, label=f"{code[m][0]}, {how}", **style)
            if ma.any():
                n_col = np.maximum(acc["collisions"][ma], 1)
                floor = 0.5 / n_col
                x = np.maximum(acc["false_ack_rate"][ma], floor)
                b.plot(x, 100 * acc["missed_capture_rate"][ma], ms=2.5, markevery=4, **style)
                if "captures" in acc:  # Wilson 95 % intervals of both rates, every 4th threshold
                    n_cap = np.maximum(acc["captures"][ma], 1)
                    miss = acc["missed_capture_rate"][ma]
                    m_lo, m_hi = wilson_interval(np.round(miss * n_cap), n_cap)
                    f_lo, f_hi = wilson_interval(np.round(acc["false_ack_rate"][ma] * n_col), n_col)
                    e = slice(None, None, 4)
                    # (clipped at 0: the Wilson bounds at k = 0 or k = n can miss the estimate by an ulp)
                    b.errorbar(x[e], 100 * miss[e],
                               yerr=np.maximum(0.0, [100 * (miss - m_lo)[e], 100 * (m_hi - miss)[e]]),
                               xerr=np.maximum(0.0, [(x - np.maximum(f_lo, floor))[e], (np.maximum(f_hi, floor) - x)[e]]),
                               fmt="none", ecolor=style["color"], elinewidth=0.5, capsize=1.0)
    n = int(c["trials"].min()) if len(c["trials"]) else 0
    a.set(xlabel="power ratio of the two\nreplies at the reader [dB]", ylabel=r"$P_\mathrm{capture}$ [%] (C-P 95 %)",
          ylim=(-3, 103), title=f"batched sweep, {n}\ncollisions/point")
    legend_outside(a, where="below", ncols=1)
    b.set_xscale("log")
    b.set(xlabel="false-ACK rate\nper collided slot (0 at 1/2n)", ylabel="missed captures [%] (Wilson 95 %)",
          title="RN16 acceptance threshold\n0–20 dB (series as left)")

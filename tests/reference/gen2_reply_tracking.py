"""Reference twin of :mod:`rfsim.gen2.reply_tracking` (the block correlations of the clock tracker
in plain NumPy)."""

from __future__ import annotations

import math

import numpy as np


def block_correlations_reference(y, start, u1, u2, el, n_blocks, base, shifts, sub):
    """Plain-NumPy twin of the block-correlation kernel: ``(corr (n_shifts, n_blocks),
    centre offsets (n_blocks,) [samples])``."""
    n_el = el.size
    t = np.arange(int(math.ceil(start)), y.size) - start
    u0 = u1 * t + u2 * t * t
    inside = (u0 >= 0) & (u0 < n_el)
    t, yy = t[inside], y[int(math.ceil(start)):][inside]
    block = np.minimum(np.floor(u0[inside] / (n_el / n_blocks)).astype(np.int64), n_blocks - 1)
    corr = np.empty((shifts.size, n_blocks))
    for i, d in enumerate(shifts):
        s = np.zeros(t.size)
        for e in sub:  # the reference averaged over the sample interval: a smooth function of d
            tt = t - base[block] - d + e
            u = u1 * tt + u2 * tt * tt
            k = np.floor(u).astype(np.int64)
            s += np.where((u >= 0) & (k < n_el), el[np.clip(k, 0, n_el - 1)], 0.0)
        corr[i] = np.bincount(block, weights=yy * s, minlength=n_blocks)
    centres = np.bincount(block, weights=t, minlength=n_blocks) / np.maximum(np.bincount(block, minlength=n_blocks), 1)
    return corr, centres


__all__ = ["block_correlations_reference"]

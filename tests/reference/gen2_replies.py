"""Reference twin of :mod:`rfsim.gen2.reply_search` (the preamble search, SciPy correlation per BLF)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.gen2.reply_core import n_pre_elements, n_reply_elements
from rfsim.gen2.reply_search import (MIN_SAMPLES_PER_ELEMENT, _geometric_grid,
                                     _preamble_template, preamble_correlation)


def _search_reference(r, fs, hyps, lo_of, hi_of):
    """Plain-NumPy twin of :func:`rfsim.gen2.reply_search._search` (scipy correlation per BLF)."""
    best, n_tests = None, 0
    for hyp in hyps:
        step_c = 1.0 / (2.0 * n_pre_elements(hyp.m, hyp.trext))
        for blf in _geometric_grid(hyp.blf_lo_hz, hyp.blf_hi_hz, step_c):
            if 2.0 * blf * MIN_SAMPLES_PER_ELEMENT > fs:
                continue
            lo, hi = int(lo_of(blf)), int(hi_of(blf))
            t0 = _preamble_template(hyp.m, hyp.trext, blf, fs)
            n_rep = int(math.ceil(n_reply_elements(0, hyp.m, hyp.trext) * fs / (2.0 * blf))) + 2
            last = min(hi, r.size - n_rep)
            if last < lo or t0.size < 3:
                continue
            n_tests += last - lo + 1
            c = preamble_correlation(r[lo: last + t0.size], t0)
            k = int(np.argmax(c))
            if best is None or c[k] > best[0]:
                frac = 0.0
                if 0 < k < c.size - 1:
                    den = c[k - 1] - 2.0 * c[k] + c[k + 1]
                    frac = 0.5 * (c[k - 1] - c[k + 1]) / den if den < 0 else 0.0
                best = (float(c[k]), float(blf), hyp, lo + k + frac, step_c, t0.size)
    return best, n_tests


__all__ = ["_search_reference"]

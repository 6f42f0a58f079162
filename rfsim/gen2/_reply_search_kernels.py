"""numba kernel of the capture reply decoder's preamble search (step 2; wrapped and documented
in :mod:`rfsim.gen2.reply_search`, whose ``_search`` calls it once per link hypothesis; its
plain-NumPy twin is ``reference.gen2_replies._search_reference`` in the tests).

``preamble_search_kernel`` fuses, per BLF hypothesis, what the twin does with several NumPy
calls: the preamble template (the element sequence of :mod:`rfsim.gen2.linecode` sampled
with ``waveform_kernel``) and the zero-mean normalised correlation at every T1 lag.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit, njit_inline
from rfsim.gen2._linecode_kernels import runs_dot, sampled_template
from rfsim.gen2._reply_core_kernels import cumulative_sums_into, normalised_correlation, parabola_offset



@njit_inline
def cumulative_sums(r):
    """Cumulative sums of Re r, Im r and |r|², each ``(r.size + 1,)`` from 0 (the running sums
    every windowed correlation of the reply search and decoding reads; |r|² added as
    P + (re² + im²))."""
    nr = r.size
    c_re = np.empty(nr + 1)
    c_im = np.empty(nr + 1)
    p2 = np.empty(nr + 1)
    cumulative_sums_into(r, c_re, c_im, p2, True)
    return c_re, c_im, p2

@njit
def preamble_search_kernel(r, pre_el, blfs, fs, lo, hi, n_rep, min_samples_per_element, out_corr):
    """Largest zero-mean normalised preamble correlation over BLFs and lags.

    For BLF ``blfs[j]`` (skipped when 2·BLF·``min_samples_per_element`` > fs) the template
    t is ``pre_el`` (pilot + preamble elements) sampled at ρ = 2·BLF/fs from lag 0 over its
    n = floor(n_pre·fs/(2·BLF)) samples, t0 = t − mean(t); the lags k = ``lo[j] …
    min(hi[j], r.size − n_rep[j])`` are tested with c = |Σ r[k+i]·t0[i]| / (‖t0‖·‖r_k −
    mean r_k‖). The template is constant over each element, so with the cumulative sums
    C of r and P of |r|² every lag costs one term per run of equal template samples
    (Σ t[i]·r[k+i] = Σ_runs t_run·(C[k + end] − C[k + begin])) instead of one per sample:
    O(lags · preamble elements), independent of the sample rate. ``out_corr[j]`` receives
    the best c of BLF j (−1 if skipped). Returns ``(best c, its BLF index, lag refined by
    the parabola through the peak, lags tested, template length)``; the first maximum wins
    ties (BLFs, then lags, in order).
    """
    best = -1.0
    best_j = -1
    best_pos = 0.0
    best_n = 0
    n_tests = 0
    n_el = pre_el.size
    c_re, c_im, p = cumulative_sums(r)
    t = np.empty(0)
    run_begin = np.empty(0, dtype=np.int64)
    run_value = np.empty(0)
    for j in range(blfs.size):
        out_corr[j] = -1.0
        blf = blfs[j]
        if 2.0 * blf * min_samples_per_element > fs:
            continue
        rho = 2.0 * blf / fs
        n = int(math.floor(n_el * fs / (2.0 * blf)))
        last = min(hi[j], r.size - n_rep[j])
        if last < lo[j] or n < 3:
            continue
        if t.size < n:
            t = np.empty(n)
            run_begin = np.empty(n + 1, dtype=np.int64)
            run_value = np.empty(n)
        tt = t[:n]
        mean = sampled_template(pre_el, 0.0, rho, tt)
        e_t = 0.0
        n_runs = 0
        for i in range(n):
            e_t += (tt[i] - mean) * (tt[i] - mean)
            if i == 0 or tt[i] != tt[i - 1]:
                run_begin[n_runs] = i
                run_value[n_runs] = tt[i]
                n_runs += 1
        run_begin[n_runs] = n
        norm_t = math.sqrt(e_t)
        n_tests += last - lo[j] + 1
        c_prev = -1.0
        kbest = -1
        cbest = -1.0
        cl = -1.0
        cr = -1.0
        for k in range(lo[j], last + 1):
            a_re, a_im = runs_dot(k, run_begin, run_value, n_runs, c_re, c_im)
            s_re = c_re[k + n] - c_re[k]
            s_im = c_im[k + n] - c_im[k]
            acc_re = a_re - mean * s_re
            acc_im = a_im - mean * s_im
            c = normalised_correlation(acc_re, acc_im, norm_t, p[k + n] - p[k], s_re, s_im, n)
            if k == kbest + 1 and kbest >= 0:
                cr = c  # right neighbour of the running best
            if c > cbest:
                cbest = c
                kbest = k
                cl = c_prev
                cr = -1.0
            c_prev = c
        out_corr[j] = cbest
        if cbest > best:
            frac = 0.0
            if kbest > lo[j] and kbest < last:
                frac = parabola_offset(cl, cbest, cr)
            best = cbest
            best_j = j
            best_pos = kbest + frac
            best_n = n
    return best, best_j, best_pos, n_tests, best_n

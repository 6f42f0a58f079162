"""numba kernels of the capture reply decoder (wrapped and documented in
:mod:`rfsim.gen2.replies`; their plain-NumPy twins are ``_search_reference`` and
``_fine_reference`` there).

Both kernels fuse, per BLF hypothesis, what the twins do with several NumPy calls: the
preamble template (the element sequence of :mod:`rfsim.gen2.linecode` sampled with
``waveform_kernel``), the zero-mean normalised correlation, the coherent decoding of
:func:`rfsim.gen2.linecode.decode_reply` at a known start (half-bit sums, Viterbi or
bit-by-bit decisions) and the least-squares residual of the remodulated reply.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim._jit import njit
from rfsim.gen2._linecode_kernels import (INDEX_EPS, bitwise_kernel, elements_kernel,
                                          projected_halfbit_sums_kernel, viterbi_kernel, waveform_kernel)


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
    n_r = r.size
    c_re = np.zeros(n_r + 1)
    c_im = np.zeros(n_r + 1)
    p = np.zeros(n_r + 1)
    for i in range(n_r):
        z = r[i]
        c_re[i + 1] = c_re[i] + z.real
        c_im[i + 1] = c_im[i] + z.imag
        p[i + 1] = p[i] + (z.real * z.real + z.imag * z.imag)
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
        waveform_kernel(pre_el, 0.0, rho, tt)
        mean = 0.0
        for i in range(n):
            mean += tt[i]
        mean /= n
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
            a_re = 0.0
            a_im = 0.0
            for q in range(n_runs):
                b0 = k + run_begin[q]
                b1 = k + run_begin[q + 1]
                a_re += run_value[q] * (c_re[b1] - c_re[b0])
                a_im += run_value[q] * (c_im[b1] - c_im[b0])
            s_re = c_re[k + n] - c_re[k]
            s_im = c_im[k + n] - c_im[k]
            acc_re = a_re - mean * s_re
            acc_im = a_im - mean * s_im
            energy = (p[k + n] - p[k]) - (s_re * s_re + s_im * s_im) / n
            c = math.hypot(acc_re, acc_im) / (norm_t * math.sqrt(max(energy, 1e-300)))
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
                den = cl - 2.0 * cbest + cr
                frac = 0.5 * (cl - cr) / den if den < 0 else 0.0
            best = cbest
            best_j = j
            best_pos = kbest + frac
            best_n = n
    return best, best_j, best_pos, n_tests, best_n


@njit
def fine_kernel(r, centre, n_bits, m, pre, cur, prev, state0, blfs, fs, viterbi, bits_out):
    """Decode at every BLF of ``blfs`` with the preamble centred on sample ``centre`` and keep
    the one whose remodulated reply leaves the least residual power.

    Per BLF (ρ = 2·BLF/fs): start = centre − n_pre_el/(2ρ); skipped when start < 0 or
    start > r.size − n_rep, n_rep = ceil(n_el/ρ) + 2. Decoding at ``start``: the template
    of the pilot + preamble elements sampled from the fractional offset start − ⌊start⌋,
    h = ⟨seg, t0⟩/‖t0‖², c = mean(seg) − h·mean(t); half-bit sums of Re((r − c)/h); Viterbi
    from ``state0`` ending on the dummy 1 (``viterbi``) or bit-by-bit decisions. The reply
    of the decoded bits (dummy 1, rest level −1 around it) is fitted as r ≈ h·ref + c by
    least squares over r[:min(r.size, ⌊start⌋ + n_rep)]; the residual is the mean
    |r − c − h·ref|². Writes the best BLF's bits into ``bits_out`` (n_bits,) and returns
    ``(best index (−1 if every BLF was skipped), residual, start)``; the first wins ties.
    """
    miller = m > 1
    n_pre_el = pre.size * m
    nh = pre.size + 2 * (n_bits + 1)
    n_el = n_pre_el + 2 * m * (n_bits + 1)
    pre_el = np.empty(n_pre_el)
    for i in range(pre.size):
        for q in range(m):
            k = i * m + q
            pre_el[k] = pre[i] if (m == 1 or k % 2 == 0) else -pre[i]
    half = 0.5 * n_pre_el
    sums = np.empty(nh)
    n_data = nh - pre.size
    a = np.empty(n_data // 2)
    b = np.empty(n_data // 2)
    dec = np.empty(n_data // 2, dtype=np.uint8)
    el = np.empty(n_el)
    best_j = -1
    best_resid = math.inf
    best_start = math.nan
    for j in range(blfs.size):
        blf = blfs[j]
        rho = 2.0 * blf / fs
        start = centre - half / rho
        n_rep = int(math.ceil(n_el / rho)) + 2
        if start < 0 or start > r.size - n_rep:
            continue
        # --- decode at start (rfsim.gen2.linecode._decode with start_sample and no gain)
        ratio = 2.0 * float(blf) / float(fs)
        n_reply = int(math.ceil(nh * m / ratio))
        n_pre = int(math.floor(pre.size * m / ratio))
        lag = int(math.floor(start))
        tpl = np.empty(n_pre)
        waveform_kernel(pre_el, start - lag, ratio, tpl)
        t_mean = 0.0
        for i in range(n_pre):
            t_mean += tpl[i]
        t_mean /= n_pre
        p_re = 0.0
        p_im = 0.0
        e_t = 0.0
        s_re = 0.0
        s_im = 0.0
        for i in range(n_pre):
            t0 = tpl[i] - t_mean
            z = r[lag + i]
            p_re += z.real * t0
            p_im += z.imag * t0
            e_t += t0 * t0
            s_re += z.real
            s_im += z.imag
        h = complex(p_re, p_im) / e_t
        if h == 0:
            continue
        dc = complex(s_re / n_pre, s_im / n_pre) - h * t_mean
        g = 1.0 / h
        end = min(r.size, lag + n_reply + 2)
        projected_halfbit_sums_kernel(r[lag:end], g.real, g.imag, (dc * g).real, start - lag, ratio, m, sums)
        for i in range(n_data // 2):
            a[i] = sums[pre.size + 2 * i]
            b[i] = sums[pre.size + 2 * i + 1]
        if viterbi:
            viterbi_kernel(a, b, miller, state0, True, dec)
        else:
            bitwise_kernel(a, b, miller, dec)
        # --- remodulate (dummy 1) and fit r ≈ h·ref + c over the reply and its rest level
        elements_kernel(dec[:n_bits], True, m, pre, cur, prev, el)
        t0s = (start / fs) * fs
        n_end = min(r.size, int(start) + n_rep)
        ss = 0.0
        s1 = 0.0
        rs_re = 0.0
        rs_im = 0.0
        r1_re = 0.0
        r1_im = 0.0
        for n in range(n_end):
            u = (n - t0s) * rho
            ref = -1.0
            if u >= 0.0:
                k = int(math.floor(u + INDEX_EPS))
                if k < n_el:
                    ref = el[k]
            z = r[n]
            ss += ref * ref
            s1 += ref
            rs_re += z.real * ref
            rs_im += z.imag * ref
            r1_re += z.real
            r1_im += z.imag
        nn = float(n_end)
        det = ss * nn - s1 * s1
        if abs(det) <= 1e-12 * max(ss * nn, 1e-300):
            continue
        rs = complex(rs_re, rs_im)
        r1 = complex(r1_re, r1_im)
        hh = (nn * rs - s1 * r1) / det
        cc = (ss * r1 - s1 * rs) / det
        acc = 0.0
        for n in range(n_end):
            u = (n - t0s) * rho
            ref = -1.0
            if u >= 0.0:
                k = int(math.floor(u + INDEX_EPS))
                if k < n_el:
                    ref = el[k]
            e = r[n] - cc - hh * ref
            acc += e.real * e.real + e.imag * e.imag
        resid = acc / nn
        if best_j < 0 or resid < best_resid:
            best_j = j
            best_resid = resid
            best_start = start
            for i in range(n_bits):
                bits_out[i] = dec[i]
    return best_j, best_resid, best_start

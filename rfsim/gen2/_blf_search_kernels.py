"""numba kernel of the reader's BLF-searching reply decoder, over a stack of windows
(wrapped and documented in :func:`rfsim.devices.reader.search_decode`; its plain-NumPy twin is
:func:`reference.devices_reader.search_decode_reference` in the tests)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit, njit_inline
from rfsim.gen2._linecode_kernels import (elements_kernel, projected_halfbit_sums_kernel, sampled_template,
                                          waveform_kernel)
from rfsim.gen2._reply_core_kernels import (blf_resolution, centred_start, cumulative_sums_into, fine_step,
                                            halfbit_decisions, is_steady, normalised_correlation, parabola_offset,
                                            preamble_gain_offset, rest_level_sums, steady_residual)


@njit
def _decode_at(r, blf_ratio, start, pre_el, n_pre, pre_levels, m, n_bits, miller, state0,
               tpl, sums, bits, elems, ref):
    """Decode ``r`` at one (elements per sample, start): preamble gain h, offset, half-bit
    sums, Viterbi; remodulate (``ref``: the reply ±1, −1 around it, over the whole window);
    return (residual energy of the least-squares fit r ≈ h2·ref + c2 over the whole window,
    the reply's end, h2, c2): every hypothesis explains the same samples."""
    lag = int(math.floor(start))
    mean_t = sampled_template(pre_el, start - lag, blf_ratio, tpl[:n_pre])
    seg_mean = 0j  # summed sample by sample (the capture decoder: from cumulative sums)
    for i in range(n_pre):
        seg_mean += r[lag + i]
    h, dc = preamble_gain_offset(r, lag, tpl, mean_t, n_pre, seg_mean / n_pre)
    if h == 0:
        return math.inf, 0, 0j, 0j
    g = 1.0 / h
    dcg = dc * g
    projected_halfbit_sums_kernel(r[lag:], g.real, g.imag, dcg.real, start - lag, blf_ratio, m, sums)
    npre = pre_levels.size
    nb = n_bits + 1
    a = np.empty(nb)
    b = np.empty(nb)
    full = np.empty(nb, dtype=np.uint8)
    halfbit_decisions(sums, npre, miller, state0, True, a, b, full)
    for i in range(n_bits):
        bits[i] = full[i]
    elements_kernel(bits, True, m, pre_levels, state0, elems)
    n_el = elems.size
    end = min(r.size, int(math.ceil(start + n_el / blf_ratio)) + 1)
    waveform_kernel(elems.astype(np.float64), start, blf_ratio, ref)
    nw = r.size  # every hypothesis explains the whole window (rest level −1 around the reply)
    srr, sr, sxr, sx = rest_level_sums(r, ref, nw, True)
    den = nw * srr - sr * sr
    h2 = (nw * sxr - sr * sx) / den if den > 0 else 0j
    c2 = (sx - h2 * sr) / nw
    res = 0.0
    for n in range(nw):
        e = r[n] - c2 - h2 * ref[n]
        res += e.real * e.real + e.imag * e.imag
    return res, end, h2, c2


@njit_inline
def _decode_centred(r, blf_ratio, centre, pre_el, nh, pre_levels, m, n_bits, miller, state0, tpl, sums, bits, elems,
                    ref):
    """:func:`_decode_at` with the preamble centred on sample ``centre``: start = centre −
    n_pre_el/(2ρ); skipped (ok False) when the reply of ``nh`` half-bits does not fit in the
    window from there. Returns ``(ok, start, residual, end, h2, c2)``."""
    ok, start, n_pre = centred_start(centre, pre_el.size, nh * m, blf_ratio, r.shape[0])
    if not ok:
        return False, start, math.inf, 0, 0j, 0j
    res, end, h2, c2 = _decode_at(r, blf_ratio, start, pre_el, n_pre, pre_levels, m, n_bits, miller, state0, tpl, sums,
                                  bits, elems, ref)
    return True, start, res, end, h2, c2


@njit
def _corr(r, tpl0, k, L, lag, norm_t, p_e, c_re, c_im):
    """Zero-mean normalised correlation of r[lag:lag+L] with template k (prefix sums p_e of
    |r|², c_re and c_im of r)."""
    acc_re = 0.0
    acc_im = 0.0
    for i in range(L):
        z = r[lag + i]
        t = tpl0[k, i]
        acc_re += z.real * t
        acc_im += z.imag * t
    return normalised_correlation(acc_re, acc_im, norm_t, p_e[lag + L] - p_e[lag], c_re[lag + L] - c_re[lag],
                                  c_im[lag + L] - c_im[lag], L)


@njit_inline
def _template_norms(coarse_tpl0, coarse_len):
    """‖t_k‖ of every coarse template ``coarse_tpl0[k, :coarse_len[k]]``."""
    norms = np.empty(coarse_len.size)
    for k in range(coarse_len.size):
        acc_n = 0.0
        for i in range(coarse_len[k]):
            acc_n += coarse_tpl0[k, i] * coarse_tpl0[k, i]
        norms[k] = math.sqrt(acc_n)
    return norms


@njit_inline
def _coarse_search(r, coarse_tpl0, coarse_len, norms, lo, hi, p_e, c_re, c_im, cv):
    """Coarse search: the largest correlation :func:`_corr` over the BLF grid × the lags
    ``lo…hi``, the first wins ties; the lag refined by a parabola through the best lag's
    neighbours (same BLF; ``cv`` (3,) scratch). Returns ``(corr, BLF index, lag, fraction of
    a lag)``."""
    nwin = r.size
    cbest = -1.0
    kbest = 0
    lbest = lo
    for k in range(coarse_len.size):
        L = coarse_len[k]
        for lag in range(lo, min(hi, nwin - L) + 1):
            c = _corr(r, coarse_tpl0, k, L, lag, norms[k], p_e, c_re, c_im)
            if c > cbest:
                cbest, kbest, lbest = c, k, lag
    # parabola through the best lag's neighbours (same BLF)
    frac = 0.0
    L = coarse_len[kbest]
    if lbest > lo and lbest < min(hi, nwin - L):
        for j in range(3):
            cv[j] = _corr(r, coarse_tpl0, kbest, L, lbest - 1 + j, norms[kbest], p_e, c_re, c_im)
        frac = parabola_offset(cv[0], cv[1], cv[2])
    return cbest, kbest, lbest, frac


@njit_inline
def _steady_disturbance(r, ref, start, end, ratio, h, c, m, nh, n_pre_levels, n_bits):
    """``(σ², σ_eff²)`` of the decoded reply (``ref`` its ±1 reference from ``start`` at
    ``ratio`` elements per sample, fit r ≈ h·ref + c): the residual power over the steady
    samples of the reply (both neighbours at the same level); and the disturbance that
    reaches the decisions: per half-bit j, δ_j = Σ y_n·ref_n − |h|·N_j over its steady
    samples, y_n = Re((r_n − c)·h*)/|h|, σ_eff² = 2·Σ δ_j² / Σ N_j over the data half-bits
    (= σ² for white noise; in-band interference is not reduced by the matched filter's gain)."""
    i0 = max(1, int(math.ceil(start)))
    acc_e, cnt = steady_residual(r, ref, h, c, i0, end - 1)
    habs = abs(h)
    dsum = np.zeros(nh)
    dcnt = np.zeros(nh)
    for n in range(i0, end - 1):
        v = ref[n]
        if is_steady(ref, n):
            z = r[n] - c
            kel = int(math.floor((n - start) * ratio + 1e-9))
            j = kel // m
            if 0 <= j < nh and habs > 0:
                yv = (z.real * h.real + z.imag * h.imag) / habs
                dsum[j] += yv * v
                dcnt[j] += 1.0
    sigma2 = acc_e / cnt if cnt > 0 else math.nan
    d2 = 0.0
    nn = 0.0
    for j in range(n_pre_levels, n_pre_levels + 2 * n_bits):  # the data half-bits
        dj = dsum[j] - habs * dcnt[j]
        d2 += dj * dj
        nn += dcnt[j]
    return sigma2, 2.0 * d2 / nn if nn > 0 else math.inf


@njit
def search_decode_kernel(rs, coarse_ratios, coarse_tpl0, coarse_len, lo, hi, pre_el, pre_levels, state0, m,
                         n_bits, n_first_bits, fine_span, fine_per_side, target_first, fine_target, out_bits,
                         out_ratio, out_start, out_corr, out_h, out_sigma2, out_sigma2_bit):
    """BLF search and decoding of every window ``rs[b]`` (see :func:`rfsim.devices.reader.search_decode`).

    Coarse: the largest zero-mean normalised preamble correlation over the BLF grid
    (``coarse_ratios`` = 2·BLF/fs, templates ``coarse_tpl0[k, :coarse_len[k]]``) and the lags
    ``lo…hi`` (parabolic refinement between lags). Fine: decodes across the coarse BLF·(1 ±
    ``fine_span``) (``2·fine_per_side + 1`` BLFs, the preamble centre held), the least
    residual wins, the span narrowed to one step until the step ≤ ``target_first``, over
    the first ``n_first_bits`` bits; a longer reply is then searched again over twice as many
    bits at a time (all of them at last) across ±4 final steps of the previous phase, each
    phase down to 1/(4·its elements) (``fine_target`` for all bits). Outputs:
    bits, elements per sample, start [samples], coarse correlation, gain h, the residual
    power σ² over the reply's steady samples (both neighbours at the same level) and the
    decision-domain disturbance σ_eff² of the data half-bits (:func:`_steady_disturbance`).
    """
    n_tr = rs.shape[0]
    nwin = rs.shape[1]
    n_pre_el = pre_el.size
    miller = m > 1
    nh = pre_levels.size + 2 * (n_bits + 1)
    best_bits = np.empty(n_bits, dtype=np.uint8)
    n_first = min(n_bits, n_first_bits)
    nh1 = pre_levels.size + 2 * (n_first + 1)
    sums1 = np.empty(nh1)
    bits1 = np.empty(n_first, dtype=np.uint8)
    elems1 = np.empty(nh1 * m, dtype=np.int8)
    ref = np.empty(nwin)
    best_ref = np.empty(nwin)
    tpl = np.empty(nwin)
    p_e = np.empty(nwin + 1)  # prefix sums of |r|² and r: sliding energy of every lag
    c_re = np.empty(nwin + 1)
    c_im = np.empty(nwin + 1)
    norms = _template_norms(coarse_tpl0, coarse_len)
    cv = np.empty(3)
    for t in range(n_tr):
        r = rs[t]
        cumulative_sums_into(r, c_re, c_im, p_e, False)  # |r|² as (P + re²) + im²
        cbest, kbest, lbest, frac = _coarse_search(r, coarse_tpl0, coarse_len, norms, lo, hi, p_e, c_re, c_im, cv)
        ratio_c = coarse_ratios[kbest]
        centre = lbest + frac + 0.5 * n_pre_el / ratio_c
        out_corr[t] = cbest
        # the Miller pilot is periodic: a lag one element off correlates almost as well; keep
        # the centre (one element either way) whose decoded reply leaves the least residual
        best_res = math.inf
        best_d = 0
        for d in range(-1, 2):
            ok, start, res, end, h2, c2 = _decode_centred(r, ratio_c, centre + d / ratio_c, pre_el, nh, pre_levels,
                                                          m, n_first, miller, state0, tpl, sums1, bits1, elems1, ref)
            if ok and res < best_res:
                best_res, best_d = res, d
        centre += best_d / ratio_c
        best_bits[:] = 0
        # --- fine: decode across the span, least residual wins; first over the first
        # ``n_first`` bits, then over twice as many bits (all of them at last) across ±4 final
        # steps of the previous phase: a long reply misaligned by one coarse step has a
        # residual with many local minima
        span = fine_span
        centre_ratio = ratio_c
        best_ratio = ratio_c
        best_start = lbest + frac
        best_h = 0j
        best_end = 0
        best_c = 0j
        nbx = n_first
        tgt = target_first
        while True:
            best_res = math.inf
            bx = np.empty(nbx, dtype=np.uint8)
            nhx = pre_levels.size + 2 * (nbx + 1)
            ex = np.empty(nhx * m, dtype=np.int8)
            sx = np.empty(nhx)
            while True:
                step, kk = fine_step(span, fine_per_side, tgt)
                found = False
                for j in range(-kk, kk + 1):
                    ratio = centre_ratio * (1.0 + step * j)
                    ok, start, res, end, h2, c2 = _decode_centred(r, ratio, centre, pre_el, nh, pre_levels, m, nbx,
                                                                  miller, state0, tpl, sx, bx, ex, ref)
                    if ok and res < best_res:
                        best_res, best_ratio, best_start, best_h, best_end, best_c = res, ratio, start, h2, end, c2
                        if nbx == n_bits:
                            best_bits[:] = bx
                            best_ref[:] = ref
                        found = True
                if not found or step <= tgt:
                    break
                span = step
                centre_ratio = best_ratio
            if nbx == n_bits:
                break
            nbx = min(n_bits, 2 * nbx)
            span = 4.0 * tgt
            tgt = blf_resolution(n_pre_el + 2 * m * (nbx + 1))
            centre_ratio = best_ratio
        out_bits[t, :] = best_bits
        out_ratio[t] = best_ratio
        out_start[t] = best_start
        out_h[t] = best_h
        # σ² over the reply's steady samples, and the disturbance that reaches the decisions
        out_sigma2[t], out_sigma2_bit[t] = _steady_disturbance(r, best_ref, best_start, best_end, best_ratio, best_h,
                                                               best_c, m, nh, pre_levels.size, n_bits)

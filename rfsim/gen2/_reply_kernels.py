"""numba kernels of the capture reply decoder's steps 3–5 (wrapped and documented in
:mod:`rfsim.gen2.reply_decoding`; their plain-NumPy twins are ``_fine_python``,
``_track_decode_python`` and ``_decode_window_python`` there). The preamble search of step 2
is in :mod:`rfsim.gen2._reply_search_kernels`.

``fine_kernel`` fuses, per BLF hypothesis, what the twins do with several NumPy calls: the
preamble template (the element sequence of :mod:`rfsim.gen2.linecode` sampled with
``waveform_kernel``), the coherent decoding of :func:`rfsim.gen2.linecode.decode_reply` at a
known start (half-bit sums, Viterbi or bit-by-bit decisions) and the least-squares residual of
the remodulated reply. ``track_decode_kernel`` is step 4 (fit, tracking loop, resampling
on the tag's clock, decoding again) and ``decode_window_kernel`` steps 3–5 of a window in
one call each, so that a reply costs one kernel call after its detection.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit, njit_inline
from rfsim.gen2._capture_kernels import track_kernel
from rfsim.gen2._reply_search_kernels import cumulative_sums as _cumulative_sums
from rfsim.gen2._linecode_kernels import (INDEX_EPS, element_sign, elements_kernel, level_elements_kernel,
                                          projected_halfbit_sums_kernel, sampled_template, waveform_kernel)
from rfsim.gen2._reply_core_kernels import (blf_resolution, centred_start, fine_step, halfbit_decisions,
                                            normalised_correlation, preamble_gain_offset, rest_level_sums,
                                            steady_residual)


@njit
def _first_sample(k, t0, rho, lo, hi):
    """Smallest n in [lo, hi] with floor((n − t0)·ρ + eps) ≥ k (hi if none): where element k
    starts on the sample grid, by exactly the rule of ``waveform_kernel``."""
    n = int(math.ceil(t0 + (k - INDEX_EPS) / rho))
    if n < lo:
        n = lo
    if n > hi:
        n = hi
    while n > lo and math.floor((n - 1 - t0) * rho + INDEX_EPS) >= k:
        n -= 1
    while n < hi and math.floor((n - t0) * rho + INDEX_EPS) < k:
        n += 1
    return n


@njit_inline
def _preamble_element_levels(pre, m):
    """Pilot + preamble elements (±1, float64) of the half-symbol levels ``pre``."""
    pre_el = np.empty(pre.size * m)
    level_elements_kernel(pre, m, pre_el)
    return pre_el


@njit_inline
def _reply_residual(c_re, c_im, p2, el, n_el, start, rho, fs, n_end):
    """Residual power of the least-squares fit r ≈ h·ref + c over r[:n_end], ref = −1 outside
    the reply and ``el[k]`` on element k (sampled from ``start`` by the rule of
    ``waveform_kernel``), from the cumulative sums of :func:`_cumulative_sums`, element by
    element (``fine_kernel``'s closed form). Returns ``(ok, residual)``; ok False when the
    reference is constant."""
    t0s = (start / fs) * fs
    # ref = −1 outside the reply, el[k] on element k: Σ ref·z = −Σz + Σ_k (el[k] + 1)·Σ_{n∈k} z
    rs_re = -c_re[n_end]
    rs_im = -c_im[n_end]
    s1 = -float(n_end)
    lo = max(0, int(math.ceil(t0s)))
    n_a = _first_sample(0, t0s, rho, lo, n_end)
    for k in range(n_el):
        n_b = _first_sample(k + 1, t0s, rho, n_a, n_end)
        if n_b > n_a and el[k] > 0:
            rs_re += 2.0 * (c_re[n_b] - c_re[n_a])
            rs_im += 2.0 * (c_im[n_b] - c_im[n_a])
            s1 += 2.0 * (n_b - n_a)
        n_a = n_b
        if n_a >= n_end:
            break
    nn = float(n_end)
    ss = nn  # every reference value is ±1
    det = ss * nn - s1 * s1
    if abs(det) <= 1e-12 * max(ss * nn, 1e-300):
        return False, 0.0
    rs = complex(rs_re, rs_im)
    r1 = complex(c_re[n_end], c_im[n_end])
    hh = (nn * rs - s1 * r1) / det
    cc = (ss * r1 - s1 * rs) / det
    acc = (p2[n_end] + nn * (cc.real * cc.real + cc.imag * cc.imag) + (hh.real * hh.real + hh.imag * hh.imag) * ss
           - 2.0 * (cc.conjugate() * r1).real - 2.0 * (hh.conjugate() * rs).real
           + 2.0 * (cc.conjugate() * hh).real * s1)
    return True, max(acc, 0.0) / nn


@njit
def fine_kernel(r, centre, n_bits, m, pre, state0, blfs, fs, viterbi, bits_out):
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

    The half-bit sums and the fit are linear in r over runs of samples that share an
    element, so both are evaluated element by element from cumulative sums of r and |r|²
    (each element's sample range found by the sampling rule of ``waveform_kernel``):
    O(elements) per BLF instead of O(samples); the residual in closed form,
    Σ|r − c − h·ref|² = Σ|r|² + n|c|² + |h|²·Σref² − 2Re(c̄·Σr) − 2Re(h̄·Σr·ref)
    + 2Re(c̄h)·Σref.
    """
    miller = m > 1
    n_pre_el = pre.size * m
    nh = pre.size + 2 * (n_bits + 1)
    n_el = n_pre_el + 2 * m * (n_bits + 1)
    pre_el = _preamble_element_levels(pre, m)
    sums = np.empty(nh)
    n_data = nh - pre.size
    a = np.empty(n_data // 2)
    b = np.empty(n_data // 2)
    dec = np.empty(n_data // 2, dtype=np.uint8)
    el = np.empty(n_el)
    nr = r.size
    c_re, c_im, p2 = _cumulative_sums(r)
    best_j = -1
    best_resid = math.inf
    best_start = math.nan
    for j in range(blfs.size):
        blf = blfs[j]
        rho = 2.0 * blf / fs
        ok, start, n_pre = centred_start(centre, n_pre_el, n_el, rho, r.size)
        if not ok:
            continue
        # --- decode at start (rfsim.gen2.linecode._decode with start_sample and no gain)
        ratio = 2.0 * float(blf) / float(fs)
        n_reply = int(math.ceil(nh * m / ratio))
        n_rep = int(math.ceil(n_el / rho)) + 2
        lag = int(math.floor(start))
        tpl = np.empty(n_pre)
        t_mean = sampled_template(pre_el, start - lag, ratio, tpl)
        # the segment's mean from the cumulative sums (the reader's search: summed sample by sample)
        s_re = c_re[lag + n_pre] - c_re[lag]
        s_im = c_im[lag + n_pre] - c_im[lag]
        h, dc = preamble_gain_offset(r, lag, tpl, t_mean, n_pre, complex(s_re / n_pre, s_im / n_pre))
        if h == 0:
            continue
        g = 1.0 / h
        g_re = g.real
        g_im = g.imag
        dc_re = (dc * g).real
        # half-bit sums of y = Re(z·g) − dc_re over the part r[lag : lag + n_reply + 2]
        end = min(nr, lag + n_reply + 2) - lag
        off = start - lag
        lo = max(0, int(math.ceil(off)))
        sums[:] = 0.0
        n_a = _first_sample(0, off, ratio, lo, end)
        for k in range(nh * m):
            n_b = _first_sample(k + 1, off, ratio, n_a, end)
            if n_b > n_a:
                cnt = n_b - n_a
                y = ((c_re[lag + n_b] - c_re[lag + n_a]) * g_re - (c_im[lag + n_b] - c_im[lag + n_a]) * g_im
                     - dc_re * cnt)
                if element_sign(k, m) < 0:
                    sums[k // m] -= y
                else:
                    sums[k // m] += y
            n_a = n_b
            if n_a >= end:
                break
        halfbit_decisions(sums, pre.size, miller, state0, viterbi, a, b, dec)
        # --- remodulate (dummy 1) and fit r ≈ h·ref + c over the reply and its rest level
        elements_kernel(dec[:n_bits], True, m, pre, state0, el)
        fitted, resid = _reply_residual(c_re, c_im, p2, el, n_el, start, rho, fs, min(r.size, int(start) + n_rep))
        if not fitted:
            continue
        if best_j < 0 or resid < best_resid:
            best_j = j
            best_resid = resid
            best_start = start
            for i in range(n_bits):
                bits_out[i] = dec[i]
    return best_j, best_resid, best_start


@njit
def _ls_gain_offset(ss, s1, nn, rs, r1):
    """Least-squares ``(h, c, ok)`` of r ≈ h·ref + c from Σref², Σref, n, Σr·ref, Σr (the
    closed form of :func:`rfsim.gen2.capture.fit_gain_offset`; ok False when ref is constant)."""
    det = ss * nn - s1 * s1
    if abs(det) <= 1e-12 * max(ss * nn, 1e-300):
        return 0j, 0j, False
    return (nn * rs - s1 * r1) / det, (ss * r1 - s1 * rs) / det, True


@njit
def _interp_unit(r, x):
    """``numpy.interp(x, arange(r.size), r)`` of complex ``r`` (real and imaginary parts)."""
    n = r.size
    if x <= 0.0:
        return r[0]
    if x >= n - 1:
        return r[n - 1]
    j = int(math.floor(x))
    f = x - j
    a = r[j]
    b = r[j + 1]
    return complex((b.real - a.real) * f + a.real, (b.imag - a.imag) * f + a.imag)


@njit_inline
def _fit_rest_level(r, ref, n_end):
    """Least-squares ``(h, c, ok)`` of r ≈ h·ref + c over r[:n_end], ``ref`` read as −1 where
    it is 0 (the rest level around the reply)."""
    ss, s1, rs, r1 = rest_level_sums(r, ref, n_end, False)
    return _ls_gain_offset(ss, s1, float(n_end), rs, r1)


@njit_inline
def _fit_decision_free(rw, pre_s, n_rest):
    """Least-squares ``(h, c, ok)`` of rw ≈ h·ref + c over the decision-free samples: the
    rest level (−1) before sample ``n_rest`` and the pilot + preamble ``pre_s`` (nonzero)."""
    ss = 0.0
    s1 = 0.0
    rs = 0j
    r1 = 0j
    cnt = 0
    for n in range(rw.size):
        if pre_s[n] != 0.0 or n < n_rest:
            v = pre_s[n] if pre_s[n] != 0.0 else -1.0
            ss += v * v
            s1 += v
            rs += rw[n] * v
            r1 += rw[n]
            cnt += 1
    return _ls_gain_offset(ss, s1, float(cnt), rs, r1)


@njit
def track_decode_kernel(r, start, rho, fs, bits, m, pre, state0, dummy, viterbi, block_elements,
                        min_blocks, spans, sub, min_drift_blocks, converged_elements, n_rest, rw):
    """Step 4 of :mod:`rfsim.gen2.replies` in one call (its NumPy twin:
    ``rfsim.gen2.reply_decoding._track_decode_python``): up to two passes of

    1. (h, c) of r ≈ h·ref + c by least squares over the reply up to its end, ref the
       remodulated reply of ``bits`` (±1, sampled by the rule of ``waveform_kernel`` from
       ``start``) and −1 around it;
    2. the tracking loop ``track_kernel`` on y = Re((r − c)/h) (blocks of
       ``block_elements`` elements, at least ``min_blocks``, each correlated about once
       across the growing spans);
    3. the window resampled on the tag's clock u(t) = u₁·t + u₂·t² (linear interpolation,
       ``numpy.interp`` clamping at the ends) at n′ = −n_rest … into ``rw``;
    4. (h, c) again over the decision-free samples of ``rw`` (rest level before the reply,
       pilot + preamble), the bits decoded from ``n_rest`` with that gain (half-bit sums,
       Viterbi ending on the dummy 1, or bit-by-bit decisions);

    the second pass is skipped when the first moved the clock by at most
    ``converged_elements`` anywhere in the reply and left the bits unchanged. ``bits``
    (in/out) holds the decoded bits. Returns ``(ok, start, u1, u2)``; ok False when a fit
    has no gain (h = 0) or a constant reference.
    """
    nb = bits.size
    miller = m > 1
    n_pre_h = pre.size
    nh = n_pre_h + 2 * (nb + 1)
    n_el_full = nh * m
    n_el = n_el_full - (0 if dummy else 2 * m)
    el = np.empty(n_el)
    el_full = np.empty(n_el_full)
    pre_el = _preamble_element_levels(pre, m)
    nr = r.size
    n_w = rw.size
    ref = np.empty(nr)
    pre_s = np.empty(n_w)
    y = np.empty(nr)
    sums = np.empty(nh)
    n_data = nb + 1
    a = np.empty(n_data)
    b = np.empty(n_data)
    dec = np.empty(n_data, dtype=np.uint8)
    n_blocks = max(min_blocks, n_el // block_elements)
    u1 = rho
    u2 = 0.0
    n_span = int(math.ceil(0.0 + n_el / rho))
    for it in range(2):
        # 1. fit over the reply and the rest level before it
        elements_kernel(bits, dummy, m, pre, state0, el_full)
        for i in range(n_el):
            el[i] = el_full[i]
        n_end = min(nr, int(math.ceil(start + n_el / rho)))
        waveform_kernel(el, (start / fs) * fs, rho, ref[:n_end])
        h, c, ok = _fit_rest_level(r, ref, n_end)
        if not ok or h == 0:
            return False, start, u1, u2
        # 2. tracking loop
        p_start, p_u1, p_u2 = start, u1, u2
        # the tracking loop reads no sample after the reply's end on the current clock
        n_y = max(0, int(math.ceil(start)))
        while n_y < nr and u1 * (n_y - start) + u2 * (n_y - start) ** 2 < n_el:
            n_y += 1
        n_y = min(nr, n_y + 1)
        for n in range(n_y):
            y[n] = ((r[n] - c) / h).real
        start, u1, u2 = track_kernel(y[:n_y], start, u1, u2, el, n_blocks, spans, sub, min_drift_blocks)
        moved = abs(start - p_start) * u1 + abs(u1 - p_u1) * n_span + abs(u2 - p_u2) * n_span ** 2
        # 3. resampling on the tag's clock
        for i in range(n_w):
            target = rho * float(i - n_rest)
            disc = max(u1 * u1 + 4.0 * u2 * target, 1e-300)
            rw[i] = _interp_unit(r, start + 2.0 * target / (u1 + math.sqrt(disc)))
        # 4. fit on the decision-free samples, decoding with that gain
        waveform_kernel(pre_el, (n_rest / fs) * fs, rho, pre_s)
        h, c, ok = _fit_decision_free(rw, pre_s, n_rest)
        if not ok or h == 0:
            return False, start, u1, u2
        g = 1.0 / h
        n_reply = int(math.ceil(nh * m / rho))
        part = np.empty(min(n_w, n_rest + n_reply + 2) - n_rest, dtype=np.complex128)
        for i in range(part.size):
            part[i] = rw[n_rest + i] - c
        projected_halfbit_sums_kernel(part, g.real, g.imag, (0.0 * g).real, 0.0, rho, m, sums)
        halfbit_decisions(sums, n_pre_h, miller, state0, viterbi, a, b, dec)  # dec[nb]: the dummy
        same = True
        for i in range(nb):
            if dec[i] != bits[i]:
                same = False
            bits[i] = dec[i]
        if moved <= converged_elements and same:
            break
    return True, start, u1, u2


#: Length rules of ``decode_window_kernel`` (``rfsim.gen2.reply_decoding._NBitsRule``): a fixed
#: number of data bits, unknown (−1), or PC + EPC + CRC-16 from the PC's L field.
RULE_FIXED = 0
RULE_EPC = 1


@njit
def _n_bits_of(rule, fixed, bits, n):
    """Data bits of the complete reply from its first ``n`` decoded ``bits`` (−1 unknown)."""
    if rule == RULE_FIXED:
        return fixed
    if n < 16:
        return -1
    pc = 0
    for i in range(16):
        pc = (pc << 1) | int(bits[i])
    return 32 + 16 * (pc >> 11)


@njit
def _bits_that_fit(n_avail, n_pre_el, m, rho):
    """Data bits (dummy excluded) of a reply whose preamble starts ``n_avail`` samples before
    the window's end (``rfsim.gen2.reply_decoding._bits_that_fit``)."""
    elements = n_avail * rho - 2 * rho
    return int(math.floor((elements - n_pre_el) / (2 * m))) - 1


@njit
def _fine_cut(r, centre, n_bits, m, pre, state0, blfs, fs, viterbi, bits_out):
    """``fine_kernel`` passed only the samples up to its last BLF's reply end (the same result)."""
    n_pre_el = pre.size * m
    n_el = n_pre_el + 2 * m * (n_bits + 1)
    cut = 0.0
    for i in range(blfs.size):
        rho = 2.0 * blfs[i] / fs
        cut = max(cut, centre - 0.5 * n_pre_el / rho + (math.ceil(n_el / rho) + 2))
    n_cut = max(0, min(r.size, int(math.ceil(cut)) + 1))
    return fine_kernel(r[:n_cut], centre, n_bits, m, pre, state0, blfs, fs, viterbi, bits_out)


@njit
def _check_start(r, centre, n_bits, m, pre, state0, blf, fs, viterbi, shifts, bits, start):
    """The preamble correlates almost as well a whole element or two off its start (a Miller
    pilot is a plain subcarrier; one element inverts it, which |correlation| does not see):
    the decoding at ``blf`` with the preamble centre moved by each of ``shifts`` elements is
    kept when its remodulated reply leaves less residual power than at ``centre``. Returns
    ``(centre, start)`` and leaves the chosen bits in ``bits``."""
    one = np.empty(1)
    one[0] = blf
    tmp = np.empty(n_bits, dtype=np.uint8)
    j, best, _ = _fine_cut(r, centre, n_bits, m, pre, state0, one, fs, viterbi, tmp)
    if j < 0:
        return centre, start
    rho = 2.0 * blf / fs
    best_centre = centre
    for q in range(shifts.size):
        c = centre + shifts[q] / rho
        j, res, st = _fine_cut(r, c, n_bits, m, pre, state0, one, fs, viterbi, tmp)
        if j >= 0 and res < best:
            best = res
            best_centre = c
            start = st
            for i in range(n_bits):
                bits[i] = tmp[i]
    return best_centre, start


@njit
def _fine_search(r, centre, n_bits, m, pre, state0, blf0, span, target, per_side, fs, viterbi, bits_out):
    """``rfsim.gen2.reply_decoding._fine_search``: ``fine_kernel`` coarse to fine, each call passed
    only the samples up to its last BLF's reply end. Returns ``(found, blf, start)``."""
    n_pre_el = pre.size * m
    n_el = n_pre_el + 2 * m * (n_bits + 1)
    found = False
    best_blf = math.nan
    best_start = math.nan
    centre_blf = blf0
    tmp = np.empty(n_bits, dtype=np.uint8)
    while True:
        step, k = fine_step(span, per_side, target)
        blfs = np.empty(2 * k + 1)
        for i in range(2 * k + 1):
            blfs[i] = centre_blf * (1.0 + step * (i - k))
        j, _, start = _fine_cut(r, centre, n_bits, m, pre, state0, blfs, fs, viterbi, tmp)
        if j < 0:
            return found, best_blf, best_start
        found = True
        best_blf = blfs[j]
        best_start = start
        for i in range(n_bits):
            bits_out[i] = tmp[i]
        if step <= target:
            return found, best_blf, best_start
        span = step
        centre_blf = blfs[j]


@njit_inline
def _fit_steady(rw, ref, n_end):
    """Least-squares ``(h, c, ok, σ²)`` of rw ≈ h·ref + c over rw[:n_end] (``ref``'s zeros set
    to the rest level −1 in place), σ² the mean residual power over the steady samples (both
    neighbours at the same level; NaN when there are none)."""
    ss, s1, rs, r1 = rest_level_sums(rw, ref, n_end, True)
    h, c, ok = _ls_gain_offset(ss, s1, float(n_end), rs, r1)
    if not ok:
        return h, c, ok, math.nan
    acc, cnt = steady_residual(rw, ref, h, c, 1, n_end - 1)
    return h, c, ok, acc / cnt if cnt > 0 else math.nan


@njit_inline
def _correlation_at(rw, n_rest, pre_el, n_t, rho):
    """Zero-mean normalised correlation of rw[n_rest : n_rest + n_t] with the pilot +
    preamble ``pre_el`` sampled from 0 at ρ elements per sample:
    |Σ z·t0| / (‖t0‖·‖z − mean z‖)."""
    tpl = np.empty(n_t)
    t_mean = sampled_template(pre_el, 0.0, rho, tpl)
    p = 0j
    e_t = 0.0
    sz = 0j
    e_z = 0.0
    for i in range(n_t):
        t0 = tpl[i] - t_mean
        z = rw[n_rest + i]
        p += z * t0
        e_t += t0 * t0
        sz += z
        e_z += z.real * z.real + z.imag * z.imag
    return normalised_correlation(p.real, p.imag, math.sqrt(e_t), e_z, sz.real, sz.imag, n_t)


@njit
def decode_window_kernel(r, fs, blf_c, start_c, step_c, m, pre, state0, viterbi, rule, fixed,
                         fine_span_steps, start_shifts, block_elements, min_blocks, spans, sub, min_drift_blocks,
                         converged_elements, bits_out):
    """Steps 3–5 of :mod:`rfsim.gen2.replies` on a working-rate window after a detection at
    BLF ``blf_c``, start ``start_c`` (coarse step ``step_c``) in one call (its NumPy twin:
    ``rfsim.gen2.reply_decoding._decode_window_python``): the fine BLF search over the first 16
    bits, the reply's length from them (``rule``/``fixed``: :data:`RULE_FIXED` bits, or the
    PC's L field), the whole reply's BLF search around the first bits' BLF, step 4
    (``track_decode_kernel``), repeated while the whole reply's PC announces another length
    (at most 3 times); then on the resampled reply the least-squares fit over the steady
    samples (both neighbours at the same level) and the preamble correlation at the decoded
    start. Writes the bits into ``bits_out``; returns ``(ok, n_bits, start, u1, u2, blf,
    truncated, n_full, n_rest, h, sigma2, corr, n_samples of the reply span)``.
    """
    n_pre_el = pre.size * m
    rho_c = 2.0 * blf_c / fs
    centre = start_c + 0.5 * n_pre_el / rho_c
    n_first = max(0, min(16, _bits_that_fit(r.size - start_c, n_pre_el, m, rho_c)))
    step_16 = blf_resolution(n_pre_el + 2 * m * (n_first + 1))
    bits0 = np.empty(n_first, dtype=np.uint8)
    fail = (False, 0, 0.0, 0.0, 0.0, 0.0, False, 0, 0, 0j, 0.0, 0.0, 0.0)
    ok, blf1, start1 = _fine_search(r, centre, n_first, m, pre, state0, blf_c, fine_span_steps * step_c,
                                    step_16, 8, fs, viterbi, bits0)
    if not ok:
        return fail
    centre, start1 = _check_start(r, centre, n_first, m, pre, state0, blf1, fs, viterbi, start_shifts,
                                  bits0, start1)
    n_full = _n_bits_of(rule, fixed, bits0, n_first)
    truncated = False
    n_bits = 0
    blf = blf1
    start = start1
    u1 = 0.0
    u2 = 0.0
    n_rest = 0
    rw = np.empty(0, dtype=np.complex128)
    bits = np.empty(0, dtype=np.uint8)
    for _ in range(3):
        n_fit = _bits_that_fit(r.size - start1, n_pre_el, m, 2.0 * blf1 / fs)
        truncated = n_full < 0 or n_fit < n_full
        n_bits = max(0, n_fit - 1) if truncated else n_full
        bits = np.empty(n_bits, dtype=np.uint8)
        blf = blf1
        start = start1
        for i in range(min(n_bits, n_first)):
            bits[i] = bits0[i]
        if n_bits > n_first:
            n_el = n_pre_el + 2 * m * (n_bits + 1)
            span = fine_span_steps * step_16
            found, b2, s2 = _fine_search(r, centre, n_bits, m, pre, state0, blf1, span,
                                         blf_resolution(n_el), max(2, int(math.ceil(span * 2.0 * n_el))), fs, viterbi,
                                         bits)
            if found:
                blf = b2
                start = s2
            else:  # as the twin: the first bits only
                bits = bits0.copy()
                n_bits = n_first
        rho = 2.0 * blf / fs
        n_rest = int(min(start, 256))
        n_el_full = n_pre_el + 2 * m * (n_bits + 1)
        rw = np.empty(n_rest + int(math.ceil(0.0 + n_el_full / rho)) + 4, dtype=np.complex128)
        ok, start, u1, u2 = track_decode_kernel(r, start, rho, fs, bits, m, pre, state0, not truncated,
                                                viterbi, block_elements, min_blocks, spans, sub, min_drift_blocks,
                                                converged_elements, n_rest, rw)
        if not ok:
            return fail
        n_again = _n_bits_of(rule, fixed, bits, n_bits)
        if truncated or n_again == n_full or n_again < 0:
            break
        n_full = n_again
    # step 5: fit over the steady samples of the resampled reply, preamble correlation
    rho = 2.0 * blf / fs
    dummy = not truncated
    n_el = n_pre_el + 2 * m * (n_bits + 1) - (0 if dummy else 2 * m)
    el = np.empty(n_pre_el + 2 * m * (n_bits + 1))
    elements_kernel(bits, dummy, m, pre, state0, el)
    n_end = min(rw.size, int(math.ceil(n_rest + n_el / rho)))
    ref = np.empty(n_end)
    waveform_kernel(el[:n_el], (n_rest / fs) * fs, rho, ref)
    h, c, ok, sigma2 = _fit_steady(rw, ref, n_end)
    if not ok:
        return fail
    corr = _correlation_at(rw, n_rest, el[:n_pre_el], int(math.floor(n_pre_el * fs / (2.0 * blf))), rho)
    for i in range(n_bits):
        bits_out[i] = bits[i]
    n_span = int(math.ceil(0.0 + n_el / rho)) / u1 * rho
    return (True, n_bits, start, u1, u2, blf, truncated, n_full, n_rest, h, sigma2, corr, n_span)

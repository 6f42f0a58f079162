"""numba kernel of the reader's receive (:meth:`rfsim.devices.reader.Reader.receive`, steps 1–5 of
its docstring, ``blf_search = "off"`` and ``rx_model = "sample"``): one call per reply window.

It calls the kernels that hold the rules: the preamble search of the reply decoder
(:func:`rfsim.gen2._linecode_kernels.preamble_search_runs_kernel`), the decoder's preamble fit
(``_preamble_fit``, here; the statistic receiver's kernels call it too; the arithmetic of
:func:`rfsim.gen2._decode_reply_kernels.decode_reply_kernel`), the signed half-bit sums
(:func:`rfsim.gen2._linecode_kernels.signed_halfbit_sums_kernel`) and the decisions from them
(:func:`rfsim.gen2._reply_core_kernels.signed_sum_decisions`), the encoder tables
(:func:`rfsim.gen2._linecode_kernels.elements_kernel`), the sampled reply
(:func:`rfsim.gen2._linecode_kernels.waveform_from`), the known levels and the measurements
(:mod:`rfsim.gen2._measure_kernels`) and the least-squares gain and offset
(:func:`rfsim.gen2._fit_kernels.fit_gain_offset_kernel`). The reply's samples are summed per
half-bit once (S_j = Σσ·r, C_j = Σσ): both sets of decisions (at the preamble's gain and offset,
then at the known levels' fit) are made from those sums, as the statistic receiver does. The
NumPy twin, step by step with the public functions, is ``reference.devices_reader.receive_reference``
in the tests.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit
from rfsim.gen2._measure_kernels import known_levels_kernel, measure_kernel
from rfsim.gen2._fit_kernels import fit_gain_offset_kernel
from rfsim.gen2._linecode_kernels import (elements_kernel, preamble_search_runs_kernel, sampled_template,
                                         signed_halfbit_sums_kernel, waveform_from)
from rfsim.gen2._reply_core_kernels import signed_sum_decisions


@njit
def _preamble_fit(seg, frac, pre_el, ratio):
    """The decoder's gain, offset and normalised correlation on the preamble samples ``seg``
    of a reply starting ``frac`` samples into it (:func:`rfsim.gen2.linecode.decode_reply`:
    h = Σ seg·t0/Σ t0², dc = mean(seg) − h·mean(t), corr = |Σ seg·t0|/√(Σt0²·Σ|seg − mean|²),
    t the template from ``frac``, t0 = t − mean(t)). Returns (corr, h, dc)."""
    n_pre = seg.size
    tpl = np.empty(n_pre)
    tpl_mean = sampled_template(pre_el, frac, ratio, tpl)
    e_t = 0.0
    peak = 0j
    seg_sum = 0j
    for i in range(n_pre):
        a = tpl[i] - tpl_mean
        e_t += a * a
        peak += seg[i] * a
        seg_sum += seg[i]
    seg_mean = seg_sum / n_pre
    e_seg = 0.0
    for i in range(n_pre):
        d = seg[i] - seg_mean
        e_seg += d.real * d.real + d.imag * d.imag
    h = peak / e_t
    return abs(peak) / math.sqrt(e_t * max(e_seg, 1e-300)), h, seg_mean - h * tpl_mean


#: Status of :func:`receive_kernel`: decoded and measured.
RECEIVED = 0
#: Status: the preamble correlation is below the threshold.
NOT_FOUND = 1
#: Status: a gain of zero (the preamble's or the fitted one), nothing to decode.
NO_GAIN = 2
#: Status: the reply does not fit after its decoded start.
NO_ROOM = 3
#: Status: the search window is shorter than the reply.
TOO_SHORT = 4
#: Status: the known levels are constant, (h, c) cannot be separated.
CONSTANT = 5


@njit
def _reference_into(bits, m, pre_levels, state0, t0_samples, elements_per_sample, first, out):
    """The ±1 reply (pilot, preamble, ``bits``, dummy 1; 0 outside) from sample ``t0_samples``,
    its samples ``first … first + out.size − 1`` into ``out``."""
    el = np.empty((pre_levels.size + 2 * (bits.size + 1)) * m)
    elements_kernel(bits, True, m, pre_levels, state0, el)
    waveform_from(el, t0_samples, elements_per_sample, first, out)
    return el.size


@njit
def receive_kernel(rx, lo, hi, n_reply, threshold, fs_hz, blf_hz, m, n_pre, n_pre_el, t0, max_runs_per_sample,
                   half_width, shifts, templates, norms, run_begin, run_value, n_runs, same_as_previous, pre_el,
                   pre_levels, state0, viterbi, n_blocks, det_bits, bits, out_f, out_c):
    """Steps 1–5 of :meth:`rfsim.devices.reader.Reader.receive` on ``rx`` ((n,) complex128).

    1. r = rx − mean(rx[:lo]) when lo ≥ 8 (else r = rx − 0, which is rx). r is formed only where
       the search and the preamble fit read it; the half-bit sums, the known levels and the
       measurement read rx and take the mean off as they read (the same subtraction, bit for bit).
    2. The preamble search on r[lo:], starts 0 … hi − lo (``n_pre`` samples of template ``t0``,
       refinement bank ``shifts``/``templates``/``norms``, the templates' runs
       ``run_begin``/``run_value``/``n_runs``/``same_as_previous``), the preamble's gain h₀,
       offset and correlation at the start (the arithmetic of
       :func:`rfsim.gen2._decode_reply_kernels.decode_reply_kernel`); below ``threshold`` →
       :data:`NOT_FOUND` (no decisions made). Then the signed half-bit sums S_j, C_j of the
       reply's samples from i0 (the sample before the start) and the first decisions
       ``det_bits`` ((n_bits + 1,) uint8) from Re(S_j/h₀) − Re(dc/h₀)·C_j.
    3. The reference of ``det_bits`` from start/fs·fs (0 outside the reply), its known levels
       (:func:`rfsim.gen2._measure_kernels.known_levels_kernel`, the first ``n_pre_el`` elements
       the preamble) and (h, c) by :func:`rfsim.gen2._fit_kernels.fit_gain_offset_kernel`.
    4. Decisions ``bits`` ((n_bits + 1,) uint8) of span = r[i0 : i0 + n_reply + 4] − c with the
       gain h, from the same sums: Re((S_j − c·C_j)/h).
    5. :func:`rfsim.gen2._measure_kernels.measure_kernel` of span against the reference of
       ``bits`` (given r[i0:i1] and c: it subtracts c as it reads the samples).

    ``out_f`` ((4,) float64) receives start [samples of rx], corr, slope [rad/s], σ² [W];
    ``out_c`` ((1,) complex128) the measured gain. Returns a status: :data:`RECEIVED`,
    :data:`NOT_FOUND` (start and corr set), or an error (:data:`NO_GAIN`, :data:`NO_ROOM`,
    :data:`TOO_SHORT`, :data:`CONSTANT`).
    """
    n = rx.size
    dc0 = 0j  # r = rx − dc0 (x − 0 is x): formed only where the search and the preamble fit read it
    if lo >= 8:
        acc = 0j
        for i in range(lo):
            acc += rx[i]
        dc0 = acc / lo
    last = min(n - lo - n_reply, hi - lo)
    if last < 0:
        return TOO_SHORT
    r = np.empty(n, np.complex128)
    # the search reads r[lo : lo + last + n_pre] (its candidates end n_pre − t0.size + 1 samples short of
    # it, and the refinement reads a template's width from each: n_pre when the widths agree)
    filled = min(n, lo + last + n_pre + max(0, templates.shape[1] - t0.size))
    for i in range(lo, filled):
        r[i] = rx[i] - dc0
    ratio = 2.0 * blf_hz / fs_hz
    lag, best, start_rel = preamble_search_runs_kernel(r[lo:], last + n_pre, t0, max_runs_per_sample, half_width,
                                                       5, shifts, templates, norms, run_begin, run_value, n_runs,
                                                       same_as_previous)
    if best < 0:
        start_rel = float(lag)
    lag = int(math.floor(start_rel))
    frac = start_rel - lag
    i0 = lo + lag
    for i in range(filled, min(n, i0 + n_pre)):
        r[i] = rx[i] - dc0
    corr, h0, dc0_ = _preamble_fit(r[i0:i0 + n_pre], frac, pre_el, ratio)
    start = lo + start_rel
    out_f[0] = start
    out_f[1] = corr
    if h0 == 0:
        return NO_GAIN
    if corr < threshold:
        return NOT_FOUND
    # the signed half-bit sums S_j, C_j of the reply's samples, once for both sets of decisions
    sums = np.empty(pre_levels.size + 2 * det_bits.size)
    s_sum = np.empty(sums.size, np.complex128)
    s_count = np.empty(sums.size)
    i_end = min(n, i0 + int(math.ceil(sums.size * m / ratio)) + 2)
    signed_halfbit_sums_kernel(rx[i0:i_end], frac, ratio, m, s_sum, s_count, dc0)
    a_s = np.empty(det_bits.size)
    b_s = np.empty(det_bits.size)
    g0 = 1.0 / h0
    signed_sum_decisions(s_sum, s_count, g0, (dc0_ * g0).real, pre_levels.size, m > 1, state0, viterbi, sums, a_s,
                         b_s, det_bits)
    # step 3: (h, c) from the known levels of the reference of the first decisions
    n_bits = bits.size - 1
    t0_samples = start / fs_hz * fs_hz
    full = np.zeros(n)
    a = max(0, int(math.floor(t0_samples)) - 1)
    b = min(n, int(math.ceil(t0_samples + (pre_el.size + 2 * m * (n_bits + 1)) / ratio)) + 2)
    if b > a:
        _reference_into(det_bits[:n_bits], m, pre_levels, state0, t0_samples, ratio, a, full[a:b])
    r_known = np.empty(n, np.complex128)
    level = np.empty(n)
    n_known = known_levels_kernel(rx, full, t0_samples, ratio, n_pre_el, r_known, level, dc0)
    h, c, ok = fit_gain_offset_kernel(r_known[:n_known], level[:n_known])
    if not ok:
        return CONSTANT
    # step 4: decisions of the reply's samples, r − c, with the gain h: sums S_j − c·C_j
    i1 = min(n, i0 + n_reply + 4)
    span = rx[i0:i1]  # less dc0 and c: the measurement subtracts them as it reads the samples
    if not (0.0 <= frac <= span.size - n_reply):
        return NO_ROOM
    if h == 0:
        return NO_GAIN
    for j in range(sums.size):
        s_sum[j] -= c * s_count[j]
    signed_sum_decisions(s_sum, s_count, 1.0 / h, 0.0, pre_levels.size, m > 1, state0, viterbi, sums, a_s, b_s,
                         bits)
    # step 5: measurements against the reference of the decisions
    same = True
    for i in range(n_bits):
        if bits[i] != det_bits[i]:
            same = False
    if same:
        ref = full[i0:i1]
    else:
        ref = np.empty(i1 - i0)
        _reference_into(bits[:n_bits], m, pre_levels, state0, t0_samples, ratio, i0, ref)
    hm, slope, sigma2 = measure_kernel(span, ref, fs_hz, n_blocks, c, dc0)
    out_c[0] = hm
    out_f[2] = slope
    out_f[3] = sigma2
    return RECEIVED


@njit
def receive_batch_kernel(rx, starts, ends, lo, hi, n_reply, threshold, fs_hz, blf_hz, m, n_pre, n_pre_el, t0,
                         max_runs_per_sample, half_width, shifts, templates, norms, run_begin, run_value, n_runs,
                         same_as_previous, pre_el, pre_levels, state0, viterbi, n_blocks, det_bits, bits, out_f, out_c,
                         status):
    """:func:`receive_kernel` on each of B windows in one call.

    The windows lie in ``rx`` ((N,) complex128): window b is ``rx[starts[b]:ends[b]]``
    (``starts``, ``ends`` (B,) int64; one after the other, or anywhere in ``rx``: the reader
    inputs of a block of trials are formed in one array; the windows may differ in length and
    in the time of their first sample, every index of a window is its own). Window b is
    searched from ``lo[b]`` to ``hi[b]`` ((B,) int64, its own lags, samples of window b) against its detection threshold ``threshold[b]`` ((B,) float64, of its number of
    lags); the arguments from ``fs_hz`` to ``n_blocks`` and ``n_reply`` are shared (one plan,
    one BLF, one reply length). Window b's outputs go to row b of ``det_bits``, ``bits``
    ((B, n_bits + 1) uint8), ``out_f`` ((B, 4) float64, the start in samples of window b),
    ``out_c`` ((B, 1) complex128) and its status to ``status[b]`` ((B,) int64): each row is
    what :func:`receive_kernel` returns for that window alone.
    """
    for b in range(starts.size):
        status[b] = receive_kernel(rx[starts[b]:ends[b]], lo[b], hi[b], n_reply, threshold[b], fs_hz, blf_hz,
                                   m, n_pre, n_pre_el, t0, max_runs_per_sample, half_width, shifts, templates, norms,
                                   run_begin, run_value, n_runs, same_as_previous, pre_el, pre_levels, state0, viterbi,
                                   n_blocks, det_bits[b], bits[b], out_f[b], out_c[b])

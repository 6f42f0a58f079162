"""numba kernel of the reader's receive (:meth:`rfsim.devices.reader.Reader.receive`, steps 1–5 of
its docstring, ``blf_search = "off"`` and ``rx_model = "sample"``): one call per reply window.

It calls the kernels that hold the rules: the reply decoder of
:func:`rfsim.gen2.linecode.decode_reply` (:mod:`rfsim.gen2._decode_reply_kernels`), the
encoder tables (:func:`rfsim.gen2._linecode_kernels.elements_kernel`), the sampled reply
(:func:`rfsim.gen2._linecode_kernels.waveform_from`), the known levels and the measurements
(:mod:`rfsim.gen2._measure_kernels`) and the least-squares gain and offset
(:func:`rfsim.gen2._fit_kernels.fit_gain_offset_kernel`). The NumPy twin, step by step with the
public functions, is ``reference.devices_reader.receive_reference`` in the tests.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit
from rfsim.gen2._measure_kernels import known_levels_kernel, measure_kernel
from rfsim.gen2._decode_reply_kernels import ZERO_GAIN, decisions_kernel, decode_reply_kernel
from rfsim.gen2._fit_kernels import fit_gain_offset_kernel
from rfsim.gen2._linecode_kernels import elements_kernel, waveform_from

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

    1. r = rx − mean(rx[:lo]) when lo ≥ 8 (else r = rx).
    2. :func:`rfsim.gen2._decode_reply_kernels.decode_reply_kernel` on r[lo:], starts 0 … hi − lo
       (``n_pre`` samples of template ``t0``, refinement bank ``shifts``/``templates``/``norms``, the
       templates' runs ``run_begin``/``run_value``/``n_runs``/``same_as_previous``):
       start, correlation and first decisions ``det_bits`` ((n_bits + 1,) uint8); below
       ``threshold`` → :data:`NOT_FOUND`.
    3. The reference of ``det_bits`` from start/fs·fs (0 outside the reply), its known levels
       (:func:`rfsim.gen2._measure_kernels.known_levels_kernel`, the first ``n_pre_el`` elements
       the preamble) and (h, c) by :func:`rfsim.gen2._fit_kernels.fit_gain_offset_kernel`.
    4. Decisions ``bits`` ((n_bits + 1,) uint8) of span = r[i0 : i0 + n_reply + 4] − c (i0 the
       sample before the start) with the gain h.
    5. :func:`rfsim.gen2._measure_kernels.measure_kernel` of span against the reference of
       ``bits``.

    ``out_f`` ((4,) float64) receives start [samples of rx], corr, slope [rad/s], σ² [W];
    ``out_c`` ((1,) complex128) the measured gain. Returns a status: :data:`RECEIVED`,
    :data:`NOT_FOUND` (start and corr set), or an error (:data:`NO_GAIN`, :data:`NO_ROOM`,
    :data:`TOO_SHORT`, :data:`CONSTANT`).
    """
    n = rx.size
    r = np.empty(n, np.complex128)
    if lo >= 8:
        acc = 0j
        for i in range(lo):
            acc += rx[i]
        dc0 = acc / lo
        for i in range(n):
            r[i] = rx[i] - dc0
    else:
        r[:] = rx
    rr = r[lo:]
    last = min(rr.size - n_reply, hi - lo)
    if last < 0:
        return TOO_SHORT
    ratio = 2.0 * blf_hz / fs_hz
    sums = np.empty(pre_levels.size + 2 * det_bits.size)
    status, start_rel, corr, h0, dc0_ = decode_reply_kernel(rr, last + n_pre, math.nan, 0j, False, t0,
                                                            max_runs_per_sample, half_width, 5, shifts, templates,
                                                            norms, run_begin, run_value, n_runs, same_as_previous,
                                                            pre_el, ratio, n_pre, m, pre_levels.size, state0, viterbi,
                                                            sums, det_bits)
    start = lo + start_rel
    out_f[0] = start
    out_f[1] = corr
    if status == ZERO_GAIN:
        return NO_GAIN
    if corr < threshold:
        return NOT_FOUND
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
    n_known = known_levels_kernel(r, full, t0_samples, ratio, n_pre_el, r_known, level)
    h, c, ok = fit_gain_offset_kernel(r_known[:n_known], level[:n_known])
    if not ok:
        return CONSTANT
    # step 4: decisions of the reply's samples, r − c, with the gain h
    i0 = lo + int(math.floor(start_rel))
    i1 = min(n, i0 + n_reply + 4)
    span = np.empty(i1 - i0, np.complex128)
    for i in range(i1 - i0):
        span[i] = r[i0 + i] - c
    frac = start_rel - (i0 - lo)
    if not (0.0 <= frac <= span.size - n_reply):
        return NO_ROOM
    if h == 0:
        return NO_GAIN
    g = 1.0 / h
    lag = int(math.floor(frac))
    n_part = min(span.size, lag + int(math.ceil(sums.size * m / ratio)) + 2)
    decisions_kernel(span[lag:n_part], g.real, g.imag, (0.0 * g).real, frac - lag, ratio, m, pre_levels.size,
                     state0, viterbi, sums, bits)
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
    hm, slope, sigma2 = measure_kernel(span, ref, fs_hz, n_blocks)
    out_c[0] = hm
    out_f[2] = slope
    out_f[3] = sigma2
    return RECEIVED

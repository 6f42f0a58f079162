"""numba kernels of :func:`rfsim.gen2.linecode.decode_reply` and :func:`rfsim.gen2.linecode.decode_bits`
(wrapped and documented there; the NumPy twin is ``reference.gen2_linecode.decode_reply_reference``
in the tests), also called by the reader's receiver (``rfsim.gen2._receive_kernels``).

The steps are the module docstring's of :mod:`rfsim.gen2.linecode`: the preamble search
(:func:`rfsim.gen2._linecode_kernels.preamble_search_runs_kernel`), the template at the refined start
(:func:`rfsim.gen2._linecode_kernels.sampled_template`), the preamble's least-squares gain and
offset (:func:`rfsim.gen2._reply_core_kernels.preamble_gain_offset`), the normalised correlation,
the projected half-bit sums and the decisions (:func:`rfsim.gen2._reply_core_kernels.halfbit_decisions`).
Sums run sample by sample, in order.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit
from rfsim.gen2._linecode_kernels import preamble_search_runs_kernel, projected_halfbit_sums_kernel, sampled_template
from rfsim.gen2._reply_core_kernels import halfbit_decisions, preamble_gain_offset

#: Status of :func:`decode_reply_kernel`: decoded.
DECODED = 0
#: Status of :func:`decode_reply_kernel`: the gain is zero, nothing to decode.
ZERO_GAIN = 1


@njit
def decisions_kernel(part, g_re, g_im, dc_re, start, elements_per_sample, m, n_pre_levels, state0, viterbi, sums,
                     out):
    """Decisions of a reply whose start, gain and offset are known: the half-bit sums of
    Re((part − dc)/h) (:func:`rfsim.gen2._linecode_kernels.projected_halfbit_sums_kernel`, g = 1/h
    = (``g_re``, ``g_im``), ``dc_re`` = Re(dc·g), reply from sample ``start`` of ``part``) into
    ``sums`` ((n_pre_levels + 2·out.size,)), then Viterbi from ``state0`` ending on the dummy 1
    (``viterbi``) or bit-by-bit decisions into ``out`` ((n_bits + 1,) uint8, the last the dummy)."""
    projected_halfbit_sums_kernel(part, g_re, g_im, dc_re, start, elements_per_sample, m, sums)
    a = np.empty(out.size)
    b = np.empty(out.size)
    halfbit_decisions(sums, n_pre_levels, m > 1, state0, viterbi, a, b, out)


@njit
def decode_reply_kernel(r, n_search, start_in, gain, has_gain, t0, max_runs_per_sample, half_width, n_max, shifts,
                        templates, norms, run_begin, run_value, n_runs, same_as_previous, pre_el,
                        elements_per_sample, n_pre, m, n_pre_levels, state0, viterbi, sums, out):
    """One reply of ``r`` ((n,) complex128): start, gain, offset, correlation and decisions.

    Start: with ``n_search ≥ 0`` the preamble search over ``r[:n_search]`` (zero-mean template
    ``t0``, refinement bank ``shifts``/``templates``/``norms`` and the templates' runs
    ``run_begin``/``run_value``/``n_runs``/``same_as_previous``,
    :func:`rfsim.gen2._linecode_kernels.preamble_search_runs_kernel`; the integer peak when no
    refined value exists), else ``start_in`` [samples]. At the start, lag = ⌊start⌋, the pilot + preamble
    elements ``pre_el`` sampled from start − lag give the template t (``n_pre`` samples, mean t̄);
    over the segment z = r[lag : lag + n_pre] (mean z̄): (h, c) by least squares
    (:func:`rfsim.gen2._reply_core_kernels.preamble_gain_offset`) or h = ``gain``, c = 0 with
    ``has_gain``; corr = |Σ z·(t − t̄)| / √(Σ(t − t̄)² · max(Σ|z − z̄|², 1e-300)). Decisions by
    :func:`decisions_kernel` into ``out`` ((n_bits + 1,) uint8), ``sums`` the half-bit sums
    ((n_pre_levels + 2·(n_bits + 1),)).

    Returns ``(status, start, corr, h, c)``: status :data:`DECODED`, or :data:`ZERO_GAIN` (h = 0,
    no decisions made).
    """
    if n_search >= 0:
        lag, best, start = preamble_search_runs_kernel(r, n_search, t0, max_runs_per_sample, half_width, n_max,
                                                       shifts, templates, norms, run_begin, run_value, n_runs,
                                                       same_as_previous)
        if best < 0:
            start = float(lag)
    else:
        start = start_in
    lag = int(math.floor(start))
    tpl = np.empty(n_pre)
    t_mean = sampled_template(pre_el, start - lag, elements_per_sample, tpl)
    seg_sum = 0j
    for i in range(n_pre):
        seg_sum += r[lag + i]
    seg_mean = seg_sum / n_pre
    if has_gain:
        h = gain
        dc = 0j
    else:
        h, dc = preamble_gain_offset(r, lag, tpl, t_mean, n_pre, seg_mean)
    peak = 0j
    e_t = 0.0
    e_seg = 0.0
    for i in range(n_pre):
        t = tpl[i] - t_mean
        z = r[lag + i]
        peak += z * t
        e_t += t * t
        d = z - seg_mean
        e_seg += d.real * d.real + d.imag * d.imag
    corr = abs(peak) / math.sqrt(e_t * max(e_seg, 1e-300))
    if h == 0:
        return ZERO_GAIN, start, corr, h, dc
    g = 1.0 / h
    n_part = min(r.size, lag + int(math.ceil(sums.size * m / elements_per_sample)) + 2)
    decisions_kernel(r[lag:n_part], g.real, g.imag, (dc * g).real, start - lag, elements_per_sample, m,
                     n_pre_levels, state0, viterbi, sums, out)
    return DECODED, start, corr, h, dc

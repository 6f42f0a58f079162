"""numba kernels of the passive tag's front end (wrapped and documented in :mod:`rfsim.devices.tag`;
the plain-NumPy twin is :func:`reference.devices_tag.cw_power_reference` in the tests)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit
from rfsim.gen2._linecode_kernels import waveform_kernel
from rfsim.gen2._pie_kernels import decode_kernel, trailing_run_start, two_level_split


@njit
def cw_power_kernel(env, threshold, select, buf):
    """Median of ``env²`` over the samples with ``env ≥ threshold`` (all samples if not
    ``select``); ``buf`` is scratch of ``env.size``. As ``numpy.median``: the mean of the
    two middle values for an even count, NaN if a NaN enters the median or nothing does."""
    n = 0
    for i in range(env.size):
        v = env[i]
        if select:
            if v >= threshold:
                buf[n] = v * v
                n += 1
        else:
            if math.isnan(v):
                return math.nan
            buf[n] = v * v
            n += 1
    if n == 0:
        return math.nan
    return np.median(buf[:n])


@njit
def plateau_kernel(x, env, threshold, select, margin, buf, idx, win):
    """Index of the CW sample the median of ``env²`` lands on (over the samples with ``env ≥
    threshold``, all if not ``select``; ties in sample order, as a stable sort) when the
    2·``margin`` + 1 samples around it in that order are all ±x at that index; −1 when they
    are not (or too few samples are selected), −2 when a NaN is among them or the median is
    none of the three candidates below (the caller then asks
    :func:`rfsim.devices.tag.plateau_reference`, which sorts). ``buf``/``idx``: scratch of ``env.size``
    (float64, int64); ``win``: int64 scratch of 2·``margin`` + 1 (:func:`plateau_split` with the
    run of equal values that ends ``env``).

    The median value v is found by counting (a candidate sample's value); with c_< samples below it,
    stable order puts the samples equal to v at positions c_< …, in sample order: position p
    is the (p − c_<)-th of them."""
    return plateau_split(x, env, trailing_run_start(env), threshold, select, margin, buf, idx, win)


@njit
def plateau_split(x, env, tail, threshold, select, margin, buf, idx, win):
    """:func:`plateau_kernel` given that ``env[tail:]`` (``tail`` < ``env.size``) all equal
    ``env[tail]``: the selected samples before ``tail`` are gathered in ``buf``/``idx``, those of
    the tail are counted, not stored (the same answer)."""
    c = env[tail]
    c2 = c * c
    n_tail = env.size - tail if ((not select) or c >= threshold) else 0
    m_head = 0
    for i in range(tail):
        v = env[i]
        if (not select) or v >= threshold:
            buf[m_head] = v * v
            idx[m_head] = i
            m_head += 1
    m = m_head + n_tail
    if m <= 2 * margin:
        return -1
    if n_tail > 0 and math.isnan(c2):
        return -2
    for k in range(m_head):
        if math.isnan(buf[k]):
            return -2
    mid = (m - 1) // 2
    # the median is usually the CW value of the first, middle or last selected sample: a
    # candidate c is the median exactly when #(< c) ≤ mid < #(≤ c); otherwise select it
    med = math.nan
    n_less = 0
    for k_c in (0, m - 1, m // 2):
        cand = buf[k_c] if k_c < m_head else c2
        n_less = 0
        n_eq = 0
        for k in range(m_head):
            v = buf[k]
            if v < cand:
                n_less += 1
            elif v == cand:
                n_eq += 1
        if c2 < cand:
            n_less += n_tail
        elif c2 == cand:
            n_eq += n_tail
        if n_less <= mid < n_less + n_eq:
            med = cand
            break
    if math.isnan(med):  # rare: the caller selects it (np.partition here would cost seconds of compilation)
        return -2
    start = mid - margin - n_less  # rank, among the samples equal to med, of the window's first
    if start < 0:
        return -1
    width = 2 * margin + 1
    r = 0
    w = 0
    for k in range(m_head):
        if buf[k] == med:
            if r >= start:
                win[w] = idx[k]
                w += 1
                if w == width:
                    break
            r += 1
    if w < width and c2 == med:
        for k in range(n_tail):
            if r >= start:
                win[w] = tail + k
                w += 1
                if w == width:
                    break
            r += 1
    if w < width:
        return -1
    xm = x[win[margin]]
    for q in range(width):
        v = x[win[q]]
        if not (v == xm or v == -xm):
            return -1
    return win[margin]


@njit
def front_end_kernel(x, env, head, max_iter, min_modulation, margin, buf_lo, buf_hi, idx, win):
    """The shared front end's work on one segment in one call (:class:`rfsim.devices.tag.SharedFrontEnd`):
    the extremes of the envelope ``env`` = |x| (a NaN among them makes both NaN, as
    ``numpy.min``/``numpy.max``), its isodata split (:func:`rfsim.gen2._pie_kernels.two_level_split`)
    from them, then :func:`plateau_split` over the CW samples that split selects (``env ≥``
    threshold when high > 0 and high − low ≥ ``min_modulation``·high, else every sample); the
    run of equal values that ends ``env`` (a reader's CW after its command) is read once
    (:func:`rfsim.gen2._pie_kernels.trailing_run_start`). Only ``env[:head]`` is read
    (1 ≤ ``head`` ≤ ``env.size``): the caller knows ``env[head - 1:]`` all equal (a reader's
    constant CW; ``head`` = ``env.size`` when it does not), so the rest need not be formed: the
    run that ends ``env[:head]`` is the one that ends ``env``, and every step reads the run's
    first sample and counts the others. ``buf_lo``/``buf_hi`` (float64) and
    ``idx`` (int64): scratch of ``env.size`` ≥ 1; ``win``: int64 scratch of 2·``margin`` + 1.
    Returns ``(threshold, low mean, high mean, plateau, tail)``, plateau as :func:`plateau_kernel`
    gives it (−1 none, −2 left to the NumPy twin), ``tail`` the index of the first of the equal
    samples that end ``env`` (:func:`rfsim.gen2._pie_kernels.trailing_run_start`)."""
    tail = trailing_run_start(env[:head])
    lo = env[tail]
    hi = lo
    for i in range(tail):
        v = env[i]
        if math.isnan(v):
            lo = v
            hi = v
            break
        if v < lo:
            lo = v
        elif v > hi:
            hi = v
    thr, m_lo, m_hi = two_level_split(env, tail, lo, hi, max_iter, buf_lo, buf_hi)
    select = m_hi > 0 and m_hi - m_lo >= min_modulation * m_hi
    p = plateau_split(x, env, tail, thr, select, margin, buf_lo, idx, win)
    return thr, m_lo, m_hi, p, tail


@njit
def front_end_decode_kernel(x, env, head, max_iter, min_modulation, margin, hysteresis, min_ratio, max_ratio,
                            max_trcal):
    """:func:`front_end_kernel` then the PIE decoding of the envelope it read in one call (the ideal
    detector's command, :meth:`rfsim.devices.tag.SharedFrontEnd.command` with no RC): the decoder's
    :func:`rfsim.gen2._pie_kernels.decode_kernel` on ``env[:tail + 1]`` (the samples it reads: it
    stops at the first of the equal samples that end ``env``) with the front end's levels, threshold
    and hysteresis ``hysteresis``·(high − low), checking that the samples are finite, as
    :func:`rfsim.gen2.pie.pie_decode` with those levels does (nothing decoded from fewer than two
    samples). Scratch is allocated here. Returns ``(threshold, low mean, high mean, plateau, tail,
    nf, start, end, delimiter, Tari, RTcal, TRcal, bits)``: the front end's values, the number of
    frames and the first frame's values and bits ((k,) uint8, a new array; NaN and empty when
    ``nf`` = 0)."""
    n = env.size
    buf_lo = np.empty(n)
    buf_hi = np.empty(n)
    idx = np.empty(n, np.int64)
    thr, m_lo, m_hi, p, tail = front_end_kernel(x, env, head, max_iter, min_modulation, margin, buf_lo, buf_hi,
                                                idx, np.empty(2 * margin + 1, np.int64))
    m = tail + 1
    nf = 0
    bits = np.empty(m, np.uint8)
    fbuf = np.empty((6, m // 2 + 1))
    ibuf = np.empty((2, m // 2 + 1), np.int64)
    if m >= 2:
        ne, nf = decode_kernel(env[:m], thr, hysteresis * (m_hi - m_lo), True, min_ratio, max_ratio, max_trcal,
                               buf_lo, np.empty(m, np.int8), fbuf, ibuf, bits)
        if ne < 0:
            nf = 0
    if nf == 0:
        return thr, m_lo, m_hi, p, tail, 0, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, bits[:0].copy()
    off = ibuf[0, 0]
    return (thr, m_lo, m_hi, p, tail, nf, fbuf[0, 0], fbuf[1, 0], fbuf[2, 0], fbuf[3, 0], fbuf[4, 0], fbuf[5, 0],
            bits[off:off + ibuf[1, 0]].copy())


@njit
def reflection_kernel(s, gamma_b, gamma_a, out):
    """Γ(t) of a reply: ``out[i] = gamma_b`` where the reply waveform ``s[i] > 0`` (float64 ``s``;
    or the mask of where it is, bool ``s``), else ``gamma_a`` (plain-NumPy twin:
    :func:`reference.devices_tag.reflection_reference` in the tests)."""
    for i in range(s.size):
        out[i] = gamma_b if s[i] > 0 else gamma_a


@njit
def reply_states_kernel(elements, t0_samples, elements_per_sample, gamma_b, gamma_a, mask, out):
    """A reply's mask and Γ(t) in one call: its ±1 waveform s (:func:`rfsim.gen2._linecode_kernels.waveform_kernel`
    of ``elements`` from ``t0_samples`` at ``elements_per_sample``, over ``mask.size`` samples), ``mask``
    = s > 0 (bool) and ``out`` = :func:`reflection_kernel` of that mask (complex128), as
    :func:`rfsim.devices.tag.reply_gamma` forms them from :func:`rfsim.gen2.linecode.reply_waveform`."""
    s = np.empty(mask.size)
    waveform_kernel(elements, t0_samples, elements_per_sample, s)
    for i in range(s.size):
        mask[i] = s[i] > 0
    reflection_kernel(mask, gamma_b, gamma_a, out)

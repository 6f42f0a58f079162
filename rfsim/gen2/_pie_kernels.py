"""numba kernels of the PIE encoder/decoder (wrapped and documented in :mod:`rfsim.gen2.pie`).

Positions are in samples (ticks of the sampling clock) as float64; kernels fill
preallocated arrays and return counts. Each kernel has a plain-NumPy twin in the tests'
``reference.gen2_pie`` that the tests compare against.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.extending import overload

from rfsim.core._jit import njit

FALL = 0
RISE = 1


def env_value(x, i):
    """Envelope sample i of ``x``: ``x[i]`` of a real envelope, ``|x[i]| = √(Re² + Im²)``
    (float64) of complex samples, so kernels read a complex capture's envelope without a
    full-length envelope array (numba overload; this Python body serves the twins)."""
    return abs(x[i]) if np.iscomplexobj(x) else x[i]


@overload(env_value)
def _env_value_overload(x, i):
    if isinstance(x.dtype, types.Complex):
        def magnitude(x, i):
            re = np.float64(x[i].real)
            im = np.float64(x[i].imag)
            return math.sqrt(re * re + im * im)
        return magnitude
    return lambda x, i: x[i]


def env_order(x, i):
    """A monotonic function of :func:`env_value` for comparisons without a square root per
    sample: ``x[i]`` of a real envelope, the power Re² + Im² of complex samples (numba
    overload; compare it with :func:`env_level` of the level)."""
    return abs(x[i]) ** 2 if np.iscomplexobj(x) else x[i]


def env_level(x, level):
    """``level`` on the scale of :func:`env_order`: level of a real envelope; level² of
    complex samples (a magnitude ≥ 0: −1 for a negative level, below every power), so
    env_value(x, i) > level ⇔ env_order(x, i) > env_level(x, level), and so for <."""
    if not np.iscomplexobj(x):
        return level
    return level * level if level >= 0 else -1.0


@overload(env_order)
def _env_order_overload(x, i):
    if isinstance(x.dtype, types.Complex):
        def power(x, i):
            re = np.float64(x[i].real)
            im = np.float64(x[i].imag)
            return re * re + im * im
        return power
    return lambda x, i: x[i]


@overload(env_level)
def _env_level_overload(x, level):
    if isinstance(x.dtype, types.Complex):
        return lambda x, level: level * level if level >= 0 else -1.0
    return lambda x, level: level


@njit
def smooth_step(tau, width):
    """Raised-cosine step 0 → 1 centred at ``tau = 0`` over ``width`` samples (0: hard step)."""
    if width <= 0.0:
        return 1.0 if tau >= 0.0 else 0.0
    half = 0.5 * width
    if tau <= -half:
        return 0.0
    if tau >= half:
        return 1.0
    return 0.5 * (1.0 + math.sin(math.pi * tau / width))


@njit
def envelope_kernel(fall_pos, rise_pos, depth, ramp_width, out):
    """Subtract ``depth`` × (low-pulse indicator) from ``out`` (pre-filled with 1.0).

    ``fall_pos``/``rise_pos`` are the 50 % points of each low pulse in samples; ramps
    of overlapping edges add up (the envelope is a sum over pulses).
    """
    n = out.size
    half = 0.5 * ramp_width
    for k in range(fall_pos.size):
        f = fall_pos[k]
        r = rise_pos[k]
        i0 = max(0, int(math.ceil(f - half)))
        i1 = min(n, int(math.floor(r + half)) + 1)
        for i in range(i0, i1):
            low = smooth_step(i - f, ramp_width) - smooth_step(i - r, ramp_width)
            out[i] -= depth * low


@njit
def timeline_kernel(lead_s, bits, data0_s, data1_s, t0_s, pw_s, cw_before_s, fall_s, rise_s):
    """Edge times of a PIE command (see :func:`rfsim.gen2.pie.pie_timeline`). The symbol lengths
    are ``lead_s`` then ``data1_s`` for a 1 bit and ``data0_s`` for a 0 bit; with ``c_k`` their
    running sum in order (as ``numpy.cumsum``), ``rise_s = [t0, t0 + c_k …]`` and ``fall_s =
    [cw_before, t0 + c_k − pw …]`` (both of ``1 + lead_s.size + bits.size`` values)."""
    rise_s[0] = t0_s
    fall_s[0] = cw_before_s
    c = 0.0
    k = 1
    for i in range(lead_s.size + bits.size):
        if i < lead_s.size:
            c += lead_s[i]
        elif bits[i - lead_s.size] == 1:
            c += data1_s
        else:
            c += data0_s
        end = t0_s + c
        rise_s[k] = end
        fall_s[k] = end - pw_s
        k += 1


@njit
def ramp_width(fall_s, rise_s, rise_fall_s, ramp_per_10_90, fs_hz):
    """Full width [samples] of the raised-cosine edges whose 10–90 % time is ``rise_fall_s`` [s]:
    ``rise_fall_s · ramp_per_10_90 · fs_hz``, or −1.0 when an edge does not fit, i.e. when
    ``rise_fall_s`` > 0 exceeds a low interval ``rise_s[i] − fall_s[i]`` or a high interval
    ``fall_s[i] − rise_s[i − 1]`` (edge times [s]). The one rule of both the Python path
    (:func:`rfsim.gen2.pie.ask_baseband`, :func:`rfsim.gen2.pie.timeline_envelope`) and
    :func:`command_baseband_kernel`."""
    if rise_fall_s > 0.0:
        for i in range(fall_s.size):
            if rise_fall_s > rise_s[i] - fall_s[i] or (i > 0 and rise_fall_s > fall_s[i] - rise_s[i - 1]):
                return -1.0
    return rise_fall_s * ramp_per_10_90 * fs_hz


@njit
def sample_counts(duration_s, modulated_s, fs_hz):
    """``(n, n_modulated)``: the samples ``n = ceil(duration_s·fs)`` of a command's baseband
    (``duration_s`` = last rising edge + CW after it [s]) and those up to which its envelope is
    evaluated, ``min(n, ceil(modulated_s·fs))`` (``n`` when ``modulated_s`` is +inf). The one
    rule of both the Python path (:func:`rfsim.gen2.pie.ask_baseband`) and
    :func:`command_baseband_kernel`."""
    n = int(math.ceil(duration_s * fs_hz))
    if modulated_s == np.inf:
        return n, n
    return n, min(n, int(math.ceil(modulated_s * fs_hz)))


@njit
def ask_baseband_kernel(fall_s, rise_s, depth, ramp_width, fs_hz, amp, pr_ask, n_modulated, out):
    """DSB-ASK ``amp·e[n]`` or PR-ASK ``(amp·s_n)·e[n]`` (:func:`pr_ask_kernel`) into the complex
    ``out`` for n < ``n_modulated``, e the envelope of :func:`envelope_kernel` (edges ``fall_s``,
    ``rise_s`` [s] at ``fs_hz``, ramps ``ramp_width`` samples wide); beyond, the CW ``amp``
    (DSB) or ``amp·(1 − 2·(k mod 2))`` after the k = ``rise_s.size`` sign changes (PR-ASK)."""
    env = np.ones(n_modulated)
    envelope_kernel(fall_s * fs_hz, rise_s * fs_hz, depth, ramp_width, env)
    if pr_ask:
        pr_ask_kernel(0.5 * (fall_s + rise_s), fs_hz, amp, env, env)
        tail = amp * (1.0 - 2.0 * (rise_s.size % 2))
    else:
        for i in range(n_modulated):
            env[i] = amp * env[i]
        tail = amp
    for i in range(n_modulated):
        out[i] = env[i]
    for i in range(n_modulated, out.size):
        out[i] = tail


@njit
def command_baseband_kernel(lead_s, bits, data0_s, data1_s, t0_s, pw_s, cw_before_s, cw_after_s, modulated_after_s,
                            depth, rise_fall_s, ramp_per_10_90, fs_hz, amp, pr_ask):
    """Bits to samples in one call: the edge times of :func:`timeline_kernel` (``lead_s``,
    ``bits`` …, ``cw_before_s``), then :func:`ask_baseband_kernel` of them over ``n =
    ceil((r_last + cw_after_s)·fs)`` samples, modulated up to ``ceil((r_last +
    modulated_after_s)·fs)`` (``r_last`` the last rising edge [s]; :func:`sample_counts`), ramps
    ``rise_fall_s · ramp_per_10_90 · fs`` samples wide (:func:`ramp_width`). Returns ``(out, code)``: code 0 when done, 1 when a bit
    is neither 0 nor 1, 2 when ``rise_fall_s`` exceeds the shortest low or high interval (then
    ``out`` is empty)."""
    for i in range(bits.size):
        if bits[i] > 1:
            return np.empty(0, dtype=np.complex128), 1
    k = 1 + lead_s.size + bits.size
    fall_s = np.empty(k)
    rise_s = np.empty(k)
    timeline_kernel(lead_s, bits, data0_s, data1_s, t0_s, pw_s, cw_before_s, fall_s, rise_s)
    width = ramp_width(fall_s, rise_s, rise_fall_s, ramp_per_10_90, fs_hz)
    if width < 0.0:
        return np.empty(0, dtype=np.complex128), 2
    last = rise_s[k - 1]
    n, n_mod = sample_counts(last + cw_after_s, last + modulated_after_s, fs_hz)
    out = np.empty(n, dtype=np.complex128)
    ask_baseband_kernel(fall_s, rise_s, depth, width, fs_hz, amp, pr_ask, n_mod, out)
    return out, 0


@njit
def equal_tail_start(x):
    """Index of the first of the equal samples (``==``, real or complex) that end ``x``
    (``x.size − 1`` when the last two differ or the last is NaN; 0 for an empty ``x``)."""
    k = x.size - 1
    if k < 0:
        return 0
    v = x[k]
    while k >= 64:  # blocks of 64 first: a loop without an early exit, which the compiler vectorises
        differ = 0
        for j in range(k - 64, k):
            differ += x[j] != v
        if differ:
            break
        k -= 64
    while k > 0 and x[k - 1] == v:
        k -= 1
    return k


@njit
def edges_kernel(x, threshold, hysteresis, edge_pos, edge_dir):
    """Comparator with hysteresis; returns the number of edges written.

    The state goes high when ``x > threshold + hysteresis`` and low when
    ``x < threshold - hysteresis``; the initial state is that of the first sample
    outside the band. An edge found at sample ``n`` is placed at the linear-interpolated
    crossing of ``threshold`` between samples ``n-1`` and ``n`` (clipped to ``[n-1, n]``).
    ``x`` is a real envelope or complex samples (their magnitude, :func:`env_value`).
    """
    # after the first of the equal samples that end x the state no longer changes
    return edges_until(x, min(x.size, equal_tail_start(x) + 1), threshold, hysteresis, edge_pos, edge_dir)


@njit
def edges_until(x, stop, threshold, hysteresis, edge_pos, edge_dir):
    """:func:`edges_kernel` given that the samples of ``x`` from ``stop`` − 1 on are equal (read
    up to ``stop`` only, besides the search of the initial state)."""
    hi = threshold + hysteresis
    lo = threshold - hysteresis
    # compared on the scale of env_order (the power of complex samples: no square root per
    # sample); the magnitudes are read only at an edge, for its interpolation
    hi_o = env_level(x, hi)
    lo_o = env_level(x, lo)
    n = x.size
    state = -1
    for i in range(n):
        if env_order(x, i) > hi_o:
            state = 1
            break
        if env_order(x, i) < lo_o:
            state = 0
            break
    ne = 0
    if state < 0:
        return ne
    for i in range(1, stop):
        v = env_order(x, i)
        new = state
        if state == 0 and v > hi_o:
            new = 1
        elif state == 1 and v < lo_o:
            new = 0
        if new != state:
            a = env_value(x, i - 1)
            d = env_value(x, i) - a
            frac = 0.5
            if d != 0.0:
                frac = (threshold - a) / d
            if frac < 0.0:
                frac = 0.0
            elif frac > 1.0:
                frac = 1.0
            edge_pos[ne] = (i - 1) + frac
            edge_dir[ne] = new
            ne += 1
            state = new
    return ne


@njit
def frames_kernel(
    pos, direction, min_ratio, max_ratio, max_trcal, f_start, f_end, f_delim, f_tari, f_rtcal,
    f_trcal, f_off, f_cnt, bits,
):
    """Parse alternating edges into PIE frames; returns the number of frames.

    A frame: falling edge (delimiter start), rising edge (delimiter end), data-0
    (rising→rising = Tari), RTcal (rising→rising), optional TRcal (next interval if
    > RTcal and ≤ ``max_trcal``·RTcal), then data symbols while the rising→rising
    interval is ≤ RTcal; bit = interval > RTcal/2. Frames need
    ``min_ratio ≤ RTcal/Tari ≤ max_ratio`` and at least one bit.
    """
    ne = pos.size
    nf = 0
    nb = 0
    i = 0
    while i < ne:
        if direction[i] != FALL or i + 5 >= ne:
            i += 1
            continue
        f0 = pos[i]
        r0 = pos[i + 1]
        r1 = pos[i + 3]
        r2 = pos[i + 5]
        tari = r1 - r0
        rtcal = r2 - r1
        if tari <= 0.0 or rtcal < min_ratio * tari or rtcal > max_ratio * tari:
            i += 1
            continue
        j = i + 5
        trcal = np.nan
        if j + 2 < ne:
            span = pos[j + 2] - pos[j]
            if span > rtcal and span <= max_trcal * rtcal:
                trcal = span
                j += 2
        start_bits = nb
        pivot = 0.5 * rtcal
        while j + 2 < ne:
            span = pos[j + 2] - pos[j]
            if span > rtcal:
                break
            bits[nb] = 1 if span > pivot else 0
            nb += 1
            j += 2
        if nb == start_bits:
            i += 1
            continue
        f_start[nf] = f0
        f_end[nf] = pos[j]
        f_delim[nf] = r0 - f0
        f_tari[nf] = tari
        f_rtcal[nf] = rtcal
        f_trcal[nf] = trcal
        f_off[nf] = start_bits
        f_cnt[nf] = nb - start_bits
        nf += 1
        i = j + 1
    return nf


@njit
def decode_kernel(x, threshold, hysteresis, check_finite, min_ratio, max_ratio, max_trcal, pos, direction, fbuf,
                  ibuf, bits):
    """:func:`edges_kernel` then :func:`frames_kernel` of ``x`` in one call; returns ``(ne, nf)``,
    the numbers of edges and frames, or ``(-1, 0)`` when ``check_finite`` is set and a sample of
    ``x`` is not finite (a real envelope; :func:`env_order` of complex samples). Scratch:
    ``pos``/``direction``/``bits`` of ``x.size`` (float64, int8, uint8), ``fbuf`` (6, m) float64
    and ``ibuf`` (2, m) int64 with m = x.size // 2 + 1: the frames' start, end, delimiter, Tari,
    RTcal, TRcal and bit offset, count."""
    stop = min(x.size, equal_tail_start(x) + 1)
    if check_finite:  # the equal samples that end x are finite if the first of them is
        for i in range(stop):
            if not math.isfinite(env_order(x, i)):
                return -1, 0
    ne = edges_until(x, stop, threshold, hysteresis, pos, direction)
    nf = frames_kernel(pos[:ne], direction[:ne], min_ratio, max_ratio, max_trcal, fbuf[0], fbuf[1], fbuf[2],
                       fbuf[3], fbuf[4], fbuf[5], ibuf[0], ibuf[1], bits)
    return ne, nf


#: Block size of numpy's pairwise summation (``PW_BLOCKSIZE`` in numpy's loops_utils).
_PW_BLOCKSIZE = 128


@njit
def _block_sum(a, lo, n):
    """One leaf of numpy's pairwise summation (n ≤ 128): 8 running sums, then the rest."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0 = a[lo]
    r1 = a[lo + 1]
    r2 = a[lo + 2]
    r3 = a[lo + 3]
    r4 = a[lo + 4]
    r5 = a[lo + 5]
    r6 = a[lo + 6]
    r7 = a[lo + 7]
    i = 8
    stop = n - (n % 8)
    while i < stop:
        j = lo + i
        r0 += a[j]
        r1 += a[j + 1]
        r2 += a[j + 2]
        r3 += a[j + 3]
        r4 += a[j + 4]
        r5 += a[j + 5]
        r6 += a[j + 6]
        r7 += a[j + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit
def _const_block_sum(c, n):
    """:func:`_block_sum` of n ≤ 128 values all equal to ``c``, the same operations in the same
    order (the 8 running sums are equal)."""
    res = 0.0
    if n < 8:
        for _ in range(n):
            res += c
        return res
    r = c
    for _ in range(n // 8 - 1):
        r += c
    res = ((r + r) + (r + r)) + ((r + r) + (r + r))
    for _ in range(n % 8):
        res += c
    return res


@njit
def pairwise_sum(a, lo, n):
    """Σ a[lo : lo + n] in the order of numpy's pairwise summation, so that the result equals
    ``np.add.reduce(a[lo:lo + n])`` bit for bit for contiguous float64 input.

    numpy sums blocks of at most 128 values with :func:`_block_sum` and otherwise returns
    ``sum(first h) + sum(rest)``, h = n/2 rounded down to a multiple of 8
    (:func:`pairwise_sum_tail` without a tail).
    """
    return pairwise_sum_tail(a, lo, n, lo + n, 0.0, np.empty(0, np.int64), np.empty(0))


@njit
def pairwise_sum_tail(a, lo, n, head, c, memo_n, memo_v):
    """:func:`pairwise_sum` of the values v[lo : lo + n] with v[i] = a[i] for i < ``head`` and
    v[i] = ``c`` for i ≥ ``head`` (a constant tail), bit for bit, without reading the tail.

    The recursion is numpy's (unrolled with an explicit stack: numba's cache does not handle
    recursive kernels); a block inside the tail is summed as :func:`_const_block_sum`, and a
    node inside the tail depends only on its length, so its sum is kept in ``memo_n``/``memo_v``
    (lengths and sums of the same ``c``; int64/float64 arrays of equal size, unused entries of
    ``memo_n`` 0; the caller may keep them across calls with the same ``c``). The block that
    holds ``head`` is read from ``a``: ``a[head : min(lo + n, head + 128)]`` must hold ``c``.
    """
    s_lo = np.empty(64, dtype=np.int64)
    s_n = np.empty(64, dtype=np.int64)
    s_stage = np.zeros(64, dtype=np.int8)  # 0: new, 1: left half pending, 2: right half pending
    s_val = np.empty(64)
    top = 0
    s_lo[0] = lo
    s_n[0] = n
    while True:
        m = s_n[top]
        known = m <= _PW_BLOCKSIZE
        if known:
            v = _const_block_sum(c, m) if s_lo[top] >= head else _block_sum(a, s_lo[top], m)
        elif s_lo[top] >= head:
            for q in range(memo_n.size):
                if memo_n[q] == m:
                    v = memo_v[q]
                    known = True
                    break
        if not known:
            h = m // 2
            h -= h % 8
            s_stage[top] = 1
            top += 1
            s_lo[top] = s_lo[top - 1]
            s_n[top] = h
            s_stage[top] = 0
            continue
        while True:  # hand v to the parents
            top -= 1
            if top < 0:
                return v
            if s_stage[top] == 1:  # v is the left half: store it, then do the right half
                s_val[top] = v
                s_stage[top] = 2
                h = s_n[top] // 2
                h -= h % 8
                top += 1
                s_lo[top] = s_lo[top - 1] + h
                s_n[top] = s_n[top - 1] - h
                s_stage[top] = 0
                break
            v = s_val[top] + v
            if s_lo[top] >= head:  # a node inside the tail: its sum is that of its length
                for q in range(memo_n.size):
                    if memo_n[q] == 0:
                        memo_n[q] = s_n[top]
                        memo_v[q] = v
                        break


@njit
def trailing_run_start(x):
    """Index of the first of the equal samples that end the real ``x`` (``x.size − 1`` when the
    last two differ, or the last is NaN; zeros of both signs are not equal here); ``x.size`` ≥ 1."""
    k = x.size - 1
    v = x[k]
    if v != 0.0:  # equal values other than zeros have equal bits
        return equal_tail_start(x)
    while k > 0 and x[k - 1] == v and math.copysign(1.0, x[k - 1]) == math.copysign(1.0, v):
        k -= 1
    return k


@njit
def two_level_kernel(x, lo, hi, max_iter, buf_lo, buf_hi):
    """Isodata split of ``x`` (see :func:`rfsim.gen2.pie.two_level_threshold`): start at
    (lo + hi)/2, iterate threshold = (mean below + mean above)/2. ``buf_lo``/``buf_hi``
    are scratch arrays of ``x.size``; the means are pairwise sums over the samples in
    input order, as numpy's ``x[mask].mean()``. Returns ``(threshold, low mean, high mean)``
    (:func:`two_level_split` with the run of equal samples that ends ``x``)."""
    return two_level_split(x, trailing_run_start(x), lo, hi, max_iter, buf_lo, buf_hi)


@njit
def two_level_split(x, tail, lo, hi, max_iter, buf_lo, buf_hi):
    """:func:`two_level_kernel` given that the samples ``x[tail:]`` (``tail`` < ``x.size``) all equal
    ``x[tail]``: those are read once (a constant tail: a reader segment's CW after its command),
    the others once per pass; the sums are the same, bit for bit
    (:func:`pairwise_sum_tail`)."""
    n = x.size
    c = x[tail]
    n_tail = n - tail
    memo_n = np.zeros(64, dtype=np.int64)
    memo_v = np.empty(64)
    thr = 0.5 * (lo + hi)
    prev = thr
    m_lo = lo
    m_hi = hi
    for it in range(max_iter):
        if it > 0:
            # the split changes only if a sample lies between the previous threshold and this
            # one; if none does, the means would come out the same, and so would the threshold
            # (the loop's own stop, new == thr, without the sums)
            a, b = (prev, thr) if prev < thr else (thr, prev)
            moved = a <= c < b
            if not moved:
                for i in range(tail):
                    if a <= x[i] < b:
                        moved = True
                        break
            if not moved:
                break
        nb = 0
        na = 0
        for i in range(tail):
            v = x[i]
            if v < thr:
                buf_lo[nb] = v
                nb += 1
            else:
                buf_hi[na] = v
                na += 1
        # the tail joins one side; the block that holds its start is read from the buffer
        buf = buf_lo if c < thr else buf_hi
        head = nb if c < thr else na
        for i in range(head, min(head + _PW_BLOCKSIZE, head + n_tail)):
            buf[i] = c
        head_lo = nb
        head_hi = na
        if c < thr:
            nb += n_tail
        else:
            na += n_tail
        if nb == 0 or nb == n:
            break
        m_lo = pairwise_sum_tail(buf_lo, 0, nb, head_lo, c, memo_n, memo_v) / nb
        m_hi = pairwise_sum_tail(buf_hi, 0, na, head_hi, c, memo_n, memo_v) / na
        new = 0.5 * (m_lo + m_hi)
        if new == thr:
            break
        prev, thr = thr, new
    return thr, m_lo, m_hi


@njit
def pr_ask_kernel(mid_s, fs_hz, amp, e, out):
    """PR-ASK baseband ``out[n] = (amp·s_n)·e[n]`` with ``s_n = ±1``: −1 after an odd number
    of the sorted sign-change times ``mid_s`` [s] are ≤ t = n/fs (``searchsorted`` right)."""
    j = 0
    nm = mid_s.size
    for n in range(e.size):
        t = n / fs_hz
        while j < nm and mid_s[j] <= t:
            j += 1
        sign = 1.0 - 2.0 * (j % 2)
        out[n] = (amp * sign) * e[n]

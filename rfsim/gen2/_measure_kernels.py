"""numba kernels of the reader's receiver (wrapped and documented in :mod:`rfsim.devices.reader`;
the plain-NumPy twin is :func:`reference.devices_reader.measure_reference` in the tests)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit
from rfsim.gen2._linecode_kernels import INDEX_EPS

#: Samples between exact evaluations of the Doppler rotation phasor in the measurement.
ROTATION_RESYNC = 64


@njit
def measure_kernel(z, s, fs_hz, n_blocks, c=0j, d=0j):
    """Gain, Doppler slope and residual power of ``z = h(t)·s(t) + noise`` (see
    :meth:`rfsim.devices.reader.Reader.receive`, step 5).

    Uses the samples of the reply span (first to last non-zero ``s``) whose two neighbours
    carry the same level; ``t`` is the time from the span's centre [s]. The span is cut into
    ``n_blocks`` blocks (block k starts at floor(k·m/K) of the m used samples); per block
    g_k = Σz·s/Σs², tc_k = mean t; the slope is the weighted (|g_k|²) least-squares line
    through the unwrapped arg g_k; h = Σ z·e^{−j·slope·t}·s / Σs²; σ² = mean |z − h·s·e^{j·slope·t}|².
    ``c`` (complex) is an offset taken off z as the samples are read: the result is that of
    ``z − c`` (the reader's receiver passes its window and the fitted offset instead of a copy
    of the span less the offset; z − 0 is z); ``d`` (complex) an offset taken off before it, as
    the samples are read: the result is that of ``(z − d) − c`` (the receiver's window before
    its DC removal d, its offset c).
    Returns ``(h, slope [rad/s], σ²)``; ``(nan, 0, nan)`` when no sample is usable.

    Passes: the times of the span (vectorised divisions), the used samples copied out
    (branch-free, the levels of the neighbours carried in registers, the times compacted in
    place), then summed per block, the rotation formed, the gain and the residual summed. The
    sums keep their order (bit for bit); each is bound by its chain of additions, and fusing
    the copy with the block sums (a branch per sample, or masked sums over every sample),
    computing the times in the block loop, reading the span through indices instead of copies
    or summing two blocks side by side all measured slower or no faster; so did dropping the
    copied levels and times for reads through the indices. The copy is bound by its stores (one
    per value per sample), the sums by their chains of additions. The block sums take the real
    and imaginary parts apart (z·s with s real: the complex product only adds a signed zero to
    each part's product, which leaves a sum started at +0 unchanged: the same sums for finite z).
    """
    n = s.size
    i0 = 0  # first and last non-zero s, scanned from either end
    while i0 < n and s[i0] == 0.0:
        i0 += 1
    if i0 == n:
        return complex(math.nan, math.nan), 0.0, math.nan
    i1 = n
    while s[i1 - 1] == 0.0:
        i1 -= 1
    centre = 0.5 * (i0 + i1 - 1)
    nn = i1 - i0
    buf_t = np.empty(nn)
    for i in range(nn):  # the times first, apart: their divisions are vectorised
        buf_t[i] = ((i0 + i) - centre) / fs_hz
    buf_z = np.empty(nn, np.complex128)
    buf_ref = np.empty(nn)
    buf_idx = np.empty(nn, np.int64)
    m = 0
    prev = s[i0]
    a = s[i0 + 1] if nn > 1 else 0.0  # read only when the loop below runs
    for i in range(i0 + 1, i1 - 1):  # written at m every time, kept when steady (no branch)
        nxt = s[i + 1]
        buf_z[m] = (z[i] - d) - c
        buf_ref[m] = a
        buf_t[m] = buf_t[i - i0]  # m < i − i0: the times not yet read stay in place
        buf_idx[m] = i - i0
        m += (a == prev) & (a == nxt)
        prev = a
        a = nxt
    if m == 0:
        return complex(math.nan, math.nan), 0.0, math.nan
    g = np.empty(n_blocks, np.complex128)
    tc = np.empty(n_blocks)
    y = np.empty(n_blocks)
    # per-block gain and centre time
    all_positive = True
    for k in range(n_blocks):
        lo = k * m // n_blocks
        hi = (k + 1) * m // n_blocks
        a_re = 0.0
        a_im = 0.0
        rr = 0.0
        ts = 0.0
        for i in range(lo, hi):
            v = buf_ref[i]
            a_re += buf_z[i].real * v
            a_im += buf_z[i].imag * v
            rr += v * v
            ts += buf_t[i]
        g[k] = complex(a_re, a_im) / rr if rr > 0.0 else complex(math.nan, math.nan)
        tc[k] = ts / (hi - lo) if hi > lo else math.nan
        w = g[k].real * g[k].real + g[k].imag * g[k].imag
        if not w > 0.0:
            all_positive = False
    slope = block_slope(g, tc, y) if all_positive else 0.0
    # gain with the rotation e^{−j·slope·t} removed, then the residual power
    pc, ps = _rotation(slope, fs_hz, i0, i1, centre)
    acc = 0j
    rr = 0.0
    for j in range(m):
        q = buf_idx[j]
        acc += buf_z[j] * complex(pc[q] * buf_ref[j], -ps[q] * buf_ref[j])
        rr += buf_ref[j] * buf_ref[j]
    h = acc / rr
    res = 0.0
    for j in range(m):
        q = buf_idx[j]
        e = buf_z[j] - h * complex(pc[q] * buf_ref[j], ps[q] * buf_ref[j])
        res += e.real * e.real + e.imag * e.imag
    return h, slope, res / m


@njit
def block_slope(g, tc, y):
    """The phase slope [rad/s] of :func:`measure_kernel`: the weighted (|g_k|²) least-squares
    line through the unwrapped arg g_k (numpy.unwrap, period 2π) against the block centre
    times ``tc`` [s]; every |g_k| > 0. ``y`` ((K,) float64) is scratch (the unwrapped phases)."""
    n_blocks = g.size
    cum = 0.0
    prev = 0.0
    sw = 0.0
    swx = 0.0
    swy = 0.0
    for k in range(n_blocks):
        p = math.atan2(g[k].imag, g[k].real)
        if k > 0:
            dd = p - prev
            ddmod = (dd + math.pi) % (2.0 * math.pi) - math.pi
            if ddmod == -math.pi and dd > 0:
                ddmod = math.pi
            if abs(dd) >= math.pi:
                cum += ddmod - dd
        prev = p
        y[k] = p + cum
        w = g[k].real * g[k].real + g[k].imag * g[k].imag
        sw += w
        swx += w * tc[k]
        swy += w * y[k]
    xm = swx / sw
    ym = swy / sw
    num = 0.0
    den = 0.0
    for k in range(n_blocks):
        w = g[k].real * g[k].real + g[k].imag * g[k].imag
        num += w * (tc[k] - xm) * (y[k] - ym)
        den += w * (tc[k] - xm) * (tc[k] - xm)
    return num / den


@njit
def _rotation(slope, fs_hz, i0, i1, centre):
    """``(cos a_i, sin a_i)``, a_i = slope·(i − centre)/fs for i in [i0, i1): evaluated exactly
    every ROTATION_RESYNC samples from i0 and advanced between by the phasor recurrence
    e^{j(a + δ)} = e^{ja}·e^{jδ}, δ = slope/fs (drift < 1e-13). The stretches between two
    exact evaluations are independent: four are advanced side by side."""
    n = i1 - i0
    pc = np.empty(n)
    ps = np.empty(n)
    step_c = math.cos(slope / fs_hz)
    step_s = math.sin(slope / fs_hz)
    R = ROTATION_RESYNC
    b = 0
    while b + 4 * R <= n:
        a = slope * ((i0 + b - centre) / fs_hz)
        c0, s0 = math.cos(a), math.sin(a)
        a = slope * ((i0 + b + R - centre) / fs_hz)
        c1, s1 = math.cos(a), math.sin(a)
        a = slope * ((i0 + b + 2 * R - centre) / fs_hz)
        c2, s2 = math.cos(a), math.sin(a)
        a = slope * ((i0 + b + 3 * R - centre) / fs_hz)
        c3, s3 = math.cos(a), math.sin(a)
        for q in range(R):
            if q > 0:
                c0, s0 = c0 * step_c - s0 * step_s, s0 * step_c + c0 * step_s
                c1, s1 = c1 * step_c - s1 * step_s, s1 * step_c + c1 * step_s
                c2, s2 = c2 * step_c - s2 * step_s, s2 * step_c + c2 * step_s
                c3, s3 = c3 * step_c - s3 * step_s, s3 * step_c + c3 * step_s
            pc[b + q] = c0
            ps[b + q] = s0
            pc[b + R + q] = c1
            ps[b + R + q] = s1
            pc[b + 2 * R + q] = c2
            ps[b + 2 * R + q] = s2
            pc[b + 3 * R + q] = c3
            ps[b + 3 * R + q] = s3
        b += 4 * R
    c0 = 1.0
    s0 = 0.0
    for q in range(b, n):
        if q % R == 0:
            a = slope * ((i0 + q - centre) / fs_hz)
            c0, s0 = math.cos(a), math.sin(a)
        else:
            c0, s0 = c0 * step_c - s0 * step_s, s0 * step_c + c0 * step_s
        pc[q] = c0
        ps[q] = s0
    return pc, ps


@njit
def _in_preamble(i, t0_samples, elements_per_sample, n_pre_elements):
    """Whether sample i falls on a preamble element (the element index of
    :func:`rfsim.gen2._linecode_kernels.waveform_kernel`)."""
    u = (i - t0_samples) * elements_per_sample
    if u < 0.0:
        return False
    return int(math.floor(u + INDEX_EPS)) < n_pre_elements


@njit
def _level(full, i):
    """Reference level of sample i: −1 outside the reply, the reply level inside it."""
    return -1.0 if full[i] == 0.0 else full[i]


@njit
def known_indices_kernel(full, t0_samples, elements_per_sample, n_pre_elements, index_out, level_out):
    """Samples whose level is known without decisions — on the preamble (pilot included) or
    outside the reply (``full == 0``: the rest state, level −1) — and whose two neighbours
    carry the same level: writes their indices (int64) and their level into ``index_out`` /
    ``level_out`` (in order) and returns their number. ``full`` is the sampled reply (±1, 0
    outside) starting at ``t0_samples``, whose first ``n_pre_elements`` elements are the
    preamble. The one definition of the known-level rule (:func:`known_levels_kernel` copies
    the samples it names)."""
    n = full.size
    last = n - 1  # the reply's last sample (its samples are ±1, never 0: one run of non-zero)
    while last > 0 and full[last] == 0.0:
        last -= 1
    m = 0
    i = 1
    while i < n - 1:
        if full[i] == 0.0 or _in_preamble(i, t0_samples, elements_per_sample, n_pre_elements):
            li = _level(full, i)
            if li == _level(full, i - 1) and li == _level(full, i + 1):
                index_out[m] = i
                level_out[m] = li
                m += 1
            i += 1
        else:  # past the preamble, inside the reply: no known level up to its last sample
            i = max(i + 1, last + 1)
    return m


@njit
def known_levels_kernel(r, full, t0_samples, elements_per_sample, n_pre_elements, r_out, level_out, dc=0j):
    """The samples of known level (:func:`known_indices_kernel`, on ``full`` from ``t0_samples``,
    its first ``n_pre_elements`` elements the preamble): copies them and their level into
    ``r_out`` / ``level_out`` (in order) and returns their number. ``dc`` (complex) is taken
    off the samples as they are copied: ``r_out`` holds samples of ``r − dc``."""
    index = np.empty(max(full.size - 2, 0), np.int64)
    m = known_indices_kernel(full, t0_samples, elements_per_sample, n_pre_elements, index, level_out)
    for j in range(m):
        r_out[j] = r[index[j]] - dc
    return m

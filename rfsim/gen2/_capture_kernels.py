"""numba kernels of the capture decoders (wrapped and documented in :mod:`rfsim.gen2.capture`
and :mod:`rfsim.gen2.replies`; the plain-NumPy twins are ``*_reference`` functions in the tests'
``reference`` package, and in :mod:`rfsim.gen2.reply_tracking` and :mod:`rfsim.gen2.replies` for
the decoding steps that also serve a caller's own reply-length rule).
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit, njit_inline
from rfsim.gen2._pie_kernels import env_order, env_value


@njit
def _within(span, nominal, tol):
    return abs(span - nominal) <= tol


@njit
def frame_gate_kernel(pos, x, first, last, tari, rtcal, trcal, rtcal_tari, trcal_rtcal, delim_tari, pw_tari,
                      tol_tari, tol_samples, min_contrast, min_bits, contrast_out, keep):
    """PIE plausibility gate of every frame (see :func:`rfsim.gen2.capture.plausible_frames`).

    Frame i spans the edges ``first[i] … last[i]`` of ``pos`` (a falling edge, then
    alternating rising/falling edges, ending on a rising edge). A frame is kept when

    * its bit count (symbols after the preamble) is ≥ ``min_bits``;
    * RTcal/Tari ∈ ``rtcal_tari``, TRcal/RTcal ∈ ``trcal_rtcal`` (frames with a TRcal),
      delimiter/Tari ∈ ``delim_tari``;
    * every data symbol (rising → rising) lies within tol = ``tol_tari``·Tari +
      ``tol_samples`` of data-0 = Tari or data-1 = RTcal − Tari;
    * every low pulse after the delimiter (falling → rising) lies within tol of their
      median-free reference, the first pulse's width, and that width/Tari ∈ ``pw_tari``;
    * the contrast (mean of the high-interval mid samples − mean of the low-pulse mid
      samples)/(pooled standard deviation) ≥ ``min_contrast``.

    ``x`` is the envelope, or complex samples whose magnitude it is (:func:`env_value`).
    Writes ``contrast_out[i]`` and ``keep[i]`` (1/0).
    """
    for i in range(first.size):
        keep[i] = 0
        contrast_out[i] = 0.0
        e0 = first[i]
        e1 = last[i]
        t = tari[i]
        rt = rtcal[i]
        tol = tol_tari * t + tol_samples
        n_pre = 3 if math.isnan(trcal[i]) else 4  # delimiter, data-0, RTcal (, TRcal)
        n_sym = (e1 - e0 - 1) // 2  # low pulses after the delimiter
        if n_sym - (n_pre - 1) < min_bits:
            continue
        ratio = rt / t
        if ratio < rtcal_tari[0] or ratio > rtcal_tari[1]:
            continue
        if n_pre == 4:
            q = trcal[i] / rt
            if q < trcal_rtcal[0] or q > trcal_rtcal[1]:
                continue
        d = (pos[e0 + 1] - pos[e0]) / t
        if d < delim_tari[0] or d > delim_tari[1]:
            continue
        ok = True
        d1 = rt - t
        for k in range(n_pre, n_sym + 1):  # data symbols: rise[k-1] → rise[k]
            span = pos[e0 + 2 * k + 1] - pos[e0 + 2 * k - 1]
            if not (_within(span, t, tol) or _within(span, d1, tol)):
                ok = False
                break
        if not ok:
            continue
        pw0 = pos[e0 + 3] - pos[e0 + 2]
        if pw0 / t < pw_tari[0] or pw0 / t > pw_tari[1]:
            continue
        for k in range(2, n_sym + 1):
            if not _within(pos[e0 + 2 * k + 1] - pos[e0 + 2 * k], pw0, tol):
                ok = False
                break
        if not ok:
            continue
        # contrast: one sample at the middle of every low pulse and every high interval
        s_lo = 0.0
        q_lo = 0.0
        s_hi = 0.0
        q_hi = 0.0
        n_lo = 0
        n_hi = 0
        for k in range(0, n_sym + 1):
            j = int(round(0.5 * (pos[e0 + 2 * k] + pos[e0 + 2 * k + 1])))
            if 0 <= j < x.size:
                v = env_value(x, j)
                s_lo += v
                q_lo += v * v
                n_lo += 1
            if k < n_sym:
                j = int(round(0.5 * (pos[e0 + 2 * k + 1] + pos[e0 + 2 * k + 2])))
                if 0 <= j < x.size:
                    v = env_value(x, j)
                    s_hi += v
                    q_hi += v * v
                    n_hi += 1
        if n_lo < 2 or n_hi < 2:
            continue
        m_lo = s_lo / n_lo
        m_hi = s_hi / n_hi
        var = 0.5 * (max(q_lo / n_lo - m_lo * m_lo, 0.0) + max(q_hi / n_hi - m_hi * m_hi, 0.0))
        c = (m_hi - m_lo) / math.sqrt(var) if var > 0.0 else math.inf
        contrast_out[i] = c
        if c >= min_contrast:
            keep[i] = 1


@njit
def magnitude_kernel(x, out):
    """``out[n] = |x[n]| = √(Re² + Im²)`` of complex samples (in float64: no overflow for
    complex64 input, and several times faster than ``hypot``); returns
    :func:`range_kernel` of ``out``."""
    for n in range(x.size):
        re = np.float64(x[n].real)
        im = np.float64(x[n].imag)
        out[n] = math.sqrt(re * re + im * im)
    return range_kernel(out)


@njit_inline
def finite_range(v, power):
    """``(min, max, number of non-finite values, index of the first one or −1)``, min and max
    over the finite values of :func:`env_order` of ``v`` if ``power`` (a constant of the
    caller) else of :func:`env_value`."""
    lo = math.inf
    hi = -math.inf
    n_bad = 0
    first_bad = -1
    for n in range(v.size):
        a = env_order(v, n) if power else env_value(v, n)
        if not math.isfinite(a):
            if n_bad == 0:
                first_bad = n
            n_bad += 1
        else:
            if a < lo:
                lo = a
            if a > hi:
                hi = a
    return lo, hi, n_bad, first_bad


@njit
def range_kernel(v):
    """``(min, max, number of non-finite values, index of the first one or −1)``, min and max
    over the finite values of the envelope of ``v`` (real, or complex: :func:`env_value`)."""
    return finite_range(v, False)


@njit
def power_range_kernel(x):
    """:func:`range_kernel` of the magnitude of complex samples from their power
    re² + im² (no square root per sample): ``(√min, √max, non-finite count, first index)``.
    The square root is monotonic, so the extremes are those of the magnitude."""
    lo, hi, n_bad, first_bad = finite_range(x, True)
    return math.sqrt(lo) if n_bad < x.size else lo, math.sqrt(hi) if n_bad < x.size else hi, n_bad, first_bad


@njit
def histogram_kernel(v, lo, hi, hist):
    """Counts of the envelope of ``v`` (real, or complex: :func:`env_value`) in ``hist.size``
    equal bins over [lo, hi] (the last bin closed)."""
    hist[:] = 0
    nb = hist.size
    scale = nb / (hi - lo) if hi > lo else 0.0
    for n in range(v.size):
        k = int((env_value(v, n) - lo) * scale)
        if k >= nb:
            k = nb - 1
        elif k < 0:
            k = 0
        hist[k] += 1


@njit
def normalize_kernel(v, lo, scale):
    """In place: ``v[n] = (v[n] − lo)·scale``."""
    for n in range(v.size):
        v[n] = (v[n] - lo) * scale


@njit
def block_correlation_kernel(y, n0, start, u1, u2, el, n_blocks, base, shifts, sub, corr, centre_sum, count,
                             n_blocks_used):
    """Timing-block correlations of the tracking loop (see :mod:`rfsim.gen2.replies`, step 4).

    For every sample n ≥ n0 with t = n − start and nominal element u(t) = u1·t + u2·t² inside
    the reply (0 ≤ u < el.size): block b = floor(u/(el.size/n_blocks)) (clipped); for every
    shift d: ``corr[i, b] += y[n]·Σ_e el[floor(u(t − d + e))]`` over the sub-sample points e
    of ``sub`` (0 outside the reply), d = base[b] + shifts[i]; ``centre_sum[b] += t``,
    ``count[b] += 1``. Only blocks b < ``n_blocks_used`` are correlated (the others are 0).

    Evaluated element by element rather than sample by sample: a shifted reference is
    constant over the samples of one element k, from the first n with t − d + e ≥ w(k) to
    before the first with t − d + e ≥ w(k + 1), w(k) = 2k/(u1 + √(u1² + 4·u2·k)) the
    stable root of u(w) = k; with the cumulative sum Y of y each element adds
    el[k]·(Y[end] − Y[begin]) — the same sum in about 1/(samples per element) of the
    operations.
    """
    first, last, cum, w = block_layout_kernel(y, n0, start, u1, u2, el.size, n_blocks, centre_sum, count)
    block_shift_correlations_kernel(start, u1, u2, el, base, shifts, sub, first, last, cum, w, 0, n_blocks_used, corr)


@njit
def block_layout_kernel(y, n0, start, u1, u2, n_el, n_blocks, centre_sum, count):
    """The part of :func:`block_correlation_kernel` that does not depend on the shifts: each
    block's first and last sample, ``centre_sum``/``count``, the cumulative sum of y and the
    element starts w(k). Returns ``(first, last, cum, w)``."""
    per_block = n_el / n_blocks
    centre_sum[:] = 0.0
    count[:] = 0
    first = np.full(n_blocks, -1, dtype=np.int64)
    last = np.full(n_blocks, -2, dtype=np.int64)
    for n in range(n0, y.size):
        t = n - start
        u0 = u1 * t + u2 * t * t
        if u0 < 0.0:
            continue
        if u0 >= n_el:
            break
        b = int(math.floor(u0 / per_block))
        if b >= n_blocks:
            b = n_blocks - 1
        centre_sum[b] += t
        count[b] += 1
        if first[b] < 0:
            first[b] = n
        last[b] = n
    cum = np.empty(y.size + 1)
    cum[0] = 0.0
    for n in range(y.size):
        cum[n + 1] = cum[n] + y[n]
    w = np.empty(n_el + 1)
    for k in range(n_el + 1):
        w[k] = 2.0 * k / (u1 + math.sqrt(max(u1 * u1 + 4.0 * u2 * k, 1e-300)))
    return first, last, cum, w


@njit
def block_shift_correlations_kernel(start, u1, u2, el, base, shifts, sub, first, last, cum, w, first_block,
                                    n_blocks_used, corr):
    """The shift-dependent part of :func:`block_correlation_kernel` on a
    :func:`block_layout_kernel` layout: ``corr[i, b]`` for the blocks ``first_block`` ≤ b <
    ``n_blocks_used`` (0 for the others)."""
    n_el = el.size
    n_blocks = first.size
    corr[:, :] = 0.0
    for b in range(max(0, first_block), min(n_blocks, n_blocks_used)):
        lo = first[b]
        hi = last[b] + 1  # samples lo … hi − 1
        if lo < 0:
            continue
        for i in range(shifts.size):
            acc = 0.0
            for j in range(sub.size):
                off = start + base[b] + shifts[i] - sub[j]  # element k starts at n = off + w(k)
                tt = lo - off
                if tt < 0.0:
                    k = 0
                else:
                    k = int(math.floor(u1 * tt + u2 * tt * tt))
                    if k > n_el:
                        k = n_el
                    while k > 0 and lo < math.ceil(off + w[k]):
                        k -= 1
                    while k < n_el and lo >= math.ceil(off + w[k + 1]):
                        k += 1
                a = max(lo, int(math.ceil(off + w[k])))
                while k < n_el and a < hi:
                    e = min(hi, int(math.ceil(off + w[k + 1])))
                    if e > a:
                        acc += el[k] * (cum[e] - cum[a])
                        a = e
                    k += 1
            corr[i, b] = acc


@njit
def _solve_small(a, b):
    """Solve the small dense system a·x = b in place (Gaussian elimination, partial pivoting)."""
    n = b.size
    for col in range(n):
        piv = col
        for row in range(col + 1, n):
            if abs(a[row, col]) > abs(a[piv, col]):
                piv = row
        if piv != col:
            for k in range(n):
                a[col, k], a[piv, k] = a[piv, k], a[col, k]
            b[col], b[piv] = b[piv], b[col]
        for row in range(col + 1, n):
            f = a[row, col] / a[col, col]
            for k in range(col, n):
                a[row, k] -= f * a[col, k]
            b[row] -= f * b[col]
    for row in range(n - 1, -1, -1):
        acc = b[row]
        for k in range(row + 1, n):
            acc -= a[row, k] * b[k]
        b[row] = acc / a[row, row]
    return b


@njit
def weighted_polyfit_kernel(t, d, w, n, deg, out):
    """Coefficients (highest power first) of the degree-``deg`` polynomial minimising
    Σ w_i·(p(t_i) − d_i)² over the first ``n`` points, into ``out[:deg + 1]``; the normal
    equations in x = (t − t̄)/max|t − t̄| (see
    :func:`rfsim.gen2.reply_tracking.weighted_polyfit`, its NumPy twin)."""
    tm = 0.0
    for i in range(n):
        tm += t[i]
    tm /= n
    ts = 0.0
    for i in range(n):
        ts = max(ts, abs(t[i] - tm))
    if ts == 0.0:
        ts = 1.0
    k1 = deg + 1
    a = np.zeros((k1, k1))
    b = np.zeros(k1)
    for i in range(n):
        x = (t[i] - tm) / ts
        for p in range(k1):
            xp = x ** p
            b[p] += w[i] * xp * d[i]
            for q in range(k1):
                a[p, q] += w[i] * xp * x ** q
    c = _solve_small(a, b)
    res = np.zeros(k1)
    for k in range(k1):
        for i in range(k + 1):
            comb = 1.0
            for q in range(i):
                comb = comb * (k - q) / (q + 1)
            res[i] += c[k] * comb * (-tm) ** (k - i) / ts ** k
    for i in range(k1):
        out[i] = res[k1 - 1 - i]


@njit
def track_kernel(y, start, u1, u2, el, n_blocks, spans, sub, min_drift_blocks):
    """The tracking loop of :func:`rfsim.gen2.reply_tracking.track` in one call (its twin:
    ``track_reference`` there): for each span fraction of ``spans`` the block offsets are
    searched around the previous fit's δ(t) (:func:`block_correlation_kernel`, 17 shifts of
    1/16 element, triangle peak; the leading blocks whose centres lay inside an earlier span
    keep the offsets measured then, so each block is correlated about once), the blocks
    whose centre lies inside the span kept, and δ(t) fitted (quadratic with ≥ ``min_drift_blocks`` blocks, else a line; spans with
    fewer than 3 blocks are skipped). Returns the refined ``(start, u1, u2)``."""
    n_el = el.size
    per_block = n_el / n_blocks
    centres = np.empty(n_blocks)
    block_starts = np.empty(n_blocks)
    for b in range(n_blocks):
        centres[b] = (b + 0.5) / n_blocks * n_el / u1
        x = b * per_block
        block_starts[b] = 2.0 * x / (u1 + math.sqrt(max(u1 * u1 + 4.0 * u2 * x, 1e-300)))
    step = 1.0 / (16.0 * u1)
    n_sh = 17
    shifts = np.empty(n_sh)
    for i in range(n_sh):
        shifts[i] = step * (i - 8)
    corr = np.empty((n_sh, n_blocks))
    centre_sum = np.empty(n_blocks)
    count = np.empty(n_blocks, dtype=np.int64)
    base = np.empty(n_blocks)
    tb = np.empty(n_blocks)
    db = np.empty(n_blocks)
    wb = np.empty(n_blocks)
    coef = np.zeros(3)
    fit = np.zeros(3)
    n0 = int(math.ceil(start))
    first, last, cum, w = block_layout_kernel(y, n0, start, u1, u2, n_el, n_blocks, centre_sum, count)
    # per block: offset δ_b, weight, whether its peak lay inside the searched range
    d_block = np.zeros(n_blocks)
    w_block = np.zeros(n_blocks)
    ok_block = np.zeros(n_blocks, dtype=np.bool_)
    done = 0  # blocks b < done were measured inside an earlier span: kept
    for s in range(spans.size):
        limit = spans[s] * n_el / u1
        n_used = 1
        for b in range(n_blocks):
            base[b] = (coef[0] * centres[b] + coef[1]) * centres[b] + coef[2]
            if block_starts[b] <= limit:
                n_used += 1
        n_used = min(n_blocks, n_used)
        block_shift_correlations_kernel(start, u1, u2, el, base, shifts, sub, first, last, cum, w, done, n_used,
                                        corr)
        for b in range(done, n_used):
            j = 0
            for i in range(1, n_sh):
                if corr[i, b] > corr[j, b]:
                    j = i
            mid = corr[j, b]
            ok_block[b] = not (mid <= 0 or j == 0 or j == n_sh - 1)
            if ok_block[b]:
                left = corr[j - 1, b]
                right = corr[j + 1, b]
                slope = max(mid - left, mid - right)
                frac = 0.5 * (right - left) / slope if slope > 0 else 0.0
                d_block[b] = base[b] + shifts[j] + frac * step
                w_block[b] = mid
        nb = 0
        inside = True
        for b in range(n_used):
            centre = centre_sum[b] / max(count[b], 1)
            if centre > limit:
                inside = False
                continue
            if inside:
                done = b + 1
            if not ok_block[b]:
                continue
            tb[nb] = centre
            db[nb] = d_block[b]
            wb[nb] = w_block[b]
            nb += 1
        if nb < 3:
            continue
        if nb >= min_drift_blocks:
            weighted_polyfit_kernel(tb, db, wb, nb, 2, fit)
            coef[0], coef[1], coef[2] = fit[0], fit[1], fit[2]
        else:
            weighted_polyfit_kernel(tb, db, wb, nb, 1, fit)
            coef[0], coef[1], coef[2] = 0.0, fit[0], fit[1]
    return start + coef[2], u1 * (1.0 - coef[1]), u2 - u1 * coef[0]

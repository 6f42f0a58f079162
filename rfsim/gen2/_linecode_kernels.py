"""numba kernels of the FM0 / Miller line codes (wrapped and documented in
:mod:`rfsim.gen2.linecode`; NumPy twins in the tests' ``reference.gen2_linecode``), and the
one definition of the line codes' rules as transition tables, read by the encoder, the Viterbi
trellis, the reply decoders and the reader's BLF search (kernels read the arrays as constants).

Rules (gen2-and-validation-anchors.md §3.6, §4.2; EPC Gen2 §6.3.1.3.2):

* FM0: the level inverts at every bit boundary; data-0 has a mid-bit inversion.
* Miller: data-1 has a mid-bit inversion; the level inverts at the boundary between two
  consecutive data-0s. The baseband is then multiplied by a square subcarrier: element k
  (half a subcarrier cycle) carries the sign (−1)^k (:data:`SUBCARRIER_SIGN`).

Levels are ±1 (int8); a *half-bit* is half a data symbol; an *element* is half a
subcarrier cycle (1/(2·BLF) s): FM0 has one element per half-bit, Miller-M has M.

The encoder state is ``s = level_index + 2·prev``: ``level_index`` 0 for the level +1 and 1 for
−1 (the level of the last half-bit sent), ``prev`` the last data bit (Miller only; FM0 states
are 0 and 1, its rows 2 and 3 repeat rows 0 and 1 and are never entered). The Viterbi trellis
has these states. Per code (:data:`FM0` = 0, :data:`MILLER` = 1), state and data bit the tables
give the two half-bit levels sent and the next state::

    HALF_LEVELS[code, state, bit] = (first, second)  (±1)
    NEXT_STATE[code, state, bit]  = state after the bit
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit, njit_inline

#: Added to the fractional element index before flooring, so that a sample that falls
#: exactly on an element boundary (up to float64 rounding) belongs to the later element.
INDEX_EPS = 1e-9

#: Table index of FM0 (M = 1) and of Miller (M = 2, 4, 8).
FM0 = 0
MILLER = 1
#: Number of encoder states (level index + 2·previous bit).
N_STATES = 4

#: ``HALF_LEVELS[code, state, bit] = (first, second)`` half-bit levels of a data bit (int8 ±1).
HALF_LEVELS = np.array([
    # FM0: invert at the boundary (first = −level); data-0 inverts again mid-bit
    [[[-1, 1], [-1, -1]],    # state 0: level +1
     [[1, -1], [1, 1]],      # state 1: level −1
     [[-1, 1], [-1, -1]],    # state 2 (= 0, never entered)
     [[1, -1], [1, 1]]],     # state 3 (= 1, never entered)
    # Miller: data-1 inverts mid-bit; a data-0 after a data-0 inverts at the boundary
    [[[-1, -1], [1, -1]],    # state 0: level +1, previous bit 0
     [[1, 1], [-1, 1]],      # state 1: level −1, previous bit 0
     [[1, 1], [1, -1]],      # state 2: level +1, previous bit 1
     [[-1, -1], [-1, 1]]],   # state 3: level −1, previous bit 1
], dtype=np.int8)

#: ``NEXT_STATE[code, state, bit]``: the encoder state after the bit (int8).
NEXT_STATE = np.array([
    [[0, 1], [1, 0], [0, 1], [1, 0]],   # FM0: level index of the second half-bit
    [[1, 3], [0, 2], [0, 3], [1, 2]],   # Miller: level index of the second half-bit + 2·bit
], dtype=np.int8)

#: ``LEVEL_OF_STATE[state]``: the level of the last half-bit sent in that state (int8 ±1).
LEVEL_OF_STATE = np.array([1, -1, 1, -1], dtype=np.int8)
#: ``PREV_BIT_OF_STATE[state]``: the last data bit in that state (Miller; uint8).
PREV_BIT_OF_STATE = np.array([0, 0, 1, 1], dtype=np.uint8)

#: ``SUBCARRIER_SIGN[code, k % 2]``: sign of element k of a half-bit of level +1 (FM0: none;
#: Miller: the square subcarrier, −1 on odd elements).
SUBCARRIER_SIGN = np.array([[1, 1], [1, -1]], dtype=np.int8)

#: :data:`SUBCARRIER_SIGN` as float64 (±1.0), for per-sample products.
SUBCARRIER_SIGN_F = SUBCARRIER_SIGN.astype(np.float64)

for _table in (HALF_LEVELS, NEXT_STATE, LEVEL_OF_STATE, PREV_BIT_OF_STATE, SUBCARRIER_SIGN, SUBCARRIER_SIGN_F):
    _table.setflags(write=False)
del _table


@njit
def code_of(m):
    """Table index of the line code with ``m`` subcarrier cycles per bit: :data:`FM0` for
    m = 1, :data:`MILLER` otherwise."""
    return FM0 if m == 1 else MILLER


@njit
def state_index(level, prev_bit, m):
    """Encoder state of the tables from the last half-bit level (±1) and the last data bit
    (ignored for FM0)."""
    return (0 if level == 1 else 1) + (2 * prev_bit if code_of(m) == MILLER else 0)


@njit_inline
def element_sign(k, m):
    """Subcarrier sign (±1) of element ``k`` (:data:`SUBCARRIER_SIGN`)."""
    return SUBCARRIER_SIGN[code_of(m), k & 1]


@njit_inline
def put_half_bit(out, k, level, m):
    """Write the ``m`` elements of a half-bit of ``level`` from element ``k`` (the level times
    :func:`element_sign`); returns the next element index."""
    for _ in range(m):
        out[k] = level * element_sign(k, m)
        k += 1
    return k


@njit
def levels_kernel(bits, m, state, out):
    """Half-bit levels ``out`` ((2·n,) int8) of ``bits`` from encoder ``state`` (the tables
    :data:`HALF_LEVELS`, :data:`NEXT_STATE` of the code of ``m``); returns the final state."""
    code = code_of(m)
    for i in range(bits.size):
        b = bits[i]
        out[2 * i] = HALF_LEVELS[code, state, b, 0]
        out[2 * i + 1] = HALF_LEVELS[code, state, b, 1]
        state = NEXT_STATE[code, state, b]
    return state


@njit
def level_elements_kernel(levels, m, out):
    """Elements ``out`` ((levels.size·m,)) of the half-bit ``levels``: each held for ``m``
    elements, times the subcarrier sign (:func:`put_half_bit`)."""
    k = 0
    for i in range(levels.size):
        k = put_half_bit(out, k, levels[i], m)


@njit
def waveform_kernel(elements, t0_samples, elements_per_sample, out):
    """``out[n] = elements[floor((n − t0)·r + eps)]`` inside the reply, 0 outside."""
    waveform_from(elements, t0_samples, elements_per_sample, 0, out)


@njit_inline
def waveform_from(elements, t0_samples, elements_per_sample, first, out):
    """Samples ``first … first + out.size − 1`` of :func:`waveform_kernel`'s waveform into
    ``out``: ``out[j]`` is sample n = first + j, ``elements[floor((n − t0)·r + eps)]`` inside the
    reply, 0 outside (the same arithmetic on the absolute index n). The element indices first, in
    a pass of their own (branch-free: vectorised; ``ne`` before the reply), then the reads."""
    ne = elements.size
    ks = np.empty(out.size, np.int64)
    for j in range(out.size):
        u = ((first + j) - t0_samples) * elements_per_sample
        k = np.int64(math.floor(u + INDEX_EPS))
        ks[j] = k if u >= 0.0 else ne
    for j in range(out.size):
        k = ks[j]
        out[j] = elements[k] if k < ne else 0.0


@njit_inline
def sampled_template(elements, t0_samples, elements_per_sample, out):
    """:func:`waveform_kernel` of ``elements`` into ``out`` (a template, e.g. the pilot +
    preamble from a fractional start); returns its mean, Σ out / out.size (summed in order)."""
    waveform_kernel(elements, t0_samples, elements_per_sample, out)
    mean = 0.0
    for i in range(out.size):
        mean += out[i]
    mean /= out.size
    return mean


@njit_inline
def runs_dot(k, begin, value, n_runs, c_re, c_im):
    """``Σ_q value[q]·(C[k + begin[q + 1]] − C[k + begin[q]])`` for the cumulative sums C = (c_re,
    c_im) of a signal: its dot product at lag k with a template made of ``n_runs`` runs of
    equal values (run q from ``begin[q]``, ``begin[n_runs]`` its end). Returns (re, im)."""
    a_re = 0.0
    a_im = 0.0
    for q in range(n_runs):
        b0 = k + begin[q]
        b1 = k + begin[q + 1]
        a_re += value[q] * (c_re[b1] - c_re[b0])
        a_im += value[q] * (c_im[b1] - c_im[b0])
    return a_re, a_im


@njit
def bitwise_kernel(a, b, miller, out):
    """Bit-by-bit coherent decisions from the half-bit sums (a, b) of each bit.

    FM0: 1 if |a + b| > |a − b| (no mid-bit inversion); Miller: 1 if |a − b| > |a + b|.
    """
    for i in range(out.size):
        s = abs(a[i] + b[i])
        d = abs(a[i] - b[i])
        one = d > s if miller else s > d
        out[i] = 1 if one else 0


@njit
def viterbi_kernel(a, b, miller, state0, last_is_one, out):
    """Maximum-likelihood sequence detection over the FM0/Miller trellis.

    Branch metric = e1·a + e2·b (correlation of the half-bit sums with the expected
    levels), maximised; starts from the known state ``state0``; if ``last_is_one`` the
    final bit (the dummy 1) is forced to 1. Returns the final state. The trellis is that of
    the tables :data:`HALF_LEVELS` (expected levels e1, e2) and :data:`NEXT_STATE`.
    """
    code = MILLER if miller else FM0
    n = out.size
    ns = N_STATES
    metric = np.full(ns, -np.inf)
    metric[state0] = 0.0
    back_state = np.zeros((n, ns), dtype=np.int8)
    back_bit = np.zeros((n, ns), dtype=np.int8)
    new = np.empty(ns)
    for i in range(n):
        new[:] = -np.inf
        for s in range(ns):
            if metric[s] == -np.inf:
                continue
            for bit in range(2):
                if last_is_one and i == n - 1 and bit == 0:
                    continue
                e1 = HALF_LEVELS[code, s, bit, 0]
                e2 = HALF_LEVELS[code, s, bit, 1]
                t = NEXT_STATE[code, s, bit]
                v = metric[s] + e1 * a[i] + e2 * b[i]
                if v > new[t]:
                    new[t] = v
                    back_state[i, t] = s
                    back_bit[i, t] = bit
        metric[:] = new
    best = 0
    for s in range(1, ns):
        if metric[s] > metric[best]:
            best = s
    final = best
    for i in range(n - 1, -1, -1):
        out[i] = back_bit[i, best]
        best = back_state[i, best]
    return final


@njit
def refine_kernel(r, cands, shifts, templates, norms):
    """Sub-sample refinement of the preamble correlation peak.

    For every candidate lag ``c`` and shift ``d = shifts[j]`` (skipped where c + d < 0):
    ``v = |Σ_i r[c + i]·templates[j, i]| / norms[j]`` (templates zero-mean, one row per
    shift); returns ``(best v, c + d of the best)``, the first one on ties (candidates in
    the given order, shifts ascending). ``(−1, nan)`` if every pair is skipped. The sums of
    all shifts run side by side over i (each still in the order i = 0, 1, …), so the
    additions of different shifts overlap instead of waiting on one another.
    """
    n_shifts, n_pre = templates.shape
    by_sample = np.ascontiguousarray(templates.T)  # (n_pre, n_shifts)
    acc_re = np.empty(n_shifts)
    acc_im = np.empty(n_shifts)
    best = -1.0
    start = math.nan
    for ci in range(cands.size):
        c = cands[ci]
        acc_re[:] = 0.0
        acc_im[:] = 0.0
        for i in range(n_pre):
            z = r[c + i]
            for j in range(n_shifts):
                t = by_sample[i, j]
                acc_re[j] += z.real * t
                acc_im[j] += z.imag * t
        for j in range(n_shifts):
            d = shifts[j]
            if c + d < 0.0:
                continue
            v = math.hypot(acc_re[j], acc_im[j]) / norms[j]
            if v > best:
                best = v
                start = c + d
    return best, start


@njit
def _direct_value(r, c, templates, j, norm):
    """|Σ_i r[c + i]·templates[j, i]| / ``norm``, the sum sample by sample in order (the value of
    :func:`refine_kernel` for candidate ``c`` and shift ``j``)."""
    acc_re = 0.0
    acc_im = 0.0
    for i in range(templates.shape[1]):
        z = r[c + i]
        t = templates[j, i]
        acc_re += z.real * t
        acc_im += z.imag * t
    return math.hypot(acc_re, acc_im) / norm


@njit_inline
def _runs_dot(c_re, c_im, o, begin, value, n_runs):
    """Σ_q value[q]·(C[o + begin[q + 1]] − C[o + begin[q]]) for the cumulative sums C = (``c_re``,
    ``c_im``): the dot product at offset ``o`` with a template of ``n_runs`` runs of equal values,
    summed in two interleaved halves (even and odd runs). Returns (re, im)."""
    x0 = 0.0
    y0 = 0.0
    x1 = 0.0
    y1 = 0.0
    p_re = c_re[o + begin[0]]
    p_im = c_im[o + begin[0]]
    q = 0
    while q + 1 < n_runs:
        e0 = o + begin[q + 1]
        e1 = o + begin[q + 2]
        a_re = c_re[e0]
        a_im = c_im[e0]
        b_re = c_re[e1]
        b_im = c_im[e1]
        x0 += value[q] * (a_re - p_re)
        y0 += value[q] * (a_im - p_im)
        x1 += value[q + 1] * (b_re - a_re)
        y1 += value[q + 1] * (b_im - a_im)
        p_re = b_re
        p_im = b_im
        q += 2
    if q < n_runs:
        e0 = o + begin[q + 1]
        x0 += value[q] * (c_re[e0] - p_re)
        y0 += value[q] * (c_im[e0] - p_im)
    return x0 + x1, y0 + y1


@njit
def refine_runs_kernel(r, cands, shifts, templates, norms, run_begin, run_value, n_runs, same_as_previous):
    """:func:`refine_kernel`'s result, bit for bit, from fewer operations.

    Row j of ``templates`` is made of ``n_runs[j]`` runs of equal values, run q from
    ``run_begin[j, q]`` to ``run_begin[j, q + 1]`` (``run_begin[j, n_runs[j]] = n_pre``) of value
    ``run_value[j, q]``; ``same_as_previous[j]`` when row j equals row j − 1 (its values are
    then row j − 1's, bit for bit: only the first row of equal ones not skipped can hold the
    first largest value). With C the cumulative sums of r over the candidates' window (N samples),
    every value is first approximated over the runs, Σ_q t_q·(C[c + e_q] − C[c + b_q]) (R terms
    instead of n_pre). Bound: a sum of k terms, in any order, is within γ_k·Σ|terms| of the exact
    sum, γ_k = k·u/(1 − k·u) (Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed.,
    §4.2); each prefix C is within γ_N·S of its exact value (S = Σ|Re r| or Σ|Im r| over the
    window), so a run's difference is within 2γ_N·S + u·|difference| and the sum of the R products
    within (2R·γ_N + γ_{R+1})·T·S (T = max |t|), and the sample-by-sample sum of
    :func:`refine_kernel` within γ_N·T·S: the two differ by at most
    E = (4(R + 1) + 1)·γ_N·T·(S_re + S_im) (a factor two to spare on the first term), their values
    (|·| is 1-Lipschitz; hypot and the division add ≤ 3u relative each) by at most
    ε = 2E/min(norms) + 16u·max value. Every pair whose approximation is within 2ε of the largest
    approximation is then evaluated sample by sample (:func:`_direct_value`) in
    :func:`refine_kernel`'s order: every pair whose value can be the largest is among them, so
    best and start are :func:`refine_kernel`'s. A window holding a non-finite sample or a
    non-positive norm falls back to :func:`refine_kernel`."""
    n_shifts, n_pre = templates.shape
    nc = cands.size
    if nc == 0:
        return -1.0, math.nan
    c_lo = cands[0]
    c_hi = cands[0]
    for ci in range(1, nc):
        c_lo = min(c_lo, cands[ci])
        c_hi = max(c_hi, cands[ci])
    n_win = c_hi - c_lo + n_pre
    c_re = np.empty(n_win + 1)
    c_im = np.empty(n_win + 1)
    c_re[0] = 0.0
    c_im[0] = 0.0
    s_abs = 0.0
    for i in range(n_win):
        z = r[c_lo + i]
        c_re[i + 1] = c_re[i] + z.real
        c_im[i + 1] = c_im[i] + z.imag
        s_abs += abs(z.real) + abs(z.imag)
    norm_min = norms[0]
    for j in range(1, n_shifts):
        norm_min = min(norm_min, norms[j])
    if not (math.isfinite(s_abs) and norm_min > 0.0):
        return refine_kernel(r, cands, shifts, templates, norms)
    approx = np.empty((nc, n_shifts))
    t_max = 0.0
    r_max = 0
    v_max = -1.0
    for j in range(n_shifts):
        nr = n_runs[j]
        if j > 0 and same_as_previous[j]:
            for ci in range(nc):
                approx[ci, j] = approx[ci, j - 1]
        else:
            r_max = max(r_max, nr)
            for q in range(nr):
                t_max = max(t_max, abs(run_value[j, q]))
            for ci in range(nc):
                a_re, a_im = _runs_dot(c_re, c_im, cands[ci] - c_lo, run_begin[j], run_value[j], nr)
                approx[ci, j] = math.hypot(a_re, a_im) / norms[j]
        for ci in range(nc):
            if cands[ci] + shifts[j] >= 0.0 and approx[ci, j] > v_max:
                v_max = approx[ci, j]
    u = 2.0 ** -53
    gamma = n_win * u / (1.0 - n_win * u)
    eps = 2.0 * (4 * (r_max + 1) + 1) * gamma * t_max * s_abs / norm_min + 16.0 * u * v_max
    keep = v_max - 2.0 * eps
    if not math.isfinite(keep):
        return refine_kernel(r, cands, shifts, templates, norms)
    best = -1.0
    start = math.nan
    for ci in range(nc):
        c = cands[ci]
        for j in range(n_shifts):
            d = shifts[j]
            if c + d < 0.0 or not approx[ci, j] >= keep:
                continue
            if j > 0 and same_as_previous[j] and not c + shifts[j - 1] < 0.0:
                continue  # row j − 1's value, already compared
            v = _direct_value(r, c, templates, j, norms[j])
            if v > best:
                best = v
                start = c + d
    return best, start


@njit
def peak_candidates_kernel(c, half_width, n_max, out):
    """Integer peak and its candidates for the sub-sample refinement: ``lag = argmax c``
    (the first maximum), then the local maxima (≥ both neighbours inside the window) of
    ``c[lo:hi]``, ``lo = max(0, lag − w)``, ``hi = min(c.size, lag + w + 1)``, the ``n_max``
    largest in descending order (equal values: the earlier lag first) into ``out``. Returns
    ``(lag, number of candidates)``."""
    lag = 0
    for i in range(1, c.size):
        if c[i] > c[lag]:
            lag = i
    lo = max(0, lag - half_width)
    hi = min(c.size, lag + half_width + 1)
    n = 0
    for i in range(lo, hi):
        v = c[i]
        if i > lo and v < c[i - 1]:
            continue
        if i < hi - 1 and v < c[i + 1]:
            continue
        # insert i among the n kept, descending by value, after the earlier lags of equal value
        pos = n
        while pos > 0 and v > c[out[pos - 1]]:
            pos -= 1
        if pos >= n_max:
            continue
        last = min(n, n_max - 1)
        for q in range(last, pos, -1):
            out[q] = out[q - 1]
        out[pos] = i
        if n < n_max:
            n += 1
    return lag, n


@njit
def corr_abs_kernel(r, t0, out):
    """``out[k] = |Σ_i r[k + i]·t0[i]|`` for k < out.size (valid correlation, t0 real)."""
    n = t0.size
    for k in range(out.size):
        acc_re = 0.0
        acc_im = 0.0
        for i in range(n):
            z = r[k + i]
            acc_re += z.real * t0[i]
            acc_im += z.imag * t0[i]
        out[k] = math.hypot(acc_re, acc_im)


@njit
def elements_kernel(bits, dummy, m, pre, state, out):
    """Element sequence of a reply into ``out`` ((len(pre) + 2·(n + dummy))·m,): the preamble
    half-bit levels ``pre``, then the half-bit levels of ``bits`` (and a dummy 1) from encoder
    ``state`` (:func:`levels_kernel`'s tables), as elements (:func:`put_half_bit`). Returns
    False (``out`` untouched) if a bit is neither 0 nor 1."""
    for i in range(bits.size):
        if bits[i] > 1:
            return False
    code = code_of(m)
    k = 0
    for i in range(pre.size):
        k = put_half_bit(out, k, pre[i], m)
    nb = bits.size + (1 if dummy else 0)
    for i in range(nb):
        b = bits[i] if i < bits.size else 1
        k = put_half_bit(out, k, HALF_LEVELS[code, state, b, 0], m)
        k = put_half_bit(out, k, HALF_LEVELS[code, state, b, 1], m)
        state = NEXT_STATE[code, state, b]
    return True


@njit
def projected_halfbit_sums_kernel(part, g_re, g_im, dc_re, start, elements_per_sample, m, out):
    """Matched-filter sums per half-bit of ``y[n] = (Re part[n]·g_re − Im part[n]·g_im) − dc_re``
    (the projection Re((part − dc)/h) with g = 1/h, dc_re = Re(dc·g), computed on the fly):
    ``out[h] += y[n]·(−1)^k`` (Miller) or ``y[n]`` (FM0) for every sample n whose element
    k = floor((n − start)·r + eps) has ``k // m == h``. The element index grows with n, so
    the sum of one half-bit is kept in a register (added in the same order) and ``h`` is
    advanced by comparison rather than division."""
    out[:] = 0.0
    nh = out.size
    n0 = max(0, int(math.ceil(start)))
    h = 0
    nxt = m  # first element of half-bit h + 1
    acc = 0.0
    for n in range(n0, part.size):
        u = (n - start) * elements_per_sample
        if u < 0.0:
            continue
        k = int(math.floor(u + INDEX_EPS))
        if k >= nxt:
            out[h] = acc
            acc = 0.0
            h = k // m
            nxt = (h + 1) * m
            if h >= nh:
                return
        z = part[n]
        y = (z.real * g_re - z.imag * g_im) - dc_re
        if element_sign(k, m) < 0:
            acc -= y
        else:
            acc += y
    if h < nh:
        out[h] = acc


@njit
def signed_halfbit_sums_kernel(part, start, elements_per_sample, m, s_sum, s_count, dc=0j):
    """The half-bit sums of :func:`projected_halfbit_sums_kernel` before the projection: per
    half-bit j, S_j = Σ σ_n·part[n] into ``s_sum`` (complex) and C_j = Σ σ_n into ``s_count``
    over the samples n whose element k = floor((n − start)·r + eps) has k // m = j, σ_n the
    subcarrier sign of k (:func:`element_sign`). The projected sums of Re((part − dc)·g) are
    Re(g·S_j) − Re(dc·g)·C_j for any gain and offset (the same value up to the order of the
    operations), so one pass serves the decisions at every gain. Sums in sample order, the
    real and imaginary parts apart (σ_n·part[n] is exact). The element indices are computed
    first, in a branch-free pass of their own (vectorised), then summed over. ``dc`` (complex) is
    taken off each sample as it is read: the sums are those of ``part − dc`` (x − 0 is x)."""
    s_sum[:] = 0j
    s_count[:] = 0.0
    nh = s_sum.size
    code = code_of(m)
    n0 = max(0, int(math.ceil(start)))
    ks = np.empty(max(part.size - n0, 0), np.int64)
    for n in range(n0, part.size):  # the element indices first (branch-free: vectorised), −1 before
        u = (n - start) * elements_per_sample
        k = np.int64(math.floor(u + INDEX_EPS))
        ks[n - n0] = k if u >= 0.0 else -1
    j = 0
    nxt = m  # first element of half-bit j + 1
    a_re = 0.0
    a_im = 0.0
    cnt = 0.0
    for n in range(n0, part.size):
        k = ks[n - n0]
        if k < 0:
            continue
        if k >= nxt:  # the element index grows with n: a new half-bit, found by comparison
            s_sum[j] = complex(a_re, a_im)
            s_count[j] = cnt
            a_re = 0.0
            a_im = 0.0
            cnt = 0.0
            j = k // m
            nxt = (j + 1) * m
            if j >= nh:
                return
        sg = SUBCARRIER_SIGN_F[code, k & 1]
        z = part[n] - dc
        a_re += z.real * sg
        a_im += z.imag * sg
        cnt += sg
    if j < nh:
        s_sum[j] = complex(a_re, a_im)
        s_count[j] = cnt


@njit
def corr_abs_runs_kernel(r, t0, out):
    """``out[k] = |Σ_i r[k + i]·t0[i]|`` for k < out.size (the valid correlation of
    :func:`corr_abs_kernel`) for a template made of runs of equal values — a sampled
    element sequence, constant over each element: with the cumulative sum C of
    r − mean(r) each lag costs one term per run, Σ_runs t_run·(C[k + end] − C[k + begin])
    (for a zero-mean ``t0`` the mean removed from r does not change the sum). Cost
    O(lags · runs) instead of O(lags · samples): at a fixed BLF the number of runs does not
    grow with the sample rate, so a search over a window of fixed duration is O(fs)."""
    n = t0.size
    n_r = out.size + n - 1
    begin = np.empty(n + 1, dtype=np.int64)
    value = np.empty(n)
    n_runs = 0
    for i in range(n):
        if i == 0 or t0[i] != t0[i - 1]:
            begin[n_runs] = i
            value[n_runs] = t0[i]
            n_runs += 1
    begin[n_runs] = n
    m_re = 0.0
    m_im = 0.0
    for i in range(n_r):
        m_re += r[i].real
        m_im += r[i].imag
    m_re /= max(n_r, 1)
    m_im /= max(n_r, 1)
    c_re = np.empty(n_r + 1)
    c_im = np.empty(n_r + 1)
    c_re[0] = 0.0
    c_im[0] = 0.0
    for i in range(n_r):
        c_re[i + 1] = c_re[i] + (r[i].real - m_re)
        c_im[i + 1] = c_im[i] + (r[i].imag - m_im)
    mean_t = 0.0
    for i in range(n):
        mean_t += t0[i]
    mean_t /= n
    # runs_dot of every lag, run after run: each lag's terms added in run order (as runs_dot
    # adds them), the lags side by side (contiguous: vectorised)
    n_lags = out.size
    a_re = np.zeros(n_lags)
    a_im = np.zeros(n_lags)
    for q in range(n_runs):
        v = value[q]
        lo_re = c_re[begin[q]:begin[q] + n_lags]
        hi_re = c_re[begin[q + 1]:begin[q + 1] + n_lags]
        lo_im = c_im[begin[q]:begin[q] + n_lags]
        hi_im = c_im[begin[q + 1]:begin[q + 1] + n_lags]
        for k in range(n_lags):
            a_re[k] += v * (hi_re[k] - lo_re[k])
            a_im[k] += v * (hi_im[k] - lo_im[k])
    for k in range(n_lags):
        # a template with a non-zero mean: add back mean(r)·Σ t0
        out[k] = math.hypot(a_re[k] + m_re * mean_t * n, a_im[k] + m_im * mean_t * n)


@njit
def corr_abs_auto_kernel(r, t0, max_runs_per_sample, out):
    """:func:`corr_abs_runs_kernel` when ``t0`` has at most ``max_runs_per_sample`` runs of
    equal values per sample, else :func:`corr_abs_kernel` (the same valid correlation)."""
    n_runs = 1
    for i in range(1, t0.size):
        if t0[i] != t0[i - 1]:
            n_runs += 1
    if n_runs <= max_runs_per_sample * t0.size:
        corr_abs_runs_kernel(r, t0, out)
    else:
        corr_abs_kernel(r, t0, out)


@njit
def _search_candidates(r, n_search, t0, max_runs_per_sample, half_width, n_max):
    """|valid correlation| of ``r[:n_search]`` with ``t0`` (:func:`corr_abs_auto_kernel`), its
    integer peak and candidates (:func:`peak_candidates_kernel`): ``(lag, candidates)``."""
    c = np.empty(n_search - t0.size + 1)
    corr_abs_auto_kernel(r[:n_search], t0, max_runs_per_sample, c)
    cands = np.empty(n_max, dtype=np.int64)
    lag, n = peak_candidates_kernel(c, half_width, n_max, cands)
    return lag, cands[:n]


@njit
def preamble_search_kernel(r, n_search, t0, max_runs_per_sample, half_width, n_max, shifts, templates, norms):
    """The preamble search of one call: |valid correlation| of ``r[:n_search]`` with the
    zero-mean template ``t0`` (:func:`corr_abs_auto_kernel`), its peak and candidates
    (:func:`peak_candidates_kernel`) and their sub-sample refinement over ``r``
    (:func:`refine_kernel`). Returns ``(integer peak lag, best refined value, refined start)``."""
    lag, cands = _search_candidates(r, n_search, t0, max_runs_per_sample, half_width, n_max)
    best, start = refine_kernel(r, cands, shifts, templates, norms)
    return lag, best, start


@njit
def preamble_search_runs_kernel(r, n_search, t0, max_runs_per_sample, half_width, n_max, shifts, templates, norms,
                                run_begin, run_value, n_runs, same_as_previous):
    """:func:`preamble_search_kernel` with the refinement by :func:`refine_runs_kernel` (the
    templates' runs ``run_begin``, ``run_value``, ``n_runs`` and ``same_as_previous``): the same
    result, bit for bit."""
    lag, cands = _search_candidates(r, n_search, t0, max_runs_per_sample, half_width, n_max)
    best, start = refine_runs_kernel(r, cands, shifts, templates, norms, run_begin, run_value, n_runs,
                                     same_as_previous)
    return lag, best, start

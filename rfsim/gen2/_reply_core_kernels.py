"""numba steps shared by the tag-reply decoders (:mod:`rfsim.gen2.reply_core` documents the
decoders and where they still differ): the cumulative sums of a window, the zero-mean
normalised preamble correlation, the parabolic refinement of a correlation peak, the start of
a reply whose preamble is centred on a sample, the schedule of the fine BLF search and the
BLF precision decoding needs, the preamble's least-squares gain and offset,
the decisions from half-bit sums (or from the signed sums of the samples), the sums of the
least-squares fit of a remodulated reply with its rest level and the residual power over its
steady samples.

Callers: the reader's BLF search (``rfsim.gen2._blf_search_kernels``), the reader's
receive (``rfsim.gen2._receive_kernels``: the decisions from signed sums) and the capture
decoder (:mod:`rfsim.gen2._reply_search_kernels`, :mod:`rfsim.gen2._reply_kernels`). Each
step is written once here in the arithmetic (order of operations) its callers had, so that
their results are bit-identical to what they were; where the callers' arithmetic differed,
the differing quantity is an argument (e.g. the mean of the preamble segment).
"""

from __future__ import annotations

import math

from rfsim.core._jit import njit_inline
from rfsim.gen2._linecode_kernels import bitwise_kernel, viterbi_kernel


@njit_inline
def cumulative_sums_into(r, c_re, c_im, p2, grouped_energy):
    """Cumulative sums of Re r, Im r and |r|² into ``c_re``, ``c_im``, ``p2`` (each
    ``(r.size + 1,)``, from 0): the running sums every windowed correlation and fit reads.

    |r|² is added as P + (re² + im²) when ``grouped_energy`` (the capture decoder), else as
    (P + re²) + im² (the reader's BLF search): the two differ in the last bits."""
    c_re[0] = 0.0
    c_im[0] = 0.0
    p2[0] = 0.0
    for n in range(r.size):
        z = r[n]
        c_re[n + 1] = c_re[n] + z.real
        c_im[n + 1] = c_im[n] + z.imag
        if grouped_energy:
            p2[n + 1] = p2[n] + (z.real * z.real + z.imag * z.imag)
        else:
            p2[n + 1] = p2[n] + z.real * z.real + z.imag * z.imag


@njit_inline
def normalised_correlation(acc_re, acc_im, norm_t, energy, s_re, s_im, n):
    """Zero-mean normalised correlation of a segment of ``n`` samples with a zero-mean
    template: |acc| / (‖t0‖·√max(E − |S|²/n, 1e-300)), acc = Σ z·t0 = (``acc_re``,
    ``acc_im``), ‖t0‖ = ``norm_t``, E = Σ|z|² (``energy``), S = Σ z = (``s_re``, ``s_im``);
    in [0, 1]."""
    en = energy - (s_re * s_re + s_im * s_im) / n
    return math.hypot(acc_re, acc_im) / (norm_t * math.sqrt(max(en, 1e-300)))


@njit_inline
def parabola_offset(c_left, c_peak, c_right):
    """Offset [lags] of the vertex of the parabola through (−1, ``c_left``), (0, ``c_peak``),
    (1, ``c_right``) from the middle lag, 0.5·(c₋ − c₊)/(c₋ − 2c₀ + c₊); 0 when the three do
    not curve downwards."""
    den = c_left - 2.0 * c_peak + c_right
    return 0.5 * (c_left - c_right) / den if den < 0 else 0.0


@njit_inline
def centred_start(centre, n_pre_el, n_el, ratio, n_samples):
    """Start of a reply whose pilot + preamble (``n_pre_el`` elements) is centred on sample
    ``centre``, at ρ = ``ratio`` elements per sample: start = centre − n_pre_el/(2ρ) [samples].

    Returns ``(ok, start, n_pre)``: ok when ``n_el`` elements from there (plus 2 samples,
    ⌈n_el/ρ⌉ + 2) fit in a window of ``n_samples`` (the reader asks for the whole reply, the
    capture decoder for the bits it decodes), n_pre = ⌊n_pre_el/ρ⌋ the samples fully inside
    the preamble."""
    start = centre - 0.5 * n_pre_el / ratio
    n_rep = int(math.ceil(n_el / ratio)) + 2
    ok = not (start < 0 or start > n_samples - n_rep)
    return ok, start, int(math.floor(n_pre_el / ratio))


@njit_inline
def fine_step(span, per_side, target):
    """One pass of the fine BLF search across ±``span`` (relative): the step
    max(span/``per_side``, ``target``) and k = ⌈span/step⌉, the pass's 2k + 1 hypotheses at
    centre·(1 + step·j), j = −k … k. The search narrows the span to the step around the best
    and stops after the pass whose step is ≤ ``target``. Returns ``(step, k)``."""
    step = max(span / per_side, target)
    return step, int(math.ceil(span / step))


@njit_inline
def blf_resolution(n_el):
    """Relative BLF precision that decoding a reply of ``n_el`` elements needs, 1/(4·n_el): a
    BLF that far off moves the reply's last element by a quarter element."""
    return 1.0 / (4.0 * n_el)


@njit_inline
def preamble_gain_offset(r, lag, tpl, t_mean, n_pre, seg_mean):
    """Least-squares gain h and offset c of r[lag : lag + n_pre] ≈ h·t + c on the sampled
    pilot + preamble ``tpl`` (mean ``t_mean``): h = Σ r·(t − t̄) / Σ(t − t̄)², c = r̄ − h·t̄
    with r̄ = ``seg_mean`` (the callers sum the segment in their own order: sample by sample
    or from cumulative sums). Returns ``(h, c)``; h = 0 when r is orthogonal to the template."""
    acc = 0j
    e_t = 0.0
    for i in range(n_pre):
        t0 = tpl[i] - t_mean
        acc += r[lag + i] * t0
        e_t += t0 * t0
    h = acc / e_t
    return h, seg_mean - h * t_mean


@njit_inline
def halfbit_decisions(sums, n_pre_levels, miller, state0, viterbi, a, b, out):
    """Bits from the half-bit sums of a reply: the data half-bits start after the
    ``n_pre_levels`` half-bits of the pilot + preamble; bit i's sums are a_i, b_i (``a``,
    ``b`` scratch of ``out.size``); Viterbi from ``state0`` ending on the dummy 1 (``viterbi``)
    or bit-by-bit decisions (:mod:`rfsim.gen2._linecode_kernels`). ``out`` (n_bits + 1,)
    uint8, the last the dummy."""
    for i in range(out.size):
        a[i] = sums[n_pre_levels + 2 * i]
        b[i] = sums[n_pre_levels + 2 * i + 1]
    if viterbi:
        viterbi_kernel(a, b, miller, state0, True, out)
    else:
        bitwise_kernel(a, b, miller, out)


@njit_inline
def signed_sum_decisions(s_sum, s_count, g, dc_re, n_pre_levels, miller, state0, viterbi, sums, a, b, out):
    """:func:`halfbit_decisions` on half-bit sums made from the signed sums of the samples
    (S_j = Σ σ_n·r_n complex, C_j = Σ σ_n, σ_n the subcarrier sign of the sample's element):
    ``sums[j]`` = Re(g·S_j) − ``dc_re``·C_j, the sum of Re((r − dc)·g) of
    :func:`rfsim.gen2._linecode_kernels.projected_halfbit_sums_kernel` (g = 1/h, dc_re =
    Re(dc·g)) up to the order of the additions, so one pass over the samples serves decisions
    at any gain and offset."""
    for j in range(sums.size):
        sums[j] = (g * s_sum[j]).real - dc_re * s_count[j]
    halfbit_decisions(sums, n_pre_levels, miller, state0, viterbi, a, b, out)


@njit_inline
def rest_level_sums(r, ref, n_end, write_ref):
    """Sums of the least-squares fit r ≈ h·ref + c over r[:n_end], ``ref`` read as −1 where it
    is 0 (the reply's rest level; written back into ``ref`` when ``write_ref``): returns
    ``(Σref², Σref, Σr·ref, Σr)``."""
    ss = 0.0
    s1 = 0.0
    rs = 0j
    r1 = 0j
    for n in range(n_end):
        v = ref[n] if ref[n] != 0.0 else -1.0
        if write_ref:
            ref[n] = v
        ss += v * v
        s1 += v
        rs += r[n] * v
        r1 += r[n]
    return ss, s1, rs, r1


@njit_inline
def is_steady(ref, n):
    """Sample n of the reference ``ref`` is steady: both neighbours carry its level (a sample at
    an element boundary may carry either level)."""
    return ref[n] == ref[n - 1] and ref[n] == ref[n + 1]


@njit_inline
def steady_residual(r, ref, h, c, n0, n1):
    """``(Σ|r − c − h·ref|², count)`` over the steady samples n0 ≤ n < n1 of ``ref``
    (:func:`is_steady`; 1 ≤ n0, n1 < ref.size)."""
    acc = 0.0
    cnt = 0
    for n in range(n0, n1):
        if is_steady(ref, n):
            e = (r[n] - c) - h * ref[n]
            acc += e.real * e.real + e.imag * e.imag
            cnt += 1
    return acc, cnt

"""numba kernels of the statistic-level receiver (wrapped and documented in
:mod:`rfsim.devices.reader_statistic`; the plain-NumPy twins are in
``reference.devices_reader_statistic`` in the tests: :func:`piece_map_reference`,
:func:`block_cuts_reference` and, for :func:`receive_kernel`, :func:`receive_reference`, the
receiver's steps as NumPy calls of the sample-level decoder)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rfsim.core._jit import njit
from rfsim.air._noise_kernels import _next_double, _standard_normals
from rfsim.gen2._measure_kernels import known_indices_kernel, measure_kernel
from rfsim.gen2._receive_kernels import _preamble_fit
from rfsim.gen2._linecode_kernels import (INDEX_EPS, element_sign, elements_kernel, preamble_search_runs_kernel,
                                          viterbi_kernel, waveform_kernel)
# the receiver's functionals from per-piece sums (the piece classes and memo rows live there)
from rfsim.devices._reader_statistic_piece_kernels import (INNER_EDGE, MB_EXACT, MB_RR, PM_ANCHOR, PM_CSIG, PM_D1,
                                                          PM_D2, PM_HALF, PM_SD1, PM_SD2, REST, SINGLE, STEADY,
                                                          _halfbit_sums, _known_fit_pieces, _measure_pieces,
                                                          _measure_plan, piece_moments_kernel, piece_runs_kernel)



@njit
def _element(i, start, elements_per_sample):
    """Element index of sample i of a reply starting at sample ``start`` (−1 before it), as
    :func:`rfsim.gen2._linecode_kernels.waveform_kernel` and the half-bit sums assign it."""
    u = (i - start) * elements_per_sample
    if u < 0.0:
        return -1
    return int(math.floor(u + INDEX_EPS))


@njit
def piece_map_kernel(n, i_first, start, elements_per_sample, m, n_elements, piece_of, sign, kind):
    """Partition of the samples ``i_first … n − 1`` into noise pieces (module docstring of
    :mod:`rfsim.devices.reader_statistic`, "Pieces").

    Writes, for sample ``i_first + q``, its piece ``piece_of[q]`` and its sign ``sign[q]``
    (the Miller subcarrier (−1)^k of element k, +1 for FM0 and outside the reply), and per
    piece p its class ``kind[p]`` (:data:`STEADY`: samples inside one element whose neighbours
    lie in the same element, merged per half-bit; :data:`INNER_EDGE`: Miller samples at an
    element edge inside one half-bit, merged per half-bit; :data:`SINGLE`: one sample at a
    half-bit edge or next to the reply's end, or the last sample; :data:`REST`: after the
    reply, both neighbours after it too, one piece). Returns the number of pieces."""
    n_p = 0
    cur = np.full(4, -1, np.int64)  # the open piece of each merged class (STEADY, INNER_EDGE: this half-bit)
    cur_half = -1
    kp = _element(i_first - 1, start, elements_per_sample)
    k = _element(i_first, start, elements_per_sample)
    k_seen = -3  # the element whose half-bit h and sign sg are held (they change only with k)
    h = -1
    sg = 1.0
    for i in range(i_first, n):
        kn = _element(i + 1, start, elements_per_sample) if i + 1 < n else -2
        q = i - i_first
        if k != k_seen:
            k_seen = k
            inside = 0 <= k < n_elements
            h = k // m if inside else -1
            sg = float(element_sign(k, m)) if inside else 1.0
        if h != cur_half:
            cur_half = h
            cur[STEADY] = -1
            cur[INNER_EDGE] = -1
        sign[q] = sg
        if k >= n_elements:
            cls = REST if (kp >= n_elements and kn >= n_elements) else SINGLE
        elif k >= 0 and kp == k and kn == k:
            cls = STEADY
        elif m > 1 and k >= 0 and kp >= 0 and kp // m == h and 0 <= kn < n_elements and kn // m == h:
            cls = INNER_EDGE
        else:
            cls = SINGLE
        if cls == SINGLE or cur[cls] < 0:
            kind[n_p] = cls
            if cls != SINGLE:
                cur[cls] = n_p
            piece_of[q] = n_p
            n_p += 1
        else:
            piece_of[q] = cur[cls]
        kp = k
        k = kn
    return n_p


@njit
def block_cuts_kernel(s, i0, b1, piece_of, kind, n_blocks, reach, cut_piece, cut_edge, cut_before, cut_after):
    """The steady pieces the measurement's block edges cut (:mod:`rfsim.devices.reader_statistic`
    step 4). ``s``: the reference reply from sample ``i0`` of the input (0 outside the reply);
    the measurement reads the samples strictly inside its first and last non-zero sample whose
    two neighbours carry the same level (:func:`rfsim.gen2._measure_kernels.measure_kernel`),
    block k starting at the floor(k·m/K)-th of those m samples. For each edge k = 1 … K − 1 at a
    sample ≥ ``b1`` (the first sample of the pieces) inside a STEADY piece with members on both
    sides (searched within ±``reach`` samples): the piece, the edge (index from ``b1``) and its
    numbers of members before and after the edge, into the ``cut_*`` arrays (K − 1). Returns
    ``(m, number of cuts)``."""
    n = s.size
    first = 0
    while first < n and s[first] == 0.0:
        first += 1
    if first == n:
        return 0, 0
    last = n - 1
    while s[last] == 0.0:
        last -= 1
    steady = np.empty(max(last - first - 1, 0), np.int64)  # the used samples, in order
    m = 0
    for i in range(first + 1, last):
        steady[m] = i
        m += (s[i] == s[i - 1]) & (s[i] == s[i + 1])
    n_cuts = 0
    for k in range(1, n_blocks):
        target = k * m // n_blocks
        if m == 0 or target >= m:
            continue
        e = i0 + steady[target] - b1  # block k starts at its target-th used sample
        if e >= 0 and kind[piece_of[e]] == STEADY:
            p = piece_of[e]
            before = 0
            after = 0
            for q in range(max(0, e - reach), min(piece_of.size, e + reach)):
                if piece_of[q] == p:
                    if q < e:
                        before += 1
                    else:
                        after += 1
            if before > 0 and after > 0:
                cut_piece[n_cuts] = p
                cut_edge[n_cuts] = e
                cut_before[n_cuts] = before
                cut_after[n_cuts] = after
                n_cuts += 1
    return m, n_cuts


@njit
def spread_add_kernel(r, b1, piece_of, sign, sums, sizes):
    """``r[b1 + q] += sign[q]·sums[p]/sizes[p]`` for p = piece_of[q] (the spread pieces added in place;
    each piece's mean sums[p]/sizes[p] formed once; :func:`_spread_add_less` with nothing
    subtracted: x − 0 is x, exactly)."""
    _spread_add_less(r, r, b1, piece_of, sign, sums, sizes, 0j)


@njit
def _spread_add_less(r, x, b1, piece_of, sign, sums, sizes, dc):
    """``r[b1 + q] = (x[b1 + q] + sign[q]·sums[p]/sizes[p]) − dc`` for p = piece_of[q]:
    :func:`spread_add_kernel` and then the subtraction of ``dc``, in one pass (the same
    operations in the same order per sample), reading the input ``x`` (``r`` itself for the
    spread in place; the receiver's noise-free row, so that ``r`` need not be a copy of it)."""
    mean = np.empty(sums.size, np.complex128)
    for p in range(sums.size):
        mean[p] = sums[p] / sizes[p]
    for q in range(piece_of.size):
        r[b1 + q] = (x[b1 + q] + sign[q] * mean[piece_of[q]]) - dc


@njit
def _cut_members(piece_of, p, e, reach):
    """The window ``lo … hi − 1`` (±``reach`` about the edge ``e``) holding the members of the cut
    piece ``p`` and its numbers of members before and after the edge: ``(lo, hi, n_a, n_b)``."""
    n_a = 0
    n_b = 0
    lo = max(0, e - reach)
    hi = min(piece_of.size, e + reach)
    for q in range(lo, hi):
        if piece_of[q] == p:
            if q < e:
                n_a += 1
            else:
                n_b += 1
    return lo, hi, n_a, n_b


@njit
def apply_cuts_kernel(r, b1, piece_of, sign, sums, sizes, cut_piece, cut_edge, reach, part_a, part_b):
    """Respread every cut piece: its members before the edge carry ``part_a``, after it
    ``part_b`` (each over its own members) instead of the whole piece's sum, in place."""
    for c in range(cut_piece.size):
        p = cut_piece[c]
        e = cut_edge[c]
        lo, hi, n_a, n_b = _cut_members(piece_of, p, e, reach)
        mean = sums[p] / sizes[p]
        for q in range(lo, hi):
            if piece_of[q] == p:
                part = part_a[c] / n_a if q < e else part_b[c] / n_b
                r[b1 + q] += sign[q] * (part - mean)


#: Slots of the integer parameters ``ip`` of :func:`receive_kernel`.
(IP_LO, IP_B0, IP_B1, IP_HEAD, IP_N_SEARCH, IP_HALF_WIDTH, IP_N_CANDIDATES, IP_STATE, IP_M, IP_N_PRE, IP_NH,
 IP_N_BITS, IP_N_ELEMENTS, IP_N_REPLY, IP_N_DECODE, IP_N_PRE_ELEMENTS, IP_N_BLOCKS) = range(17)
#: Slots of the float parameters ``fp`` of :func:`receive_kernel`.
FP_SIGMA2, FP_RATIO, FP_FS, FP_THRESHOLD, FP_RUNS_PER_SAMPLE = range(5)
#: Slots of the results ``res`` of :func:`receive_kernel`.
(RES_STATUS, RES_START, RES_CORR, RES_C_RE, RES_C_IM, RES_I0, RES_N_FREE, RES_N_USED, RES_N_SPAN, RES_H_RE, RES_H_IM,
 RES_SLOPE, RES_SIGMA2, RES_GAMMA_LEFT) = range(14)
#: Slots of ``Memo.flags``: the start whose piece map the ``pm_*`` arrays hold and its number
#: of pieces (−1: none yet); the start [samples] and validity (1) of the reference waveform
#: ``wf_full`` of the bits ``wf_bits``; the validity (1), reply start i0 and span of the block
#: cuts in ``cut_memo`` (:func:`_cuts`); the slot's last use (:func:`_slot`); the number of runs of
#: the piece map in ``pm_runs``; the validity (1) of the known-level samples in ``known``, their
#: number, Σlevel² and Σlevel (:func:`_known`).
(MEMO_PM_START, MEMO_PM_PIECES, MEMO_WF_T0, MEMO_WF_VALID, MEMO_CUT_VALID, MEMO_CUT_I0, MEMO_CUT_SPAN,
 MEMO_STAMP, MEMO_PM_RUNS, MEMO_KF_VALID, MEMO_KF_N, MEMO_KF_SS, MEMO_KF_S1) = range(13)
#: Columns of ``Memo.flags``.
MEMO_FLAGS = 13
#: Slots of the content memo (:class:`Memo`, the first axis of its arrays; :func:`_slot`).
MEMO_SLOTS = 4


class PlanArrays(NamedTuple):
    """The arrays :func:`receive_kernel` reads from a reply's plan (the decoder's search
    template and refinement bank, the preamble)."""

    t0: np.ndarray  # (pre_n,) float64: the search template at offset 0
    shifts: np.ndarray  # (17,) float64: the refinement's sub-sample shifts
    templates: np.ndarray  # (17, ·) float64: the refinement bank
    norms: np.ndarray  # (17,) float64: its norms
    pre_el: np.ndarray  # (n_pre_elements,) float64: the preamble's elements
    pre_levels: np.ndarray  # (·,) int8: the preamble's half-bit levels
    run_begin: np.ndarray  # the refinement bank's runs of equal values (rfsim.gen2.linecode._refine_runs)
    run_value: np.ndarray
    n_runs: np.ndarray
    same_as_previous: np.ndarray


class Memo(NamedTuple):
    """The content memo of :func:`receive_kernel` for one plan, input length n and search
    window: :data:`MEMO_SLOTS` slots (the first axis of every array, chosen by the reply start,
    :func:`_slot`), each holding pure functions of what its ``flags`` row names, checked by
    :func:`_pieces`, :func:`_reference`, :func:`_known` and :func:`_cuts` on every call. Per slot:"""

    flags: np.ndarray  # (MEMO_FLAGS,) float64: the MEMO_* slots
    pm_piece_of: np.ndarray  # (n − b1,) int64: the piece of each sample from b1 on
    pm_sign: np.ndarray  # (n − b1,) float64: its subcarrier sign
    pm_kind: np.ndarray  # (n − b1,) int64: the class of each piece (first n_pieces used)
    pm_sizes: np.ndarray  # (n − b1,) float64: the samples of each piece (first n_pieces used)
    wf_bits: np.ndarray  # (n_bits,) uint8: the bits of the reference in wf_full
    wf_full: np.ndarray  # (n,) float64: their ±1 reference (0 outside the reply)
    cut_memo: np.ndarray  # (6, max(n_blocks − 1, 3)) int64: the block cuts (:func:`_cuts`)
    pm_mom: np.ndarray  # (7, n − b1) float64: per piece the PM_* rows (:func:`_pieces`)
    mu: np.ndarray  # (2, n − b1) float64: per piece its measurement block (−1: not read whole) and level
    ms: np.ndarray  # (2, n_reply + 4) int64: the samples the measurement reads one by one, their block
    mb: np.ndarray  # (MB_RR + 2·n_blocks,) float64: the MB_* slots of the measurement's plan
    pm_runs: np.ndarray  # (3, n − b1) int64: the runs of the piece map (piece_runs_kernel)
    known: np.ndarray  # (2, min(b1 + 1, n)) float64: the known-level samples before b1 + 1 and their levels (_known)


#: Status codes of :func:`receive_kernel` (``res[RES_STATUS]``).
OK, NOT_FOUND, ZERO_GAIN, CONSTANT_REFERENCE, NO_ROOM = range(5)


@njit
def _piece_scale(sigma2, size):
    """The scale √(σ²·|p|/2) of each part (real, imaginary) of a piece sum P_p ~ CN(0, σ²·|p|) of
    ``size`` = |p| samples: the one rule of :func:`_draw_sums` and :func:`_search`."""
    return math.sqrt(0.5 * sigma2 * size)


@njit
def _draw_sums(st, sizes, sigma2, out, ki, wi, fi):
    """Piece sums P_p ~ CN(0, σ²·|p|) into ``out`` as :func:`rfsim.devices.reader_statistic.draw_piece_sums`
    draws them: a (2, k) standard-normal block (the real parts, then the imaginary parts, in
    order, from the PCG64 state ``st``), each part times :func:`_piece_scale`."""
    k = sizes.size
    z = np.empty(2 * k)
    _standard_normals(st, z, ki, wi, fi)
    for p in range(k):
        scale = _piece_scale(sigma2, sizes[p])
        out[p] = complex(scale * z[p], scale * z[k + p])


@njit
def _mean(r, n):
    """Σ r[:n] / n (0 when n = 0)."""
    acc = 0j
    for i in range(n):
        acc += r[i]
    return acc / n if n > 0 else 0j


@njit
def _decide(s_sum, s_count, g, dc_re, miller, n_pre_half, state, out):
    """Viterbi decisions (:func:`rfsim.gen2._linecode_kernels.viterbi_kernel`, the last bit the
    dummy 1) on the projected half-bit sums Re(g·S_j) − dc_re·C_j of the data half-bits into
    ``out`` ((n_bits + 1,) uint8)."""
    n = out.size
    a = np.empty(n)
    b = np.empty(n)
    for i in range(n):
        j = n_pre_half + 2 * i
        a[i] = (g * s_sum[j]).real - dc_re * s_count[j]
        b[i] = (g * s_sum[j + 1]).real - dc_re * s_count[j + 1]
    viterbi_kernel(a, b, miller, state, True, out)


@njit
def _search(st, r, ip, fp, plan, ki, wi, fi):
    """Steps 1–2: the noise of the stretch before the search block (two pieces: sample 0 and
    samples 1 … b0 − 1) and of the block b0 … b1 − 1 drawn per sample and added to ``r`` in place
    (the pieces' sums of :func:`_draw_sums`, one-sample pieces added as drawn), the mean of
    ``r[:lo]`` taken off ``r[:b1]`` in place, then the decoder's preamble search
    (:func:`rfsim.gen2._linecode_kernels.preamble_search_runs_kernel`, the sample-level decoder's,
    with the :class:`PlanArrays` ``plan``) over ``r[lo:b1]`` (the search reads nothing after the
    block). Returns (that mean, the reply start relative to ``lo`` [samples])."""
    lo, b0, b1, head = ip[IP_LO], ip[IP_B0], ip[IP_B1], ip[IP_HEAD]
    sigma2 = fp[FP_SIGMA2]
    k = head + b1 - b0
    z = np.empty(2 * k)
    _standard_normals(st, z, ki, wi, fi)
    one = _piece_scale(sigma2, 1.0)  # a one-sample piece's scale
    if head > 0:
        r[0] += complex(one * z[0], one * z[k])
    if head == 2:
        scale = _piece_scale(sigma2, float(b0 - 1))
        share = complex(scale * z[1], scale * z[k + 1]) / (b0 - 1)
        for i in range(1, b0):
            r[i] += share
    for i in range(b0, b1):
        j = head + i - b0
        r[i] += complex(one * z[j], one * z[k + j])
    dc0 = _mean(r, lo) if lo >= 8 else 0j
    for i in range(b1):
        r[i] = r[i] - dc0
    lag, best, start_rel = preamble_search_runs_kernel(r[lo:b1], ip[IP_N_SEARCH], plan.t0, fp[FP_RUNS_PER_SAMPLE],
                                                       ip[IP_HALF_WIDTH], ip[IP_N_CANDIDATES], plan.shifts,
                                                       plan.templates, plan.norms, plan.run_begin, plan.run_value,
                                                       plan.n_runs, plan.same_as_previous)
    return dc0, (float(lag) if best < 0 else start_rel)


@njit
def _cuts(s, i0, b1, piece_of, sign, kind, sizes, n_blocks, fs, memo, cut_memo, mu, ms, mb):
    """The content of steps 4 and 6 (:func:`_bridge_cuts`): Σ(|p| − 1) over the steady pieces,
    the reach of :func:`block_cuts_kernel` and its cuts, in ``cut_memo`` ((6, n_blocks − 1)
    int64: the cut pieces, edges, members before and after; in row 4 the samples the
    measurement reads, the number of cuts, the reach; in row 5 Σ(|p| − 1) and 1 when the
    measurement reads an inner-edge piece whole, else 0) and the measurement's
    plan (:func:`_measure_plan` into ``mu``, ``ms``, ``mb``), made only when it does
    not already hold those of this start ``i0`` and span ``s.size`` (``memo``: valid while the
    piece map and the reference it was made from are those of :func:`_pieces` and
    :func:`_reference`, which clear it when they make new ones)."""
    if memo[MEMO_CUT_VALID] > 0 and memo[MEMO_CUT_I0] == i0 and memo[MEMO_CUT_SPAN] == s.size:
        return
    memo[MEMO_CUT_VALID] = 0.0
    n_free = 0.0
    biggest = 0.0
    for p in range(kind.size):
        if kind[p] == STEADY:
            n_free += sizes[p] - 1.0
            biggest = max(biggest, sizes[p])
    reach = int(biggest) * 8 + 8  # a steady piece lies within one half-bit: ≤ 8× its steady samples (+ 8)
    n_used, n_cuts = block_cuts_kernel(s, i0, b1, piece_of, kind, n_blocks, reach, cut_memo[0], cut_memo[1],
                                       cut_memo[2], cut_memo[3])
    cut_memo[4, 0], cut_memo[4, 1], cut_memo[4, 2] = n_used, n_cuts, reach
    cut_memo[5, 0] = int(n_free)
    _measure_plan(s, i0, b1, piece_of, sign, sizes, cut_memo[0, :n_cuts], n_blocks, fs, mu, ms, mb)
    inner = 0  # (never where the reference's element edges agree with the piece map's: the subcarrier flips there)
    for p in range(kind.size):
        if kind[p] == INNER_EDGE and mu[0, p] >= 0.0:
            inner = 1
    cut_memo[5, 1] = inner
    memo[MEMO_CUT_I0], memo[MEMO_CUT_SPAN] = i0, s.size
    memo[MEMO_CUT_VALID] = 1.0


@njit
def _bridge_cuts(st, r, x, dc, s, i0, b1, piece_of, sign, kind, sums, sizes, sigma2, n_blocks, fs, memo, cut_memo, mu,
                 ms, mb, ki, wi, fi):
    """Steps 4 and 6: the steady pieces cut by the measurement's block edges
    (:func:`block_cuts_kernel` through the memo :func:`_cuts`, ``s`` the reference from sample
    ``i0``) split by a Gaussian bridge (one (2, 2·cuts) normal block); their members written
    into ``r`` as x − ``dc`` plus their part spread over them (:func:`_fill_cuts`; the members
    of :func:`apply_cuts_kernel`; ``memo``, ``cut_memo``, ``mu``, ``ms``, ``mb`` those of
    :func:`_cuts`). Returns (Σ(|p| − 1) over
    the steady pieces less one per cut, the samples the measurement reads)."""
    _cuts(s, i0, b1, piece_of, sign, kind, sizes, n_blocks, fs, memo, cut_memo, mu, ms, mb)
    n_used, n_cuts, reach = cut_memo[4, 0], cut_memo[4, 1], cut_memo[4, 2]
    n_free = float(cut_memo[5, 0])
    piece, edge, n_a, n_b = cut_memo[0], cut_memo[1], cut_memo[2], cut_memo[3]
    if n_cuts > 0:
        ab_sizes = np.empty(2 * n_cuts)
        for j in range(n_cuts):
            ab_sizes[j] = n_a[j]
            ab_sizes[n_cuts + j] = n_b[j]
        ab = np.empty(2 * n_cuts, np.complex128)
        _draw_sums(st, ab_sizes, sigma2, ab, ki, wi, fi)
        part_a = np.empty(n_cuts, np.complex128)
        part_b = np.empty(n_cuts, np.complex128)
        for j in range(n_cuts):
            tot = float(n_a[j] + n_b[j])
            miss = sums[piece[j]] - ab[j] - ab[n_cuts + j]
            part_a[j] = ab[j] + miss * (n_a[j] / tot)
            part_b[j] = ab[n_cuts + j] + miss * (n_b[j] / tot)
        _fill_cuts(r, x, dc, b1, piece_of, sign, piece[:n_cuts], edge[:n_cuts], reach, part_a, part_b)
    return n_free - n_cuts, n_used


@njit
def _fill_cuts(r, x, dc, b1, piece_of, sign, cut_piece, cut_edge, reach, part_a, part_b):
    """The members of every cut piece (those of :func:`apply_cuts_kernel`) written into ``r``:
    (x_i − ``dc``) + σ_i·``part_a``/n_a before the edge, ``part_b``/n_b after it."""
    for c in range(cut_piece.size):
        p = cut_piece[c]
        e = cut_edge[c]
        lo, hi, n_a, n_b = _cut_members(piece_of, p, e, reach)
        for q in range(lo, hi):
            if piece_of[q] == p:
                part = part_a[c] / n_a if q < e else part_b[c] / n_b
                r[b1 + q] = (x[b1 + q] - dc) + sign[q] * part


@njit
def _reference(bits, t0_samples, ratio, m, pre_levels, state, memo, wf_bits, wf_full):
    """The ±1 reference of ``bits`` (dummy 1 appended) from sample ``t0_samples``, 0 outside,
    in ``wf_full`` (:func:`rfsim.gen2._linecode_kernels.waveform_kernel`): made only when
    ``wf_full`` does not already hold it (``memo`` and ``wf_bits`` name what it holds: a pure
    function of the bits and the start for the plan and input length of the caller)."""
    if memo[MEMO_WF_VALID] > 0 and memo[MEMO_WF_T0] == t0_samples:
        same = True
        for i in range(bits.size):
            same = same and wf_bits[i] == bits[i]
        if same:
            return
    memo[MEMO_WF_VALID] = 0.0
    memo[MEMO_CUT_VALID] = 0.0
    memo[MEMO_KF_VALID] = 0.0
    el = np.empty((pre_levels.size + 2 * (bits.size + 1)) * m)
    elements_kernel(bits, True, m, pre_levels, state, el)
    waveform_kernel(el, t0_samples, ratio, wf_full)
    wf_bits[:] = bits
    memo[MEMO_WF_T0] = t0_samples
    memo[MEMO_WF_VALID] = 1.0


@njit
def _known(full, b1, t0_samples, ratio, n_pre_elements, memo, known):
    """The samples before ``b1`` + 1 of known level (:func:`rfsim.gen2._measure_kernels.known_indices_kernel`
    on the reference ``full`` from ``t0_samples``): their indices into ``known[0]``, their levels
    into ``known[1]``, in order, made only when ``memo`` does not hold those of the reference in
    ``full`` (:func:`_reference` clears it when it makes a new one). Returns (their number,
    Σlevel², Σlevel) (sums in order)."""
    if memo[MEMO_KF_VALID] <= 0.0:
        nb = known.shape[1]
        found = np.empty(nb, np.int64)
        mk = known_indices_kernel(full[:nb], t0_samples, ratio, n_pre_elements, found, known[1])
        ss = s1 = 0.0
        for i in range(mk):
            known[0, i] = found[i]
            ss += known[1, i] * known[1, i]
            s1 += known[1, i]
        memo[MEMO_KF_N], memo[MEMO_KF_SS], memo[MEMO_KF_S1] = mk, ss, s1
        memo[MEMO_KF_VALID] = 1.0
    return int(memo[MEMO_KF_N]), memo[MEMO_KF_SS], memo[MEMO_KF_S1]


@njit
def _slot(flags, start):
    """The memo slot (row of ``flags``, (S, MEMO_FLAGS)) holding the pieces of ``start``, else the one
    used longest ago (its content made anew by the callers); the slot's use stamped in
    column :data:`MEMO_STAMP`. The slots' contents are pure functions of their keys: which
    slot holds what never changes a result."""
    best = 0
    for j in range(flags.shape[0]):
        if flags[j, MEMO_PM_PIECES] >= 0.0 and flags[j, MEMO_PM_START] == start:
            best = j
            break
        if flags[j, MEMO_STAMP] < flags[best, MEMO_STAMP]:
            best = j
    top = 0.0
    for j in range(flags.shape[0]):
        top = max(top, flags[j, MEMO_STAMP])
    flags[best, MEMO_STAMP] = top + 1.0
    return best


@njit
def _pieces(n, b1, start, ratio, m, n_elements, memo, pm_piece_of, pm_sign, pm_kind, pm_sizes, pm_mom, pm_runs):
    """The piece map of the samples ``b1 … n − 1`` (:func:`piece_map_kernel`), the pieces'
    sizes, their moments (rows ``PM_*`` of ``pm_mom``) and runs (:func:`piece_runs_kernel`, their
    number in ``memo[MEMO_PM_RUNS]``) in the ``pm_*`` arrays, made only
    when they do not already hold those of ``start`` (``memo``; a pure function of the start
    for the plan and input length of the caller). Returns the number of pieces."""
    if memo[MEMO_PM_PIECES] >= 0.0 and memo[MEMO_PM_START] == start:
        return int(memo[MEMO_PM_PIECES])
    memo[MEMO_PM_PIECES] = -1.0
    memo[MEMO_CUT_VALID] = 0.0
    n_p = piece_map_kernel(n, b1, start, ratio, m, n_elements, pm_piece_of, pm_sign, pm_kind)
    pm_sizes[:n_p] = 0.0
    pm_mom[:, :n_p] = 0.0
    n_q = n - b1
    q = 0
    while q < n_q:  # per run of samples of one piece: the count and Σi
        p = pm_piece_of[q]
        if pm_sizes[p] == 0.0:
            k = _element(b1 + q, start, ratio)
            pm_mom[PM_HALF, p] = k // m if 0 <= k < n_elements else -1
        cnt = 0.0
        acc = 0.0
        while q < n_q and pm_piece_of[q] == p:
            cnt += 1.0
            acc += b1 + q
            q += 1
        pm_sizes[p] += cnt
        pm_mom[PM_ANCHOR, p] += acc
    for p in range(n_p):
        pm_mom[PM_ANCHOR, p] = math.floor(pm_mom[PM_ANCHOR, p] / pm_sizes[p] + 0.5)
    q = 0
    while q < n_q:  # per run: Σσ, Σδ, Σδ², Σσδ, Σσδ²
        p = pm_piece_of[q]
        a = pm_mom[PM_ANCHOR, p]
        c0 = c1 = c2 = c3 = c4 = 0.0
        while q < n_q and pm_piece_of[q] == p:
            sg = pm_sign[q]
            d = b1 + q - a
            c0 += sg
            c1 += d
            c2 += d * d
            c3 += sg * d
            c4 += sg * d * d
            q += 1
        pm_mom[PM_CSIG, p] += c0
        pm_mom[PM_D1, p] += c1
        pm_mom[PM_D2, p] += c2
        pm_mom[PM_SD1, p] += c3
        pm_mom[PM_SD2, p] += c4
    memo[MEMO_PM_RUNS] = piece_runs_kernel(pm_piece_of[:n_q], pm_sign[:n_q], pm_kind[:n_p], pm_runs)
    memo[MEMO_PM_START] = start
    memo[MEMO_PM_PIECES] = n_p
    return n_p


@njit
def standard_gamma_kernel(st, shape, ki, wi, fi):
    """A standard Gamma(``shape``) draw, ``shape`` > 1, from the PCG64 state ``st`` (advanced in
    place): NumPy's ``Generator.gamma(shape)`` draw for draw (Marsaglia and Tsang 2000, "A simple
    method for generating gamma variables", ACM TOMS 26(3), as NumPy's
    ``random_standard_gamma``): b = shape − 1/3, c = 1/√(9b); X a standard normal (the
    ziggurat of :func:`rfsim.air._noise_kernels._standard_normals`) redrawn while V = 1 + cX ≤ 0;
    V = V³, U uniform on [0, 1) (53 bits); accept b·V when U < 1 − 0.0331·X⁴ or
    log U < X²/2 + b·(1 − V + log V), else draw again."""
    b = shape - 1.0 / 3.0
    c = 1.0 / math.sqrt(9.0 * b)
    z = np.empty(1)
    while True:
        while True:
            _standard_normals(st, z, ki, wi, fi)
            x = z[0]
            v = 1.0 + c * x
            if v > 0.0:
                break
        v = v * v * v
        u = _next_double(st)
        if u < 1.0 - 0.0331 * (x * x) * (x * x):
            return b * v
        if np.log(u) < 0.5 * x * x + b * (1.0 - v + np.log(v)):
            return b * v


@njit
def receive_kernel(st, xs, trial, r, ip, fp, plan, bits_out, z_out, res, memo, ki, wi, fi):
    """The statistic-level receiver of :func:`rfsim.devices.reader_statistic.receive_many`, steps
    1–4 and step 6's draw (its module docstring) for the trials ``trial[0], trial[0] + 1, …`` of one
    plan, input length and search window in one call, the draws from the PCG64 state in
    ``st`` (advanced in place) trial after trial in the order of the NumPy steps.

    ``st`` (4,) uint64: the generator's state in the noise kernels' order (state high, low word,
    increment high, low word; :func:`rfsim.air._noise_kernels._pcg64_state`). ``xs`` (B, n)
    complex: the noise-free inputs. ``r`` (n,) complex: scratch (the samples of the search
    block and before it, with their noise and less the DC; the members of cut pieces; all
    samples where the measurement falls back to the spread pieces). ``ip``, ``fp``: the
    integer and float parameters (slots ``IP_*``, ``FP_*``); ``plan``: the :class:`PlanArrays`
    of the reply; ``memo``: the :class:`Memo` of the plan, input length and search window. Per
    trial b: the decoded bits into ``bits_out[b]`` ((B, n_bits + 1) uint8); the measurement
    against the ±1 reference of the span (0 outside the reply; the memo's reference) from the
    pieces' sums (:func:`_measure_pieces`), or where a piece would be read in part from the
    reply span r − c in ``z_out`` ((n_reply + 4,) complex, scratch, ``res[b, RES_N_SPAN]`` of them
    used) by :func:`rfsim.gen2._measure_kernels.measure_kernel`; into ``res[b]`` ((B, 14), slots
    ``RES_*``) the status, the reply start (relative to ``lo``), the correlation, c, i0, the
    in-piece degrees of freedom, the measurement's sample count and its gain h, phase slope and
    residual power (step 6's in-piece energy added, :func:`standard_gamma_kernel`; when the
    degrees of freedom are 1 or fewer its shape is left in ``res[b, RES_GAMMA_LEFT]`` for the
    caller to draw with NumPy). Stops after a trial that leaves a draw to the caller or fails
    with a status the caller raises (ZERO_GAIN, CONSTANT_REFERENCE, NO_ROOM), so that the draws
    stay in trial order. ``trial`` (1,) int64: on entry the first trial, on return the index
    after the last trial done."""
    b = trial[0]
    b1 = ip[IP_B1]
    while b < xs.shape[0]:
        r[:b1] = xs[b, :b1]  # the rest is written by the spread, from xs[b]
        _receive(st, r, xs[b], ip, fp, plan, bits_out[b], z_out, res[b], memo, ki, wi, fi)
        b += 1
        if res[b - 1, RES_GAMMA_LEFT] > 0 or res[b - 1, RES_STATUS] >= ZERO_GAIN:
            break
    trial[0] = b


@njit
def _receive(st, r, x, ip, fp, plan, bits_out, z_out, res, memo, ki, wi, fi):
    """:func:`receive_kernel`'s steps for one trial (``x`` its noise-free input, of which ``r``
    holds the samples before the pieces, ``r[:b1]``; ``bits_out`` and ``res`` its rows) on the
    state ``st`` in the noise kernels' order; ``r`` is written where :func:`receive_kernel` says."""
    lo, b1, m, nh, n_bits = ip[IP_LO], ip[IP_B1], ip[IP_M], ip[IP_NH], ip[IP_N_BITS]
    n_decode, state = ip[IP_N_DECODE], ip[IP_STATE]
    sigma2, ratio, fs = fp[FP_SIGMA2], fp[FP_RATIO], fp[FP_FS]
    n = r.size
    n_pre_half = nh - 2 * (n_bits + 1)
    res[RES_GAMMA_LEFT] = 0.0
    dc0, start_rel = _search(st, r, ip, fp, plan, ki, wi, fi)
    start = lo + start_rel
    res[RES_START] = start_rel
    # step 3: the pieces after the block, spread, the DC subtraction again
    slot = _slot(memo.flags, start)
    flags = memo.flags[slot]
    pm_mom, mu, ms, mb = memo.pm_mom[slot], memo.mu[slot], memo.ms[slot], memo.mb[slot]
    n_p = _pieces(n, b1, start, ratio, m, ip[IP_N_ELEMENTS], flags, memo.pm_piece_of[slot], memo.pm_sign[slot],
                  memo.pm_kind[slot], memo.pm_sizes[slot], pm_mom, memo.pm_runs[slot])
    n_q = max(n - b1, 0)
    piece_of, sign = memo.pm_piece_of[slot, :n_q], memo.pm_sign[slot, :n_q]
    kind, sizes = memo.pm_kind[slot, :n_p], memo.pm_sizes[slot, :n_p]
    sums = np.empty(n_p, np.complex128)
    _draw_sums(st, sizes, sigma2, sums, ki, wi, fi)
    runs = memo.pm_runs[slot, :, :int(flags[MEMO_PM_RUNS])]
    mom, energy = piece_moments_kernel(x, dc0, b1, piece_of, sign, pm_mom[PM_ANCHOR], n_p, runs, False)
    # the decoder at the start found: gain and offset from the preamble, correlation, decisions
    lag = int(math.floor(start_rel))
    frac = start_rel - lag
    i0 = lo + lag
    corr, h, dcp = _preamble_fit(r[i0: i0 + ip[IP_N_PRE]], frac, plan.pre_el, ratio)
    res[RES_CORR] = corr
    if h == 0:
        res[RES_STATUS] = ZERO_GAIN
        return
    det_bits = np.empty(n_bits + 1, np.uint8)
    s_sum = np.empty(nh, np.complex128)
    s_count = np.empty(nh)
    _halfbit_sums(r, i0, b1, n_decode, frac, ratio, m, mom, sums, pm_mom, s_sum, s_count)
    _decide(s_sum, s_count, 1.0 / h, (dcp * (1.0 / h)).real, m > 1, n_pre_half, state, det_bits)
    if corr < fp[FP_THRESHOLD]:
        res[RES_STATUS] = NOT_FOUND
        return
    # (h, c) on the known levels of the reference of the search's decisions
    t0_samples = start / fs * fs
    full, wf_bits = memo.wf_full[slot], memo.wf_bits[slot]
    _reference(det_bits[:n_bits], t0_samples, ratio, m, plan.pre_levels, state, flags, wf_bits, full)
    known = memo.known[slot]
    mk, ss, s1 = _known(full, b1, t0_samples, ratio, ip[IP_N_PRE_ELEMENTS], flags, known)
    h, c, fitted = _known_fit_pieces(r, full, known, mk, ss, s1, kind, pm_mom[PM_ANCHOR], mom, sums, sizes)
    if not fitted:
        res[RES_STATUS] = CONSTANT_REFERENCE
        return
    res[RES_C_RE], res[RES_C_IM] = c.real, c.imag
    # the final decisions on r − c with h given: the half-bit sums of r − c are S_j − c·C_j
    n_span = min(ip[IP_N_REPLY] + 4, n - i0)
    res[RES_I0], res[RES_N_SPAN] = i0, n_span
    if not (0.0 <= start_rel - lag <= n_span - n_decode):
        res[RES_STATUS] = NO_ROOM
        return
    if h == 0:
        res[RES_STATUS] = ZERO_GAIN
        return
    for j in range(nh):
        s_sum[j] -= c * s_count[j]
    _decide(s_sum, s_count, 1.0 / h, 0.0, m > 1, n_pre_half, state, bits_out)
    same = True
    for i in range(n_bits):
        same = same and bits_out[i] == det_bits[i]
    if not same:
        _reference(bits_out[:n_bits], t0_samples, ratio, m, plan.pre_levels, state, flags, wf_bits, full)
    s_span = full[i0:i0 + n_span]  # the reference of the span (read, not copied)
    n_blocks = ip[IP_N_BLOCKS]
    cut_memo = memo.cut_memo[slot]
    _cuts(s_span, i0, b1, piece_of, sign, kind, sizes, n_blocks, fs, flags, cut_memo, mu, ms, mb)
    exact = mb[MB_EXACT] > 0.0
    if exact and cut_memo[5, 1] > 0:  # an inner-edge piece read whole: the pass again with its every sum
        mom, energy = piece_moments_kernel(x, dc0, b1, piece_of, sign, pm_mom[PM_ANCHOR], n_p, runs, True)
    if not exact:  # a piece the measurement reads in part: the samples after b1 spread (the sample-level path)
        _spread_add_less(r, x, b1, piece_of, sign, sums, sizes, dc0)
    n_free, n_used = _bridge_cuts(st, r, x, dc0, s_span, i0, b1, piece_of, sign, kind, sums, sizes, sigma2, n_blocks,
                                  fs, flags, cut_memo, mu, ms, mb, ki, wi, fi)
    if exact:
        gain, slope, resid = _measure_pieces(r, full, c, mom, energy, sums, sizes, pm_mom, mu, ms, mb,
                                             i0, fs, n_blocks)
    else:
        for i in range(n_span):
            z_out[i] = r[i0 + i] - c
        gain, slope, resid = measure_kernel(z_out[:n_span], s_span, fs, n_blocks)
    # step 6: the in-piece noise energy σ²·Gamma(n_free)/n_used, where the SNR is finite
    if resid > 0.0 and abs(gain) ** 2 > 0.0 and n_used > 0 and n_free > 0:  # (as Reader._measurements)
        if n_free > 1.0:
            resid = resid + sigma2 * standard_gamma_kernel(st, n_free, ki, wi, fi) / n_used
        else:
            res[RES_GAMMA_LEFT] = n_free
    res[RES_H_RE], res[RES_H_IM], res[RES_SLOPE], res[RES_SIGMA2] = gain.real, gain.imag, slope, resid
    res[RES_N_FREE] = n_free
    res[RES_N_USED] = n_used
    res[RES_STATUS] = OK

"""numba kernels of the statistic-level receiver's functionals from per-piece sums (the steps
after the search block in :mod:`rfsim.devices.reader_statistic`, "Implementation"; called by
:func:`rfsim.devices._reader_statistic_kernels.receive_kernel`): the one pass over the
noise-free input, the half-bit sums, the known-level fit and the measurement (gain, Doppler
slope, residual power) from the pieces' sums and the drawn noise sums. The NumPy twin of the
whole receiver, ``reference.devices_reader_statistic.receive_reference`` in the tests, measures
on the spread samples; :func:`piece_moments_kernel` has its own twin there."""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit
from rfsim.gen2._linecode_kernels import signed_halfbit_sums_kernel
from rfsim.gen2._measure_kernels import _level, block_slope

#: Piece classes (``kind`` of :func:`rfsim.devices._reader_statistic_kernels.piece_map_kernel`).
STEADY, INNER_EDGE, SINGLE, REST = 0, 1, 2, 3
#: Rows of ``Memo.pm_mom`` per piece p (δ_i = i − a_p, a_p the sample nearest the mean of the
#: piece's sample indices): Σσ_i, a_p, Σδ_i, Σδ_i², Σσ_i·δ_i, Σσ_i·δ_i², the half-bit of its
#: samples (−1 outside the reply's elements).
PM_CSIG, PM_ANCHOR, PM_D1, PM_D2, PM_SD1, PM_SD2, PM_HALF = range(7)
#: Slots of ``Memo.mb`` (:func:`_measure_plan`): the samples the measurement reads, the entries
#: of ``Memo.ms``, the span's centre (span index), 1 when the pieces carry the measurement
#: (else the per-sample path), the span's first non-zero and one past its last; then per block
#: its samples (from MB_RR) and the sum of their times [s] (from MB_RR + n_blocks).
MB_M, MB_N_MS, MB_CENTRE, MB_EXACT, MB_FIRST, MB_END, MB_RR = 0, 1, 2, 3, 4, 5, 8


#: Codes of a run of consecutive samples of one piece (row 2 of ``Memo.pm_runs``,
#: :func:`piece_runs_kernel`) besides its subcarrier sign ±1 where the sign is constant over the
#: run: the sign changes inside the run; the run of an :data:`INNER_EDGE` piece (whose sums
#: the receiver reads only as Σσ_i·u_i, the half-bit sums: the measurement never reads its
#: samples, which sit at a subcarrier flip).
RUN_MIXED, RUN_INNER_EDGE = 0, 2


@njit
def piece_runs_kernel(piece_of, sign, kind, runs):
    """The runs of consecutive samples of one piece (``piece_of``, ``sign`` and ``kind`` of
    :func:`rfsim.devices._reader_statistic_kernels.piece_map_kernel`), in sample order: run j
    is the samples ``runs[0, j] … runs[1, j] − 1`` (indices of ``piece_of``), ``runs[2, j]`` its
    code (the constant sign ±1, :data:`RUN_MIXED` or :data:`RUN_INNER_EDGE`). ``runs``:
    (3, piece_of.size) int64. Returns the number of runs."""
    n_q = piece_of.size
    n_runs = 0
    q = 0
    while q < n_q:
        p = piece_of[q]
        first = q
        s0 = sign[q]
        mixed = False
        while q < n_q and piece_of[q] == p:
            mixed = mixed or sign[q] != s0
            q += 1
        runs[0, n_runs] = first
        runs[1, n_runs] = q
        runs[2, n_runs] = RUN_INNER_EDGE if kind[p] == INNER_EDGE else (RUN_MIXED if mixed else int(s0))
        n_runs += 1
    return n_runs


@njit
def piece_moments_kernel(x, dc, b1, piece_of, sign, anchor, n_p, runs, every):
    """The one pass over the noise-free input after the search block: per piece p of the
    samples ``b1 …`` (``piece_of``, ``sign`` σ_i, ``anchor`` a_p of :data:`PM_ANCHOR`), with
    u_i = x_i − ``dc``, δ_i = i − a_p, the sums ``mom[0] = Σσ_i·u_i``, ``mom[1] = Σu_i``,
    ``mom[2] = Σσ_i·u_i·δ_i``, ``mom[3] = Σσ_i·u_i·δ_i²`` ((4, n_p) complex) and
    ``energy = Σ|u_i|²`` ((n_p,) float), summed per run of consecutive samples of a piece (the
    runs of :func:`piece_runs_kernel`, ``runs`` (3, ·)) and the runs in sample order. A run of
    constant sign σ sums u, u·δ and u·δ² and takes σ times the sums: the same numbers as the
    sums of σ·u, σ·u·δ, σ·u·δ² (σ = ±1: a change of sign is exact and rounding is symmetric in
    sign). Of an inner-edge piece's runs only ``mom[0]`` (its other sums 0) unless ``every``
    (then every sum of every piece). Returns ``(mom, energy)``."""
    mom = np.zeros((4, n_p), np.complex128)
    energy = np.zeros(n_p)
    for j in range(runs.shape[1]):  # per run: sums in registers, added to the piece's once
        first, end, code = runs[0, j], runs[1, j], runs[2, j]
        p = piece_of[first]
        if code == RUN_INNER_EDGE and not every:
            a_re = a_im = 0.0
            for q in range(first, end):
                u = x[b1 + q] - dc
                sg = sign[q]
                a_re += sg * u.real
                a_im += sg * u.imag
            mom[0, p] += complex(a_re, a_im)
            continue
        d = b1 + first - anchor[p]  # δ_i, an integer: stepped by 1 exactly
        if code == 1 or code == -1:
            b_re = b_im = c_re = c_im = d_re = d_im = e = 0.0
            for q in range(first, end):
                u = x[b1 + q] - dc
                ur, ui = u.real, u.imag
                b_re += ur
                b_im += ui
                tr, ti = ur * d, ui * d
                c_re += tr
                c_im += ti
                d_re += tr * d
                d_im += ti * d
                e += ur * ur + ui * ui
                d += 1.0
            sg = float(code)
            mom[0, p] += complex(sg * b_re, sg * b_im)
            mom[1, p] += complex(b_re, b_im)
            mom[2, p] += complex(sg * c_re, sg * c_im)
            mom[3, p] += complex(sg * d_re, sg * d_im)
            energy[p] += e
            continue
        a_re = a_im = b_re = b_im = c_re = c_im = d_re = d_im = e = 0.0
        for q in range(first, end):
            u = x[b1 + q] - dc
            ur, ui = u.real, u.imag
            sg = sign[q]
            sr, si = sg * ur, sg * ui
            a_re += sr
            a_im += si
            b_re += ur
            b_im += ui
            c_re += sr * d
            c_im += si * d
            d_re += sr * d * d
            d_im += si * d * d
            e += ur * ur + ui * ui
            d += 1.0
        mom[0, p] += complex(a_re, a_im)
        mom[1, p] += complex(b_re, b_im)
        mom[2, p] += complex(c_re, c_im)
        mom[3, p] += complex(d_re, d_im)
        energy[p] += e
    return mom, energy


@njit
def _halfbit_sums(r, i0, b1, n_decode, frac, ratio, m, mom, sums, pm_mom, s_sum, s_count):
    """The half-bit sums S_j = Σσ_i·r_i and C_j = Σσ_i of the reply from sample ``i0``
    (:func:`rfsim.gen2._linecode_kernels.signed_halfbit_sums_kernel` over the span
    ``i0 … i0 + n_decode + 1``): the samples before ``b1`` one by one from ``r`` (the input less
    the DC, the noise added), then per piece of its half-bit (:data:`PM_HALF`) Σσ_i·u_i + P_p
    and Σσ_i (the spread piece reads σ_i²·P_p/|p| per sample: P_p in all)."""
    end = min(b1, i0 + n_decode + 2, r.size)
    signed_halfbit_sums_kernel(r[i0:max(end, i0)], frac, ratio, m, s_sum, s_count)
    for p in range(sums.size):
        j = int(pm_mom[PM_HALF, p])
        if 0 <= j < s_sum.size:
            s_sum[j] += mom[0, p] + sums[p]
            s_count[j] += pm_mom[PM_CSIG, p]


@njit
def _known_fit_pieces(r, full, known, mk, ss, s1, kind, anchor, mom, sums, sizes):
    """Step 3's least-squares (h, c) of r ≈ h·level + c on the samples of known level (the
    2×2 normal equations of :func:`rfsim.gen2.capture.fit_gain_offset`): those before ``b1``
    one by one from ``r`` (the first ``mk`` of ``known``: their indices in row 0, levels in
    row 1, of :func:`rfsim.gen2._measure_kernels.known_indices_kernel` on ``full``, the
    reference; ``ss``, ``s1`` their Σlevel², Σlevel), after it the pieces outside the reply
    (level −1): a REST piece whole (Σ r_i = Σu_i + P_p), a single sample (u_i + σ_i·P_p) where
    its neighbours carry its level. Returns (h, c, False) when the levels are constant (no
    fit)."""
    n = full.size
    rs = r1 = 0j
    for i in range(mk):
        v = r[int(known[0, i])]
        rs += v * known[1, i]
        r1 += v
    cnt = float(mk)
    for p in range(sums.size):
        a = int(anchor[p])  # a single piece's sample
        if kind[p] == REST:
            v = mom[1, p] + sums[p]
            cnt += sizes[p]
            ss += sizes[p]
            s1 -= sizes[p]
            rs -= v
            r1 += v
        elif kind[p] == SINGLE and a >= 1 and a < n - 1 and full[a] == 0.0:
            if _level(full, a - 1) == -1.0 and _level(full, a + 1) == -1.0:
                v = mom[1, p] + sums[p]
                cnt += 1.0
                ss += 1.0
                s1 -= 1.0
                rs -= v
                r1 += v
    det = ss * cnt - s1 * s1
    if abs(det) <= 1e-12 * max(ss * cnt, 1e-300):
        return 0j, 0j, False
    return (cnt * rs - s1 * r1) / det, (ss * r1 - s1 * rs) / det, True


@njit
def _measure_plan(s, i0, b1, piece_of, sign, sizes, cut_piece, n_blocks, fs, mu, ms, mb):
    """The measurement's plan of the reference ``s`` (the span from sample ``i0``; the samples
    and blocks of :func:`rfsim.gen2._measure_kernels.measure_kernel`): per block its samples
    and the sum of their times; the samples read one by one (before ``b1`` or in a piece cut by
    a block edge, ``cut_piece``) with their block in ``ms``; per piece after ``b1`` read whole
    its block and level L_p (s_i = L_p·σ_i) in ``mu``, −1 for the others. ``mb[MB_EXACT]`` is 0
    when a piece is read in part or with two levels or blocks (then the caller measures on the
    samples)."""
    mu[0, :sizes.size] = -1.0
    mb[:] = 0.0
    mb[MB_EXACT] = 1.0
    n = s.size
    first = 0
    while first < n and s[first] == 0.0:
        first += 1
    if first == n:
        return
    end = n
    while s[end - 1] == 0.0:
        end -= 1
    centre = 0.5 * (first + end - 1)
    mb[MB_CENTRE], mb[MB_FIRST], mb[MB_END] = centre, first, end
    m = 0
    for i in range(first + 1, end - 1):
        m += (s[i] == s[i - 1]) & (s[i] == s[i + 1])
    mb[MB_M] = m
    for c in range(cut_piece.size):
        mu[0, cut_piece[c]] = -2.0
    seen = np.zeros(sizes.size)
    n_ms = 0
    k = 0
    edge = m // n_blocks if n_blocks > 1 else m + 1  # the first used sample of block k + 1
    o = 0
    rr = ts = 0.0  # block k's samples and Σt so far
    run_p = -1  # the piece of the current run of used samples (read whole) and its count
    run_n = 0.0
    run_level = 0.0
    for i in range(first + 1, end - 1):
        if not ((s[i] == s[i - 1]) & (s[i] == s[i + 1])):
            continue
        if o >= edge and k + 1 < n_blocks:
            while k + 1 < n_blocks and o >= (k + 1) * m // n_blocks:
                mb[MB_RR + k] += rr
                mb[MB_RR + n_blocks + k] += ts
                rr = ts = 0.0
                k += 1
            edge = (k + 1) * m // n_blocks if k + 1 < n_blocks else m + 1
            if run_p >= 0:
                _plan_run(run_p, run_n, run_level, k - 1, seen, mu, mb)
                run_p = -1
        o += 1
        rr += 1.0
        ts += (i - centre) / fs
        a = i0 + i
        p = piece_of[a - b1] if a >= b1 else -1
        if p < 0 or mu[0, p] == -2.0:
            ms[0, n_ms] = a
            ms[1, n_ms] = k
            n_ms += 1
            continue
        level = s[i] * sign[a - b1]
        if p != run_p or level != run_level:
            if run_p >= 0:
                _plan_run(run_p, run_n, run_level, k, seen, mu, mb)
            run_p = p
            run_n = 0.0
            run_level = level
        run_n += 1.0
    if run_p >= 0:
        _plan_run(run_p, run_n, run_level, k, seen, mu, mb)
    mb[MB_RR + k] += rr
    mb[MB_RR + n_blocks + k] += ts
    mb[MB_N_MS] = n_ms
    for p in range(sizes.size):
        if seen[p] > 0.0 and seen[p] != sizes[p]:
            mb[MB_EXACT] = 0.0
    for c in range(cut_piece.size):
        for d in range(c):
            if cut_piece[d] == cut_piece[c]:
                mb[MB_EXACT] = 0.0


#: Largest index step the phasor walk of :func:`_phasor_at` takes from its table.
PHASOR_STEPS = 64


@njit
def _phasor_table(w):
    """e^{j·w·g} for g = 0 … :data:`PHASOR_STEPS` (``w`` [rad per sample]), by the recurrence
    e^{j·w·(g + 1)} = e^{j·w·g}·e^{j·w}."""
    table = np.empty(PHASOR_STEPS + 1, np.complex128)
    step = complex(math.cos(w), math.sin(w))
    table[0] = 1.0
    for g in range(1, PHASOR_STEPS + 1):
        table[g] = table[g - 1] * step
    return table


@njit
def _phasor_at(i, last, rot, walked, slope, fs, centre, table):
    """e^{j·a_i}, a_i = slope·(i − centre)/fs (the rotation of
    :func:`rfsim.gen2._measure_kernels.measure_kernel` at span index ``i``), and the steps walked
    since the last exact value: from ``rot`` = e^{j·a} at the last index ``last`` (``walked``
    steps since an exact value) by a step of the table (:func:`_phasor_table`,
    |step| ≤ :data:`PHASOR_STEPS`), exactly (cos, sin) when the step is longer or after
    :data:`PHASOR_STEPS` steps (drift < 1e−13). The walk's state is the caller's scalars (a
    state array would cost a store and a load per step on the walk's chain)."""
    g = i - last
    if -PHASOR_STEPS <= g <= PHASOR_STEPS and walked < PHASOR_STEPS:
        t = table[g] if g >= 0 else table[-g].conjugate()
        return rot * t, walked + 1
    a = slope * ((i - centre) / fs)
    return complex(math.cos(a), math.sin(a)), 0


@njit
def _plan_run(p, count, level, k, seen, mu, mb):
    """A run of ``count`` used samples of piece ``p`` in block ``k`` at ``level`` into the plan
    of :func:`_measure_plan` (``mb[MB_EXACT]`` cleared when the piece was seen in another block
    or at another level)."""
    if seen[p] == 0.0:
        mu[0, p] = k
        mu[1, p] = level
    elif mu[0, p] != k or mu[1, p] != level:
        mb[MB_EXACT] = 0.0
    seen[p] += count


@njit
def _measure_pieces(r, full, c, mom, energy, sums, sizes, pm_mom, mu, ms, mb, i0, fs, n_blocks):
    """Step 5 on the plan of :func:`_measure_plan`: the gain, Doppler slope and residual power
    of :func:`rfsim.gen2._measure_kernels.measure_kernel` on z = r − ``c`` (``r`` the input less
    the DC with the noise; ``c`` the offset of the fit), the samples of ``ms`` from ``r`` and
    ``full`` one by one, every piece p read whole from its sums (u = x − DC, P_p the noise):

    * block sums: L_p·(Σσu − c·Σσ + P_p);
    * gain with the rotation removed: L_p·e^{−jω'a_p}·(Σσu·e^{−jω'δ} − c·Σσe^{−jω'δ} +
      (P_p/|p|)·Σe^{−jω'δ}), ω' = slope/fs, e^{−jω'δ} to second order (1 − jω'δ − ω'²δ²/2; the
      error of a term (ω'δ)³/6 relative, |δ| ≤ half a half-bit);
    * residual: Σ|z|² − |h|²·m over the m samples read (the least-squares identity) with
      Σ_p|z|² = Σ|u|² − 2·Re(c̄·Σu) + |p|·|c|² + 2·Re(conj(P_p/|p|)·(Σσu − c·Σσ)) + |P_p|²/|p|.

    Returns ``(h, slope [rad/s], σ²)`` as the measurement kernel."""
    m = int(mb[MB_M])
    if m == 0:
        return complex(math.nan, math.nan), 0.0, math.nan
    g = np.zeros(n_blocks, np.complex128)
    tc = np.empty(n_blocks)
    y = np.empty(n_blocks)
    for e in range(int(mb[MB_N_MS])):
        a = ms[0, e]
        g[ms[1, e]] += (r[a] - c) * full[a]
    n_p = sums.size
    for p in range(n_p):
        k = int(mu[0, p])
        if k >= 0:
            g[k] += mu[1, p] * (mom[0, p] - c * pm_mom[PM_CSIG, p] + sums[p])
    all_positive = True
    for k in range(n_blocks):
        rr = mb[MB_RR + k]
        g[k] = g[k] / rr if rr > 0.0 else complex(math.nan, math.nan)
        tc[k] = mb[MB_RR + n_blocks + k] / rr if rr > 0.0 else math.nan
        w = g[k].real * g[k].real + g[k].imag * g[k].imag
        if not w > 0.0:
            all_positive = False
    slope = block_slope(g, tc, y) if all_positive else 0.0
    centre = mb[MB_CENTRE]
    table = _phasor_table(slope / fs)
    last = -(1 << 40)  # the phasor walk (_phasor_at): last index, its rotation, steps since an exact value
    rot = 1 + 0j
    walked = 0
    acc = 0j
    zz = 0.0
    for e in range(int(mb[MB_N_MS])):
        a = ms[0, e]
        rot, walked = _phasor_at(a - i0, last, rot, walked, slope, fs, centre, table)
        last = a - i0
        z = r[a] - c
        sv = full[a]
        acc += z * complex(rot.real * sv, -rot.imag * sv)
        zz += z.real * z.real + z.imag * z.imag
    last = -(1 << 40)
    w1 = slope / fs
    w2 = 0.5 * w1 * w1
    for p in range(n_p):
        if mu[0, p] < 0.0:
            continue
        i = int(pm_mom[PM_ANCHOR, p]) - i0
        rot, walked = _phasor_at(i, last, rot, walked, slope, fs, centre, table)
        last = i
        size = sizes[p]
        mean = sums[p] / size
        term = (mom[0, p] - 1j * w1 * mom[2, p] - w2 * mom[3, p]
                - c * complex(pm_mom[PM_CSIG, p] - w2 * pm_mom[PM_SD2, p], -w1 * pm_mom[PM_SD1, p])
                + mean * complex(size - w2 * pm_mom[PM_D2, p], -w1 * pm_mom[PM_D1, p]))
        acc += mu[1, p] * complex(rot.real, -rot.imag) * term
        a_c = mom[0, p] - c * pm_mom[PM_CSIG, p]
        zz += (energy[p] - 2.0 * (c.real * mom[1, p].real + c.imag * mom[1, p].imag)
               + size * (c.real * c.real + c.imag * c.imag)
               + 2.0 * (mean.real * a_c.real + mean.imag * a_c.imag)
               + (sums[p].real * sums[p].real + sums[p].imag * sums[p].imag) / size)
    h = acc / m
    resid = (zz - (h.real * h.real + h.imag * h.imag) * m) / m
    return h, slope, max(resid, 0.0)

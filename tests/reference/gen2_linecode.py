"""Reference twins of :mod:`rfsim.gen2.linecode`: the encoder, waveform and decoder steps in plain
NumPy/Python (the obviously right, slow formulations of the numba kernels)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.gen2._linecode_kernels import INDEX_EPS
from rfsim.gen2.bits import as_bits
from rfsim.gen2.linecode import (_REFINE_SHIFTS, ReplyDetection, _check_m, _check_rates, _plan, _refine_bank, _template,
                                 corr_abs_reference, halfbit_levels)


def _state_index(cur: int, prev: int, miller: bool) -> int:
    """Trellis state of a level and a previous bit: ``level index (0 for +1) + 2·prev`` (Miller)."""
    return (0 if cur == 1 else 1) + (2 * int(prev) if miller else 0)


def _elements(levels: np.ndarray, m: int) -> np.ndarray:
    """Each half-bit level repeated M times, every odd element inverted for Miller (subcarrier)."""
    if m == 1:
        return np.asarray(levels, dtype=np.int8)
    el = np.repeat(levels, m)
    el[1::2] *= -1
    return el


def fm0_levels_reference(bits, cur: int) -> tuple[np.ndarray, int]:
    """Plain-Python twin of the FM0 level kernel: ``(levels (2n,) int8, last level)``."""
    out = []
    for b in as_bits(bits):
        first = -cur
        second = first if b == 1 else -first
        out += [first, second]
        cur = second
    return np.array(out, dtype=np.int8), cur


def miller_levels_reference(bits, cur: int, prev: int) -> tuple[np.ndarray, int, int]:
    """Plain-Python twin of the Miller level kernel: ``(levels, last level, last bit)``."""
    out = []
    for b in as_bits(bits):
        first = -cur if (b == 0 and prev == 0) else cur
        second = -first if b == 1 else first
        out += [first, second]
        cur, prev = second, int(b)
    return np.array(out, dtype=np.int8), cur, prev


def halfsymbols_reference(bits, *, m: int, trext: bool, dummy: bool = True) -> np.ndarray:
    """Plain-NumPy twin of :func:`rfsim.gen2.linecode.halfsymbols` (half-bit levels, repeated M times, subcarrier
    sign on the odd elements)."""
    m = _check_m(m)
    levels, _ = halfbit_levels(bits, m=m, trext=trext, dummy=dummy)
    return _elements(levels, m)


def reply_waveform_reference(
    bits, *, m: int, trext: bool, blf_hz: float, fs_hz: float, t0_s: float = 0.0,
    dummy: bool = True, n_samples: int | None = None,
) -> np.ndarray:
    """Plain-NumPy twin of :func:`rfsim.gen2.linecode.reply_waveform`."""
    el = halfsymbols_reference(bits, m=m, trext=trext, dummy=dummy).astype(np.float64)
    r = _check_rates(blf_hz, fs_hz)
    t0 = float(t0_s) * float(fs_hz)
    if n_samples is None:
        n_samples = int(math.ceil(t0 + el.size / r))
    u = (np.arange(int(n_samples)) - t0) * r
    k = np.floor(u + INDEX_EPS).astype(np.int64)
    ok = (u >= 0) & (k < el.size)
    out = np.zeros(int(n_samples))
    out[ok] = el[k[ok]]
    return out


def halfbit_sums_reference(y, start, elements_per_sample, m, n_halfbits) -> np.ndarray:
    """Plain-NumPy twin of the half-bit matched-filter kernel."""
    n, h, ok, sign = _halfbit_samples(y.size, start, elements_per_sample, m, n_halfbits)
    return np.bincount(h[ok], weights=(y[n] * sign)[ok], minlength=n_halfbits)[:n_halfbits]


def _halfbit_samples(size, start, elements_per_sample, m, n_halfbits):
    """The samples n ≥ ⌈start⌉ of a reply from ``start``, their half-bit h = k // m (k the
    element), whether they lie in the first ``n_halfbits`` half-bits, and their subcarrier sign."""
    n = np.arange(max(0, int(math.ceil(start))), size)
    u = (n - start) * elements_per_sample
    k = np.floor(u + INDEX_EPS).astype(np.int64)
    h = k // m
    ok = (u >= 0) & (h < n_halfbits)
    sign = np.where((m > 1) & (k % 2 == 1), -1.0, 1.0)
    return n, h, ok, sign


def signed_halfbit_sums_reference(part, start, elements_per_sample, m, n_halfbits) -> tuple[np.ndarray, np.ndarray]:
    """Plain-NumPy twin of the signed half-bit sums kernel: per half-bit, S = Σ σ·part (complex)
    and C = Σ σ, σ the subcarrier sign of the sample's element (the samples of
    :func:`halfbit_sums_reference`); ``numpy.bincount`` adds its weights in sample order."""
    n, h, ok, sign = _halfbit_samples(part.size, start, elements_per_sample, m, n_halfbits)
    z = part[n]
    s_re = np.bincount(h[ok], weights=(z.real * sign)[ok], minlength=n_halfbits)[:n_halfbits]
    s_im = np.bincount(h[ok], weights=(z.imag * sign)[ok], minlength=n_halfbits)[:n_halfbits]
    c = np.bincount(h[ok], weights=sign[ok], minlength=n_halfbits)[:n_halfbits]
    return s_re + 1j * s_im, c


def bitwise_reference(a, b, miller: bool) -> np.ndarray:
    """Plain-NumPy twin of the bit-by-bit decision kernel."""
    s, d = np.abs(a + b), np.abs(a - b)
    return ((d > s) if miller else (s > d)).astype(np.uint8)


def _branch_reference(state: int, bit: int, miller: bool) -> tuple[int, int, int]:
    cur, prev = (1 if state % 2 == 0 else -1), state // 2
    if miller:
        first = -cur if (bit == 0 and prev == 0) else cur
        second = -first if bit else first
    else:
        first = -cur
        second = first if bit else -first
    return first, second, _state_index(second, bit, miller)


def viterbi_reference(a, b, miller: bool, state0: int, last_is_one: bool) -> np.ndarray:
    """Plain-Python twin of the Viterbi kernel (same trellis, same tie-breaking)."""
    n = len(a)
    metric = [-math.inf] * 4
    metric[state0] = 0.0
    back = []
    for i in range(n):
        new = [-math.inf] * 4
        bp = [(0, 0)] * 4
        for s in range(4):
            if metric[s] == -math.inf:
                continue
            for bit in (0, 1):
                if last_is_one and i == n - 1 and bit == 0:
                    continue
                e1, e2, t = _branch_reference(s, bit, miller)
                v = metric[s] + e1 * a[i] + e2 * b[i]
                if v > new[t]:
                    new[t], bp[t] = v, (s, bit)
        metric = new
        back.append(bp)
    best = max(range(4), key=lambda s: (metric[s], -s))
    out = np.empty(n, dtype=np.uint8)
    for i in range(n - 1, -1, -1):
        best, out[i] = back[i][best][0], back[i][best][1]
    return out


def projected_halfbit_sums_reference(part, g, dc_g, start, r, m, nh) -> np.ndarray:
    """Plain-NumPy twin of the projecting half-bit sums: ``y = Re(part·g) − dc_g`` (as
    ``Re part·Re g − Im part·Im g − dc_g``), then :func:`halfbit_sums_reference`."""
    y = np.ascontiguousarray(part.real * g.real - part.imag * g.imag - dc_g)
    return halfbit_sums_reference(y, start, r, m, nh)


def refine_reference(r, cands, shifts, templates, norms) -> tuple[float, float]:
    """Plain-NumPy twin of the sub-sample peak refinement kernel: ``(best, start)``."""
    best, start = -1.0, math.nan
    n_pre = templates.shape[1]
    for cand in np.asarray(cands).tolist():
        seg = r[cand: cand + n_pre]
        for d, t0, norm in zip(np.asarray(shifts).tolist(), templates, norms):
            if cand + d < 0:
                continue
            v = abs(complex(seg @ t0)) / norm
            if v > best:
                best, start = v, cand + d
    return best, start


def peak_candidates_reference(c, half_width: int, n_max: int = 5) -> tuple[int, np.ndarray]:
    """Plain-NumPy twin of the candidate kernel: ``(argmax c, the n_max largest local maxima
    of c within ±half_width of it, descending; equal values in lag order)``."""
    lag = int(np.argmax(c))
    lo, hi = max(0, lag - half_width), min(c.size, lag + half_width + 1)
    win = c[lo:hi]
    is_max = np.ones(win.size, dtype=bool)
    is_max[1:] &= win[1:] >= win[:-1]
    is_max[:-1] &= win[:-1] >= win[1:]
    return lag, lo + np.flatnonzero(is_max)[np.argsort(-win[is_max], kind="stable")[:n_max]]


def decode_reply_reference(r, **kwargs) -> ReplyDetection:
    """Plain NumPy/Python twin of :func:`rfsim.gen2.linecode.decode_reply` (same keyword arguments)."""
    args = [kwargs.pop(k, d) for k, d in (("n_bits", None), ("m", None), ("trext", None), ("blf_hz", None),
                                            ("fs_hz", None), ("method", "viterbi"), ("search_samples", None),
                                            ("start_sample", None), ("gain", None))]
    if kwargs:
        raise TypeError(f"unexpected arguments {sorted(kwargs)}")
    n_bits, m, trext, blf_hz, fs_hz, method, search_samples, start_sample, gain = args
    plan = _plan(n_bits, m, trext, blf_hz, fs_hz, method)
    r = np.ascontiguousarray(r, dtype=np.complex128)
    m, ratio, n_reply, n_pre = plan.m, plan.ratio, plan.n_reply, plan.n_pre
    if start_sample is None:
        last = r.size - n_reply if search_samples is None else min(r.size - n_reply, int(search_samples))
        if last < 0:
            raise ValueError(f"input of {r.size} samples is shorter than the reply ({n_reply} samples)")
        t0, w = _template(m, plan.trext, ratio, 0.0)[1], int(math.ceil(m / ratio)) + 1
        lag, cands = peak_candidates_reference(corr_abs_reference(r[: last + n_pre], t0), w)
        best, start = refine_reference(r, cands, _REFINE_SHIFTS, *_refine_bank(m, plan.trext, ratio))
        if best < 0:
            start = float(lag)
    else:
        start = float(start_sample)
        if not 0 <= start <= r.size - n_reply:
            raise ValueError(f"start_sample {start_sample} leaves no room for the reply ({n_reply} samples)")
    lag = int(math.floor(start))
    tpl, tpl0, tpl_mean, e_t = _template(m, plan.trext, ratio, start - lag)
    seg = r[lag: lag + n_pre]
    peak = complex(seg @ tpl0)
    seg0 = seg - seg.mean()
    corr = float(abs(peak) / math.sqrt(e_t * max(float(np.vdot(seg0, seg0).real), 1e-300)))
    if gain is None:
        h = peak / e_t
        dc = seg.mean() - h * tpl_mean
    else:
        h, dc = complex(gain), 0.0
    if h == 0:
        raise ValueError("zero channel gain: no reply to decode")
    g = 1.0 / h
    part = r[lag: lag + int(math.ceil(plan.nh * m / ratio)) + 2]
    sums = projected_halfbit_sums_reference(part, g, (dc * g).real, start - lag, ratio, m, plan.nh)
    data = sums[plan.nh - 2 * (n_bits + 1):]
    a, b = np.ascontiguousarray(data[0::2]), np.ascontiguousarray(data[1::2])
    if method == "bitwise":
        bits = bitwise_reference(a[:n_bits], b[:n_bits], m > 1)
    else:
        bits = viterbi_reference(a, b, m > 1, plan.state, True)[:n_bits]
    return ReplyDetection(bits=bits, start_sample=start, gain=complex(h), dc=complex(dc), corr=corr)


__all__ = ["fm0_levels_reference", "miller_levels_reference", "halfsymbols_reference", "reply_waveform_reference",
           "halfbit_sums_reference", "bitwise_reference", "viterbi_reference", "projected_halfbit_sums_reference",
           "refine_reference", "peak_candidates_reference", "corr_abs_reference", "decode_reply_reference"]

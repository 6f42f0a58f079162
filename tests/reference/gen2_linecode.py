"""Reference twins of :mod:`rfsim.gen2.linecode`: the encoder, waveform and decoder steps in plain
NumPy/Python (the obviously right, slow formulations of the numba kernels)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.gen2._linecode_kernels import INDEX_EPS
from rfsim.gen2.bits import as_bits
from rfsim.gen2.linecode import ReplyDetection, _check_m, _check_rates, _decode, corr_abs_reference, halfbit_levels


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
    n = np.arange(max(0, int(math.ceil(start))), y.size)
    u = (n - start) * elements_per_sample
    k = np.floor(u + INDEX_EPS).astype(np.int64)
    h = k // m
    ok = (u >= 0) & (h < n_halfbits)
    sign = np.where((m > 1) & (k % 2 == 1), -1.0, 1.0)
    return np.bincount(h[ok], weights=(y[n] * sign)[ok], minlength=n_halfbits)[:n_halfbits]


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


_REFERENCES = (projected_halfbit_sums_reference, bitwise_reference, viterbi_reference, refine_reference,
               corr_abs_reference, peak_candidates_reference)


def decode_reply_reference(r, **kwargs) -> ReplyDetection:
    """Plain NumPy/Python twin of :func:`rfsim.gen2.linecode.decode_reply` (same keyword arguments)."""
    args = [kwargs.pop(k, d) for k, d in (("n_bits", None), ("m", None), ("trext", None), ("blf_hz", None),
                                            ("fs_hz", None), ("method", "viterbi"), ("search_samples", None),
                                            ("start_sample", None), ("gain", None))]
    if kwargs:
        raise TypeError(f"unexpected arguments {sorted(kwargs)}")
    return _decode(r, *args, _REFERENCES)


__all__ = ["fm0_levels_reference", "miller_levels_reference", "halfsymbols_reference", "reply_waveform_reference",
           "halfbit_sums_reference", "bitwise_reference", "viterbi_reference", "projected_halfbit_sums_reference",
           "refine_reference", "peak_candidates_reference", "corr_abs_reference", "decode_reply_reference"]

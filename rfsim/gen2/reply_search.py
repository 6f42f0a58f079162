"""Steps 1–2 of the capture reply decoder (:mod:`rfsim.gen2.replies`): the link hypotheses,
the working rate and the detection of a reply by its preamble.

A window after a command is averaged over boxcars of D samples
(:func:`boxcar_decimate`, D from :data:`SAMPLES_PER_ELEMENT` at the highest BLF of each
BLF octave, :func:`_bands`); every link hypothesis (:class:`LinkHypothesis`: M, TRext and a
BLF range on a geometric grid of relative step 1/(2·preamble elements)) is correlated with
its zero-mean pilot + preamble at every T1 lag (:class:`_Lags`); the largest normalised
correlation is kept when it clears the threshold of
:func:`rfsim.gen2.capture.preamble_threshold` over all lags and hypotheses tested
(:func:`_detect`, with the narrow search around an earlier reply's BLF first).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.gen2.capture import preamble_threshold
from rfsim.core.memo import PureCache
from rfsim.gen2.linecode import halfsymbols
from rfsim.gen2.reply_core import (FINE_SPAN_STEPS, coarse_blf_step, geometric_blf_grid_hz, n_pre_elements, n_reply_elements,
                                   preamble_template0)
from rfsim.core.lazy import lazy_import

_rsk = lazy_import("rfsim.gen2._reply_search_kernels")

#: Samples per element (half subcarrier cycle) at the working rate, at the highest BLF searched.
SAMPLES_PER_ELEMENT = 6
#: Fewest samples per element a BLF hypothesis needs (above it the reply is not resolved).
MIN_SAMPLES_PER_ELEMENT = 2.0


@dataclass(frozen=True)
class LinkHypothesis:
    """Line code and BLF range [Hz] searched for a reply."""

    m: int
    trext: bool
    blf_lo_hz: float
    blf_hi_hz: float


def _kept(tables: dict | None, table: str, key, make):
    """``make()``, kept in ``tables[table][key]`` when ``tables`` is given (the decode plan's
    memo, :class:`rfsim.gen2.reply_decoder.DecodePlan`: the same hypotheses are searched after
    every command of a capture); bounded, cleared when full."""
    if tables is None:
        return make()
    entries = tables.setdefault(table, {})
    hit = entries.get(key)
    if hit is None:
        if len(entries) >= _KEPT_MAX:
            entries.clear()
        hit = entries[key] = make()
    return hit


#: Entries of each table :func:`_kept` keeps.
_KEPT_MAX = 256


def _make_grid(lo: float, hi: float, step: float) -> np.ndarray:
    grid = geometric_blf_grid_hz(lo, hi, step)
    grid.flags.writeable = False
    return grid


def _geometric_grid(lo: float, hi: float, step: float, tables: dict | None = None) -> np.ndarray:
    """BLFs lo … hi on a geometric grid of relative step ≤ ``step`` (read-only; kept in
    ``tables``, :func:`_kept`)."""
    key = (float(lo), float(hi), float(step))
    return _kept(tables, "grids", key, lambda: _make_grid(*key))


def _geomspace(lo: float, hi: float, n: int) -> np.ndarray:
    """``n`` ≥ 2 values from ``lo`` to ``hi`` (both exact) in equal ratios, lo·(hi/lo)^(k/(n−1))
    (:func:`numpy.geomspace` without its overhead: this runs after every command)."""
    out = lo * np.exp(np.arange(n) * (math.log(hi / lo) / (n - 1)))
    out[0], out[-1] = lo, hi
    return out


def boxcar_decimate(r: np.ndarray, d: int) -> np.ndarray:
    """Means of consecutive blocks of ``d`` samples.

    Sample j of the result is at input position j·d + (d − 1)/2.

    Parameters
    ----------
    r : numpy.ndarray
        ``(n,)`` samples (real or complex, any unit).
    d : int
        Block length [samples]; 1 returns a copy.

    Returns
    -------
    numpy.ndarray
        ``(n // d,)`` block means, same unit as ``r``.
    """
    n = r.size // d
    return r[: n * d].reshape(n, d).mean(axis=1) if d > 1 else r.copy()


def preamble_correlation(r: np.ndarray, template0: np.ndarray) -> np.ndarray:
    """Zero-mean normalised correlation of ``r`` with a zero-mean real template at every valid lag.

    ρ[k] = |Σᵢ r[k+i]·t0[i]| / (‖t0‖·‖r[k:k+L] − mean‖), the statistic of
    :func:`rfsim.gen2.linecode.decode_reply` and of the detection threshold; sliding sums by
    cumulative sums.

    Parameters
    ----------
    r : numpy.ndarray
        ``(n,)`` samples, real or complex, any unit.
    template0 : numpy.ndarray
        ``(L,) float64`` zero-mean template.

    Returns
    -------
    numpy.ndarray
        ``(n − L + 1,) float64`` correlation in [0, 1].
    """
    from scipy.signal import correlate  # imported when first used: scipy.signal costs ≈ 1 s to import

    n = template0.size
    c = np.abs(correlate(r, template0, mode="valid"))
    p = np.concatenate([[0.0], np.cumsum(np.abs(r) ** 2)])
    q = np.concatenate([[0.0], np.cumsum(r)])
    energy = (p[n:] - p[:-n]) - np.abs(q[n:] - q[:-n]) ** 2 / n
    return c / (math.sqrt(float(template0 @ template0)) * np.sqrt(np.maximum(energy, 1e-300)))


def _preamble_template(m: int, trext: bool, blf: float, fs: float) -> np.ndarray:
    """Zero-mean samples fully inside pilot + preamble (rfsim.gen2.linecode sampling), the
    capture decoder's count ⌊n_pre·fs/(2·BLF)⌋ (:mod:`rfsim.gen2.reply_core`)."""
    return preamble_template0(m, trext, blf, fs, int(math.floor(n_pre_elements(m, trext) * fs / (2.0 * blf))))


def _make_preamble_elements(m: int, trext: bool) -> np.ndarray:
    """Pilot + preamble elements (±1, float64, read-only) of a line code."""
    el = halfsymbols(np.zeros(0, np.uint8), m=m, trext=trext, dummy=False).astype(np.float64)
    el.flags.writeable = False
    return el


#: Pilot + preamble elements (±1, float64) per line code: a constant table.
_preamble_elements = PureCache(_make_preamble_elements, 8)


def _per_blf(f, blfs: np.ndarray) -> np.ndarray:
    """``f`` (a lag bound of a BLF, given one BLF or an array of them) at every BLF of ``blfs``."""
    v = f(blfs)
    if isinstance(v, np.ndarray) and v.shape == blfs.shape:
        return v.astype(np.int64, copy=False)
    return np.broadcast_to(np.asarray(v), blfs.shape).astype(np.int64)


def _search(r, fs, hyps, lo_of, hi_of, tables=None):
    """Step 2 on one working-rate window: ``(best, n_tests)`` with best = (corr, blf,
    hypothesis, start, coarse step, preamble samples) of the largest preamble correlation
    over the hypotheses and T1 lags (None if no lag fits; the start refined between lags by
    a parabola through the peak) and the number of lags tested (numba kernel
    ``preamble_search_kernel``, one call per hypothesis; the tests hold it to a NumPy twin)."""
    best, n_tests = None, 0
    r = np.ascontiguousarray(r, dtype=np.complex128)
    for hyp in hyps:
        step_c = coarse_blf_step(hyp.m, hyp.trext)
        blfs = _geometric_grid(hyp.blf_lo_hz, hyp.blf_hi_hz, step_c, tables)
        lo, hi = _per_blf(lo_of, blfs), _per_blf(hi_of, blfs)
        n_rep = (np.ceil(n_reply_elements(0, hyp.m, hyp.trext) * fs / (2.0 * blfs)) + 2).astype(np.int64)
        pre_el = _preamble_elements(hyp.m, hyp.trext)
        # no lag after hi leaves room for the preamble: the samples after it are not passed
        cut = max(0, min(r.size, int(np.max(hi + n_rep)) + 1))
        c, j, pos, nt, n_t = _rsk.preamble_search_kernel(r[:cut], pre_el, blfs, float(fs), lo, hi, n_rep,
                                                        MIN_SAMPLES_PER_ELEMENT, np.empty(blfs.size))
        n_tests += nt
        if j >= 0 and (best is None or c > best[0]):
            best = (float(c), float(blfs[j]), hyp, float(pos), step_c, int(n_t))
    return best, n_tests


def _bands(hyps, tables: dict | None = None) -> list[list[LinkHypothesis]]:
    """Hypotheses split into BLF octaves (each gets its own working rate; kept in ``tables``,
    :func:`_kept`)."""
    key = tuple(hyps)
    return _kept(tables, "bands", key, lambda: _make_bands(key))


def _make_bands(hyps: tuple) -> list[list[LinkHypothesis]]:
    out = []
    for h in hyps:
        edges = _geomspace(h.blf_lo_hz, h.blf_hi_hz, max(2, int(math.ceil(math.log2(h.blf_hi_hz / h.blf_lo_hz))) + 1))
        for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
            while len(out) <= k:
                out.append([])
            out[k].append(LinkHypothesis(h.m, h.trext, float(a), float(b)))
    return out


@dataclass(frozen=True)
class _Lags:
    """T1 window of a BLF as lags into a window decimated by ``d`` (sample j at input sample
    i0 + j·d + (d − 1)/2), its end moved ``delay_max_s`` later for a delayed reply (T5 =
    T1 min … T1 max + delay), and kept inside ``span_s`` = (earliest, latest) start after the
    command's last rising edge [s] when given (:func:`modulation_onsets`)."""

    fs: float
    d: int
    i0: int
    cmd_end_s: float
    rtcal_s: float
    frt: float
    delay_max_s: float = 0.0
    span_s: tuple | None = None

    def _lag(self, t_s):
        return ((self.cmd_end_s + t_s) * self.fs - self.i0 - 0.5 * (self.d - 1)) / self.d

    def _nominal(self, blf):
        # T1 nominal max(RTcal, 10/BLF) of rfsim.gen2.link.t1_range, for one BLF or an array
        return np.maximum(self.rtcal_s, 10.0 / np.asarray(blf, dtype=np.float64))

    def lo(self, blf):
        """First lag of the T1 window (t1_range min, one sample early) of a BLF or array of BLFs."""
        t_s = self._nominal(blf) * (1 - self.frt) - 2e-6
        if self.span_s is not None:
            t_s = np.maximum(t_s, self.span_s[0])
        return np.maximum(0, np.floor(self._lag(t_s)).astype(np.int64) - 1)

    def hi(self, blf):
        """Last lag of the T1 window (t1_range max, one sample late; plus the delay of a delayed reply)."""
        t_s = self._nominal(blf) * (1 + self.frt) + 2e-6 + self.delay_max_s
        if self.span_s is not None:
            t_s = np.minimum(t_s, self.span_s[1])
        return np.ceil(self._lag(t_s)).astype(np.int64) + 1


def _search_bands(r, fs, hyps, i0, cmd_end_s, rtcal_s, frt, delay_max_s=0.0, span_s=None, tables=None):
    """Step 2 over every BLF octave of ``hyps`` (each at its own working rate): ``(best,
    n_tests)``, best = (:func:`_search` result, working-rate window, decimation) or None.
    With ``span_s`` only the starts inside it are searched, but every lag of the whole
    window is counted in ``n_tests`` (the span was chosen by looking at the data)."""
    best, n_tests = None, 0
    for band in _bands(hyps, tables):
        d = max(1, int(fs / (2.0 * max(h.blf_hi_hz for h in band) * SAMPLES_PER_ELEMENT)))
        lags = _Lags(fs, d, i0, cmd_end_s, rtcal_s, frt, delay_max_s, span_s)
        rd = boxcar_decimate(r, d) if d > 1 else r
        cand, nt = _search(rd, fs / d, band, lags.lo, lags.hi, tables)
        if span_s is not None:
            full = _Lags(fs, d, i0, cmd_end_s, rtcal_s, frt, delay_max_s)
            nt = sum(_n_lags(rd.size, fs / d, h, full.lo, full.hi, tables) for h in band)
        n_tests += nt
        if cand is not None and (best is None or cand[0] > best[0][0]):
            best = (cand, rd, d)
    return best, n_tests


def _n_lags(r_size, fs, hyp, lo_of, hi_of, tables=None) -> int:
    """Lags :func:`_search` tests for ``hyp`` on a working-rate window of ``r_size`` samples
    (the kernel's skip rules), without searching."""
    blfs = _geometric_grid(hyp.blf_lo_hz, hyp.blf_hi_hz, coarse_blf_step(hyp.m, hyp.trext), tables)
    lo, hi = _per_blf(lo_of, blfs), _per_blf(hi_of, blfs)
    n_rep = (np.ceil(n_reply_elements(0, hyp.m, hyp.trext) * fs / (2.0 * blfs)) + 2).astype(np.int64)
    n = np.floor(n_pre_elements(hyp.m, hyp.trext) * fs / (2.0 * blfs)).astype(np.int64)
    last = np.minimum(hi, r_size - n_rep)
    ok = (2.0 * blfs * MIN_SAMPLES_PER_ELEMENT <= fs) & (last >= lo) & (n >= 3)
    return int(np.sum((last - lo + 1)[ok]))


def _detect(r, fs, hyps, i0, cmd_end_s, rtcal_s, frt, blf_hint_hz, false_alarm_probability, delay_max_s=0.0,
            span_s=None, tables=None):
    """Step 2 with its threshold: ``(found, working-rate window, decimation)`` or None.

    With ``blf_hint_hz`` (the BLF of the reply before) and one hypothesis, the BLFs within
    ±2 coarse steps of the hint are searched first, at the working rate of the full search;
    their best is kept if it does not lie at an inner edge of the narrow range (a tag with
    another BLF) and clears the threshold of the narrow and the full search's tests together
    (the full search's lags counted, not searched), otherwise the full range is searched,
    with the same threshold: the union bound of the detection rule then covers both
    searches, so the false-alarm probability per window stays as stated. ``delay_max_s``
    extends the lags of a delayed reply beyond T1, ``span_s`` restricts the starts searched
    (:class:`_Lags`; the threshold still counts every lag of the window). ``tables``: where the
    BLF grids and octaves are kept (:func:`_kept`)."""
    if blf_hint_hz is not None and len(hyps) == 1 and hyps[0].blf_lo_hz <= blf_hint_hz <= hyps[0].blf_hi_hz:
        hyp = hyps[0]
        span = FINE_SPAN_STEPS * coarse_blf_step(hyp.m, hyp.trext)
        lo_n, hi_n = max(hyp.blf_lo_hz, blf_hint_hz * (1 - span)), min(hyp.blf_hi_hz, blf_hint_hz * (1 + span))
        n_full, n_narrow, narrow = 0, 0, None
        for band in _bands(hyps, tables):
            b = band[0]
            d = max(1, int(fs / (2.0 * b.blf_hi_hz * SAMPLES_PER_ELEMENT)))
            lags = _Lags(fs, d, i0, cmd_end_s, rtcal_s, frt, delay_max_s, span_s)
            full = _Lags(fs, d, i0, cmd_end_s, rtcal_s, frt, delay_max_s)
            n_full += _n_lags(r.size // d, fs / d, b, full.lo, full.hi, tables)
            a, z = max(b.blf_lo_hz, lo_n), min(b.blf_hi_hz, hi_n)
            if a < z:
                rd = boxcar_decimate(r, d) if d > 1 else r
                cand, nt = _search(rd, fs / d, [LinkHypothesis(hyp.m, hyp.trext, a, z)], lags.lo, lags.hi, tables)
                n_narrow += nt
                if cand is not None and (narrow is None or cand[0] > narrow[0][0]):
                    narrow = (cand, rd, d)
        if narrow is not None:
            blf = narrow[0][1]
            inner_edge = (blf <= lo_n and lo_n > hyp.blf_lo_hz) or (blf >= hi_n and hi_n < hyp.blf_hi_hz)
            if not inner_edge and narrow[0][0] >= preamble_threshold(narrow[0][5], n_full + n_narrow,
                                                                     false_alarm_probability):
                return narrow
    else:
        n_narrow = 0
    best, n_tests = _search_bands(r, fs, hyps, i0, cmd_end_s, rtcal_s, frt, delay_max_s, span_s, tables)
    n_tests += n_narrow
    if best is None or not best[0][0] >= preamble_threshold(best[0][5], n_tests, false_alarm_probability):
        return None
    return best


#: Onset search of a delayed reply (:func:`modulation_onsets`): fewest blocks a window needs
#: (shorter windows are searched whole), the quantile of the block variances taken as the
#: noise floor, the most onsets returned.
ONSET_MIN_BLOCKS = 16
ONSET_FLOOR_QUANTILE = 0.1
ONSET_MAX = 3
#: Rise above the floor that marks modulation, in standard deviations of a block variance.
ONSET_SIGMAS = 8.0


def modulation_onsets(r: np.ndarray, fs_hz: float, blf_lo_hz: float, first: int = 0) -> tuple[list[int] | None, int]:
    """Where a tag starts modulating in a long window: candidate reply starts of a delayed reply.

    The preamble search costs O(lags · BLFs · preamble elements); over a 20 ms delayed-reply
    window (T5) a blind search would take minutes. A backscatter reply raises the variance
    of the window (the tag switches between two levels at least once per subcarrier cycle,
    so a block of 4 elements at the lowest BLF, B = ⌈2·fs/BLF_lo⌉ samples, sees both). The
    window's blocks of B samples are compared with a noise floor, the
    :data:`ONSET_FLOOR_QUANTILE` quantile of their variances (at least that share of the
    window must be rest level): a block is modulated when its variance exceeds the floor by
    :data:`ONSET_SIGMAS` standard deviations of a block variance, floor·(1 + ONSET_SIGMAS·√(2/B))
    (a variance of B samples of white noise has relative standard deviation ≤ √(2/B)). The
    first block of each run of modulated blocks is an onset.

    Parameters
    ----------
    r : numpy.ndarray
        ``(n,)`` window (complex, or a real envelope), any unit, rest level removed or not.
    fs_hz : float
        Sample rate of ``r`` [Hz].
    blf_lo_hz : float
        Lowest BLF searched [Hz].
    first : int
        Blocks that start before this sample are not onsets (the rest before T1 min, where
        the command's last edge may still ring).

    Returns
    -------
    onsets : list of int or None
        Sample indices of the first :data:`ONSET_MAX` onsets (block starts; a reply starts
        within a block of one), ``[]`` when no block is modulated, None when the window
        is shorter than :data:`ONSET_MIN_BLOCKS` blocks (search it whole).
    block : int
        The block length B [samples].
    """
    b = max(8, int(math.ceil(2.0 * fs_hz / blf_lo_hz)))
    nb = r.size // b
    if nb < ONSET_MIN_BLOCKS:
        return None, b
    blocks = r[: nb * b].reshape(nb, b)
    dev = blocks - blocks.mean(axis=1, keepdims=True)
    var = np.mean(dev.real ** 2 + dev.imag ** 2, axis=1) if np.iscomplexobj(dev) else np.mean(dev ** 2, axis=1)
    floor = float(np.quantile(var, ONSET_FLOOR_QUANTILE))
    hot = var > floor * (1.0 + ONSET_SIGMAS * math.sqrt(2.0 / b))
    hot[: (max(0, int(first)) + b - 1) // b] = False
    starts = np.flatnonzero(hot & ~np.concatenate([[False], hot[:-1]]))
    return [int(k) * b for k in starts[:ONSET_MAX]], b


__all__ = ["SAMPLES_PER_ELEMENT", "MIN_SAMPLES_PER_ELEMENT", "ONSET_MIN_BLOCKS", "ONSET_FLOOR_QUANTILE",
           "ONSET_MAX", "ONSET_SIGMAS", "LinkHypothesis", "boxcar_decimate", "preamble_correlation",
           "geometric_blf_grid_hz", "modulation_onsets"]

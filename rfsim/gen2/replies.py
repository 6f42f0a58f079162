"""Tag replies in recorded captures: search, link estimation, timing tracking, decoding.

After every reader command that elicits an immediate reply (gen2-and-validation-anchors.md
§4.3–4.4: Query/QueryRep/QueryAdjust → RN16; ACK → PC + EPC + CRC-16; Req_RN → handle +
CRC-16; Read → header bit + words + handle + CRC-16) the reply is searched in the T1 window
after the command's last rising edge, T1 = max(RTcal, 10/BLF)·(1 ± FrT) ± 2 µs (§4.3). In
a monostatic capture the reply rides on the reader's CW leakage, a constant complex offset
c over the window; outside its reply the tag rests in its absorbing state, the reply's −1
level, so the window is ``r = c + h·s(t) + noise`` with s = ±1 the line code during the
reply and −1 around it. A magnitude-only capture |c + h·s| ≈ |c| + Re(h·c*/|c|)·s has the
same form with real h (|h| ≪ |c|). Steps per window:

1. **Working rate**: the window, with the mean of its samples before the earliest reply
   start removed, is averaged over boxcars of D samples, D = floor(fs/(2·BLF_max·6)) (≥ 6
   samples per element of half a subcarrier cycle at the highest BLF searched; sample j of
   the result is at (j·D + (D − 1)/2)/fs). Decoding needs no more, and pre-filtered,
   decimated captures are handled alike.
2. **Detection** (the simulated reader's rule, :func:`rfsim.gen2.capture.preamble_threshold`):
   maximum zero-mean normalised preamble correlation over the T1 lags of every link
   hypothesis (M, TRext, BLF on a geometric grid of relative step 1/(2·preamble
   elements)); the threshold γ makes P(false alarm) = ``false_alarm_probability`` per
   window on white noise, corr² ~ Beta(1, n − 2) with the union bound over all lags and
   hypotheses tested. With the line code known (a Query in the capture, or given) the BLF
   grid spans DR/TRcal·(1 ± FrT); without it, M ∈ {1, 2, 4, 8}, TRext ∈ {0, 1} and BLF
   over the Gen2 range 40–640 kHz widened by the largest FrT (22 %) are searched blind.
   After a reply, the next window is searched first within ±2 coarse steps of its BLF, and
   over the whole range when that finds nothing or its best lies at the narrow range's edge
   (another tag), the threshold counting both searches (:func:`_detect`).
3. **BLF from the reply itself**: BLFs across ±2 coarse steps are decoded over the first
   16 bits, coarse to fine (17 BLFs, then the span narrowed to one step around the best)
   down to a step of 1/(4·their elements); the one whose remodulated reply
   (rest level −1 around it) leaves the least residual power under
   :func:`rfsim.gen2.capture.fit_gain_offset` wins. That gives the reply's length (EPC:
   the PC's L field); the search is repeated over the whole reply across ±2 steps of the
   first bits' search around their BLF, first on a grid of 1/(2·its elements) (the whole
   reply's residual has a minimum ≈ 1/elements wide in BLF: a coarser grid can step over
   it and settle on a wrong BLF), then narrowed down to a step of 1/(4·its elements)
   (decoding needs the BLF to ≈ 1/(4·elements), 0.02 % for a 128-bit Miller-4 reply). A reply the next command cuts is decoded to its
   last whole bit (**truncated**: reported with the bits that fit, never as a complete
   frame).
4. **Timing tracking** (tag clock drift, :mod:`rfsim.gen2.reply_tracking`): with the decoded bits as reference the reply is
   cut into blocks of ≈ 24 elements (at least 6 blocks); in each block the timing offset
   δ_b that maximises the correlation with the remodulated reply (averaged over each
   sample interval at 4 points, so that the correlation varies smoothly with δ even where
   a sample is taken at one point of a sharp edge) is found on a 1/16-element grid within
   ±1/2 element of a prediction and refined by the peak of the triangular correlation. A
   weighted least-squares quadratic δ(t) (start, BLF, linear BLF drift; a line for replies
   of fewer than 8 blocks) is fitted over growing spans from the reply start (¼, ½, all),
   each span's offsets searched around the previous fit's extrapolation — a
   tracking loop that follows a timing error growing past half an element towards the
   end. The element clock u(t) = u₁·t + u₂·t² is updated, the window resampled on the tag's
   clock (linear interpolation) and decoded again (twice, unless the first pass moved the
   clock by ≤ :data:`TRACK_CONVERGED_ELEMENTS` of an element and left the bits unchanged). Reported: the mean BLF
   (u₁ + u₂·T)·fs_w/2 over the reply's T samples and the drift, the relative BLF change
   across it, 2·u₂·T/u₁.
5. **Validation**: (h, c) by least squares over the decision-free samples (preamble and
   rest level), then over the whole remodulated reply; the reply is kept only if its
   energy per half-bit over the residual noise, E_h/N₀ = |h|²·(samples per half-bit)/σ²,
   is ≥ :data:`MIN_HALFBIT_SNR_DB` (noise forced through the decoder gives ≈ 0 dB), so
   coloured or impulsive noise that passes the correlation test is not reported.
   RSSI 10·log10|h|² + 30 (dBm if the capture is in √W, else dB relative to its unit),
   phase (−arg h) mod 2π and SNR |h|²/σ² per sample at the capture's rate, as the
   simulated reader defines them (rfsim.devices.reader ``ReadResult``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.gen2.bits import bits_to_int, bits_to_str
from rfsim.gen2.capture import ReaderCommandRecord, fit_gain_offset, preamble_threshold
from rfsim.gen2.commands import DR_VALUES, normalize_dr
from rfsim.gen2.crc import crc16_ok
from rfsim.gen2.link import BLF_RANGE_HZ, M_VALUES, TRCAL_TABLE_RANGE_S, frt_fraction, t1_range
from rfsim.gen2.linecode import (METHODS, _preamble, _state_index, decode_reply, halfsymbols, preamble_levels,
                                 reply_waveform)
from rfsim.gen2.reply_tracking import (MIN_DRIFT_BLOCKS, MIN_TRACK_BLOCKS, SUBSAMPLES, TRACK_BLOCK_ELEMENTS, TRACK_SPANS,
                                      resample, track_reference, warp_positions)
from rfsim.core.lazy import lazy_import

_rk = lazy_import("rfsim.gen2._reply_kernels")

#: Reply kind elicited by each command (anchors §4.4).
REPLY_KIND = {"Query": "RN16", "QueryRep": "RN16", "QueryAdjust": "RN16", "ACK": "EPC", "Req_RN": "handle",
              "Read": "read"}
#: FrT assumed when the divide ratio or TRcal is unknown (the largest value of the table).
FRT_UNKNOWN = 0.22
#: BLF range of the blind search [Hz]: the Gen2 range widened by FRT_UNKNOWN.
BLIND_BLF_RANGE_HZ = (BLF_RANGE_HZ[0] * (1 - FRT_UNKNOWN), BLF_RANGE_HZ[1] * (1 + FRT_UNKNOWN))
#: Samples per element (half subcarrier cycle) at the working rate, at the highest BLF searched.
SAMPLES_PER_ELEMENT = 6
#: Fewest samples per element a BLF hypothesis needs (above it the reply is not resolved).
MIN_SAMPLES_PER_ELEMENT = 2.0
#: Smallest energy per half-bit over the noise of a reported reply (step 5).
MIN_HALFBIT_SNR_DB = 6.0
#: Half-width of the fine BLF searches in coarse steps (a short FM0 preamble, 12 elements,
#: can correlate best one coarse step off).
FINE_SPAN_STEPS = 2
#: The tracking loop runs a second time unless its first pass moved the element clock by
#: at most this many elements anywhere in the reply and left the decoded bits unchanged
#: (1/8 element, half the 1/4-element timing the decoding needs: the first pass's fit was
#: then made on a reference at most that far off; on the benchmark captures the largest
#: BLF error of the 500 Miller-4 replies goes from 1.24e-4 to 1.31e-4 against 0.05).
TRACK_CONVERGED_ELEMENTS = 0.125
#: Whole-element shifts of the preamble centre at which the start found by the fine search
#: over the first bits is checked (step 3): the preamble correlates almost as well an element
#: or two off (a Miller pilot is a plain subcarrier, and |correlation| does not see the sign
#: one element turns), which left Miller RN16s decoded a whole element late (bits right, the
#: reply's fit and SNR wrong).
START_CHECK_SHIFTS = (-2, -1, 1, 2)
_START_SHIFTS = np.array(START_CHECK_SHIFTS, dtype=np.float64)
_START_SHIFTS.flags.writeable = False
#: Sub-sample points of the tracking reference and the tracking spans, as kernel arguments.
_SUB = (np.arange(SUBSAMPLES) + 0.5) / SUBSAMPLES - 0.5
_SPANS = np.array(TRACK_SPANS, dtype=np.float64)
_SUB.flags.writeable = False
_SPANS.flags.writeable = False
#: A window whose variance is below this fraction of its power holds no modulation at all.
_MIN_RELATIVE_VARIANCE = 1e-12


@dataclass(frozen=True)
class TagReplyRecord:
    """One tag reply found in a capture.

    Attributes
    ----------
    command_index : index of the preceding reader command in the command records
    command : its name ("Query", "ACK", "Req_RN", …)
    kind : "RN16", "EPC" (PC + EPC + CRC-16), "handle" (RN16 + CRC-16) or "read"
        (header + words + handle + CRC-16)
    start_s : start of the reply (pilot or preamble) [s]
    bits : decoded data bits as a 0/1 string (dummy 1 removed)
    blf_hz : BLF measured on the reply (its mean over the reply) [Hz]
    blf_drift : relative BLF change from the reply's start to its end (tracked)
    m, trext : line code of the reply (1 = FM0, 2/4/8 = Miller), pilot
    corr : normalised preamble correlation (0…1) at the decoded start and BLF (on the
        tag's clock)
    truncated : the next command (or the capture's end) cut the reply at ``end_s``;
        ``bits`` holds the whole bits before the cut
    end_s : end of the reply, or where it was cut [s]
    n_bits_expected : data bits of the complete reply (−1 when unknown)
    crc_ok : CRC-16 over the reply (EPC, handle, read); None for an RN16 or truncated reply
    rn16 : the RN16 (RN16 replies) or the handle (handle, read replies), else None
    pc, epc_hex : PC word and EPC as upper-case hex (EPC replies), else None
    data_hex : the words read (read replies), else None
    rssi_dbm, phase_rad, snr_db : step 5 of the module docstring
    """

    command_index: int
    command: str
    kind: str
    start_s: float
    bits: str
    blf_hz: float
    m: int
    trext: bool
    corr: float
    truncated: bool = False
    end_s: float = math.nan
    n_bits_expected: int = -1
    blf_drift: float = 0.0
    crc_ok: bool | None = None
    rn16: int | None = None
    pc: int | None = None
    epc_hex: str | None = None
    data_hex: str | None = None
    rssi_dbm: float = math.nan
    phase_rad: float = math.nan
    snr_db: float = math.nan


@dataclass(frozen=True)
class LinkHypothesis:
    """Line code and BLF range [Hz] searched for a reply."""

    m: int
    trext: bool
    blf_lo_hz: float
    blf_hi_hz: float


@functools.lru_cache(maxsize=32)
def _n_pre_elements(m: int, trext: bool) -> int:
    return preamble_levels(m=m, trext=trext)[0].size * m


def _n_elements(n_bits: int, m: int, trext: bool) -> int:
    return _n_pre_elements(m, trext) + 2 * m * (int(n_bits) + 1)


@functools.lru_cache(maxsize=256)
def _geometric_grid_cached(lo: float, hi: float, step: float) -> np.ndarray:
    grid = _geometric_grid_uncached(lo, hi, step)
    grid.flags.writeable = False
    return grid


def _geometric_grid(lo: float, hi: float, step: float) -> np.ndarray:
    """BLFs lo … hi on a geometric grid of relative step ≤ ``step`` (read-only, cached: the
    same hypotheses are searched after every command)."""
    return _geometric_grid_cached(float(lo), float(hi), float(step))


def _geometric_grid_uncached(lo: float, hi: float, step: float) -> np.ndarray:
    if hi <= lo:
        return np.array([0.5 * (lo + hi)])
    n = int(math.ceil(math.log(hi / lo) / math.log1p(step))) + 1
    return _geomspace(lo, hi, max(n, 2))


def _geomspace(lo: float, hi: float, n: int) -> np.ndarray:
    """``n`` ≥ 2 values from ``lo`` to ``hi`` (both exact) in equal ratios, lo·(hi/lo)^(k/(n−1))
    (:func:`numpy.geomspace` without its overhead: this runs after every command)."""
    out = lo * np.exp(np.arange(n) * (math.log(hi / lo) / (n - 1)))
    out[0], out[-1] = lo, hi
    return out


def boxcar_decimate(r: np.ndarray, d: int) -> np.ndarray:
    """Means of consecutive blocks of ``d`` samples, ``(len(r)//d,)`` (sample j of the result
    is at input position j·d + (d − 1)/2)."""
    n = r.size // d
    return r[: n * d].reshape(n, d).mean(axis=1) if d > 1 else r.copy()


def _fit_full(r: np.ndarray, s: np.ndarray, n_end: int, steady_only: bool = False):
    """(h, c, σ²) of r ≈ h·ref + c over r[:n_end], ref = s (reply ±1) and −1 around it; σ²
    over all those samples, or (``steady_only``) over those whose two neighbours carry the
    same level (a sample at an element boundary may carry either level)."""
    ref = np.where(s == 0, -1.0, s)[:n_end]
    rr = r[:n_end]
    h, c = fit_gain_offset(rr, ref)
    steady = np.ones(ref.size, dtype=bool)
    if steady_only:
        steady[[0, -1]] = False
        steady[1:-1] = (ref[1:-1] == ref[:-2]) & (ref[1:-1] == ref[2:])
    e = (rr - c - h * ref)[steady]
    return h, c, float(np.mean(np.abs(e) ** 2)) if e.size else math.nan


def _fine(r, centre, n_bits, m, trext, blfs, fs, method):
    """Decode at every BLF of ``blfs`` with the preamble centred on sample ``centre`` (a BLF
    error moves the best-correlating start so that the preamble's centre stays put); keep
    the one whose remodulated reply leaves the least residual power. Returns
    (blf, bits (n_bits,) uint8, start) or None (numba kernel ``fine_kernel``;
    :func:`_fine_reference` is its NumPy twin)."""
    pre, cur, prev = _preamble(m, trext)
    bits = np.empty(int(n_bits), dtype=np.uint8)
    blfs = np.ascontiguousarray(blfs, dtype=np.float64)
    # the kernel reads no sample after the last start + reply of a BLF: the rest is not passed
    rho = 2.0 * blfs / fs
    n_rep = np.ceil(_n_elements(n_bits, m, trext) / rho) + 2
    cut = min(r.size, int(math.ceil(float(np.max(centre - 0.5 * _n_pre_elements(m, trext) / rho + n_rep)))) + 1)
    j, resid, start = _rk.fine_kernel(np.ascontiguousarray(r[:max(cut, 0)], dtype=np.complex128), float(centre), int(n_bits), int(m),
                                  pre, np.int8(cur), np.uint8(prev), _state_index(cur, prev, m > 1), blfs, float(fs),
                                  method == "viterbi", bits)
    return None if j < 0 else (float(blfs[j]), bits, float(start), float(resid))


def _fine_reference(r, centre, n_bits, m, trext, blfs, fs, method):
    """Plain-NumPy twin of :func:`_fine` (decode_reply, reply_waveform and the fit per BLF)."""
    best = None
    half = 0.5 * _n_pre_elements(m, trext)
    for blf in blfs:
        rho = 2.0 * blf / fs
        start = centre - half / rho
        n_rep = int(math.ceil(_n_elements(n_bits, m, trext) / rho)) + 2
        if start < 0 or start > r.size - n_rep:
            continue
        det = decode_reply(r, n_bits=n_bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, method=method,
                           start_sample=start)
        s = reply_waveform(det.bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=start / fs, n_samples=r.size)
        _, _, resid = _fit_full(r, s, min(r.size, int(start) + n_rep))
        if best is None or resid < best[0]:
            best = (resid, float(blf), det.bits.astype(np.uint8), start)
    return None if best is None else best[1:] + best[:1]


def _fine_search(r, centre, n_bits, m, trext, blf0, span, target, per_side, fs, method, fine=None):
    """:func:`_fine` coarse to fine: ``2·per_side + 1`` BLFs across blf0·(1 ± span), then the
    same around the best with the span narrowed to one step, until the step is ≤ ``target``
    (relative). Returns (blf, bits, start) or None."""
    best, centre_blf = None, blf0
    while True:
        step = max(span / per_side, target)
        k = int(math.ceil(span / step))
        found = (fine or _fine)(r, centre, n_bits, m, trext, centre_blf * (1.0 + step * np.arange(-k, k + 1)), fs,
                                method)
        if found is None:
            return best
        best = found
        if step <= target:
            return best
        span, centre_blf = step, found[0]


def preamble_correlation(r: np.ndarray, template0: np.ndarray) -> np.ndarray:
    """Zero-mean normalised correlation of ``r`` with the zero-mean real template at every
    valid lag: |Σ r[k+i]·t0[i]| / (‖t0‖·‖r[k:k+L] − mean‖), ``(r.size − L + 1,)`` in [0, 1]
    (the statistic of :func:`rfsim.gen2.linecode.decode_reply` and of the detection
    threshold; sliding sums by cumulative sums)."""
    from scipy.signal import correlate  # imported when first used: scipy.signal costs ≈ 1 s to import

    n = template0.size
    c = np.abs(correlate(r, template0, mode="valid"))
    p = np.concatenate([[0.0], np.cumsum(np.abs(r) ** 2)])
    q = np.concatenate([[0.0], np.cumsum(r)])
    energy = (p[n:] - p[:-n]) - np.abs(q[n:] - q[:-n]) ** 2 / n
    return c / (math.sqrt(float(template0 @ template0)) * np.sqrt(np.maximum(energy, 1e-300)))


def _correlation_at(seg: np.ndarray, template0: np.ndarray) -> float:
    """:func:`preamble_correlation` at the one lag where ``seg`` (as long as the template)
    starts: |Σ seg·t0| / (‖t0‖·‖seg − mean(seg)‖)."""
    n = template0.size
    energy = float(np.sum(seg.real * seg.real + seg.imag * seg.imag)) - abs(complex(seg.sum())) ** 2 / n
    return abs(complex(seg @ template0)) / (math.sqrt(float(template0 @ template0)) * math.sqrt(max(energy, 1e-300)))


def _preamble_template(m: int, trext: bool, blf: float, fs: float) -> np.ndarray:
    """Zero-mean samples fully inside pilot + preamble (rfsim.gen2.linecode sampling)."""
    n = int(math.floor(_n_pre_elements(m, trext) * fs / (2.0 * blf)))
    t = reply_waveform(np.zeros(0, np.uint8), m=m, trext=trext, blf_hz=blf, fs_hz=fs, dummy=False, n_samples=n)
    return t - t.mean()


def _bits_that_fit(n_avail: float, m: int, trext: bool, rho: float) -> int:
    """Data bits (dummy excluded) of a reply whose preamble starts ``n_avail`` samples before
    the end of the window (ρ elements per sample)."""
    elements = n_avail * rho - 2 * rho
    return int(math.floor((elements - _n_pre_elements(m, trext)) / (2 * m))) - 1


def _reply_end(start: float, n_bits: int, m: int, trext: bool, rho: float, dummy: bool) -> int:
    """First sample after the reply's decoded part (dummy 1 included if ``dummy``)."""
    n_el = _n_elements(n_bits, m, trext) - (0 if dummy else 2 * m)
    return int(math.ceil(start + n_el / rho))


@functools.lru_cache(maxsize=32)
def _preamble_elements(m: int, trext: bool) -> np.ndarray:
    """Pilot + preamble elements (±1) of a line code (read-only, cached)."""
    el = halfsymbols(np.zeros(0, np.uint8), m=m, trext=trext, dummy=False).astype(np.float64)
    el.flags.writeable = False
    return el


def _per_blf(f, blfs: np.ndarray) -> np.ndarray:
    """``f`` (a lag bound of a BLF, given one BLF or an array of them) at every BLF of ``blfs``."""
    v = f(blfs)
    if isinstance(v, np.ndarray) and v.shape == blfs.shape:
        return v.astype(np.int64, copy=False)
    return np.broadcast_to(np.asarray(v), blfs.shape).astype(np.int64)


def _search(r, fs, hyps, lo_of, hi_of):
    """Step 2 on one working-rate window: ``(best, n_tests)`` with best = (corr, blf,
    hypothesis, start, coarse step, preamble samples) of the largest preamble correlation
    over the hypotheses and T1 lags (None if no lag fits; the start refined between lags by
    a parabola through the peak) and the number of lags tested (numba kernel
    ``preamble_search_kernel``, one call per hypothesis; the tests hold it to a NumPy twin)."""
    best, n_tests = None, 0
    r = np.ascontiguousarray(r, dtype=np.complex128)
    for hyp in hyps:
        step_c = 1.0 / (2.0 * _n_pre_elements(hyp.m, hyp.trext))
        blfs = _geometric_grid(hyp.blf_lo_hz, hyp.blf_hi_hz, step_c)
        lo, hi = _per_blf(lo_of, blfs), _per_blf(hi_of, blfs)
        n_rep = (np.ceil(_n_elements(0, hyp.m, hyp.trext) * fs / (2.0 * blfs)) + 2).astype(np.int64)
        pre_el = _preamble_elements(hyp.m, hyp.trext)
        # no lag after hi leaves room for the preamble: the samples after it are not passed
        cut = max(0, min(r.size, int(np.max(hi + n_rep)) + 1))
        c, j, pos, nt, n_t = _rk.preamble_search_kernel(r[:cut], pre_el, blfs, float(fs), lo, hi, n_rep,
                                                        MIN_SAMPLES_PER_ELEMENT, np.empty(blfs.size))
        n_tests += nt
        if j >= 0 and (best is None or c > best[0]):
            best = (float(c), float(blfs[j]), hyp, float(pos), step_c, int(n_t))
    return best, n_tests


def _bands(hyps) -> list[list[LinkHypothesis]]:
    """Hypotheses split into BLF octaves (each gets its own working rate; cached)."""
    return _bands_cached(tuple(hyps))


@functools.lru_cache(maxsize=64)
def _bands_cached(hyps: tuple) -> list[list[LinkHypothesis]]:
    out = []
    for h in hyps:
        edges = _geomspace(h.blf_lo_hz, h.blf_hi_hz, max(2, int(math.ceil(math.log2(h.blf_hi_hz / h.blf_lo_hz))) + 1))
        for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
            while len(out) <= k:
                out.append([])
            out[k].append(LinkHypothesis(h.m, h.trext, float(a), float(b)))
    return out


def _decode_length(r, fs, centre, blf, bits, start, step_first, n_first, n_bits, truncated, m, trext, method):
    """Step 3 (whole reply) and step 4 for a reply of ``n_bits`` data bits; ``blf`` the BLF
    found on the first ``n_first`` bits to a step ``step_first`` (relative). Returns (bits,
    start, u1, u2, resampled window, its rest samples before the reply, BLF) or None; the
    plain-NumPy steps of :func:`_decode_window_reference`."""
    if n_bits > n_first:
        # the whole reply is searched across ±FINE_SPAN_STEPS steps of the first bits' search
        # around its BLF, on a grid no coarser than 1/(2·elements): the residual of the whole
        # reply has a minimum about 1/elements wide in BLF, which a coarser grid can step over
        # (and then settle on a wrong BLF whose decoded bits fit the noise a little better)
        n_el = _n_elements(n_bits, m, trext)
        span = FINE_SPAN_STEPS * step_first
        again = _fine_search(r, centre, n_bits, m, trext, blf, span, 1.0 / (4.0 * n_el),
                             max(2, int(math.ceil(span * 2.0 * n_el))), fs, method, _fine_reference)
        if again is not None:
            blf, bits, start = again[:3]
    out = _track_decode_reference(r, fs, blf, bits[:n_bits].astype(np.uint8), start, truncated, m, trext, method)
    return None if out is None else out + (blf,)


def _track_decode(r, fs, blf, bits, start, truncated, m, trext, method):
    """Step 4 (timing tracking, resampling on the tag's clock, decoding again) of a reply
    decoded as ``bits`` from ``start`` at ``blf``: ``(bits, start, u1, u2, resampled window,
    its rest samples before the reply)`` or None (numba kernel ``track_decode_kernel``;
    :func:`_track_decode_reference` is its NumPy twin)."""
    bits = np.array(bits, dtype=np.uint8)
    rho = 2.0 * blf / fs
    n_rest = int(min(start, 256))
    pre, cur, prev = _preamble(m, trext)
    rw = np.empty(n_rest + _reply_end(0.0, bits.size, m, trext, rho, True) + 4, dtype=np.complex128)
    sub = (np.arange(SUBSAMPLES) + 0.5) / SUBSAMPLES - 0.5
    ok, start, u1, u2 = _rk.track_decode_kernel(
        np.ascontiguousarray(r, dtype=np.complex128), float(start), rho, float(fs), bits, int(m), pre, np.int8(cur),
        np.uint8(prev), _state_index(cur, prev, m > 1), not truncated, method == "viterbi", TRACK_BLOCK_ELEMENTS,
        MIN_TRACK_BLOCKS, np.array(TRACK_SPANS, dtype=np.float64), sub, MIN_DRIFT_BLOCKS, TRACK_CONVERGED_ELEMENTS,
        n_rest, rw)
    return (bits, float(start), float(u1), float(u2), rw, n_rest) if ok else None


def _track_decode_reference(r, fs, blf, bits, start, truncated, m, trext, method):
    """Plain-NumPy twin of :func:`_track_decode` (:func:`rfsim.gen2.reply_tracking.track`,
    :func:`rfsim.gen2.linecode.decode_reply` and the least-squares fits)."""
    bits = np.asarray(bits, dtype=np.uint8)
    rho = 2.0 * blf / fs
    dummy = not truncated
    # step 4: timing tracking, resampling on the tag's clock, decoding again
    n_rest = int(min(start, 256))
    u1, u2 = rho, 0.0
    n_span = _reply_end(0.0, bits.size, m, trext, rho, dummy)  # reply length [samples]
    for it in range(2):
        s = reply_waveform(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=start / fs, n_samples=r.size,
                           dummy=dummy)
        h, c, _ = _fit_full(r, s, min(r.size, _reply_end(start, bits.size, m, trext, rho, dummy)))
        if h == 0:
            return None
        prev = (start, u1, u2)
        start, u1, u2 = track_reference(r, start, u1, u2, h, c, bits, m, trext, dummy)
        # the clock moved by at most this many elements anywhere in the reply
        moved = (abs(start - prev[0]) * u1 + abs(u1 - prev[1]) * n_span + abs(u2 - prev[2]) * n_span ** 2)
        n_prime = np.arange(-n_rest, _reply_end(0.0, bits.size, m, trext, rho, True) + 4, dtype=np.float64)
        rw = resample(r, start + warp_positions(n_prime, u1, u2, rho))
        pre = reply_waveform(np.zeros(0, np.uint8), m=m, trext=trext, blf_hz=blf, fs_hz=fs,
                             t0_s=n_rest / fs, n_samples=rw.size, dummy=False)
        known = pre != 0
        known[:n_rest] = True
        h, c = fit_gain_offset(rw[known], np.where(pre[known] == 0, -1.0, pre[known]))
        det = decode_reply(rw - c, n_bits=bits.size, m=m, trext=trext, blf_hz=blf, fs_hz=fs, method=method,
                           start_sample=float(n_rest), gain=h)
        new_bits = det.bits.astype(np.uint8)
        converged = moved <= TRACK_CONVERGED_ELEMENTS and np.array_equal(new_bits, bits)
        bits = new_bits
        if converged:  # a second pass would move the clock by less still: same bits
            break
    return bits, start, u1, u2, rw, n_rest


def _decode_window(r, fs, found, n_bits_of, method):
    """Steps 3–5 on the working-rate window ``r`` (module docstring) after the detection
    ``found`` of :func:`_search`; ``n_bits_of(bits)`` gives the length of the complete reply
    from its first decoded bits (−1: not known yet). Returns a dict or None (numba kernel
    ``decode_window_kernel`` for the rules of :func:`_n_bits_rule`;
    :func:`_decode_window_reference` is its NumPy twin, and decodes with any other rule)."""
    if not isinstance(n_bits_of, _NBitsRule):
        return _decode_window_reference(r, fs, found, n_bits_of, method)
    _, blf_c, hyp, start_c, step_c, _ = found
    m, trext = hyp.m, hyp.trext
    pre, cur, prev = _preamble(m, trext)
    r = np.ascontiguousarray(r, dtype=np.complex128)
    bits = np.empty(max(16, _bits_that_fit(r.size, m, trext, 2.0 * blf_c / fs) + 1), dtype=np.uint8)
    (ok, n_bits, start, u1, u2, blf, truncated, n_full, n_rest, h, sigma2, corr, n_span) = _rk.decode_window_kernel(
        r, float(fs), float(blf_c), float(start_c), float(step_c), int(m), pre, np.int8(cur), np.uint8(prev),
        _state_index(cur, prev, m > 1), method == "viterbi", n_bits_of.rule, n_bits_of.fixed, float(FINE_SPAN_STEPS),
        _START_SHIFTS,
        TRACK_BLOCK_ELEMENTS, MIN_TRACK_BLOCKS, _SPANS, _SUB, MIN_DRIFT_BLOCKS, TRACK_CONVERGED_ELEMENTS, bits)
    if not ok:
        return None
    rho = 2.0 * blf / fs
    eh_n0 = abs(h) ** 2 * (m / rho) / sigma2 if sigma2 > 0 else math.inf
    if not eh_n0 >= 10.0 ** (MIN_HALFBIT_SNR_DB / 10.0):
        return None
    return dict(bits=bits[:n_bits].copy(), start=start, blf=(u1 + u2 * n_span) * fs / 2.0, drift=2.0 * u2 * n_span / u1,
                m=m, trext=trext, corr=float(corr), truncated=bool(truncated), n_full=int(n_full), h=complex(h),
                sigma2=float(sigma2), end=start + n_span)


def _decode_window_reference(r, fs, found, n_bits_of, method):
    """Plain-NumPy twin of :func:`_decode_window` (:func:`_fine_reference`,
    :func:`_track_decode_reference` and the fits written out)."""
    corr, blf_c, hyp, start_c, step_c, _ = found
    m, trext = hyp.m, hyp.trext
    rho_c = 2.0 * blf_c / fs
    centre = start_c + 0.5 * _n_pre_elements(m, trext) / rho_c
    # step 3: fine BLF over the first 16 bits (or what fits), then the whole reply
    n_first = max(0, min(16, _bits_that_fit(r.size - start_c, m, trext, rho_c)))
    step_16 = 1.0 / (4.0 * _n_elements(n_first, m, trext))
    fine = _fine_search(r, centre, n_first, m, trext, blf_c, FINE_SPAN_STEPS * step_c, step_16, 8, fs, method,
                        _fine_reference)
    if fine is None:
        return None
    blf, bits0, start, resid = fine
    for shift in START_CHECK_SHIFTS:  # whole-element shifts of the start (decode_window_kernel)
        c = centre + shift / (2.0 * blf / fs)
        alt = _fine_reference(r, c, n_first, m, trext, np.array([blf]), fs, method)
        if alt is not None and alt[3] < resid:
            centre, (_, bits0, start, resid) = c, alt
    n_full = n_bits_of(bits0)
    for _ in range(3):  # the reply's length follows from its first bits (EPC: the PC's L field)
        n_fit = _bits_that_fit(r.size - start, m, trext, 2.0 * blf / fs)
        truncated = n_full < 0 or n_fit < n_full
        n_bits = max(0, n_fit - 1) if truncated else n_full  # when cut, the last whole bit stands in for the dummy
        out = _decode_length(r, fs, centre, blf, bits0, start, step_16, n_first, n_bits, truncated, m, trext, method)
        if out is None:
            return None
        n_again = n_bits_of(out[0])
        if truncated or n_again == n_full or n_again < 0:
            break
        n_full = n_again  # a PC decoded better on the whole reply announces another length
    bits, start, u1, u2, rw, n_rest, blf = out
    rho = 2.0 * blf / fs
    dummy = not truncated
    # step 5: measurements on the resampled reply, E_h/N0 gate
    s = reply_waveform(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=n_rest / fs, n_samples=rw.size,
                       dummy=dummy)
    h, c, sigma2 = _fit_full(rw, s, min(rw.size, _reply_end(n_rest, bits.size, m, trext, rho, dummy)), True)
    eh_n0 = abs(h) ** 2 * (m / rho) / sigma2 if sigma2 > 0 else math.inf
    t0 = _preamble_template(m, trext, blf, fs)  # the correlation at the decoded start and BLF
    corr = _correlation_at(rw[n_rest: n_rest + t0.size], t0)
    if not eh_n0 >= 10.0 ** (MIN_HALFBIT_SNR_DB / 10.0):
        return None
    n_span = _reply_end(0.0, bits.size, m, trext, rho, dummy) / u1 * rho
    return dict(bits=bits, start=start, blf=(u1 + u2 * n_span) * fs / 2.0, drift=2.0 * u2 * n_span / u1, m=m, trext=trext,
                corr=float(corr), truncated=truncated, n_full=n_full, h=complex(h), sigma2=sigma2,
                end=start + n_span)


@dataclass(frozen=True)
class _Lags:
    """T1 window of a BLF as lags into a window decimated by ``d`` (sample j at input sample
    i0 + j·d + (d − 1)/2)."""

    fs: float
    d: int
    i0: int
    cmd_end_s: float
    rtcal_s: float
    frt: float

    def _lag(self, t_s):
        return ((self.cmd_end_s + t_s) * self.fs - self.i0 - 0.5 * (self.d - 1)) / self.d

    def _nominal(self, blf):
        # T1 nominal max(RTcal, 10/BLF) of rfsim.gen2.link.t1_range, for one BLF or an array
        return np.maximum(self.rtcal_s, 10.0 / np.asarray(blf, dtype=np.float64))

    def lo(self, blf):
        """First lag of the T1 window (t1_range min, one sample early) of a BLF or array of BLFs."""
        t_s = self._nominal(blf) * (1 - self.frt) - 2e-6
        return np.maximum(0, np.floor(self._lag(t_s)).astype(np.int64) - 1)

    def hi(self, blf):
        """Last lag of the T1 window (t1_range max, one sample late)."""
        t_s = self._nominal(blf) * (1 + self.frt) + 2e-6
        return np.ceil(self._lag(t_s)).astype(np.int64) + 1


def _reply_fields(kind: str, bits: np.ndarray, truncated: bool) -> dict:
    """RN16/handle/PC/EPC/data and CRC of a decoded reply (``bits`` (n,) uint8)."""
    out: dict = {}
    if kind == "RN16":
        if bits.size >= 16:
            out["rn16"] = bits_to_int(bits[:16])
        return out
    out["crc_ok"] = None if truncated else bool(bits.size >= 32 and crc16_ok(bits))
    if kind == "EPC":
        if bits.size >= 16:
            out["pc"] = bits_to_int(bits[:16])
        epc = bits[16:-16] if not truncated else bits[16:16 + 16 * ((bits.size - 16) // 16)]
        n_hex = epc.size // 4
        out["epc_hex"] = f"{bits_to_int(epc[:4 * n_hex]):0{n_hex}X}" if n_hex else ""
    elif kind == "handle":
        if bits.size >= 16:
            out["rn16"] = bits_to_int(bits[:16])
    elif kind == "read" and not truncated and bits.size >= 33:
        data = bits[1:-32]
        out["data_hex"] = "".join(f"{bits_to_int(data[i:i + 4]):X}" for i in range(0, data.size, 4))
        out["rn16"] = bits_to_int(bits[-32:-16])
    return out


def _max_bits(kind: str, rec: ReaderCommandRecord) -> int:
    """Most data bits a reply of ``kind`` can have: RN16 16, handle 32, EPC 32 + 16·31 (the
    PC's 5-bit L field), read 1 + 16·WordCount + 32 (WordCount 0: 255 words)."""
    if kind == "RN16":
        return 16
    if kind == "handle":
        return 32
    if kind == "read":
        return 1 + 16 * (int(rec.fields.get("word_count", 0)) or 255) + 32
    return 32 + 16 * 31


@dataclass(frozen=True)
class _NBitsRule:
    """``n_bits_of(bits)``: the complete reply's data bits (−1 unknown) from its first decoded
    bits, ``fixed`` (rule ``RULE_FIXED``) or PC + EPC + CRC-16 (``RULE_EPC``: the EPC length
    in words in the PC's 5 MSBs, anchors §4.4)."""

    rule: int
    fixed: int = -1

    def __call__(self, bits) -> int:
        if self.rule == _rk.RULE_FIXED:
            return self.fixed
        return 32 + 16 * (bits_to_int(bits[:16]) >> 11) if bits.size >= 16 else -1


def _n_bits_rule(kind: str, rec: ReaderCommandRecord) -> _NBitsRule:
    """``n_bits_of(bits)`` of a reply kind: the complete reply's data bits (−1 unknown)."""
    if kind == "RN16":
        return _NBitsRule(_rk.RULE_FIXED, 16)
    if kind == "handle":
        return _NBitsRule(_rk.RULE_FIXED, 32)
    if kind == "read":
        wc = int(rec.fields.get("word_count", 0))
        return _NBitsRule(_rk.RULE_FIXED, 1 + 16 * wc + 32 if wc > 0 else -1)
    return _NBitsRule(_rk.RULE_EPC)


def decode_tag_reply(samples, fs_hz: float, *, listen_s: float, window_end_s: float, cmd_end_s: float,
                     rtcal_s: float, frt: float, hypotheses, kind: str, n_bits_of, max_bits: int,
                     cut_s: float | None = None,
                     method: str = "viterbi", false_alarm_probability: float = 1e-3, command_index: int = -1,
                     command: str = "", blf_hint_hz: float | None = None) -> TagReplyRecord | None:
    """Search, decode and check one tag reply in a capture (module docstring, steps 1–5).

    Parameters
    ----------
    samples : (n,) complex baseband or real envelope, arbitrary scale, sample k at k/fs [s]
    fs_hz : sample rate [Hz]
    listen_s, window_end_s : the part of the capture used [s] (after the command's last edge
        has settled, up to before the next command)
    cmd_end_s, rtcal_s, frt : the command's last rising edge [s], its RTcal [s] and the BLF
        tolerance FrT that set the T1 window
    hypotheses : sequence of :class:`LinkHypothesis` searched
    kind : reply kind (:data:`REPLY_KIND` values); ``n_bits_of(bits)`` the complete reply's
        data bits from its first decoded bits (−1 unknown), ``max_bits`` the most it can have
        (the window is cut after the longest reply)
    cut_s : where the window is cut (the next command's start) [s]; default ``window_end_s``
    method : "viterbi" or "bitwise"
    false_alarm_probability : per window, sets the detection threshold

    command_index, command : written into the record (the preceding command)
    blf_hint_hz : BLF of an earlier reply in the capture: a single hypothesis is searched
        first within ±2 coarse steps of it (:func:`_detect`)

    Returns the :class:`TagReplyRecord` or None.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    hyps = list(hypotheses)
    if not hyps:
        return None
    fs = float(fs_hz)
    x = np.asarray(samples)
    i0 = max(0, int(math.ceil(listen_s * fs)))
    # no longer than the longest reply any hypothesis allows (rest level around it included)
    longest_s = max(t1_range(rtcal_s=rtcal_s, blf_hz=h.blf_lo_hz, frt=frt).max_s
                    + _n_elements(max_bits, h.m, h.trext) / (2.0 * h.blf_lo_hz) for h in hyps)
    end_s = min(window_end_s, cmd_end_s + longest_s + 16.0 / fs + 2e-6)
    i1 = min(x.size, int(math.floor(end_s * fs)))
    if i1 - i0 < 16:
        return None
    r = x[i0:i1].astype(np.complex128)
    power = float(np.mean(r.real * r.real + r.imag * r.imag))
    if power == 0.0 or power - abs(complex(r.sum()) / r.size) ** 2 <= _MIN_RELATIVE_VARIANCE * power:
        return None
    t1_earliest = min(t1_range(rtcal_s=rtcal_s, blf_hz=h.blf_hi_hz, frt=frt).min_s for h in hyps)
    lo_full = int(math.floor((cmd_end_s + t1_earliest) * fs)) - i0 - 1
    if lo_full >= 8:  # step 1: conditioning only (detection is invariant to a constant offset)
        r = r - r[:lo_full].sum() / lo_full
    best = _detect(r, fs, hyps, i0, cmd_end_s, rtcal_s, frt, blf_hint_hz, false_alarm_probability)
    if best is None:
        return None
    found, rd, d = best
    res = _decode_window(rd, fs / d, found, n_bits_of, method)
    if res is None:
        return None
    centre = 0.5 * (d - 1)
    bits = res["bits"]
    to_s = lambda j: (i0 + j * d + centre) / fs  # noqa: E731  (working-rate sample → time)
    h = res["h"]
    p = abs(h) ** 2
    snr = 10.0 * math.log10(p / (res["sigma2"] * d)) if res["sigma2"] > 0 else math.inf
    truncated = bool(res["truncated"])
    return TagReplyRecord(
        command_index=int(command_index), command=str(command), kind=kind, start_s=float(to_s(res["start"])), bits=bits_to_str(bits),
        blf_hz=float(res["blf"]), m=int(res["m"]), trext=bool(res["trext"]), corr=res["corr"], truncated=truncated,
        end_s=float(((window_end_s if cut_s is None else cut_s) if end_s >= window_end_s else end_s) if truncated
                    else to_s(res["end"])),
        n_bits_expected=int(res["n_full"]), blf_drift=float(res["drift"]),
        rssi_dbm=10.0 * math.log10(p) + 30.0 if p > 0 else -math.inf,
        phase_rad=float((-np.angle(h)) % (2.0 * math.pi)), snr_db=snr, **_reply_fields(kind, bits, truncated))


def _search_bands(r, fs, hyps, i0, cmd_end_s, rtcal_s, frt):
    """Step 2 over every BLF octave of ``hyps`` (each at its own working rate): ``(best,
    n_tests)``, best = (:func:`_search` result, working-rate window, decimation) or None."""
    best, n_tests = None, 0
    for band in _bands(hyps):
        d = max(1, int(fs / (2.0 * max(h.blf_hi_hz for h in band) * SAMPLES_PER_ELEMENT)))
        lags = _Lags(fs, d, i0, cmd_end_s, rtcal_s, frt)
        rd = boxcar_decimate(r, d) if d > 1 else r
        cand, nt = _search(rd, fs / d, band, lags.lo, lags.hi)
        n_tests += nt
        if cand is not None and (best is None or cand[0] > best[0][0]):
            best = (cand, rd, d)
    return best, n_tests


def _n_lags(r_size, fs, hyp, lo_of, hi_of) -> int:
    """Lags :func:`_search` tests for ``hyp`` on a working-rate window of ``r_size`` samples
    (the kernel's skip rules), without searching."""
    step_c = 1.0 / (2.0 * _n_pre_elements(hyp.m, hyp.trext))
    blfs = _geometric_grid(hyp.blf_lo_hz, hyp.blf_hi_hz, step_c)
    lo, hi = _per_blf(lo_of, blfs), _per_blf(hi_of, blfs)
    n_rep = (np.ceil(_n_elements(0, hyp.m, hyp.trext) * fs / (2.0 * blfs)) + 2).astype(np.int64)
    n = np.floor(_n_pre_elements(hyp.m, hyp.trext) * fs / (2.0 * blfs)).astype(np.int64)
    last = np.minimum(hi, r_size - n_rep)
    ok = (2.0 * blfs * MIN_SAMPLES_PER_ELEMENT <= fs) & (last >= lo) & (n >= 3)
    return int(np.sum((last - lo + 1)[ok]))


def _detect(r, fs, hyps, i0, cmd_end_s, rtcal_s, frt, blf_hint_hz, false_alarm_probability):
    """Step 2 with its threshold: ``(found, working-rate window, decimation)`` or None.

    With ``blf_hint_hz`` (the BLF of the reply before) and one hypothesis, the BLFs within
    ±2 coarse steps of the hint are searched first, at the working rate of the full search;
    their best is kept if it does not lie at an inner edge of the narrow range (a tag with
    another BLF) and clears the threshold of the narrow and the full search's tests together
    (the full search's lags counted, not searched), otherwise the full range is searched,
    with the same threshold: the union bound of the detection rule then covers both
    searches, so the false-alarm probability per window stays as stated."""
    if blf_hint_hz is not None and len(hyps) == 1 and hyps[0].blf_lo_hz <= blf_hint_hz <= hyps[0].blf_hi_hz:
        hyp = hyps[0]
        span = 2.0 / (2.0 * _n_pre_elements(hyp.m, hyp.trext))
        lo_n, hi_n = max(hyp.blf_lo_hz, blf_hint_hz * (1 - span)), min(hyp.blf_hi_hz, blf_hint_hz * (1 + span))
        n_full, n_narrow, narrow = 0, 0, None
        for band in _bands(hyps):
            b = band[0]
            d = max(1, int(fs / (2.0 * b.blf_hi_hz * SAMPLES_PER_ELEMENT)))
            lags = _Lags(fs, d, i0, cmd_end_s, rtcal_s, frt)
            n_full += _n_lags(r.size // d, fs / d, b, lags.lo, lags.hi)
            a, z = max(b.blf_lo_hz, lo_n), min(b.blf_hi_hz, hi_n)
            if a < z:
                rd = boxcar_decimate(r, d) if d > 1 else r
                cand, nt = _search(rd, fs / d, [LinkHypothesis(hyp.m, hyp.trext, a, z)], lags.lo, lags.hi)
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
    best, n_tests = _search_bands(r, fs, hyps, i0, cmd_end_s, rtcal_s, frt)
    n_tests += n_narrow
    if best is None or not best[0][0] >= preamble_threshold(best[0][5], n_tests, false_alarm_probability):
        return None
    return best


def _hypotheses(query: ReaderCommandRecord | None, learned, *, blf_hz, trcal_s, dr, m, trext, blf_tolerance):
    """``(hypotheses, frt)`` for the reply after a command: the line code of the last Query
    (or the caller's), BLF = DR/TRcal·(1 ± FrT) or the given BLF·(1 ± tolerance); what is not
    known is searched blind (:data:`BLIND_BLF_RANGE_HZ`, every M and TRext), unless an
    earlier reply in the capture (``learned`` = (m, trext, blf)) already told it."""
    f = query.fields if query is not None else {}
    m = f.get("m") if m is None else m
    trext = f.get("trext") if trext is None else trext
    dr = f.get("dr") if dr is None else dr
    trcal = (query.trcal_s if query is not None else math.nan) if trcal_s is None else trcal_s
    frt = FRT_UNKNOWN
    if dr is not None and not math.isnan(trcal):
        lo_s, hi_s = TRCAL_TABLE_RANGE_S[dr]
        # a TRcal measured within 5 % outside the table (edge quantisation, reader clock)
        # takes the nearest row
        t = min(max(trcal, lo_s), hi_s) if 0.95 * lo_s <= trcal <= 1.05 * hi_s else trcal
        try:
            frt = frt_fraction(dr, t)
        except ConfigError:
            pass
    if blf_hz is not None:
        blf, tol = float(blf_hz), 0.02 if blf_tolerance is None else blf_tolerance
    elif dr is not None and not math.isnan(trcal):
        blf, tol = float(DR_VALUES[dr]) / trcal, frt if blf_tolerance is None else blf_tolerance
    else:
        blf, tol = None, None
    if blf is None and m is None and trext is None and learned is not None:
        m, trext, blf = learned
        tol = 0.1 if blf_tolerance is None else blf_tolerance
    lo, hi = (BLIND_BLF_RANGE_HZ if blf is None else (blf * (1 - tol), blf * (1 + tol)))
    ms = M_VALUES if m is None else (int(m),)
    trexts = (False, True) if trext is None else (bool(trext),)
    return [LinkHypothesis(mm, tt, lo, hi) for mm in ms for tt in trexts], frt


def decode_tag_replies(samples, fs_hz: float, records: list[ReaderCommandRecord], *,
                       blf_hz: float | None = None, trcal_s: float | None = None, dr=None,
                       m: int | None = None, trext: bool | None = None, blf_tolerance: float | None = None,
                       method: str = "viterbi", false_alarm_probability: float = 1e-3,
                       max_blind_misses: int = 4) -> list[TagReplyRecord]:
    """Find and decode the tag reply after every command of ``records`` that elicits one
    (:data:`REPLY_KIND`; ``records`` from :func:`rfsim.gen2.capture.decode_reader_commands`).

    Parameters
    ----------
    samples : (n,) complex baseband capture or real envelope, arbitrary scale
    fs_hz : sample rate [Hz]
    records : the reader commands found in ``samples``
    blf_hz : the tags' BLF [Hz]; default DR/TRcal of the last Query (TRcal measured), else
        searched blind
    trcal_s, dr, m, trext : override the last Query's measured TRcal [s] and parsed DR
        ("8" or "64/3"), M (1, 2, 4, 8) and TRext
    blf_tolerance : relative BLF search range; default FrT when the BLF comes from TRcal,
        2 % when ``blf_hz`` is given
    method, false_alarm_probability : see :func:`decode_tag_reply`
    max_blind_misses : a blind search (no Query, no link given) costs about a second per
        window; after this many blind windows without a reply the remaining windows that would
        need one are not searched (give the link, or a capture with a Query, to search them).
        Once a reply has told the link (M, TRext, BLF), later windows are searched with it
        first (BLF ± 10 %), and blind only when that finds no reply (a tag with another link)

    The reply after command k is searched from half a Tari after its last rising edge up to
    half a Tari before command k + 1 (or the capture's end), its start within the T1 window
    of the BLF range searched (RTcal measured on the command). Returns the replies found,
    in time order.
    """
    fs = float(fs_hz)
    if not (math.isfinite(fs) and fs > 0):
        raise ValueError(f"fs_hz must be > 0, got {fs_hz}")
    if blf_hz is not None and not (math.isfinite(blf_hz) and blf_hz > 0):
        raise ConfigError("blf", blf_hz, "a positive frequency in Hz")
    if trcal_s is not None and not (math.isfinite(trcal_s) and trcal_s > 0):
        raise ConfigError("trcal", trcal_s, "a positive duration in s")
    if dr is not None:
        dr = normalize_dr(dr, "dr")
    if m is not None and m not in M_VALUES:
        raise ConfigError("m", m, "1 (FM0), 2, 4 or 8 (Miller)")
    if blf_tolerance is not None and not 0.0 <= blf_tolerance < 0.5:
        raise ConfigError("blf_tolerance", blf_tolerance, "a fraction in [0, 0.5)")
    out: list[TagReplyRecord] = []
    query, learned, blind_misses = None, None, 0
    n = np.asarray(samples).size
    for k, rec in enumerate(records):
        if rec.name == "Query" and rec.fields:
            query = rec
        kind = REPLY_KIND.get(rec.name)
        if kind is None or not rec.fields or math.isnan(rec.end_s):
            continue
        link = dict(blf_hz=blf_hz, trcal_s=trcal_s, dr=dr, m=m, trext=trext, blf_tolerance=blf_tolerance)
        hyps, frt = _hypotheses(query, None, **link)
        blind = len(hyps) > 1 and hyps[0].blf_lo_hz == BLIND_BLF_RANGE_HZ[0]
        # an earlier reply told the link: it is tried first, the blind search only when it
        # finds no reply (a tag with another link)
        tries = ([_hypotheses(query, learned, **link)] if blind and learned is not None else []) + [(hyps, frt)]
        tari = rec.tari_s if not math.isnan(rec.tari_s) else 0.0
        cut_s = records[k + 1].start_s if k + 1 < len(records) else n / fs
        found = None
        for hyps_k, frt_k in tries:
            searching_blind = blind and hyps_k is hyps
            if searching_blind and blind_misses >= max_blind_misses:
                break
            found = decode_tag_reply(samples, fs, listen_s=rec.end_s + 0.5 * tari,
                                     window_end_s=cut_s - (0.5 * tari if k + 1 < len(records) else 0.0),
                                     cmd_end_s=rec.end_s, rtcal_s=rec.rtcal_s, frt=frt_k, hypotheses=hyps_k,
                                     kind=kind, n_bits_of=_n_bits_rule(kind, rec), max_bits=_max_bits(kind, rec),
                                     cut_s=cut_s, method=method, false_alarm_probability=false_alarm_probability,
                                     command_index=k, command=rec.name,
                                     blf_hint_hz=out[-1].blf_hz if out and not searching_blind else None)
            if found is not None:
                break
            if searching_blind:
                blind_misses += 1
        if found is not None:
            out.append(found)
            if query is None and blf_hz is None:
                learned = (found.m, found.trext, found.blf_hz)
    return out


__all__ = [
    "REPLY_KIND",
    "FRT_UNKNOWN",
    "BLIND_BLF_RANGE_HZ",
    "MIN_HALFBIT_SNR_DB",
    "TagReplyRecord",
    "LinkHypothesis",
    "boxcar_decimate",
    "preamble_correlation",
    "decode_tag_reply",
    "decode_tag_replies",
]

"""Steps 3–5 of the capture reply decoder (:mod:`rfsim.gen2.replies`) after a detection: the
BLF from the reply itself, its length, timing tracking on the tag's clock and the
measurements with their E_h/N₀ gate (the "track" timing step of the one reply decoder's
"link" plan, :func:`rfsim.gen2.reply_decoder.decode`).

:func:`_decode_window` runs them in one numba kernel (``decode_window_kernel`` of
:mod:`rfsim.gen2._reply_kernels`) when the reply's length follows one of the rules of
:class:`_NBitsRule`; with any other ``n_bits_of`` callable the same steps run in plain
NumPy (:func:`_decode_window_python`, :func:`_fine_python`, :func:`_track_decode_python`),
which the tests also hold the kernels to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.gen2.bits import bits_to_int
from rfsim.gen2.capture import fit_gain_offset
from rfsim.gen2.linecode import _preamble, decode_reply, reply_waveform
from rfsim.gen2.reply_core import FINE_SPAN_STEPS, n_pre_elements, n_reply_elements
from rfsim.gen2.reply_search import _preamble_template
from rfsim.gen2.reply_tracking import (MIN_DRIFT_BLOCKS, MIN_TRACK_BLOCKS, SUBSAMPLES, TRACK_BLOCK_ELEMENTS, TRACK_SPANS,
                                      resample, track_reference, warp_positions)
from rfsim.core.lazy import lazy_import

_rk = lazy_import("rfsim.gen2._reply_kernels")
_rck = lazy_import("rfsim.gen2._reply_core_kernels")

#: Smallest energy per half-bit over the noise of a reported reply (step 5).
MIN_HALFBIT_SNR_DB = 6.0
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
    :func:`_fine_python` is its plain-NumPy strategy)."""
    pre, state = _preamble(m, trext)
    bits = np.empty(int(n_bits), dtype=np.uint8)
    blfs = np.ascontiguousarray(blfs, dtype=np.float64)
    # the kernel reads no sample after the last start + reply of a BLF: the rest is not passed
    rho = 2.0 * blfs / fs
    n_rep = np.ceil(n_reply_elements(n_bits, m, trext) / rho) + 2
    cut = min(r.size, int(math.ceil(float(np.max(centre - 0.5 * n_pre_elements(m, trext) / rho + n_rep)))) + 1)
    j, resid, start = _rk.fine_kernel(np.ascontiguousarray(r[:max(cut, 0)], dtype=np.complex128), float(centre), int(n_bits), int(m),
                                  pre, state, blfs, float(fs),
                                  method == "viterbi", bits)
    return None if j < 0 else (float(blfs[j]), bits, float(start), float(resid))


def _fine_python(r, centre, n_bits, m, trext, blfs, fs, method):
    """:func:`_fine` in plain NumPy (decode_reply, reply_waveform and the fit per BLF): the strategy of
    :func:`_decode_window_python`, and the tests' twin of ``fine_kernel``."""
    best = None
    half = 0.5 * n_pre_elements(m, trext)
    for blf in blfs:
        rho = 2.0 * blf / fs
        start = centre - half / rho
        n_rep = int(math.ceil(n_reply_elements(n_bits, m, trext) / rho)) + 2
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


def _correlation_at(seg: np.ndarray, template0: np.ndarray) -> float:
    """:func:`preamble_correlation` at the one lag where ``seg`` (as long as the template)
    starts: |Σ seg·t0| / (‖t0‖·‖seg − mean(seg)‖)."""
    n = template0.size
    energy = float(np.sum(seg.real * seg.real + seg.imag * seg.imag)) - abs(complex(seg.sum())) ** 2 / n
    return abs(complex(seg @ template0)) / (math.sqrt(float(template0 @ template0)) * math.sqrt(max(energy, 1e-300)))


def _bits_that_fit(n_avail: float, m: int, trext: bool, rho: float) -> int:
    """Data bits (dummy excluded) of a reply whose preamble starts ``n_avail`` samples before
    the end of the window (ρ elements per sample)."""
    elements = n_avail * rho - 2 * rho
    return int(math.floor((elements - n_pre_elements(m, trext)) / (2 * m))) - 1


def _reply_end(start: float, n_bits: int, m: int, trext: bool, rho: float, dummy: bool) -> int:
    """First sample after the reply's decoded part (dummy 1 included if ``dummy``)."""
    n_el = n_reply_elements(n_bits, m, trext) - (0 if dummy else 2 * m)
    return int(math.ceil(start + n_el / rho))


def _decode_length(r, fs, centre, blf, bits, start, step_first, n_first, n_bits, truncated, m, trext, method):
    """Step 3 (whole reply) and step 4 for a reply of ``n_bits`` data bits; ``blf`` the BLF
    found on the first ``n_first`` bits to a step ``step_first`` (relative). Returns (bits,
    start, u1, u2, resampled window, its rest samples before the reply, BLF) or None; the
    plain-NumPy steps of :func:`_decode_window_python`."""
    if n_bits > n_first:
        # the whole reply is searched across ±FINE_SPAN_STEPS steps of the first bits' search
        # around its BLF, on a grid no coarser than 1/(2·elements): the residual of the whole
        # reply has a minimum about 1/elements wide in BLF, which a coarser grid can step over
        # (and then settle on a wrong BLF whose decoded bits fit the noise a little better)
        n_el = n_reply_elements(n_bits, m, trext)
        span = FINE_SPAN_STEPS * step_first
        again = _fine_search(r, centre, n_bits, m, trext, blf, span, _rck.blf_resolution(n_el),
                             max(2, int(math.ceil(span * 2.0 * n_el))), fs, method, _fine_python)
        if again is not None:
            blf, bits, start = again[:3]
    out = _track_decode_python(r, fs, blf, bits[:n_bits].astype(np.uint8), start, truncated, m, trext, method)
    return None if out is None else out + (blf,)


def _track_decode(r, fs, blf, bits, start, truncated, m, trext, method):
    """Step 4 (timing tracking, resampling on the tag's clock, decoding again) of a reply
    decoded as ``bits`` from ``start`` at ``blf``: ``(bits, start, u1, u2, resampled window,
    its rest samples before the reply)`` or None (numba kernel ``track_decode_kernel``;
    :func:`_track_decode_python` is its plain-NumPy strategy)."""
    bits = np.array(bits, dtype=np.uint8)
    rho = 2.0 * blf / fs
    n_rest = int(min(start, 256))
    pre, state = _preamble(m, trext)
    rw = np.empty(n_rest + _reply_end(0.0, bits.size, m, trext, rho, True) + 4, dtype=np.complex128)
    sub = (np.arange(SUBSAMPLES) + 0.5) / SUBSAMPLES - 0.5
    ok, start, u1, u2 = _rk.track_decode_kernel(
        np.ascontiguousarray(r, dtype=np.complex128), float(start), rho, float(fs), bits, int(m), pre, state,
        not truncated, method == "viterbi", TRACK_BLOCK_ELEMENTS,
        MIN_TRACK_BLOCKS, np.array(TRACK_SPANS, dtype=np.float64), sub, MIN_DRIFT_BLOCKS, TRACK_CONVERGED_ELEMENTS,
        n_rest, rw)
    return (bits, float(start), float(u1), float(u2), rw, n_rest) if ok else None


def _track_decode_python(r, fs, blf, bits, start, truncated, m, trext, method):
    """:func:`_track_decode` in plain NumPy (:func:`rfsim.gen2.reply_tracking.track`,
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
    :func:`_decode_window_python`, its plain-NumPy strategy, decodes with any other rule)."""
    if not isinstance(n_bits_of, _NBitsRule):
        return _decode_window_python(r, fs, found, n_bits_of, method)
    _, blf_c, hyp, start_c, step_c, _ = found
    m, trext = hyp.m, hyp.trext
    pre, state = _preamble(m, trext)
    r = np.ascontiguousarray(r, dtype=np.complex128)
    bits = np.empty(max(16, _bits_that_fit(r.size, m, trext, 2.0 * blf_c / fs) + 1), dtype=np.uint8)
    (ok, n_bits, start, u1, u2, blf, truncated, n_full, n_rest, h, sigma2, corr, n_span) = _rk.decode_window_kernel(
        r, float(fs), float(blf_c), float(start_c), float(step_c), int(m), pre, state,
        method == "viterbi", n_bits_of.rule, n_bits_of.fixed, float(FINE_SPAN_STEPS),
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


def _decode_window_python(r, fs, found, n_bits_of, method):
    """:func:`_decode_window` in plain NumPy (:func:`_fine_python`, :func:`_track_decode_python`
    and the fits written out): the strategy for an ``n_bits_of`` that is not an
    :class:`_NBitsRule`, and the tests' twin of ``decode_window_kernel``."""
    corr, blf_c, hyp, start_c, step_c, _ = found
    m, trext = hyp.m, hyp.trext
    rho_c = 2.0 * blf_c / fs
    centre = start_c + 0.5 * n_pre_elements(m, trext) / rho_c
    # step 3: fine BLF over the first 16 bits (or what fits), then the whole reply
    n_first = max(0, min(16, _bits_that_fit(r.size - start_c, m, trext, rho_c)))
    step_16 = _rck.blf_resolution(n_reply_elements(n_first, m, trext))
    fine = _fine_search(r, centre, n_first, m, trext, blf_c, FINE_SPAN_STEPS * step_c, step_16, 8, fs, method,
                        _fine_python)
    if fine is None:
        return None
    blf, bits0, start, resid = fine
    for shift in START_CHECK_SHIFTS:  # whole-element shifts of the start (decode_window_kernel)
        c = centre + shift / (2.0 * blf / fs)
        alt = _fine_python(r, c, n_first, m, trext, np.array([blf]), fs, method)
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


def fixed_length(n_bits: int) -> _NBitsRule:
    """The ``n_bits_of`` rule of a reply whose length is known, ``n_bits`` data bits (the reader's
    replies, :func:`rfsim.gen2.reply_decoder.decode` with timing tracking).

    Parameters
    ----------
    n_bits : int
        Data bits of the reply (without the dummy 1).

    Returns
    -------
    _NBitsRule
        The rule (the compiled ``decode_window_kernel`` reads it).
    """
    return _NBitsRule(_rk.RULE_FIXED, int(n_bits))


__all__ = ["MIN_HALFBIT_SNR_DB", "FINE_SPAN_STEPS", "TRACK_CONVERGED_ELEMENTS", "START_CHECK_SHIFTS"]

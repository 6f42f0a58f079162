"""The one tag-reply decoder: :func:`decode` with a :class:`DecodePlan`.

The reader in the loop (:meth:`rfsim.devices.reader.Reader.receive`) and the capture decoder
(``rfsim decode``, :func:`rfsim.gen2.replies.decode_tag_reply`) both call :func:`decode`; what
differs between them is the plan's ``search`` and its parameters, built once per link (the
reader keeps its plans in the run's :class:`rfsim.air.cache.AirCache`, :class:`LinkPlans`).

Map of the steps
----------------

One column per ``search`` of the plan ("known", "blf", "link").

==========================  ======================  ======================  =====================================
step                        "known" (reader, one    "blf" (reader,          "link" (captures: blind or given
                            BLF)                    ``blf_search``)         link, ``rfsim decode``)
==========================  ======================  ======================  =====================================
conditioning (DC)           r − mean(r[:lo]),       the same, in Python     r − Σr[:lo]/lo by the caller (also
                            lo ≥ 8, in the kernel   (here)                  for the onsets of a delayed reply)
working rate                fs                      fs                      boxcar means of D samples per BLF
                                                                            octave (:mod:`~rfsim.gen2.reply_search`)
link hypotheses             (M, TRext) of the plan  (M, TRext) of the plan  :attr:`DecodePlan.hypotheses`
BLF hypotheses              one (given or nominal)  coarse grid of          coarse grid per hypothesis; first
                                                    ``blf_grid_hz``, or     ±2 steps around ``blf_hint_hz``
                                                    the hint ±
                                                    1/(RN16 el.)
preamble search             every lag lo…hi,        every lag × BLF,        T1 lags × BLF per hypothesis
                            runs + 1/16-sample      parabola between lags   (``preamble_search_kernel``),
                            refinement                                      parabola between lags
false alarm                 ``preamble_threshold``  the same over lags ×    the same over every lag and
                            over the lags (memo in  grid size (nominal      hypothesis tested (union bound)
                            plan)                   preamble length)
fine BLF                    —                       centre held, coarse to  centre held, first 16 bits then the
                                                    fine, least residual    whole reply, whole-element start
                                                                            checks
reply length                fixed ``n_bits``        fixed ``n_bits``        from its first bits (``n_bits_of``:
                                                                            RN16, EPC's PC, read header), cut
                                                                            replies truncated
(h, c)                      LS on known levels      in the kernel's fit;    LS over the remodulated reply
                                                    the reader refits on
                                                    known levels
timing tracking             —                       —                       ``track_timing``: blocks of 24
                                                                            elements, quadratic clock, resample
decisions                   half-bit sums +         the same kernels        the same kernels
                            Viterbi/bitwise (the
                            kernels of
                            ``halfbit_decisions``)
CRC                         the caller (reader:     the caller (reader:     the caller (the record's
                            ``crc16_ok``)           ``crc16_ok``)           fields)
measurements                gain, Doppler slope,    gain, σ², σ_eff²        gain, σ² and the E_h/N₀ gate,
                            σ² (the kernel          (Eb/(N0+I))             BLF drift, the correlation at the
                            ``measure_kernel``)                             decoded start
==========================  ======================  ======================  =====================================

Each strategy runs its steps as one numba call where it did before (``receive_kernel``,
``search_decode_kernel``, ``preamble_search_kernel`` + ``decode_window_kernel``); the shared
steps inside them are written once (:mod:`rfsim.gen2.reply_core`,
:mod:`rfsim.gen2._reply_core_kernels`). Where the strategies still compute a shared step in a
different order (the sums of ``|r|²``, the segment mean, the fine BLF grid, …) the difference is
listed in :mod:`rfsim.gen2.reply_core`; records stay bit-identical to the separate
orchestrations this module replaces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from rfsim.gen2.capture import preamble_threshold
from rfsim.gen2.linecode import METHODS, search_arrays
from rfsim.gen2.reply_core import n_pre_elements
from rfsim.core.lazy import lazy_import

_rxk = lazy_import("rfsim.gen2._receive_kernels")

__all__ = ["DOPPLER_BLOCKS", "SEARCHES", "DecodePlan", "DecodedReply", "CaptureTiming", "LinkPlans", "decode"]

#: Blocks of the reply of the "known" search's Doppler fit (``measure_kernel``).
DOPPLER_BLOCKS = 8
#: The searches of :class:`DecodePlan` (module docstring).
SEARCHES = ("known", "blf", "link")

#: The message of the ValueError of each error status of the receive kernel.
_RECEIVE_ERRORS = {2: "zero channel gain: no reply to decode",
                   3: "the decoded reply start leaves no room for the reply",
                   4: "the input is shorter than the reply",
                   5: "the reference s is constant: gain and offset cannot be separated"}
#: Entries of a plan's memo tables before they are cleared.
_MEMO_SIZE = 64


class _Detection(NamedTuple):
    """Preamble length [samples] at one BLF and the detection threshold γ for some lags."""

    preamble_samples: int
    threshold: float


@dataclass(frozen=True, eq=False)
class DecodePlan:
    """What :func:`decode` does, fixed per link (module docstring: the map of the steps).

    Attributes
    ----------
    search : str
        One of :data:`SEARCHES`: "known" (one BLF), "blf" (BLF search on a grid, or around a
        hint), "link" (link hypotheses at a working rate, captures).
    fs_hz : float
        Sample rate of the windows [Hz].
    m, trext : int, bool
        Line code ("known", "blf"): Miller M (1 = FM0), pilot tone.
    method : str
        "viterbi" or "bitwise" decisions.
    false_alarm_probability : float
        P(false alarm) per window of the detection threshold.
    blf_hz : float
        Nominal BLF [Hz] ("known": the BLF decoded at unless one is given; "blf": the preamble
        length of the threshold).
    blf_grid_hz : numpy.ndarray or None
        ``(K,)`` coarse BLF hypotheses [Hz] of the "blf" search (read-only).
    hypotheses : tuple
        :class:`rfsim.gen2.reply_search.LinkHypothesis` of the "link" search.
    track_timing : bool
        Follow the tag's clock (timing tracking, resampling): the "link" search.
    dc_from_lead : bool
        "blf": subtract the mean of the samples before the first start searched (≥ 8 of
        them) before the search (the reader; the capture sweep's synthetic windows are
        searched as drawn).
    memo : dict
        Values derived from the plan and a call's BLF or lag count (named tables ``"arrays"``,
        ``"detection"``; the "link" search's ``"grids"`` and ``"bands"``, the BLF grid of each
        hypothesis and the hypotheses by BLF octave), bounded.
    """

    search: str
    fs_hz: float
    m: int = 1
    trext: bool = False
    method: str = "viterbi"
    false_alarm_probability: float = 1e-3
    blf_hz: float = math.nan
    blf_grid_hz: np.ndarray | None = None
    hypotheses: tuple = ()
    track_timing: bool = False
    dc_from_lead: bool = True
    memo: dict = field(default_factory=lambda: {"arrays": {}, "detection": {}}, repr=False)

    def __post_init__(self):
        if self.search not in SEARCHES:
            raise ValueError(f"search must be one of {SEARCHES}, got {self.search!r}")
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        if self.track_timing != (self.search == "link"):
            raise ValueError("timing tracking is a step of the 'link' search only")

    def arrays(self, blf_hz: float):
        """The preamble search's arrays at ``blf_hz`` (:func:`rfsim.gen2.linecode.search_arrays`),
        kept in the plan.

        Parameters
        ----------
        blf_hz : float
            BLF [Hz].

        Returns
        -------
        rfsim.gen2.linecode.SearchArrays
            The read-only arrays.
        """
        table = self.memo["arrays"]
        hit = table.get(blf_hz)
        if hit is None:
            if len(table) >= _MEMO_SIZE:
                table.clear()
            hit = table[blf_hz] = search_arrays(self.m, self.trext, 2.0 * blf_hz / self.fs_hz)
        return hit

    def detection(self, n_lags: int, blf_hz: float) -> _Detection:
        """Preamble samples ⌊elements·fs/(2·BLF)⌋ and the threshold of
        :func:`rfsim.gen2.capture.preamble_threshold` for ``n_lags`` tests, kept in the plan.

        Parameters
        ----------
        n_lags : int
            Tests (lags × BLF hypotheses) of the search.
        blf_hz : float
            BLF of the preamble length [Hz].

        Returns
        -------
        _Detection
            ``(preamble_samples, threshold)``.
        """
        table = self.memo["detection"]
        key = (n_lags, blf_hz)
        hit = table.get(key)
        if hit is None:
            if len(table) >= _MEMO_SIZE:
                table.clear()
            n = int(math.floor(n_pre_elements(self.m, self.trext) * self.fs_hz / (2.0 * blf_hz)))
            hit = table[key] = _Detection(n, preamble_threshold(n, n_lags, self.false_alarm_probability))
        return hit


class CaptureTiming(NamedTuple):
    """Where the "link" search looks for a reply in a capture window (:class:`rfsim.gen2.reply_search._Lags`).

    Attributes
    ----------
    i0 : int
        Capture sample of the window's first sample.
    cmd_end_s, rtcal_s, frt : float
        The command's last rising edge [s], its RTcal [s] and the BLF tolerance (T1 window).
    delay_max_s : float
        T1 max extended by this for a delayed reply [s].
    spans_s : tuple
        Spans of reply starts searched in turn (``None``: the whole T1 window).
    n_bits_of : callable
        The complete reply's data bits from its first decoded bits (−1 unknown).
    """

    i0: int
    cmd_end_s: float
    rtcal_s: float
    frt: float
    delay_max_s: float
    spans_s: tuple
    n_bits_of: object


class DecodedReply(NamedTuple):
    """What :func:`decode` found in a window (NaN / None where a search does not measure it).

    Attributes
    ----------
    found : bool
        A reply cleared the detection threshold (and, "link", the E_h/N₀ gate).
    start : float
        Reply start [samples of the window; "link": of the working rate].
    corr : float
        Normalised preamble correlation.
    bits : numpy.ndarray or None
        Decoded data bits (uint8).
    blf_hz : float
        BLF decoded at [Hz] (NaN: "known", the BLF given).
    gain : complex
        h [unit of the samples].
    sigma2 : float
        Residual power per sample.
    slope : float
        "known": phase slope of h [rad/s].
    decision_ebn0_db : float
        "blf": Eb/(N0 + I) in the decision domain [dB].
    window : numpy.ndarray or None
        "blf": the window after the DC conditioning (its measurements read it).
    extra : dict or None
        "link": drift, truncated, n_full, end, m, trext, the working rate's decimation.
    """

    found: bool
    start: float
    corr: float
    bits: np.ndarray | None = None
    blf_hz: float = math.nan
    gain: complex = complex(math.nan, math.nan)
    sigma2: float = math.nan
    slope: float = math.nan
    decision_ebn0_db: float = math.nan
    window: np.ndarray | None = None
    extra: dict | None = None


class LinkPlans:
    """The reader's decode plans of one (frozen) link profile, by (search, fs, method, P_FA).

    Kept in the run's cache with the link (``air_cache.derived(link, LinkPlans)``).

    Parameters
    ----------
    link : rfsim.gen2.link.LinkProfile
        The link (M, TRext, nominal BLF and its tolerance).
    """

    def __init__(self, link):
        self.link = link
        self.plans: dict = {}

    def plan(self, search: str, fs_hz: float, method: str, false_alarm_probability: float,
             dc_from_lead: bool = True) -> DecodePlan:
        """The plan of ``search`` for this link at ``fs_hz`` (made once).

        Parameters
        ----------
        search : str
            "known" or "blf".
        fs_hz : float
            Sample rate [Hz].
        method : str
            "viterbi" or "bitwise".
        false_alarm_probability : float
            P(false alarm) per window.
        dc_from_lead : bool, optional
            :attr:`DecodePlan.dc_from_lead`, default True.

        Returns
        -------
        DecodePlan
            The plan.
        """
        key = (search, fs_hz, method, false_alarm_probability, dc_from_lead)
        hit = self.plans.get(key)
        if hit is None:
            from rfsim.gen2.blf_search import blf_grid_hz

            lk = self.link
            grid = None
            if search == "blf":
                grid = blf_grid_hz(lk)
                grid.flags.writeable = False
            hit = self.plans[key] = DecodePlan(search, float(fs_hz), lk.m, lk.trext, method,
                                               false_alarm_probability, lk.blf_hz, grid,
                                               dc_from_lead=dc_from_lead)
        return hit


def decode(r: np.ndarray, plan: DecodePlan, *, lo: int = 0, hi: int = -1, n_bits: int = 16, n_reply: int = 0,
           blf_hz: float | None = None, blf_hint_hz: float | None = None,
           timing: CaptureTiming | None = None, threads: int = 1) -> DecodedReply:
    """Detect and decode one tag reply in the window ``r`` as ``plan`` says (module docstring).

    Parameters
    ----------
    r : numpy.ndarray
        ``(n,) complex128`` window ``h·s(t) + c + noise`` (any unit, any constant offset c);
        "blf" also ``(B, n)``, a batch of windows (then every field of the result is an array
        over them, ``bits`` ``(B, n_bits)``, and ``extra`` holds ``ebn0_db``).
    plan : DecodePlan
        The search and its parameters.
    lo, hi : int
        "known", "blf": first and last reply start searched [samples].
    n_bits : int
        "known", "blf": data bits of the reply (without the dummy 1).
    n_reply : int
        "known": samples of the whole reply at the BLF decoded at.
    blf_hz : float or None
        "known": the BLF [Hz]; default the plan's.
    blf_hint_hz : float or None
        A BLF measured on an earlier reply of the same tag [Hz]: "blf" decodes at it within
        1/(RN16 elements); "link" searches ±2 coarse steps around it first.
    timing : CaptureTiming or None
        "link": where the reply may start and how long it is.
    threads : int
        "blf" on a batch ``r`` of shape ``(B, n)``: threads of the BLF search (the result does
        not depend on it).

    Returns
    -------
    DecodedReply
        The detection, decoded bits and measurements.

    Raises
    ------
    ValueError
        From the "known" kernel, when the window leaves nothing to decode (zero gain, no room
        for the reply, a constant reference).
    """
    if plan.search == "known":
        return _decode_known(r, plan, lo, hi, n_bits, n_reply, plan.blf_hz if blf_hz is None else blf_hz)
    if plan.search == "blf":
        return _decode_blf(r, plan, lo, hi, n_bits, blf_hint_hz, threads)
    return _decode_link(r, plan, timing, blf_hint_hz)


def _decode_known(rx, plan, lo, hi, n_bits, n_reply, blf) -> DecodedReply:
    """The "known" search: ``receive_kernel`` (detection, (h, c) on the known levels,
    decisions, measurements) at one BLF."""
    a = plan.arrays(blf)
    pre_n, threshold = plan.detection(hi - lo + 1, blf)
    det_bits, bits = np.empty(n_bits + 1, dtype=np.uint8), np.empty(n_bits + 1, dtype=np.uint8)
    out_f, out_c = np.empty(4), np.empty(1, dtype=np.complex128)
    status = _rxk.receive_kernel(rx, lo, hi, n_reply, threshold, plan.fs_hz, blf, plan.m,
                                 pre_n, a.pre_el.size, a.t0, a.max_runs_per_sample, a.half_width,
                                 a.shifts, a.templates, a.norms, a.run_begin, a.run_value, a.n_runs,
                                 a.same_as_previous, a.pre_el, a.pre_levels, a.state,
                                 plan.method != "bitwise", DOPPLER_BLOCKS, det_bits, bits, out_f, out_c)
    if status > _rxk.NOT_FOUND:
        raise ValueError(_RECEIVE_ERRORS[status])
    if status == _rxk.NOT_FOUND:
        return DecodedReply(False, float(out_f[0]), float(out_f[1]))
    return DecodedReply(True, float(out_f[0]), float(out_f[1]), bits[:n_bits], math.nan, complex(out_c[0]),
                        float(out_f[3]), float(out_f[2]))


def _decode_blf(rx, plan, lo, hi, n_bits, blf_hint_hz, threads) -> DecodedReply:
    """The "blf" search: :func:`rfsim.gen2.blf_search.search_decode` on the (conditioned)
    window, over the plan's grid or at the hint, then the detection threshold; ``rx`` 2-D: a
    batch of windows, every field an array over them."""
    from rfsim.gen2.blf_search import search_decode

    r = rx - (rx[:lo].mean() if lo >= 8 else 0.0) if plan.dc_from_lead else rx
    m, trext = plan.m, plan.trext
    if blf_hint_hz is not None:  # the tag's BLF is known from its RN16
        n_el16 = n_pre_elements(m, trext) + 2 * m * 17
        n_grid = 1
        out = search_decode(r, m=m, trext=trext, n_bits=n_bits, blfs_hz=np.array([blf_hint_hz]), fs_hz=plan.fs_hz,
                            lo=lo, hi=hi, known_within=1.0 / n_el16)
    else:
        n_grid = plan.blf_grid_hz.size
        out = search_decode(r, m=m, trext=trext, n_bits=n_bits, blfs_hz=plan.blf_grid_hz, fs_hz=plan.fs_hz, lo=lo,
                            hi=hi, threads=threads)
    threshold = plan.detection((hi - lo + 1) * n_grid, plan.blf_hz).threshold
    if r.ndim == 2:
        return DecodedReply(out.corr >= threshold, out.start, out.corr, out.bits, out.blf_hz, out.gain, out.sigma2,
                            math.nan, out.decision_ebn0_db, r, dict(ebn0_db=out.ebn0_db))
    start, blf, corr = float(out.start[0]), float(out.blf_hz[0]), float(out.corr[0])
    if corr < threshold:
        return DecodedReply(False, start, corr, window=r)
    return DecodedReply(True, start, corr, out.bits[0].astype(np.uint8), blf, complex(out.gain[0]),
                        float(out.sigma2[0]), math.nan, float(out.decision_ebn0_db[0]), r)


def _decode_link(r, plan, timing, blf_hint_hz) -> DecodedReply:
    """The "link" search: detection over the hypotheses and spans
    (:func:`rfsim.gen2.reply_search._detect`), then the fine BLF, the length, timing tracking
    and the E_h/N₀ gate (:func:`rfsim.gen2.reply_decoding._decode_window`)."""
    from rfsim.gen2.reply_decoding import _decode_window
    from rfsim.gen2.reply_search import _detect

    fs = plan.fs_hz
    best = None
    for span_s in timing.spans_s:
        best = _detect(r, fs, plan.hypotheses, timing.i0, timing.cmd_end_s, timing.rtcal_s, timing.frt, blf_hint_hz,
                       plan.false_alarm_probability, timing.delay_max_s, span_s, plan.memo)
        if best is not None:
            break
    if best is None:
        return DecodedReply(False, math.nan, math.nan)
    found, rd, d = best
    res = _decode_window(rd, fs / d, found, timing.n_bits_of, plan.method)
    if res is None:
        return DecodedReply(False, float(found[3]), float(found[0]))
    extra = dict(drift=res["drift"], truncated=res["truncated"], n_full=res["n_full"], end=res["end"], m=res["m"],
                 trext=res["trext"], decimation=d)
    return DecodedReply(True, float(res["start"]), float(res["corr"]), res["bits"], float(res["blf"]),
                        complex(res["h"]), float(res["sigma2"]), extra=extra)

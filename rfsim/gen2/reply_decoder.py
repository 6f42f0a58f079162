"""The one tag-reply decoder: :func:`decode` with a :class:`DecodePlan`.

The reader in the loop (:meth:`rfsim.devices.reader.Reader.receive`) and the capture decoder
(``rfsim decode``, :func:`rfsim.gen2.replies.decode_tag_reply`) both call :func:`decode`; what
differs between them is the plan's ``search`` and its parameters, built once per link (the
reader keeps its plans in the run's :class:`rfsim.air.cache.AirCache`, :class:`LinkPlans`).

Steps
-----

:func:`decode` is one orchestration: every call runs the steps of :data:`STEPS` in this order,
each in the variant its plan names (:attr:`DecodePlan.variants`, derived from the plan's fields
``search``, ``dc_from_lead``, ``refit``, ``track_timing``; the functions in :data:`VARIANTS`),
and stops after the search when there is no reply. Where a compiled kernel does several steps in
one call (``receive_kernel``, ``search_decode_kernel``, ``decode_window_kernel``: which steps each
computes is listed below, "Kernels that compute several steps"), the later steps take their
results from it. One column per ``search``:

============  ======================  ======================  =====================================
step          "known" (reader, one    "blf" (reader,          "link" (captures: blind or given
              BLF)                    ``blf_search``)         link, ``rfsim decode``)
============  ======================  ======================  =====================================
condition     "in kernel":            "lead": r − Σr[:lo]/lo  "lead": the same before the earliest
              r − mean(r[:lo]),       (lo ≥ 8; the capture    T1 start (:attr:`CaptureTiming.lead`)
              lo ≥ 8                  sweep: "none")
windows       "lags": lo…hi at one    "lags x grid": lo…hi ×  "t1": the T1 window, or a delayed
              BLF; threshold of       the BLF grid (or the    reply's spans around the onsets of
              hi − lo + 1 tests       hint ± 1/(RN16 el.));   modulation; working rate: boxcar
              (:meth:`DecodePlan.     threshold of lags ×     means of D samples per BLF octave
              detection`)             BLFs tests              (:mod:`~rfsim.gen2.reply_search`)
search        "one blf":              "blf grid":             "hypotheses": ``_detect``, T1 lags ×
              ``receive_kernel``,     ``search_decode``,      BLF per (M, TRext), parabola between
              runs + 1/16-sample      parabola between lags,  lags, union-bound threshold; first
              refinement              fine BLF (centre held)  ±2 steps around ``blf_hint_hz``
timing        "none"; "track" with    "none"; "track" with    "track": ``_decode_window``: fine BLF
              ``track_timing`` (the   ``track_timing``: the   (first 16 bits, then the whole reply),
              reader's): the same     same from the BLF       length from the first bits
              from the start found,   found (then condition   (``n_bits_of``), blocks of 24
              ``n_bits`` long; then   "lead" or "none",       elements, quadratic clock, resample
              condition "lead",       decisions and measure
              decisions and measure   "timing", no refit)
              "timing", no Doppler
decisions     "receive kernel":       "search kernel": the    "timing": the same kernels on the
              half-bit sums on        same kernels at the     resampled reply
              r − c with h given,     fine BLF
              Viterbi or bitwise
measure       "kernel": (h, c) on     "known levels" (the     "timing": LS over the remodulated
              the known levels,       reader, ``refit``): as  reply, σ², E_h/N₀ gate, BLF drift,
              gain, Doppler slope,    "known" at the BLF      the correlation at the decoded start
              σ² (``measure_kernel``  found; Eb/(N0 + I);
              in the kernel)          "search fit" (the
                                      capture sweep): h, σ²,
                                      Eb/(N0 + I) of the
                                      search
crc           "check": CRC-16 of the  the same                the same (asked for every reply kind
              bits when asked                                 but the RN16; None when truncated)
============  ======================  ======================  =====================================

Kernels that compute several steps
----------------------------------

Four compiled calls compute several steps in one call (splitting them would add numba calls
per reply); the variant in the first column calls it, the later steps' variants in the last
column take their results from it (:data:`KERNEL_STEPS`, the same table):

==========================  =====================  ===============================================
kernel                      called by              computes, for these step variants
==========================  =====================  ===============================================
``receive_kernel``          search "one blf"       condition "in kernel" (r − mean(r[:lo])); the
                                                   preamble search; decisions "receive kernel"
                                                   (first decisions, (h, c) on the known levels,
                                                   decisions on r − c); measure "kernel"
                                                   (``measure_kernel``: gain, Doppler slope, σ²)
``receive_batch_kernel``    search "one blf"       the same for a batch of B windows in one array
                                                   (:class:`Windows`; each its own length, ``lo``,
                                                   ``hi`` and threshold): a loop over
                                                   ``receive_kernel`` in one call, per-window
                                                   results in ``(B, …)`` arrays
``search_decode_kernel``    search "blf grid"      the coarse search over lags × BLF and the fine
(``search_decode``)                                BLF; decisions "search kernel" (at the fine
                                                   BLF); measure "search fit" (h, σ², Eb/(N0 + I))
                                                   and the Eb/(N0 + I) measure "known levels"
                                                   keeps
``decode_window_kernel``    timing "track"         the fine BLF, the reply's length, the tracked
(``_decode_window``)                               clock and resampling; decisions "timing"; the
                                                   fit of measure "timing" (h, σ², E_h/N₀ gate,
                                                   drift)
==========================  =====================  ===============================================

A plan whose later step reads a kernel's result always runs the variant that calls that kernel
(tests/test_each_rule_once.py). With the reader's ``track_timing`` the search's kernel still
computes its own decisions and measurement; the "timing" variants do not read them.

The shared steps inside the kernels are written once (:mod:`rfsim.gen2.reply_core`,
:mod:`rfsim.gen2._reply_core_kernels`). Where the searches still compute a shared step in a
different order (the sums of ``|r|²``, the segment mean, the fine BLF grid, …) the difference is
listed in :mod:`rfsim.gen2.reply_core`; records stay bit-identical to the separate
orchestrations this module replaces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial
from typing import NamedTuple

import numpy as np

from rfsim.gen2.capture import fit_gain_offset, preamble_threshold
from rfsim.gen2.crc import crc16_ok
from rfsim.gen2.linecode import METHODS, reply_waveform, search_arrays
from rfsim.gen2.reply_core import n_pre_elements
from rfsim.gen2.reply_search import _kept, modulation_onsets
from rfsim.core.lazy import lazy_import

_rxk = lazy_import("rfsim.gen2._receive_kernels")
_mk = lazy_import("rfsim.gen2._measure_kernels")

__all__ = ["DOPPLER_BLOCKS", "SEARCHES", "STEPS", "KERNEL_STEPS", "VARIANTS", "StepVariants", "DecodePlan",
           "DecodedReply", "CaptureTiming", "LinkPlans", "Windows", "decode"]

#: Blocks of the reply of the "known" search's Doppler fit (``measure_kernel``).
DOPPLER_BLOCKS = 8
#: The searches of :class:`DecodePlan` (module docstring).
SEARCHES = ("known", "blf", "link")

#: The compiled calls that compute several steps (module docstring, "Kernels that compute several
#: steps"): kernel → ((step, variant) that calls it, ((step, variant) that take its results, …)).
KERNEL_STEPS = {
    "receive_kernel": (("search", "one blf"), (("condition", "in kernel"), ("decisions", "receive kernel"),
                                                ("measure", "kernel"))),
    "receive_batch_kernel": (("search", "one blf"), (("condition", "in kernel"), ("decisions", "receive kernel"),
                                                      ("measure", "kernel"))),
    "search_decode_kernel": (("search", "blf grid"), (("decisions", "search kernel"), ("measure", "search fit"),
                                                      ("measure", "known levels"))),
    "decode_window_kernel": (("timing", "track"), (("decisions", "timing"), ("measure", "timing"))),
}

#: The message of the ValueError of each error status of the receive kernel.
_RECEIVE_ERRORS = {2: "zero channel gain: no reply to decode",
                   3: "the decoded reply start leaves no room for the reply",
                   4: "the input is shorter than the reply",
                   5: "the reference s is constant: gain and offset cannot be separated"}


class StepVariants(NamedTuple):
    """The variant of each step of :func:`decode` a plan runs (:data:`VARIANTS`; the field
    order is the order of the steps, :data:`STEPS`).

    Attributes
    ----------
    condition : str
        DC conditioning: "in kernel" (the search's kernel), "lead" (r − mean of the samples
        before the first start), "none" (as given).
    windows : str
        Candidate starts and their detection threshold: "lags" (one BLF), "lags x grid" (every
        BLF of the grid, or the hint), "t1" (the T1 window or, delayed, spans around the onsets
        of modulation).
    search : str
        Preamble / BLF search: "one blf", "blf grid", "hypotheses".
    timing : str
        "none" (the receiver's clock) or "track" (the tag's clock, resampled).
    decisions : str
        Whose kernel decided the bits: "receive kernel", "search kernel", "timing".
    measure : str
        "kernel" (``receive_kernel``'s), "search fit", "known levels", "timing".
    crc : str
        "check" (when :func:`decode` is asked to).
    """

    condition: str
    windows: str
    search: str
    timing: str
    decisions: str
    measure: str
    crc: str


class _Detection(NamedTuple):
    """Preamble length [samples] at one BLF and the detection threshold γ for some lags."""

    preamble_samples: int
    threshold: float


class _KnownArguments(NamedTuple):
    """The arguments of ``receive_kernel`` that a "known" plan fixes at one BLF, in the kernel's
    order between the call's ``threshold`` and its output arrays (:meth:`DecodePlan.known_arguments`)."""

    fs_hz: float
    blf_hz: float
    m: int
    n_pre: int  # preamble samples at the BLF (:meth:`DecodePlan.preamble_samples`)
    n_pre_el: int  # pilot + preamble elements
    t0: np.ndarray
    max_runs_per_sample: float
    half_width: int
    shifts: np.ndarray
    templates: np.ndarray
    norms: np.ndarray
    run_begin: np.ndarray
    run_value: np.ndarray
    n_runs: np.ndarray
    same_as_previous: np.ndarray
    pre_el: np.ndarray
    pre_levels: np.ndarray
    state: int
    viterbi: bool  # Viterbi (True) or bitwise decisions
    n_blocks: int  # :data:`DOPPLER_BLOCKS`


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
        Follow the tag's clock (timing tracking, resampling; the "track" timing step): always
        with the "link" search; with "known" and "blf" (the reader's ``track_timing``) the reply
        found is decoded again on the tag's clock, its length fixed (``n_bits``), and measured
        there (gain and σ², no Doppler slope; not with ``refit``).
    dc_from_lead : bool
        "blf": subtract the mean of the samples before the first start searched (≥ 8 of
        them) before the search (the reader; the capture sweep's synthetic windows are
        searched as drawn).
    refit : bool
        "blf": measure on the known levels at the BLF found (gain, Doppler slope, σ², as
        "known" does in its kernel; the reader) instead of keeping the search's own fit.
    variants : StepVariants
        The variant of each step, derived from the fields above (not an argument).
    steps : tuple
        The functions of those variants (:data:`VARIANTS`), in the order of :data:`STEPS`.
    memo : dict
        Values derived from the plan and a call's BLF, lag count or decoded bits (named tables
        ``"arrays"``, ``"detection"``, ``"kernel"`` (:meth:`known_arguments`), ``"crc"``
        (:meth:`crc16_ok`); the "link" search's ``"grids"`` and ``"bands"``, the BLF grid of each
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
    refit: bool = False
    memo: dict = field(default_factory=lambda: {"arrays": {}, "detection": {}, "kernel": {}, "crc": {}}, repr=False)
    variants: StepVariants = field(init=False, repr=False)
    steps: tuple = field(init=False, repr=False)

    def __post_init__(self):
        if self.search not in SEARCHES:
            raise ValueError(f"search must be one of {SEARCHES}, got {self.search!r}")
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        if self.search == "link" and not self.track_timing:
            raise ValueError("the 'link' search always tracks timing")
        if self.refit and (self.search != "blf" or self.track_timing):
            raise ValueError("the refit on the known levels is a step of the 'blf' search without timing tracking")
        search, track = self.search, self.track_timing
        if search == "known" and not track:
            v = StepVariants("in kernel", "lags", "one blf", "none", "receive kernel", "kernel", "check")
        elif search == "known":  # the window conditioned first: the timing step reads it
            v = StepVariants("lead", "lags", "one blf", "track", "timing", "timing", "check")
        elif search == "blf":
            v = StepVariants("lead" if self.dc_from_lead else "none", "lags x grid", "blf grid",
                             "track" if track else "none", "timing" if track else "search kernel",
                             "timing" if track else "known levels" if self.refit else "search fit", "check")
        else:
            v = StepVariants("lead", "t1", "hypotheses", "track", "timing", "timing", "check")
        object.__setattr__(self, "variants", v)
        object.__setattr__(self, "steps", tuple(VARIANTS[step][variant] for step, variant in zip(STEPS, v)))

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
        hit = self.memo["arrays"].get(blf_hz)
        return hit if hit is not None else _kept(self.memo, "arrays", blf_hz, partial(
            search_arrays, self.m, self.trext, 2.0 * blf_hz / self.fs_hz))

    def known_arguments(self, blf_hz: float) -> _KnownArguments:
        """The arguments of ``receive_kernel`` fixed by this plan at ``blf_hz`` (the search
        arrays, the preamble length, the decisions, the Doppler blocks), kept in the plan: the
        "one blf" search prepares them once per BLF, not per call.

        Parameters
        ----------
        blf_hz : float
            The BLF the reply is decoded at [Hz].

        Returns
        -------
        _KnownArguments
            The arguments, in the kernel's order.
        """
        hit = self.memo["kernel"].get(blf_hz)
        return hit if hit is not None else _kept(self.memo, "kernel", blf_hz,
                                                 partial(self._known_arguments, blf_hz))

    def _known_arguments(self, blf_hz: float) -> _KnownArguments:
        """:meth:`known_arguments` made anew."""
        a = self.arrays(blf_hz)
        return _KnownArguments(self.fs_hz, blf_hz, self.m, self.preamble_samples(blf_hz), a.pre_el.size, a.t0,
                               a.max_runs_per_sample, a.half_width, a.shifts, a.templates, a.norms, a.run_begin,
                               a.run_value, a.n_runs, a.same_as_previous, a.pre_el, a.pre_levels, a.state,
                               self.method != "bitwise", DOPPLER_BLOCKS)

    def crc16_ok(self, bits: np.ndarray) -> bool:
        """:func:`rfsim.gen2.crc.crc16_ok` of decoded ``bits`` (uint8), kept in the plan by their
        content: the replies a reader decodes repeat (a tag's EPC, trial after trial).

        Parameters
        ----------
        bits : numpy.ndarray
            ``(n,) uint8`` data bits followed by their CRC-16 (anything else is checked, not kept).

        Returns
        -------
        bool
            The CRC-16 check.
        """
        if not isinstance(bits, np.ndarray):
            return crc16_ok(bits)
        key = (bits.dtype.str, bits.shape, bits.tobytes())
        hit = self.memo["crc"].get(key)
        return hit if hit is not None else _kept(self.memo, "crc", key, partial(crc16_ok, bits))

    def detection(self, n_lags: int, blf_hz: float) -> _Detection:
        """Preamble samples (:meth:`preamble_samples`) and the detection threshold for
        ``n_lags`` tests, kept in the plan: the one definition the decoder's searches and the
        reader (:meth:`rfsim.devices.reader.Reader.detection_threshold`) use.

        On complex white noise the zero-mean, normalised preamble correlation at one lag obeys
        corr² ~ Beta(1, n − 2), n the preamble samples, and the refinement between lags acts
        like about twice as many tests: γ = √(1 − (P_FA/(2·n_lags))^(1/(n−2)))
        (:func:`rfsim.gen2.capture.preamble_threshold`).

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
        hit = self.memo["detection"].get((n_lags, blf_hz))
        return hit if hit is not None else _kept(self.memo, "detection", (n_lags, blf_hz),
                                                 partial(self._detection, n_lags, blf_hz))

    def _detection(self, n_lags: int, blf_hz: float) -> _Detection:
        """:meth:`detection` made anew."""
        n = self.preamble_samples(blf_hz)
        return _Detection(n, preamble_threshold(n, n_lags, self.false_alarm_probability))

    def preamble_samples(self, blf_hz: float) -> int:
        """Samples fully inside the reply preamble (pilot included) as the detector correlates
        them: ⌊elements · fs / (2·BLF)⌋.

        Parameters
        ----------
        blf_hz : float
            The reply's BLF [Hz].

        Returns
        -------
        int
            Samples of the preamble.
        """
        return int(math.floor(n_pre_elements(self.m, self.trext) * self.fs_hz / (2.0 * blf_hz)))


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
    lead : int
        Window samples before the earliest reply start (T1 min at the fastest BLF): their
        mean is the conditioning step's DC when there are ≥ 8.
    delayed : bool
        A delayed reply: the starts are searched in spans around the onsets of modulation.
    n_bits_of : callable
        The complete reply's data bits from its first decoded bits (−1 unknown).
    """

    i0: int
    cmd_end_s: float
    rtcal_s: float
    frt: float
    delay_max_s: float
    lead: int
    delayed: bool
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
        The window after the conditioning step ("known": as given, its kernel conditions it).
    extra : dict or None
        "link": drift, truncated, n_full, end, m, trext, the working rate's decimation;
        "blf" on a batch: ``ebn0_db``.
    crc_ok : bool or None
        The CRC step's CRC-16 check of the decoded bits (None: not asked, or no reply).
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
    crc_ok: bool | None = None


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
             dc_from_lead: bool = True, refit: bool = False, track_timing: bool = False) -> DecodePlan:
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
        refit : bool, optional
            :attr:`DecodePlan.refit` ("blf"), default False.
        track_timing : bool, optional
            :attr:`DecodePlan.track_timing`, default False.

        Returns
        -------
        DecodePlan
            The plan.
        """
        key = (search, fs_hz, method, false_alarm_probability, dc_from_lead, refit, track_timing)
        hit = self.plans.get(key)
        if hit is None:
            from rfsim.gen2.blf_search import blf_grid_hz

            lk = self.link
            grid = None
            if search == "blf":
                grid = blf_grid_hz(lk)
                grid.flags.writeable = False
            hit = self.plans[key] = DecodePlan(search, float(fs_hz), lk.m, lk.trext, method,
                                               false_alarm_probability, lk.blf_hz, grid, track_timing=track_timing,
                                               dc_from_lead=dc_from_lead, refit=refit)
        return hit


class _Work:
    """What the steps of one :func:`decode` call hand on to each other (module docstring): the
    call's inputs, what a step leaves for the next (``threshold``, ``pre_n``, ``n_grid``,
    ``spans``, ``out``, ``best``, ``blf_found``, ``res``) and the result's fields (the class attributes are
    their values until a step sets them; ``found`` None: not searched yet). A batch of windows of
    the "known" search: ``r`` holds them, window b ``r[starts[b]:ends[b]]`` (``starts`` None: one
    window)."""

    found = starts = ends = None
    start = corr = blf_hz = blf_found = sigma2 = slope = decision_ebn0_db = math.nan
    gain = complex(math.nan, math.nan)
    bits = extra = crc_ok = best = None

    def __init__(self, r, lo, hi, n_bits, n_reply, blf, hint, timing, threads, crc, reference):
        self.r, self.lo, self.hi, self.n_bits, self.n_reply, self.blf = r, lo, hi, n_bits, n_reply, blf
        self.hint, self.timing, self.threads, self.crc, self.reference = hint, timing, threads, crc, reference


def decode(r: np.ndarray, plan: DecodePlan, *, lo: int = 0, hi: int = -1, n_bits: int = 16, n_reply: int = 0,
           blf_hz: float | None = None, blf_hint_hz: float | None = None,
           timing: CaptureTiming | None = None, threads: int = 1, crc: bool = False,
           reference=None) -> DecodedReply:
    """Detect and decode one tag reply in the window ``r`` as ``plan`` says (module docstring).

    Every search runs the steps of :data:`STEPS` in that order, each in the variant the plan
    names (:attr:`DecodePlan.variants`, their functions :attr:`DecodePlan.steps` from the table
    :data:`VARIANTS`); a window without a reply stops after the search step.

    Parameters
    ----------
    r : numpy.ndarray
        ``(n,) complex128`` window ``h·s(t) + c + noise`` (any unit, any constant offset c);
        "blf" also ``(B, n)``, a batch of windows (then every field of the result is an array
        over them, ``bits`` ``(B, n_bits)``, and ``extra`` holds ``ebn0_db``; not with a plan
        that measures on the known levels). "known" without timing tracking also ``(B, n)``,
        a sequence of B 1-D windows or :class:`Windows` (read where they lie; their lengths and
        the times of their first samples may differ), each window with its own ``lo``, ``hi``
        (scalars or ``(B,)``, samples of that window): ``found``, ``start`` (samples of each
        window), ``corr``, ``gain``, ``sigma2``, ``slope`` are ``(B,)`` arrays, ``bits``
        ``(B, n_bits)`` and ``crc_ok`` a list (None for a window without a reply), ``window`` the
        windows as given; window b's values are those of its own call.
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
    crc : bool
        The CRC step checks the last 16 decoded bits as CRC-16 over the reply
        (:attr:`DecodedReply.crc_ok`); default False (not checked, None).
    reference : callable or None
        The measurement on the known levels ("blf" plans with ``refit``):
        ``reference(bits, start, n, blf_hz)`` → the ``(n,)`` ±1 reply waveform (dummy 1
        included, 0 outside the reply) starting at sample ``start``; default
        :func:`rfsim.gen2.linecode.reply_waveform` (the reader passes one that keeps it in
        its run's cache).

    Returns
    -------
    DecodedReply
        The detection, decoded bits and measurements.

    Raises
    ------
    ValueError
        From the "known" kernel, when the window leaves nothing to decode (zero gain, no room
        for the reply, a constant reference); for a batch with a plan that measures on the
        known levels; for a batch of "known" windows with timing tracking.
    """
    w = _Work(r, lo, hi, n_bits, n_reply, plan.blf_hz if blf_hz is None else blf_hz, blf_hint_hz, timing,
              threads, crc, reference)
    for step in plan.steps:
        step(w, plan)
        if w.found is False:  # no reply: nothing to decide or measure
            break
    return DecodedReply(w.found, w.start, w.corr, w.bits, w.blf_hz, w.gain, w.sigma2, w.slope, w.decision_ebn0_db,
                        w.r if w.starts is None else r, w.extra, w.crc_ok)


class Windows:
    """B windows in one array: window b is ``samples[starts[b]:ends[b]]`` (one after the other,
    or anywhere in ``samples``, e.g. the reader inputs of a block of trials formed in one array):
    a batch that :func:`decode` ("known") reads without laying the windows out anew.

    Parameters
    ----------
    samples : numpy.ndarray
        ``(N,) complex128`` samples holding the windows.
    starts, ends : numpy.ndarray
        ``(B,) int64`` first sample and end (exclusive) of each window in ``samples``.
    """

    __slots__ = ("samples", "starts", "ends")

    def __init__(self, samples: np.ndarray, starts: np.ndarray, ends: np.ndarray):
        self.samples, self.starts, self.ends = samples, starts, ends

    def __len__(self) -> int:
        return self.starts.size

    def __getitem__(self, b: int) -> np.ndarray:
        """Window b (a view of ``samples``)."""
        return self.samples[self.starts[b]:self.ends[b]]

    def lengths(self) -> np.ndarray:
        """Return the length of each window.

        Returns
        -------
        numpy.ndarray
            ``(B,) int64`` samples of each window.
        """
        return self.ends - self.starts

    def subset(self, index: np.ndarray) -> "Windows":
        """Return some of these windows.

        Parameters
        ----------
        index : numpy.ndarray
            ``(k,) int`` the windows taken, in that order.

        Returns
        -------
        Windows
            Those windows of the same samples (no copy).
        """
        return Windows(self.samples, self.starts[index], self.ends[index])


def _in_a_row(windows) -> Windows:
    """B windows (a ``(B, n)`` array, a sequence of 1-D arrays, or :class:`Windows` as they are) as
    :class:`Windows`; the first two laid one after the other in one ``(N,) complex128`` array."""
    if isinstance(windows, Windows):
        return windows
    if isinstance(windows, np.ndarray):
        b, n = windows.shape
        offsets = np.arange(b + 1, dtype=np.int64) * n
        return Windows(np.ascontiguousarray(windows, dtype=np.complex128).reshape(-1), offsets[:-1], offsets[1:])
    r = np.ascontiguousarray(np.concatenate(windows), dtype=np.complex128)
    if r.ndim != 1:
        raise ValueError("a batch of windows: each window 1-D")
    offsets = np.zeros(len(windows) + 1, dtype=np.int64)
    np.cumsum([x.shape[0] for x in windows], out=offsets[1:])
    return Windows(r, offsets[:-1], offsets[1:])


# ----------------------------------------------------------------- step 1: conditioning

def _condition_in_kernel(w: _Work, plan: DecodePlan) -> None:
    """The search's kernel subtracts mean(r[:lo]) itself (``receive_kernel``, lo ≥ 8). A batch of
    windows (``(B, n)`` or a sequence of 1-D windows) is laid one after the other in ``r``
    (``starts``, ``ends``, :func:`_in_a_row`) for the batch kernel; :class:`Windows` are read where
    they lie."""
    if not isinstance(w.r, np.ndarray) or w.r.ndim == 2:
        laid = _in_a_row(w.r)
        w.r, w.starts, w.ends = laid.samples, laid.starts, laid.ends


def _condition_lead(w: _Work, plan: DecodePlan) -> None:
    """r − Σr[:lo]/lo over the samples before the first start searched, when there are ≥ 8 of them
    ("blf": ``lo``; "link": :attr:`CaptureTiming.lead`). Conditioning only: detection is
    invariant to a constant offset."""
    lo = w.lo if w.timing is None else w.timing.lead
    if lo >= 8:
        w.r = w.r - w.r[:lo].sum() / lo


def _condition_none(w: _Work, plan: DecodePlan) -> None:
    """The window is searched as given (the capture sweep's synthetic windows)."""


# ----------------------------------------------------------------- step 2: candidate windows

def _windows_lags(w: _Work, plan: DecodePlan) -> None:
    """Starts ``lo…hi`` at the BLF given; the detection threshold of that many tests
    (:meth:`DecodePlan.detection`, the preamble at that BLF); for a batch of windows each
    window's own (``lo``, ``hi`` and the threshold ``(B,)`` arrays)."""
    w.spans, w.n_grid = ((w.lo, w.hi),), 1
    if w.starts is None:
        w.pre_n, w.threshold = plan.detection(w.hi - w.lo + 1, w.blf)
    else:
        w.lo, w.hi = (np.ascontiguousarray(np.broadcast_to(np.asarray(v, dtype=np.int64), (w.starts.size,)))
                      for v in (w.lo, w.hi))
        detections = {k: plan.detection(k, w.blf) for k in set((w.hi - w.lo + 1).tolist())}
        w.pre_n = next(iter(detections.values())).preamble_samples
        w.threshold = np.array([detections[k].threshold for k in (w.hi - w.lo + 1).tolist()])


def _windows_lags_grid(w: _Work, plan: DecodePlan) -> None:
    """Starts ``lo…hi`` at every BLF of the plan's grid, or at the hint alone; the detection
    threshold of lags × BLF hypotheses tests (:meth:`DecodePlan.detection`, the preamble at the
    nominal BLF)."""
    w.spans, w.n_grid = ((w.lo, w.hi),), 1 if w.hint is not None else plan.blf_grid_hz.size
    w.threshold = plan.detection((w.hi - w.lo + 1) * w.n_grid, plan.blf_hz).threshold


def _windows_t1(w: _Work, plan: DecodePlan) -> None:
    """The T1 window, or, for a delayed reply, ±2 blocks around each onset of modulation
    (:func:`rfsim.gen2.reply_search.modulation_onsets`; none: no reply), searched in turn; the
    whole window when it is too short to gate. The threshold is the search's (union bound)."""
    t = w.timing
    w.spans = (None,)
    if t.delayed:
        hyps = plan.hypotheses
        onsets, block = modulation_onsets(w.r, plan.fs_hz, min(h.blf_lo_hz for h in hyps), first=max(t.lead, 0))
        if onsets is not None:
            fs = plan.fs_hz
            w.spans = tuple(((t.i0 + k - 2 * block) / fs - t.cmd_end_s, (t.i0 + k + 2 * block) / fs - t.cmd_end_s)
                            for k in onsets)


# ----------------------------------------------------------------- step 3: preamble / BLF search

def _search_one_blf(w: _Work, plan: DecodePlan) -> None:
    """``receive_kernel`` at one BLF: the preamble over the lags (runs + 1/16-sample
    refinement) and, in the same call, (h, c) on the known levels, the decisions and the
    measurement (steps 5 and 6 take them from it). A batch of windows (one after the other in
    ``r``, ``starts``, ``ends``): the same kernel on each window in one call (``receive_batch_kernel``),
    every result a ``(B,)`` array."""
    batch = () if w.starts is None else (w.starts.size,)
    det_bits, bits = np.empty((2, *batch, w.n_bits + 1), dtype=np.uint8)  # the first decisions', the bits
    out_f, out_c = np.empty((*batch, 4)), np.empty((*batch, 1), dtype=np.complex128)
    if batch:
        status = np.empty(batch, dtype=np.int64)
        _rxk.receive_batch_kernel(w.r, w.starts, w.ends, w.lo, w.hi, w.n_reply, w.threshold,
                                  *plan.known_arguments(w.blf), det_bits, bits, out_f, out_c, status)
        worst = int(status.max(initial=_rxk.RECEIVED))
        w.start, w.corr, w.found = out_f[:, 0], out_f[:, 1], status != _rxk.NOT_FOUND
    else:
        worst = status = _rxk.receive_kernel(w.r, w.lo, w.hi, w.n_reply, w.threshold, *plan.known_arguments(w.blf),
                                             det_bits, bits, out_f, out_c)
        w.start, w.corr, w.found = float(out_f[0]), float(out_f[1]), status != _rxk.NOT_FOUND
    if worst > _rxk.NOT_FOUND:
        raise ValueError(_RECEIVE_ERRORS[worst])
    w.out, w.blf_found = (bits, out_f, out_c), w.blf


def _search_blf_grid(w: _Work, plan: DecodePlan) -> None:
    """:func:`rfsim.gen2.blf_search.search_decode` over the plan's BLF grid, or at the hint
    within 1/(RN16 elements): coarse preamble correlation over lags × BLF, the fine BLF and, in
    the same call, the decisions and the search's own fit; then the threshold."""
    from rfsim.gen2.blf_search import search_decode

    m, trext = plan.m, plan.trext
    if w.hint is not None:  # the tag's BLF is known from its RN16
        n_el16 = n_pre_elements(m, trext) + 2 * m * 17
        out = search_decode(w.r, m=m, trext=trext, n_bits=w.n_bits, blfs_hz=np.array([w.hint]), fs_hz=plan.fs_hz,
                            lo=w.lo, hi=w.hi, known_within=1.0 / n_el16)
    else:
        out = search_decode(w.r, m=m, trext=trext, n_bits=w.n_bits, blfs_hz=plan.blf_grid_hz, fs_hz=plan.fs_hz,
                            lo=w.lo, hi=w.hi, threads=w.threads)
    w.out = out
    if w.r.ndim == 2:
        w.found, w.start, w.corr = out.corr >= w.threshold, out.start, out.corr
    else:
        w.start, w.corr, w.blf_found = float(out.start[0]), float(out.corr[0]), float(out.blf_hz[0])
        w.found = w.corr >= w.threshold


def _search_hypotheses(w: _Work, plan: DecodePlan) -> None:
    """:func:`rfsim.gen2.reply_search._detect` over the link hypotheses at their working rates,
    span after span until one holds a reply (its threshold: the union bound over every lag and
    hypothesis tested)."""
    from rfsim.gen2.reply_search import _detect

    t, best = w.timing, None
    for span_s in w.spans:
        best = _detect(w.r, plan.fs_hz, plan.hypotheses, t.i0, t.cmd_end_s, t.rtcal_s, t.frt, w.hint,
                       plan.false_alarm_probability, t.delay_max_s, span_s, plan.memo)
        if best is not None:
            break
    w.best, w.found = best, best is not None
    if best is not None:
        w.start, w.corr = float(best[0][3]), float(best[0][0])


# ----------------------------------------------------------------- step 4: timing

def _timing_none(w: _Work, plan: DecodePlan) -> None:
    """The reply is decoded on the receiver's clock at the BLF found."""


def _timing_track(w: _Work, plan: DecodePlan) -> None:
    """:func:`rfsim.gen2.reply_decoding._decode_window` on the working-rate window: fine BLF,
    the reply's length from its first bits, timing tracking (quadratic clock, resampling) and,
    in the same call, the decisions and the fit with its E_h/N₀ gate (steps 5, 6). After the
    reader's searches ("known", "blf": no ``best`` of the "link" search) the same call starts
    from the start and BLF they found, on the (conditioned) window at its own rate, the fine
    BLF searched ±2 coarse steps (:func:`rfsim.gen2.reply_core.coarse_blf_step`) around it and
    the reply ``n_bits`` long."""
    from rfsim.gen2.reply_core import coarse_blf_step
    from rfsim.gen2.reply_decoding import _decode_window, fixed_length
    from rfsim.gen2.reply_search import LinkHypothesis

    if w.best is None:
        if w.r.ndim != 1 or w.starts is not None:
            raise ValueError("timing tracking takes one window, not a batch")
        blf = w.blf_found
        w.best = ((w.corr, blf, LinkHypothesis(plan.m, plan.trext, blf, blf), w.start,
                   coarse_blf_step(plan.m, plan.trext), None), w.r, 1)
        n_bits_of = fixed_length(w.n_bits)
    else:
        n_bits_of = w.timing.n_bits_of
    found, rd, d = w.best
    w.res = _decode_window(rd, plan.fs_hz / d, found, n_bits_of, plan.method)
    if w.res is None:
        w.found = False
    else:
        w.start, w.corr = float(w.res["start"]), float(w.res["corr"])


# ----------------------------------------------------------------- step 5: decisions

def _decisions_of_receive(w: _Work, plan: DecodePlan) -> None:
    """The data bits ``receive_kernel`` decided on r − c with h given (half-bit sums, Viterbi
    or bitwise)."""
    w.bits = w.out[0][..., :w.n_bits]


def _decisions_of_search(w: _Work, plan: DecodePlan) -> None:
    """The data bits and BLF the BLF search's kernel decided at (half-bit sums, Viterbi or
    bitwise, at the fine BLF)."""
    if w.r.ndim == 2:
        w.bits, w.blf_hz = w.out.bits, w.out.blf_hz
    else:
        w.bits, w.blf_hz = w.out.bits[0].astype(np.uint8), float(w.out.blf_hz[0])


def _decisions_of_timing(w: _Work, plan: DecodePlan) -> None:
    """The data bits decided on the resampled reply (the timing step's kernel)."""
    w.bits, w.blf_hz = w.res["bits"], float(w.res["blf"])


# ----------------------------------------------------------------- step 6: measurement

def _measure_of_kernel(w: _Work, plan: DecodePlan) -> None:
    """Gain at the reply centre, Doppler slope and σ² of ``receive_kernel`` (its
    ``measure_kernel`` against the decoded reply, :data:`DOPPLER_BLOCKS` blocks)."""
    _, out_f, out_c = w.out
    if out_f.ndim == 2:  # a batch
        w.gain, w.sigma2, w.slope = out_c[:, 0], out_f[:, 3], out_f[:, 2]
    else:
        w.gain, w.sigma2, w.slope = complex(out_c[0]), float(out_f[3]), float(out_f[2])


def _measure_of_search(w: _Work, plan: DecodePlan) -> None:
    """The BLF search's own fit: h, σ² over the reply's steady samples, Eb/N₀ and the
    decision-domain Eb/(N₀ + I) (:class:`rfsim.gen2.blf_search.SearchDecode`)."""
    out = w.out
    if w.r.ndim == 2:
        w.gain, w.sigma2, w.decision_ebn0_db = out.gain, out.sigma2, out.decision_ebn0_db
        w.extra = dict(ebn0_db=out.ebn0_db)
    else:
        w.gain, w.sigma2 = complex(out.gain[0]), float(out.sigma2[0])
        w.decision_ebn0_db = float(out.decision_ebn0_db[0])


def _measure_known_levels(w: _Work, plan: DecodePlan) -> None:
    """As "known" measures inside its kernel, at the BLF found: (h, c) by least squares on the
    samples whose level is known without decisions (preamble, rest level around the reply,
    two equal neighbours; :func:`rfsim.gen2.capture.fit_gain_offset`), then gain, Doppler
    slope and σ² of r − c against the decoded reply (``measure_kernel``); the search's
    decision-domain Eb/(N₀ + I) is kept."""
    if w.r.ndim != 1:
        raise ValueError("the measurement on the known levels takes one window, not a batch")
    _measure_of_search(w, plan)
    r, start, blf, fs = w.r, w.start, w.blf_hz, plan.fs_hz
    if w.reference is None:
        full = reply_waveform(w.bits, m=plan.m, trext=plan.trext, blf_hz=blf, fs_hz=fs, t0_s=start / fs,
                              n_samples=r.size)
    else:
        full = w.reference(w.bits, start, r.size, blf)
    r = np.ascontiguousarray(r, dtype=np.complex128)
    full = np.ascontiguousarray(full, dtype=np.float64)
    r_known, level = np.empty(r.size, dtype=np.complex128), np.empty(r.size)
    k = _mk.known_levels_kernel(r, full, float(start), 2.0 * blf / fs, n_pre_elements(plan.m, plan.trext),
                                r_known, level)
    _, c = fit_gain_offset(r_known[:k], level[:k])
    h, slope, sigma2 = _mk.measure_kernel(np.ascontiguousarray(r - c), full, fs, DOPPLER_BLOCKS)
    w.gain, w.slope, w.sigma2 = complex(h), float(slope), float(sigma2)


def _measure_of_timing(w: _Work, plan: DecodePlan) -> None:
    """The timing step's fit over the remodulated, resampled reply: h, σ² (its E_h/N₀ gate
    passed), the BLF drift and the reply's length and end."""
    res, d = w.res, w.best[2]
    w.gain, w.sigma2 = complex(res["h"]), float(res["sigma2"])
    w.extra = dict(drift=res["drift"], truncated=res["truncated"], n_full=res["n_full"], end=res["end"], m=res["m"],
                   trext=res["trext"], decimation=d)


# ----------------------------------------------------------------- step 7: CRC

def _crc_check(w: _Work, plan: DecodePlan) -> None:
    """With ``crc``: CRC-16 over the decoded reply, data bits followed by their CRC-16
    (:func:`rfsim.gen2.crc.crc16_ok`); None for a reply the timing step found cut (``truncated``:
    the next command or the capture's end cut it, its CRC is not in the window). The one check of
    a decoded reply's CRC: the reader's ``expect_crc`` and a capture record's ``crc_ok`` are this."""
    if w.crc and w.starts is not None:  # a batch of "known" windows: the windows with a reply
        w.crc_ok = [plan.crc16_ok(bits) if found else None for bits, found in zip(w.bits, w.found.tolist())]
    elif w.crc:
        w.crc_ok = None if w.extra is not None and w.extra.get("truncated", False) else plan.crc16_ok(w.bits)


#: The steps of every :func:`decode` call, in order (module docstring).
STEPS = StepVariants._fields
#: Each step's variants by name: the function that runs it (:attr:`DecodePlan.variants` names one per step).
VARIANTS = {
    "condition": {"in kernel": _condition_in_kernel, "lead": _condition_lead, "none": _condition_none},
    "windows": {"lags": _windows_lags, "lags x grid": _windows_lags_grid, "t1": _windows_t1},
    "search": {"one blf": _search_one_blf, "blf grid": _search_blf_grid, "hypotheses": _search_hypotheses},
    "timing": {"none": _timing_none, "track": _timing_track},
    "decisions": {"receive kernel": _decisions_of_receive, "search kernel": _decisions_of_search,
                  "timing": _decisions_of_timing},
    "measure": {"kernel": _measure_of_kernel, "search fit": _measure_of_search, "known levels": _measure_known_levels,
                "timing": _measure_of_timing},
    "crc": {"check": _crc_check},
}

"""Pulse-interval encoding (PIE): the interrogator→tag envelope and its decoder.

Encoder (gen2-and-validation-anchors.md §4.1; pass-paris-simulator.md §2.1). Every PIE
symbol is a high interval followed by a low pulse of width PW; data-0 lasts Tari, data-1
lasts ``data1_tari``·Tari (1.5–2.0 Tari), RTcal = data-0 + data-1, TRcal (1.1–3 RTcal)
appears only in the Query preamble. A command starts with

* ``preamble="query"``:      delimiter, data-0, RTcal, TRcal;
* ``preamble="frame-sync"``: delimiter, data-0, RTcal;

where the delimiter is a low interval (12.5 µs ± 5 %). The amplitude envelope is

    e(t) = 1 − depth · Σ_k [g(t − f_k) − g(t − r_k)],    depth = (A − B)/A,

with A = 1 the CW level, B = 1 − depth the modulated level, ``f_k``/``r_k`` the 50 %
points of the falling/rising edge of low pulse k and g a hard step or a raised-cosine
step ``(1 + sin(πτ/w))/2`` for |τ| < w/2 whose 10–90 % time is
``rise_fall_s = (2w/π)·asin(0.8)``; ramps may overlap (a short pulse with slow edges
then does not reach the full depth), the sum above stays exact. Edge times are exact float64 seconds; sample n is the
envelope at ``t = n/fs`` — non-integer samples per Tari never accumulate drift.

Decoder (pass-paris-simulator.md §2.2, ``tag_decoding``): threshold midway between the
two level clusters (iterative isodata split, so unknown scale and DC do not matter),
comparator with hysteresis, sub-sample edge positions by linear interpolation, then the
rising-edge intervals give data-0 (Tari), RTcal, optional TRcal and the bits
(interval > pivot = RTcal/2 → 1). All durations are in ticks of the input's sampling
clock (the decoder's own clock).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rfsim.gen2.bits import as_bits
from rfsim.core.lazy import lazy_import

_k = lazy_import("rfsim.gen2._pie_kernels")

#: Ratio between the full width w of the raised-cosine step and its 10–90 % time.
_RAMP_WIDTH_PER_10_90 = math.pi / (2.0 * math.asin(0.8))

#: Frame acceptance: RTcal/Tari must lie in this range (spec 2.5–3.0, with margin for
#: clock error and quantisation), TRcal ≤ this many RTcal (spec 1.1–3.0).
RTCAL_TARI_RANGE = (1.8, 3.6)
MAX_TRCAL_RTCAL = 4.0

#: Default half-width of the decoder's hysteresis band, a fraction of high − low cluster means.
PIE_HYSTERESIS = 0.1

PREAMBLES = ("query", "frame-sync")


@dataclass(frozen=True)
class PieTimeline:
    """Edge times of one PIE command.

    Attributes
    ----------
    fall_s, rise_s : (k,) float64 [s]
        50 % times of the falling and rising edge of every low pulse (delimiter first).
    duration_s : float [s]
        Total duration incl. CW before and after.
    """

    fall_s: np.ndarray
    rise_s: np.ndarray
    duration_s: float


@dataclass(frozen=True)
class PieFrame:
    """One decoded PIE command; all durations in ticks of the input sampling clock.

    ``start`` is the falling edge of the delimiter, ``end`` the rising edge closing the
    last bit; ``trcal`` is NaN for a frame-sync (no TRcal). ``bits`` is ``(n,) uint8``.
    """

    start: float
    end: float
    delimiter: float
    tari: float
    rtcal: float
    trcal: float
    bits: np.ndarray

    @property
    def has_trcal(self) -> bool:
        return not math.isnan(self.trcal)


# ----------------------------------------------------------------------------- encoder


@dataclass(frozen=True)
class PieLeadIn:
    """The fixed part of a PIE command: its checked timing and lead-in (:func:`pie_lead_in`).

    Attributes
    ----------
    symbols_s : (2,) or (3,) float64 [s], read-only
        Lead-in symbol lengths after the delimiter: data-0, RTcal (, TRcal for a Query).
    data0_s, data1_s : float [s]
        Data-0 (Tari) and data-1 durations.
    pw_s : float [s]
        Low-pulse width.
    cw_before_s : float [s]
        CW before the delimiter's falling edge.
    t0_s : float [s]
        Rising edge of the delimiter, ``cw_before_s + delimiter_s``.
    """

    symbols_s: np.ndarray
    data0_s: float
    data1_s: float
    pw_s: float
    cw_before_s: float
    t0_s: float


def pie_lead_in(*, tari_s: float, data1_tari: float, trcal_s: float | None, pw_s: float, delimiter_s: float,
                preamble: str = "query", cw_before_s: float = 0.0) -> PieLeadIn:
    """Check the timing of a PIE command and return its lead-in (the part every command shares).

    Symbol lengths of gen2-and-validation-anchors.md §4.1: delimiter, data-0, RTcal =
    (1 + data1_tari)·Tari and, for the Query preamble, TRcal.

    Parameters
    ----------
    tari_s, data1_tari, trcal_s, pw_s, delimiter_s, preamble, cw_before_s : float, …, str, float
        As in :func:`pie_timeline`: Tari [s], data-1 in Tari, TRcal [s] (or None for a
        frame-sync), PW [s], delimiter [s], ``"query"`` or ``"frame-sync"``, CW before the
        delimiter [s].

    Returns
    -------
    PieLeadIn
        The checked timing.

    Raises
    ------
    ValueError
        For an unknown preamble, non-positive durations, PW ≥ Tari, data1_tari outside
        (1, 2.5], a Query without TRcal > RTcal, or ``cw_before_s < 0``.
    """
    if preamble not in PREAMBLES:
        raise ValueError(f"preamble must be one of {PREAMBLES}, got {preamble!r}")
    tari_s, pw_s, delimiter_s = float(tari_s), float(pw_s), float(delimiter_s)
    if not tari_s > 0 or not 0 < pw_s < tari_s or not delimiter_s > 0:
        raise ValueError("need tari_s > 0, 0 < pw_s < tari_s and delimiter_s > 0")
    if not 1.0 < float(data1_tari) <= 2.5:
        raise ValueError(f"data1_tari must be in (1, 2.5], got {data1_tari}")
    if cw_before_s < 0:
        raise ValueError("cw_before_s and cw_after_s must be >= 0")
    data1_s = float(data1_tari) * tari_s
    rtcal_s = tari_s + data1_s
    symbols = [tari_s, rtcal_s]
    if preamble == "query":
        if trcal_s is None or not float(trcal_s) > rtcal_s:
            raise ValueError(f"a query preamble needs trcal_s > RTcal = {rtcal_s:g} s, got {trcal_s}")
        symbols.append(float(trcal_s))
    symbols_s = np.array(symbols)
    symbols_s.setflags(write=False)
    return PieLeadIn(symbols_s=symbols_s, data0_s=tari_s, data1_s=data1_s, pw_s=pw_s, cw_before_s=float(cw_before_s),
                     t0_s=float(cw_before_s) + delimiter_s)


def pie_timeline(
    bits,
    *,
    tari_s: float,
    data1_tari: float,
    trcal_s: float | None,
    pw_s: float,
    delimiter_s: float,
    preamble: str = "query",
    cw_before_s: float = 0.0,
    cw_after_s: float = 0.0,
) -> PieTimeline:
    """Exact edge times of the PIE command carrying ``bits``.

    Lead-in and symbol lengths of gen2-and-validation-anchors.md §4.1 (:func:`pie_lead_in`):
    delimiter, data-0, RTcal (and TRcal for the Query preamble), then Tari per data-0 and
    data1_tari·Tari per data-1, each symbol ending with a low pulse of width PW.

    Parameters
    ----------
    bits : array_like
        ``(n,)`` 0/1, MSB first.
    tari_s : float
        Data-0 duration [s].
    data1_tari : float
        Data-1 duration in Tari (1.5–2.0); RTcal = (1 + data1_tari)·Tari.
    trcal_s : float or None
        TRcal [s]; required for ``preamble="query"``, ignored for frame-sync.
    pw_s : float
        Low-pulse width [s], 0 < PW < Tari.
    delimiter_s : float
        Delimiter (low) duration [s].
    preamble : {"query", "frame-sync"}
        Lead-in.
    cw_before_s, cw_after_s : float
        Unmodulated carrier before the delimiter / after the last rising edge [s]. Use
        ``cw_after_s > 0`` if the last rising edge must be sampled.

    Returns
    -------
    PieTimeline
        Falling and rising edge times [s] and total duration [s].

    Raises
    ------
    ValueError
        For an unknown preamble, non-positive durations, PW ≥ Tari, data1_tari outside
        (1, 2.5], or a Query without TRcal > RTcal.
    """
    arr = as_bits(bits)
    if cw_after_s < 0:
        raise ValueError("cw_before_s and cw_after_s must be >= 0")
    lead = pie_lead_in(tari_s=tari_s, data1_tari=data1_tari, trcal_s=trcal_s, pw_s=pw_s, delimiter_s=delimiter_s,
                       preamble=preamble, cw_before_s=cw_before_s)
    n_edges = 1 + lead.symbols_s.size + arr.size
    fall, rise = np.empty(n_edges), np.empty(n_edges)
    # rise = [t0, t0 + cumsum(symbol lengths)], fall = [cw_before, rise[1:] − PW]
    _k.timeline_kernel(lead.symbols_s, arr, lead.data0_s, lead.data1_s, lead.t0_s, lead.pw_s, lead.cw_before_s, fall,
                       rise)
    return PieTimeline(fall_s=fall, rise_s=rise, duration_s=float(rise[-1] + cw_after_s))


#: The ValueError of an edge slower than the shortest low or high interval (:func:`_ramp_width_samples`).
_SLOW_EDGES = "rise_fall_s must not exceed the shortest low or high interval"


def _ramp_width_samples(rise_fall_s: float, fs_hz: float, timeline: PieTimeline) -> float:
    """Full width [samples] of the raised-cosine edges of ``timeline`` whose 10–90 % time is
    ``rise_fall_s`` [s] (the kernels' one rule, :func:`rfsim.gen2._pie_kernels.ramp_width`),
    checked: ``rise_fall_s`` ≥ 0 and not above the shortest low or high interval."""
    if rise_fall_s < 0:
        raise ValueError("rise_fall_s must be >= 0")
    width = _k.ramp_width(np.ascontiguousarray(timeline.fall_s, dtype=np.float64),
                          np.ascontiguousarray(timeline.rise_s, dtype=np.float64), float(rise_fall_s),
                          _RAMP_WIDTH_PER_10_90, float(fs_hz))
    if width < 0.0:
        raise ValueError(_SLOW_EDGES)
    return width


def _ask_arguments(depth: float, fs_hz: float) -> float:
    """``fs_hz`` of an ASK envelope, checked: fs > 0, 0 < depth ≤ 1."""
    fs_hz = _check_fs(fs_hz)
    if not 0 < depth <= 1:
        raise ValueError(f"depth must be in (0, 1], got {depth}")
    return fs_hz


def _envelope_arguments(timeline: PieTimeline, depth: float, fs_hz: float, rise_fall_s: float) -> tuple[float, float]:
    """``(fs_hz, ramp width [samples])`` of an envelope of ``timeline``, checked: fs > 0, 0 < depth ≤ 1."""
    fs_hz = _ask_arguments(depth, fs_hz)
    return fs_hz, _ramp_width_samples(float(rise_fall_s), fs_hz, timeline)


def _check_fs(fs_hz: float) -> float:
    fs_hz = float(fs_hz)
    if not fs_hz > 0:
        raise ValueError(f"fs_hz must be > 0, got {fs_hz}")
    return fs_hz


def pie_envelope(
    bits,
    *,
    tari_s: float,
    data1_tari: float,
    trcal_s: float | None,
    pw_s: float,
    delimiter_s: float,
    depth: float,
    fs_hz: float,
    rise_fall_s: float = 0.0,
    preamble: str = "query",
    cw_before_s: float = 0.0,
    cw_after_s: float = 0.0,
) -> np.ndarray:
    """Sampled ASK amplitude envelope of a PIE command (numba kernel).

    ``1`` during CW and ``1 − depth`` during the low pulses (``depth = (A−B)/A``), sample n at
    ``t = n/fs``. Source: gen2-and-validation-anchors.md §4.1, pass-paris-simulator.md §2.1.

    Parameters
    ----------
    bits : array_like
        ``(n,)`` 0/1, MSB first.
    tari_s, data1_tari, trcal_s, pw_s, delimiter_s, preamble, cw_before_s, cw_after_s
        Timing as in :func:`pie_timeline` (durations [s], data1_tari [Tari]).
    depth : float
        Modulation depth (A−B)/A, 0 < depth ≤ 1.
    fs_hz : float
        Sample rate [Hz].
    rise_fall_s : float
        10–90 % time of the raised-cosine edges [s] (0: hard edges).

    Returns
    -------
    numpy.ndarray
        ``(ceil(T·fs),) float64`` envelope in units of the CW amplitude [1].

    Raises
    ------
    ValueError
        If ``depth`` is outside (0, 1], ``fs_hz`` is not positive, or a timing is invalid.
    """
    fs_hz = _ask_arguments(depth, fs_hz)
    tl = pie_timeline(
        bits, tari_s=tari_s, data1_tari=data1_tari, trcal_s=trcal_s, pw_s=pw_s,
        delimiter_s=delimiter_s, preamble=preamble, cw_before_s=cw_before_s,
        cw_after_s=cw_after_s,
    )
    return timeline_envelope(tl, depth=depth, fs_hz=fs_hz, rise_fall_s=rise_fall_s)


def timeline_envelope(timeline: PieTimeline, *, depth: float, fs_hz: float, rise_fall_s: float = 0.0) -> np.ndarray:
    """:func:`pie_envelope` of an already computed :class:`PieTimeline` (numba kernel).

    Parameters
    ----------
    timeline : PieTimeline
        Edge times [s].
    depth : float
        Modulation depth (A−B)/A, 0 < depth ≤ 1.
    fs_hz : float
        Sample rate [Hz].
    rise_fall_s : float
        10–90 % time of the raised-cosine edges [s] (0: hard edges).

    Returns
    -------
    numpy.ndarray
        ``(ceil(T·fs),) float64`` envelope in units of the CW amplitude [1].

    Raises
    ------
    ValueError
        If ``depth`` is outside (0, 1] or ``fs_hz`` is not positive.
    """
    fs_hz, width = _envelope_arguments(timeline, depth, fs_hz, rise_fall_s)
    out = np.ones(int(math.ceil(timeline.duration_s * fs_hz)), dtype=np.float64)
    _k.envelope_kernel(timeline.fall_s * fs_hz, timeline.rise_s * fs_hz, float(depth), width, out)
    return out


def pr_ask_baseband(timeline: PieTimeline, envelope: np.ndarray, *, amplitude: float, fs_hz: float) -> np.ndarray:
    """PR-ASK baseband ``x = A·s(t)·e(t)`` (numba kernel).

    ``s(t) = ±1`` changes sign at the middle of every low pulse (delimiter included),
    ``(fall_s + rise_s)/2`` of ``timeline``: every PIE symbol has the opposite polarity of
    the previous one (gen2-and-validation-anchors.md §4.1).

    Parameters
    ----------
    timeline : PieTimeline
        Edge times [s].
    envelope : numpy.ndarray
        ``(n,)`` e(t) at ``t = n/fs`` (:func:`timeline_envelope`) [1].
    amplitude : float
        CW amplitude A [√W].
    fs_hz : float
        Sample rate [Hz].

    Returns
    -------
    numpy.ndarray
        ``(n,) complex128`` baseband [√W].
    """
    fs_hz = _check_fs(fs_hz)
    mid = np.ascontiguousarray(0.5 * (timeline.fall_s + timeline.rise_s), dtype=np.float64)
    e = np.ascontiguousarray(envelope, dtype=np.float64)
    out = np.empty(e.size, dtype=np.float64)
    _k.pr_ask_kernel(mid, fs_hz, float(amplitude), e, out)
    return out.astype(np.complex128)


def ask_baseband(timeline: PieTimeline, *, amplitude: float, pr_ask: bool, depth: float, fs_hz: float,
                 rise_fall_s: float = 0.0, modulated_s: float | None = None) -> np.ndarray:
    """DSB-ASK ``x = A·e(t)`` or PR-ASK ``x = A·s(t)·e(t)`` of a timeline in one pass (numba kernel).

    The samples of ``A·(``:func:`timeline_envelope```)`` or of :func:`pr_ask_baseband` of it,
    bit for bit, over the first ``ceil(modulated_s·fs)`` samples; after them the caller
    states that the envelope is 1 and the PR-ASK sign no longer changes (the last edge's ramp
    is over), so the rest is the constant CW ``A`` (DSB) or ``A·s_end`` (PR-ASK, ``s_end = −1``
    after an odd number of low pulses).

    Parameters
    ----------
    timeline : PieTimeline
        Edge times [s].
    amplitude : float
        CW amplitude A [√W].
    pr_ask : bool
        PR-ASK (True) or DSB-ASK (False).
    depth : float
        Modulation depth (A−B)/A, 0 < depth ≤ 1.
    fs_hz : float
        Sample rate [Hz].
    rise_fall_s : float, optional
        10–90 % time of the raised-cosine edges [s] (default 0: hard edges).
    modulated_s : float or None, optional
        Time after sample 0 up to which the envelope is evaluated [s] (default None: the
        whole timeline).

    Returns
    -------
    numpy.ndarray
        ``(ceil(T·fs),) complex128`` baseband [√W].

    Raises
    ------
    ValueError
        If ``depth`` is outside (0, 1], ``fs_hz`` is not positive or the edges are too slow.
    """
    fs_hz, width = _envelope_arguments(timeline, depth, fs_hz, rise_fall_s)
    n, n_mod = _k.sample_counts(float(timeline.duration_s), math.inf if modulated_s is None else float(modulated_s),
                                fs_hz)
    out = np.empty(n, dtype=np.complex128)
    _k.ask_baseband_kernel(timeline.fall_s, timeline.rise_s, float(depth), width, fs_hz, float(amplitude),
                           bool(pr_ask), n_mod, out)
    return out


class AskCommand(NamedTuple):
    """What a transmitter fixes of a command's ASK baseband, all but its bits: the arguments of
    ``command_baseband_kernel`` in its order without ``bits``, checked (:func:`ask_command`).

    Attributes
    ----------
    symbols_s : numpy.ndarray
        ``(2,)`` or ``(3,)`` lead-in symbol lengths after the delimiter [s] (:class:`PieLeadIn`).
    data0_s, data1_s, t0_s, pw_s, cw_before_s : float
        The lead-in's data-0 and data-1 durations, delimiter rising edge, low-pulse width and CW
        before the delimiter [s].
    cw_after_s, modulated_after_s : float
        CW after the last rising edge, and the time after it up to which the envelope is
        evaluated [s].
    depth : float
        (A−B)/A in (0, 1].
    rise_fall_s : float
        10–90 % edge time [s].
    ramp_per_10_90 : float
        Ramp width per 10–90 % time of the raised-cosine edge [1].
    fs_hz : float
        Sample rate [Hz].
    amplitude : float
        CW amplitude A [√W].
    pr_ask : bool
        PR-ASK (True) or DSB-ASK.
    """

    symbols_s: np.ndarray
    data0_s: float
    data1_s: float
    t0_s: float
    pw_s: float
    cw_before_s: float
    cw_after_s: float
    modulated_after_s: float
    depth: float
    rise_fall_s: float
    ramp_per_10_90: float
    fs_hz: float
    amplitude: float
    pr_ask: bool


def ask_command(lead: PieLeadIn, *, cw_after_s: float, modulated_after_s: float, amplitude: float, pr_ask: bool,
                depth: float, fs_hz: float, rise_fall_s: float = 0.0) -> AskCommand:
    """The checked arguments of :func:`command_ask_baseband` but the bits: a transmitter makes
    them once per lead-in and CW lengths and modulates command after command with them
    (:func:`ask_command_baseband`).

    Parameters
    ----------
    lead : PieLeadIn
        The command's timing and lead-in (:func:`pie_lead_in`).
    cw_after_s, modulated_after_s : float
        As in :func:`command_ask_baseband`: CW after the last rising edge [s] (≥ 0), the time
        after it up to which the envelope is evaluated [s].
    amplitude, pr_ask, depth, fs_hz, rise_fall_s : float, bool, float, float, float
        CW amplitude A [√W], PR-ASK or DSB-ASK, depth (A−B)/A in (0, 1], sample rate [Hz],
        10–90 % edge time [s] (≥ 0; default 0).

    Returns
    -------
    AskCommand
        The arguments.

    Raises
    ------
    ValueError
        If ``cw_after_s`` or ``rise_fall_s`` is negative, ``depth`` is outside (0, 1] or
        ``fs_hz`` is not positive.
    """
    fs_hz = _ask_arguments(depth, fs_hz)
    if cw_after_s < 0:
        raise ValueError("cw_before_s and cw_after_s must be >= 0")
    if rise_fall_s < 0:
        raise ValueError("rise_fall_s must be >= 0")
    return AskCommand(lead.symbols_s, lead.data0_s, lead.data1_s, lead.t0_s, lead.pw_s, lead.cw_before_s,
                      float(cw_after_s), float(modulated_after_s), float(depth), float(rise_fall_s),
                      _RAMP_WIDTH_PER_10_90, fs_hz, float(amplitude), bool(pr_ask))


def ask_command_baseband(command: AskCommand, bits) -> np.ndarray:
    """:func:`command_ask_baseband` of ``bits`` with its other arguments made by :func:`ask_command`:
    one kernel call.

    Parameters
    ----------
    command : AskCommand
        The lead-in, CW lengths and modulation (:func:`ask_command`).
    bits : array_like
        ``(n,)`` 0/1, MSB first (a ``uint8`` array is passed on as is; the kernel checks its values).

    Returns
    -------
    numpy.ndarray
        The baseband [√W], ``complex128``, ceil((r_last + cw_after_s)·fs) samples.

    Raises
    ------
    ValueError
        If a bit is not 0/1 or the edges are too slow.
    """
    if not (isinstance(bits, np.ndarray) and bits.dtype == np.uint8 and bits.ndim == 1
            and bits.flags.c_contiguous):
        bits = as_bits(bits)
    out, code = _k.command_baseband_kernel(command.symbols_s, bits, *command[1:])
    if code == 1:
        raise ValueError("bits must contain only 0 and 1")
    if code == 2:
        raise ValueError(_SLOW_EDGES)
    return out


def command_ask_baseband(lead: PieLeadIn, bits, *, cw_after_s: float, modulated_after_s: float, amplitude: float,
                         pr_ask: bool, depth: float, fs_hz: float, rise_fall_s: float = 0.0) -> np.ndarray:
    """:func:`ask_baseband` of a command's bits in one kernel call, from its checked lead-in.

    The samples of ``ask_baseband(pie_timeline(bits, …), …, modulated_s=r_last +
    modulated_after_s)``, bit for bit (``r_last`` the last rising edge [s], the timeline's
    lead-in and timing those of ``lead``), without the intermediate arrays and checks
    (:func:`ask_command`, then :func:`ask_command_baseband`).

    Parameters
    ----------
    lead : PieLeadIn
        The command's timing and lead-in (:func:`pie_lead_in`).
    bits : array_like
        ``(n,)`` 0/1, MSB first (a ``uint8`` array is passed on as is; the kernel checks its values).
    cw_after_s : float
        CW after the last rising edge [s], ≥ 0.
    modulated_after_s : float
        Time after the last rising edge up to which the envelope is evaluated [s]
        (:func:`ask_baseband` ``modulated_s``); beyond it the constant CW.
    amplitude, pr_ask, depth, fs_hz, rise_fall_s : float, bool, float, float, float
        As in :func:`ask_baseband`: CW amplitude A [√W], PR-ASK (True) or DSB-ASK, depth
        (A−B)/A in (0, 1], sample rate [Hz], 10–90 % edge time [s] (default 0: hard edges).

    Returns
    -------
    numpy.ndarray
        ``(ceil((r_last + cw_after_s)·fs),) complex128`` baseband [√W].

    Raises
    ------
    ValueError
        If a bit is not 0/1, ``cw_after_s`` or ``rise_fall_s`` is negative, ``depth`` is
        outside (0, 1], ``fs_hz`` is not positive or the edges are too slow.
    """
    return ask_command_baseband(ask_command(lead, cw_after_s=cw_after_s, modulated_after_s=modulated_after_s,
                                            amplitude=amplitude, pr_ask=pr_ask, depth=depth, fs_hz=fs_hz,
                                            rise_fall_s=rise_fall_s), bits)


def pie_envelope_for_profile(bits, profile, *, fs_hz: float, preamble: str = "query", **kwargs):
    """:func:`pie_envelope` with the PIE timing and depth taken from a ``LinkProfile``.

    Parameters
    ----------
    bits : array_like
        ``(n,)`` 0/1, MSB first.
    profile : rfsim.gen2.link.LinkProfile
        Supplies ``tari_s, data1_tari, trcal_s, pw_s, delimiter_s, depth``.
    fs_hz : float
        Sample rate [Hz].
    preamble : {"query", "frame-sync"}
        Lead-in.
    **kwargs
        ``rise_fall_s``, ``cw_before_s``, ``cw_after_s`` [s] of :func:`pie_envelope`.

    Returns
    -------
    numpy.ndarray
        Envelope in units of the CW amplitude [1].
    """
    return pie_envelope(
        bits, tari_s=profile.tari_s, data1_tari=profile.data1_tari, trcal_s=profile.trcal_s,
        pw_s=profile.pw_s, delimiter_s=profile.delimiter_s, depth=profile.depth, fs_hz=fs_hz,
        preamble=preamble, **kwargs,
    )


# ----------------------------------------------------------------------------- decoder


#: Most iterations of the isodata split (:func:`two_level_threshold`'s default).
ISODATA_MAX_ITER = 50


def two_level_threshold(x: np.ndarray, *, max_iter: int = ISODATA_MAX_ITER) -> tuple[float, float, float]:
    """Isodata split of a two-level signal (numba kernel).

    Starts at (min + max)/2 and iterates threshold = (mean below + mean above)/2; the
    result is independent of the signal's scale and offset and of the duty cycle.

    Parameters
    ----------
    x : numpy.ndarray
        Real samples, any scale and offset (flattened).
    max_iter : int
        Most iterations.

    Returns
    -------
    threshold, low_mean, high_mean : float
        Threshold and the cluster means, unit of ``x``.
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    lo, hi = float(x.min()), float(x.max())
    if x.ndim != 1:
        x = x.ravel()
    thr, m_lo, m_hi = _k.two_level_kernel(x, lo, hi, int(max_iter), np.empty(x.size), np.empty(x.size))
    return float(thr), float(m_lo), float(m_hi)


def _prepare(x, threshold, hysteresis, levels=None, check_finite=True):
    x = np.asarray(x)
    if x.dtype in (np.complex64, np.complex128) and levels is not None:
        # complex samples: the kernels read their magnitude on the fly; the caller's levels
        # come from a pass that has already refused non-finite samples
        x = np.ascontiguousarray(x)
        if x.ndim != 1:
            raise ValueError(f"x must be 1-D, got shape {x.shape}")
        if x.size < 2:
            return x, None, None
    else:
        x = np.ascontiguousarray(x, dtype=np.float64)
        if x.ndim != 1:
            raise ValueError(f"x must be 1-D, got shape {x.shape}")
        if x.size < 2 or (check_finite and not np.all(np.isfinite(x))):
            return x, None, None
    thr, m_lo, m_hi = two_level_threshold(x) if levels is None else (float(v) for v in levels)
    if threshold is not None:
        thr = float(threshold)
    return x, thr, float(hysteresis) * (m_hi - m_lo)


@dataclass(frozen=True)
class PieEdges:
    """Comparator output and frame boundaries of :func:`pie_decode_arrays` (samples of x).

    ``pos``/``direction``: (ne,) edge positions and directions (0 fall, 1 rise);
    ``start``/``end``/``delimiter``/``tari``/``rtcal``/``trcal``: (nf,) per frame;
    ``bits[offset[i]: offset[i] + count[i]]`` the bits of frame i.
    """

    pos: np.ndarray
    direction: np.ndarray
    start: np.ndarray
    end: np.ndarray
    delimiter: np.ndarray
    tari: np.ndarray
    rtcal: np.ndarray
    trcal: np.ndarray
    offset: np.ndarray
    count: np.ndarray
    bits: np.ndarray

    def frames(self, keep=None) -> list[PieFrame]:
        """The frames as :class:`PieFrame` objects.

        Parameters
        ----------
        keep : array_like of bool or None
            ``(nf,)`` frames to keep (None: all).

        Returns
        -------
        list of PieFrame
            In time order, durations in samples.
        """
        idx = range(self.start.size) if keep is None else np.flatnonzero(keep).tolist()
        return [
            PieFrame(start=float(self.start[i]), end=float(self.end[i]), delimiter=float(self.delimiter[i]),
                     tari=float(self.tari[i]), rtcal=float(self.rtcal[i]), trcal=float(self.trcal[i]),
                     bits=self.bits[self.offset[i]: self.offset[i] + self.count[i]].copy())
            for i in idx
        ]


def pie_decode_arrays(x, *, threshold: float | None = None, hysteresis: float = PIE_HYSTERESIS,
                      levels: tuple[float, float, float] | None = None) -> PieEdges:
    """:func:`pie_decode` returning the edges and per-frame arrays instead of frame objects (numba kernels).

    With ``levels`` given, ``x`` may also be complex samples (complex64/128): the comparator
    then reads their magnitude sample by sample, without a full-length envelope array.

    Parameters
    ----------
    x : array_like
        ``(n,)`` real envelope of any scale and offset (or complex samples with ``levels``).
    threshold : float or None
        Comparator threshold, unit of ``x``; default midway between the two level clusters.
    hysteresis : float
        Half-width of the hysteresis band as a fraction of high − low cluster means.
    levels : tuple of float or None
        ``(threshold, low, high)`` of ``x`` if already computed.

    Returns
    -------
    PieEdges
        Edges and per-frame arrays, in samples of ``x`` (empty for fewer than 2 samples or
        non-finite real samples).

    Raises
    ------
    ValueError
        If ``x`` is not 1-D.
    """
    # with levels given, the kernel checks that a real envelope is finite (two_level_threshold
    # needs that check before it runs)
    x, thr, hyst = _prepare(x, threshold, hysteresis, levels, check_finite=levels is None)
    if thr is None:
        z = np.zeros(0)
        return PieEdges(z, np.zeros(0, np.int8), z, z, z, z, z, z, np.zeros(0, np.int64),
                        np.zeros(0, np.int64), np.zeros(0, np.uint8))
    n = x.size
    pos, direction, bits = np.empty(n), np.empty(n, dtype=np.int8), np.empty(n, dtype=np.uint8)
    f, i = np.empty((6, n // 2 + 1)), np.empty((2, n // 2 + 1), dtype=np.int64)
    ne, nf = _k.decode_kernel(x, thr, hyst, levels is not None and x.dtype == np.float64, *RTCAL_TARI_RANGE,
                              MAX_TRCAL_RTCAL, pos, direction, f, i, bits)
    if ne < 0:  # a non-finite sample
        return PieEdges(pos[:0], direction[:0], *f[:, :0], *i[:, :0], bits[:0])
    return PieEdges(pos[:ne], direction[:ne], *f[:, :nf], *i[:, :nf], bits[:max(ne, 1)])


def pie_decode(x, *, threshold: float | None = None, hysteresis: float = PIE_HYSTERESIS,
               levels: tuple[float, float, float] | None = None) -> list[PieFrame]:
    """Find and decode every PIE command in a real envelope (numba kernels).

    Parameters
    ----------
    x : array_like
        ``(n,) float`` envelope of arbitrary scale and offset sampled by the decoder's clock.
    threshold : float or None
        Comparator threshold; default midway between the two level clusters.
    hysteresis : float
        Half-width of the comparator's hysteresis band as a fraction of the difference
        between the high and low cluster means.
    levels : tuple of float or None
        ``two_level_threshold(x)`` if the caller has already computed it (saves the second
        isodata split); must belong to this ``x``.

    Returns
    -------
    list of PieFrame
        In time order (durations in samples of ``x``).
    """
    return pie_decode_arrays(x, threshold=threshold, hysteresis=hysteresis, levels=levels).frames()


__all__ = [
    "PREAMBLES",
    "PieTimeline",
    "PieFrame",
    "pie_timeline",
    "PieLeadIn",
    "pie_lead_in",
    "command_ask_baseband",
    "AskCommand",
    "ask_command",
    "ask_command_baseband",
    "pie_envelope",
    "pie_envelope_for_profile",
    "timeline_envelope",
    "pr_ask_baseband",
    "ask_baseband",
    "two_level_threshold",
    "ISODATA_MAX_ITER",
    "PIE_HYSTERESIS",
    "PieEdges",
    "pie_decode_arrays",
    "pie_decode",
]

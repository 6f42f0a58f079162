"""Recorded baseband captures: loading them and decoding the reader commands they contain.

A capture is a complex baseband recording (GNU Radio file sink: raw interleaved
complex64, or a NumPy ``.npy`` array) of unknown amplitude scale, or a real envelope
(|IQ|) that may also carry an unknown offset; it must be finite (NaN/Inf are refused with
a one-line :class:`rfsim.core.errors.UserError`). Reader commands are found in its envelope,
normalised to 0…1 by the two level clusters (:func:`envelope_levels`), decoded with the PIE
decoder of :mod:`rfsim.gen2.pie` and kept only when they pass the PIE plausibility gate
(:func:`plausible_frames`: every symbol Tari or RTcal − Tari, equal pulse widths, Gen2
ratios, level contrast), so threshold crossings of noise are not commands; the bits are
parsed with :mod:`rfsim.gen2.commands`. Timings are the medians over all commands (anchors
§3.7: gr-rfid reader waveform); :func:`timing_warnings` says when they lie outside the Gen2
limits (a wrong sample rate). Tag replies: :mod:`rfsim.gen2.replies`.

:func:`fit_gain_offset` and :func:`preamble_threshold` are shared by the capture decoder
and the simulated reader's receiver (rfsim.devices.reader).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rfsim.core.errors import UserError
from rfsim.gen2.bits import bits_to_str
from rfsim.gen2.commands import COMMAND_CRC, COMMAND_PREFIXES, CommandParseError, command_fields, command_name, parse
from rfsim.gen2.crc import crc5_ok, crc16_ok
from rfsim.gen2.link import (DATA1_TARI_RANGE, DELIMITER_NOMINAL_S, DELIMITER_RANGE_S, TARI_RANGE_S,
                             TRCAL_RTCAL_RANGE)
from rfsim.gen2.pie import PieEdges, pie_decode_arrays
from rfsim.core.lazy import lazy_import

_ck = lazy_import("rfsim.gen2._capture_kernels")
_fk = lazy_import("rfsim.gen2._fit_kernels")

#: File name endings read as raw interleaved complex64 (GNU Radio file sink).
RAW_SUFFIXES = (".cf32", ".fc32", ".cfile", ".c64", ".bin", ".raw", ".dat")
SUFFIXES = RAW_SUFFIXES + (".npy",)


def load_capture(path) -> np.ndarray:
    """Read a capture file as ``(n,) complex64``.

    ``.npy`` (1-D, real or complex) or raw interleaved float32 I/Q with one of
    :data:`RAW_SUFFIXES`.

    Parameters
    ----------
    path : str or os.PathLike
        The capture file.

    Returns
    -------
    numpy.ndarray
        ``(n,) complex64`` samples in the file's unit.

    Raises
    ------
    rfsim.core.errors.UserError
        (one line) When the file is missing, has another ending, is empty, malformed or holds
        NaN/Inf.
    """
    p = Path(path)
    if not p.is_file():
        raise UserError(f"capture '{p}' not found")
    if p.suffix.lower() not in SUFFIXES:
        raise UserError(f"capture '{p}': unsupported file type '{p.suffix}'; use one of {', '.join(SUFFIXES)}")
    if p.suffix.lower() == ".npy":
        try:
            arr = np.load(p, allow_pickle=False)
        except (ValueError, OSError) as err:
            raise UserError(f"capture '{p}' is not a readable .npy file ({err})") from None
        if arr.ndim != 1 or not (np.issubdtype(arr.dtype, np.number) and arr.dtype != bool):
            raise UserError(f"capture '{p}' must hold a 1-D numeric array, got {arr.dtype} {arr.shape}")
        x = arr.astype(np.complex64)
    else:
        size = p.stat().st_size
        if size % 8:
            raise UserError(f"capture '{p}': {size} bytes is not a whole number of complex64 samples")
        x = np.fromfile(p, dtype=np.complex64)
    if x.size == 0:
        raise UserError(f"capture '{p}' is empty")
    check_finite(x, f"capture '{p}'")
    return x


def check_finite(samples, what: str = "capture") -> None:
    """Raise a one-line error when ``samples`` hold NaN or ±Inf.

    Parameters
    ----------
    samples : array_like
        Samples of any shape and unit.
    what : str
        What the samples are, for the message.

    Raises
    ------
    rfsim.core.errors.UserError
        If a sample is not finite (the count and the first index are stated).
    """
    x = np.asarray(samples)
    bad = ~np.isfinite(x)
    if bad.any():
        k = int(np.argmax(bad))
        raise UserError(f"{what} holds {int(bad.sum())} non-finite samples (NaN or Inf), the first at "
                        f"sample {k}; a capture must be finite numbers")


@dataclass(frozen=True)
class ReaderCommandRecord:
    """One reader command found in a capture.

    ``name`` is the command name ("Query", "ACK", … or "unknown"), ``fields`` the parsed
    fields (empty when parsing failed), ``crc_ok`` True/False for commands with a CRC and
    None otherwise, ``error`` the parse error message or None. Times in seconds;
    ``trcal_s`` is NaN for commands sent with frame-sync.
    """

    start_s: float
    name: str
    bits: str
    fields: dict = field(default_factory=dict)
    crc_ok: bool | None = None
    error: str | None = None
    end_s: float = math.nan
    delimiter_s: float = math.nan
    tari_s: float = math.nan
    rtcal_s: float = math.nan
    trcal_s: float = math.nan


@dataclass(frozen=True)
class ReaderTiming:
    """Median PIE timings over the commands of a capture [s] (NaN when none), and warnings."""

    n_commands: int
    tari_s: float
    rtcal_s: float
    trcal_s: float
    delimiter_s: float
    #: one-line warnings where a timing lies outside the Gen2 limits (:func:`timing_warnings`)
    warnings: tuple[str, ...] = ()


def _name_from_prefix(bits: str) -> str:
    for n in (8, 4, 2):
        if bits[:n] in COMMAND_PREFIXES and len(bits) >= n:
            return COMMAND_PREFIXES[bits[:n]]
    return "unknown"


def _crc_ok(name: str, bits: np.ndarray) -> bool | None:
    kind = COMMAND_CRC.get(name)
    if kind == 5:
        return crc5_ok(bits)
    if kind == 16:
        return crc16_ok(bits)
    return None


def parse_record(bits: np.ndarray, **timing) -> ReaderCommandRecord:
    """Parse decoded command bits into a :class:`ReaderCommandRecord` (never raises).

    Parameters
    ----------
    bits : numpy.ndarray
        ``(n,) uint8`` command bits.
    **timing
        ``start_s``, ``end_s``, ``delimiter_s``, ``tari_s``, ``rtcal_s``, ``trcal_s`` [s] of
        the frame, passed to the record.

    Returns
    -------
    ReaderCommandRecord
        The record; a parse failure gives ``error`` and the name from the bits' prefix.
    """
    text = bits_to_str(bits)
    try:
        cmd = parse(bits)
    except CommandParseError as err:
        name = _name_from_prefix(text)
        return ReaderCommandRecord(bits=text, name=name, crc_ok=_crc_ok(name, bits), error=str(err), **timing)
    name = command_name(cmd)
    return ReaderCommandRecord(bits=text, name=name, fields=command_fields(cmd), crc_ok=_crc_ok(name, bits), **timing)


#: Bins of the level histogram of :func:`envelope_levels`.
LEVEL_BINS = 16384


def _check_samples(samples) -> np.ndarray:
    x = np.ascontiguousarray(samples)
    if x.ndim != 1:
        raise ValueError(f"samples must be 1-D, got shape {x.shape}")
    if not (np.issubdtype(x.dtype, np.number) and x.dtype != bool):
        raise ValueError(f"samples must be numeric, got {x.dtype}")
    if x.dtype not in (np.complex64, np.complex128, np.float32, np.float64):
        x = x.astype(np.complex128 if np.iscomplexobj(x) else np.float64)
    return x


def _split_levels(v) -> tuple[float, float, float]:
    """``(threshold, low, high)`` of the envelope of ``v`` (real, or complex: its magnitude
    read on the fly): the isodata split on the :data:`LEVEL_BINS`-bin histogram (module
    docstring of :func:`envelope_levels`); raises :class:`rfsim.core.errors.UserError` on NaN/Inf."""
    cplx = v.dtype in (np.complex64, np.complex128)
    lo, hi, n_bad, first_bad = (_ck.power_range_kernel if cplx else _ck.range_kernel)(v)
    if n_bad:
        raise UserError(f"capture holds {n_bad} non-finite samples (NaN or Inf), the first at sample "
                        f"{first_bad}; a capture must be finite numbers")
    hist = np.empty(LEVEL_BINS, dtype=np.int64)
    _ck.histogram_kernel(v, lo, hi, hist)
    centres = lo + (np.arange(LEVEL_BINS) + 0.5) * ((hi - lo) / LEVEL_BINS)
    thr, m_lo, m_hi = 0.5 * (lo + hi), lo, hi
    csum, wsum = np.cumsum(hist), np.cumsum(hist * centres)
    for _ in range(100):
        k = int(np.searchsorted(centres, thr))  # bins below the threshold: 0 … k−1
        if k == 0 or k == LEVEL_BINS or csum[k - 1] == 0 or csum[k - 1] == csum[-1]:
            break
        m_lo = wsum[k - 1] / csum[k - 1]
        m_hi = (wsum[-1] - wsum[k - 1]) / (csum[-1] - csum[k - 1])
        new = 0.5 * (m_lo + m_hi)
        if new == thr:
            break
        thr = new
    return float(thr), float(m_lo), float(m_hi)


def envelope_levels(samples) -> tuple[np.ndarray, float, float, float]:
    """Envelope and its two level clusters.

    ``env = |x|`` for complex samples, ``x`` for a real envelope. The levels are the isodata
    split of :func:`rfsim.gen2.pie.two_level_threshold` (threshold = midpoint of the means
    below and above it, iterated) computed on a :data:`LEVEL_BINS`-bin histogram of the
    envelope instead of the samples themselves (one pass over the capture; the threshold
    is exact to one bin, 1/16384 of the envelope's range).

    Parameters
    ----------
    samples : array_like
        ``(n,)`` complex baseband or real envelope, any scale.

    Returns
    -------
    env : numpy.ndarray
        ``(n,) float64`` envelope, unit of ``samples``.
    threshold, low, high : float
        Decision threshold and the means of the low and high clusters, unit of ``samples``.

    Raises
    ------
    rfsim.core.errors.UserError
        When a sample is NaN or ±Inf (numba kernels).
    ValueError
        If ``samples`` is not 1-D numeric.
    """
    x = _check_samples(samples)
    if x.size == 0:
        return np.zeros(0), 0.0, 0.0, 0.0
    if np.iscomplexobj(x):
        env = np.empty(x.size, dtype=np.float64)
        _ck.magnitude_kernel(x, env)
    else:
        env = x.astype(np.float64)
    thr, m_lo, m_hi = _split_levels(env)
    return env, thr, m_lo, m_hi


def normalized_envelope(samples) -> np.ndarray:
    """Envelope scaled so that the low level cluster is 0 and the high one 1.

    (env − low)/(high − low) with the levels of :func:`envelope_levels`.

    Parameters
    ----------
    samples : array_like
        ``(n,)`` complex baseband (→ |x|) or a real envelope of any scale and offset.

    Returns
    -------
    numpy.ndarray
        ``(n,) float64`` normalised envelope [1].
    """
    env, _, lo, hi = envelope_levels(samples)
    _ck.normalize_kernel(env, lo, 1.0 / (hi - lo) if hi > lo else 1.0)
    return env


#: PIE plausibility gate (:func:`plausible_frames`): the Gen2 ratios (gen2-and-validation-
#: anchors.md §4.1; rfsim.gen2.link) widened by 10 % for reader clock error and edge
#: quantisation: RTcal/Tari 2.5–3.0, TRcal/RTcal 1.1–3.0, delimiter/Tari 12.5 µs ± 5 % over
#: Tari 6.25–25 µs = 0.475–2.1, PW/Tari 0.265–0.525. The delimiter and PW limits are
#: widened further (delimiter 0.5×/1.25×, PW 0.15–0.75): band-limited edges move the 50 %
#: points, and the gr-rfid reader's Query delimiter measures 9.6 µs (2.4 samples at 250 kS/s).
GATE_RTCAL_TARI = (0.9 * (1 + DATA1_TARI_RANGE[0]), 1.1 * (1 + DATA1_TARI_RANGE[1]))
GATE_TRCAL_RTCAL = (0.9 * TRCAL_RTCAL_RANGE[0], 1.1 * TRCAL_RTCAL_RANGE[1])
GATE_DELIMITER_TARI = (0.5 * DELIMITER_RANGE_S[0] / TARI_RANGE_S[1], 1.25 * DELIMITER_RANGE_S[1] / TARI_RANGE_S[0])
GATE_PW_TARI = (0.15, 0.75)
#: Symbol and pulse-width tolerance: GATE_TOL_TARI·Tari + GATE_TOL_SAMPLES (edges are
#: interpolated to a fraction of a sample at good SNR; one sample covers slow edges).
GATE_TOL_TARI = 0.1
GATE_TOL_SAMPLES = 1.0
#: Minimum contrast (high − low level)/σ of a frame's mid-pulse and mid-interval samples.
#: An envelope of complex Gaussian noise gives ≈ 1–3 on the frames its threshold crossings
#: form; a command at 10 dB envelope SNR gives ≈ 9 (σ ≈ 0.3 of the low-high step).
GATE_MIN_CONTRAST = 6.0
#: Fewest data bits of a command (QueryRep: 4).
GATE_MIN_BITS = 4


def plausible_frames(edges: PieEdges, env: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """PIE plausibility gate for the frames of ``edges``.

    A frame is a command only if its timing is that of a PIE reader (every data symbol
    Tari or RTcal − Tari, equal pulse widths, Gen2 ratios, :data:`GATE_RTCAL_TARI` …;
    gen2-and-validation-anchors.md §4.1) and its levels are two well separated clusters
    (contrast ≥ :data:`GATE_MIN_CONTRAST`); thresholds crossed by noise alone form frames
    that fail both (numba kernel ``frame_gate_kernel``; the tests hold it to a plain-NumPy
    twin).

    Parameters
    ----------
    edges : rfsim.gen2.pie.PieEdges
        Edges and frames from :func:`rfsim.gen2.pie.pie_decode_arrays` of ``env``.
    env : numpy.ndarray
        ``(n,)`` envelope (any scale and offset) or complex samples, whose magnitude is then read.

    Returns
    -------
    keep : numpy.ndarray
        ``(nf,) bool``, the frames that pass.
    contrast : numpy.ndarray
        ``(nf,) float64`` (high − low level)/σ of each frame [1].
    """
    first, last = _frame_edges(edges)
    n = first.size
    keep = np.zeros(n, dtype=np.uint8)
    contrast = np.zeros(n)
    env = np.asarray(env)
    env = np.ascontiguousarray(env) if env.dtype in (np.complex64, np.complex128) else np.ascontiguousarray(
        env, dtype=np.float64)
    _ck.frame_gate_kernel(edges.pos, env, first, last, edges.tari,
                          edges.rtcal, edges.trcal, np.array(GATE_RTCAL_TARI), np.array(GATE_TRCAL_RTCAL),
                          np.array(GATE_DELIMITER_TARI), np.array(GATE_PW_TARI), GATE_TOL_TARI, GATE_TOL_SAMPLES,
                          GATE_MIN_CONTRAST, GATE_MIN_BITS, contrast, keep)
    return keep.astype(bool), contrast


def _frame_edges(edges: PieEdges) -> tuple[np.ndarray, np.ndarray]:
    """Edge indices of each frame's first (delimiter fall) and last (closing rise) edge."""
    return (np.searchsorted(edges.pos, edges.start).astype(np.int64),
            np.searchsorted(edges.pos, edges.end).astype(np.int64))


def decode_reader_commands(samples, fs_hz: float, *, gate: bool = True
                           ) -> tuple[list[ReaderCommandRecord], ReaderTiming]:
    """Find, decode and parse every reader PIE command in a capture.

    Parameters
    ----------
    samples : (n,) complex baseband or real envelope, arbitrary scale (and offset, if real);
        must be finite (NaN/Inf raise :class:`rfsim.core.errors.UserError`)
    fs_hz : sample rate [Hz]
    gate : apply the PIE plausibility gate (:func:`plausible_frames`)

    Returns
    -------
    records : list of :class:`ReaderCommandRecord` in time order
    timing : :class:`ReaderTiming`, medians over the commands, with warnings where the
        measured timings lie outside the Gen2 limits (:func:`timing_warnings`)
    """
    fs_hz = float(fs_hz)
    if not (math.isfinite(fs_hz) and fs_hz > 0):
        raise ValueError(f"fs_hz must be > 0, got {fs_hz}")
    x = _check_samples(samples)
    # the comparator, the frame parser and the gate are invariant to the envelope's scale
    # and offset: the raw envelope is used with its levels (no normalisation pass); of
    # complex samples the kernels read the magnitude on the fly (no envelope array: a
    # 10 s capture at 2 MS/s would need 160 MB more)
    env = x if np.iscomplexobj(x) else x.astype(np.float64)
    levels = _split_levels(env) if x.size else (0.0, 0.0, 0.0)
    edges = pie_decode_arrays(env, levels=levels)
    keep = plausible_frames(edges, env)[0] if gate else None
    records = [
        parse_record(
            f.bits, start_s=f.start / fs_hz, end_s=f.end / fs_hz, delimiter_s=f.delimiter / fs_hz,
            tari_s=f.tari / fs_hz, rtcal_s=f.rtcal / fs_hz, trcal_s=f.trcal / fs_hz,
        )
        for f in edges.frames(keep)
    ]

    def med(values):
        v = np.array([x for x in values if not math.isnan(x)])
        return float(np.median(v)) if v.size else math.nan

    timing = ReaderTiming(
        n_commands=len(records),
        tari_s=med(r.tari_s for r in records),
        rtcal_s=med(r.rtcal_s for r in records),
        trcal_s=med(r.trcal_s for r in records),
        delimiter_s=med(r.delimiter_s for r in records),
    )
    return records, dataclasses.replace(timing, warnings=timing_warnings(timing, fs_hz))


def timing_warnings(timing: ReaderTiming, fs_hz: float) -> tuple[str, ...]:
    """One-line warnings for measured PIE timings outside the Gen2 limits.

    Limits of gen2-and-validation-anchors.md §4.1: Tari 6.25–25 µs, RTcal 2.5–3.0 Tari,
    TRcal 1.1–3.0 RTcal (1 % slack for measurement). A wrong ``fs_hz`` scales every duration:
    the Tari warning states the sample rates that would put the measured Tari (in samples)
    inside 6.25–25 µs, and, where the delimiter spans ≥ 10 samples (so that its edges do not
    dominate), the sample rate at which it is the nominal 12.5 µs. (The delimiter itself is
    not checked: at a few samples per Tari its measured length is off by up to a sample,
    e.g. 9.6 µs for the gr-rfid Query at 250 kS/s.)

    Parameters
    ----------
    timing : ReaderTiming
        Median timings [s] (NaN: not measured).
    fs_hz : float
        Sample rate the timings were measured with [Hz].

    Returns
    -------
    tuple of str
        The warnings (empty when all timings are inside).
    """
    out = []
    t, d = timing.tari_s, timing.delimiter_s
    if not math.isnan(t) and not (0.99 * TARI_RANGE_S[0] <= t <= 1.01 * TARI_RANGE_S[1]):
        n_tari = t * fs_hz
        hint = (f"; a sample rate of {n_tari / TARI_RANGE_S[1]:.4g}–{n_tari / TARI_RANGE_S[0]:.4g} Hz would put it "
                f"inside (is --fs {fs_hz:.4g} right?)")
        if not math.isnan(d) and d * fs_hz >= 10:
            hint += f"; the delimiter is 12.5 µs at {d * fs_hz / DELIMITER_NOMINAL_S:.4g} Hz"
        out.append(f"measured Tari {t * 1e6:.4g} µs is outside the Gen2 range "
                   f"{TARI_RANGE_S[0] * 1e6:.4g}–{TARI_RANGE_S[1] * 1e6:.4g} µs{hint}")
    lo, hi = 1 + DATA1_TARI_RANGE[0], 1 + DATA1_TARI_RANGE[1]
    if not math.isnan(t) and not math.isnan(timing.rtcal_s) and not (
            0.99 * lo <= timing.rtcal_s / t <= 1.01 * hi):
        out.append(f"measured RTcal {timing.rtcal_s * 1e6:.4g} µs = {timing.rtcal_s / t:.3g} Tari is outside "
                   f"the Gen2 range {lo:g}–{hi:g} Tari")
    if not math.isnan(timing.trcal_s) and not math.isnan(timing.rtcal_s) and not (
            0.99 * TRCAL_RTCAL_RANGE[0] <= timing.trcal_s / timing.rtcal_s <= 1.01 * TRCAL_RTCAL_RANGE[1]):
        out.append(f"measured TRcal {timing.trcal_s * 1e6:.4g} µs = {timing.trcal_s / timing.rtcal_s:.3g} RTcal "
                   f"is outside the Gen2 range {TRCAL_RTCAL_RANGE[0]:g}–{TRCAL_RTCAL_RANGE[1]:g} RTcal")
    return tuple(out)


# ------------------------------------------------- shared with the reader's receiver


def fit_gain_offset(r, s) -> tuple[complex, complex]:
    """Least-squares gain and offset ``(h, c)`` of ``r ≈ h·s + c``.

    Solves the 2×2 normal equations [[Σs², Σs], [Σs, n]]·[h, c] = [Σr·s, Σr] in closed form (numba
    kernel; the sums run sample by sample).

    Parameters
    ----------
    r : array_like
        ``(n,)`` complex, received baseband (any unit).
    s : array_like
        ``(n,)`` real, the known reference: the ±1 reply levels, and −1 where the tag rests in
        its absorbing state outside its reply (the DC step of a monostatic capture).

    Returns
    -------
    h, c : complex
        Gain and offset, unit of ``r``.

    Raises
    ------
    ValueError
        If ``r`` and ``s`` differ in shape or ``s`` is constant.
    """
    r = np.ascontiguousarray(r, dtype=np.complex128)
    s = np.ascontiguousarray(s, dtype=np.float64)
    if r.ndim != 1 or r.shape != s.shape:
        raise ValueError(f"r and s must be 1-D of equal length, got {r.shape} and {s.shape}")
    h, c, ok = _fk.fit_gain_offset_kernel(r, s)
    if not ok:
        raise ValueError("the reference s is constant: gain and offset cannot be separated")
    return complex(h), complex(c)


def preamble_threshold(n_samples: int, n_tests: int, false_alarm_probability: float = 1e-3) -> float:
    """Normalised preamble-correlation threshold γ for ``n_tests`` trial lags (and BLFs).

    On complex white noise the zero-mean normalised correlation of an ``n_samples`` template
    obeys corr² ~ Beta(1, n − 2), P(corr > γ) = (1 − γ²)^(n−2); the sub-sample refinement
    of :func:`rfsim.gen2.linecode.decode_reply` counts as about twice as many tests (the
    rule and the factor of the reader receiver, rfsim.devices.reader ``detection_threshold``).
    γ = √(1 − (P_FA/(2·n_tests))^(1/(n−2))).

    Parameters
    ----------
    n_samples : int
        Template length n [samples].
    n_tests : int
        Trial lags × hypotheses tested.
    false_alarm_probability : float
        P_FA over all tests, in (0, 1).

    Returns
    -------
    float
        γ in [0, 1).

    Raises
    ------
    ValueError
        If ``false_alarm_probability`` is not in (0, 1).
    """
    if not 0.0 < false_alarm_probability < 1.0:
        raise ValueError(f"false_alarm_probability must be in (0, 1), got {false_alarm_probability}")
    p = false_alarm_probability / (2.0 * max(int(n_tests), 1))
    return math.sqrt(1.0 - p ** (1.0 / max(int(n_samples) - 2, 1)))


__all__ = [
    "RAW_SUFFIXES",
    "SUFFIXES",
    "ReaderCommandRecord",
    "ReaderTiming",
    "load_capture",
    "check_finite",
    "envelope_levels",
    "normalized_envelope",
    "plausible_frames",
    "parse_record",
    "decode_reader_commands",
    "timing_warnings",
    "fit_gain_offset",
    "preamble_threshold",
]

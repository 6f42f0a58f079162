"""Reference twins of :mod:`rfsim.gen2.pie` (PIE envelope, PR-ASK baseband, isodata split and the
PIE decoder in plain NumPy/Python)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.gen2._pie_kernels import FALL
from rfsim.gen2.pie import (MAX_TRCAL_RTCAL, RTCAL_TARI_RANGE, PieFrame, PieTimeline, _check_fs, _prepare,
                            _ramp_width_samples, pie_timeline)


def pie_timeline_reference(bits, *, tari_s: float, data1_tari: float, trcal_s: float | None, pw_s: float,
                           delimiter_s: float, preamble: str = "query", cw_before_s: float = 0.0,
                           cw_after_s: float = 0.0) -> PieTimeline:
    """Plain-NumPy twin of :func:`rfsim.gen2.pie.pie_timeline` (valid arguments): the symbol
    lengths' ``numpy.cumsum`` after the delimiter."""
    arr = np.asarray(bits, dtype=np.uint8)
    data1_s = float(data1_tari) * tari_s
    symbols = [tari_s, tari_s + data1_s] + ([float(trcal_s)] if preamble == "query" else [])
    lengths = np.concatenate([symbols, np.where(arr == 1, data1_s, tari_s)])
    t0 = float(cw_before_s) + delimiter_s
    ends = t0 + np.cumsum(lengths)
    rise = np.concatenate([[t0], ends])
    fall = np.concatenate([[float(cw_before_s)], ends - pw_s])
    return PieTimeline(fall_s=fall, rise_s=rise, duration_s=float(rise[-1] + cw_after_s))


def pr_ask_baseband_reference(timeline: PieTimeline, envelope: np.ndarray, *, amplitude: float,
                              fs_hz: float) -> np.ndarray:
    """Plain-NumPy twin of :func:`rfsim.gen2.pie.pr_ask_baseband`."""
    mid = 0.5 * (timeline.fall_s + timeline.rise_s)
    t = np.arange(envelope.size) / fs_hz
    flips = np.searchsorted(mid, t, side="right")
    sign = 1.0 - 2.0 * (flips % 2)
    return (amplitude * sign * envelope).astype(np.complex128)


def pie_envelope_reference(bits, *, depth: float, fs_hz: float, rise_fall_s: float = 0.0, **timing):
    """Plain-NumPy twin of :func:`rfsim.gen2.pie.pie_envelope` (same arguments)."""
    fs_hz = _check_fs(fs_hz)
    tl = pie_timeline(bits, **timing)
    width = _ramp_width_samples(float(rise_fall_s), fs_hz, tl)
    n = np.arange(int(math.ceil(tl.duration_s * fs_hz)), dtype=np.float64)

    def step(tau):
        if width <= 0:
            return (tau >= 0).astype(np.float64)
        inner = 0.5 * (1.0 + np.sin(np.pi * np.clip(tau, -width / 2, width / 2) / width))
        return np.where(tau <= -width / 2, 0.0, np.where(tau >= width / 2, 1.0, inner))

    out = np.ones(n.size)
    for f, r in zip(tl.fall_s * fs_hz, tl.rise_s * fs_hz):
        out -= depth * (step(n - f) - step(n - r))
    return out


def two_level_threshold_reference(x: np.ndarray, *, max_iter: int = 50) -> tuple[float, float, float]:
    """Plain-NumPy twin of :func:`rfsim.gen2.pie.two_level_threshold`."""
    x = np.asarray(x, dtype=np.float64)
    lo, hi = float(x.min()), float(x.max())
    thr = 0.5 * (lo + hi)
    m_lo, m_hi = lo, hi
    for _ in range(max_iter):
        below = x < thr
        if below.all() or not below.any():
            break
        m_lo, m_hi = float(x[below].mean()), float(x[~below].mean())
        new = 0.5 * (m_lo + m_hi)
        if new == thr:
            break
        thr = new
    return thr, m_lo, m_hi


def pie_decode_reference(x, *, threshold: float | None = None, hysteresis: float = 0.1) -> list[PieFrame]:
    """Plain NumPy/Python twin of :func:`rfsim.gen2.pie.pie_decode` (same algorithm)."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    levels = two_level_threshold_reference(x) if x.ndim == 1 and x.size >= 2 and np.all(np.isfinite(x)) else None
    x, thr, hyst = _prepare(x, threshold, hysteresis, levels)
    if thr is None:
        return []
    above, below = x > thr + hyst, x < thr - hyst
    defined = above | below
    if not defined.any():
        return []
    idx = np.maximum.accumulate(np.where(defined, np.arange(x.size), -1))
    first = int(np.argmax(defined))
    state = np.where(idx >= 0, above[np.maximum(idx, 0)], above[first]).astype(np.int8)
    n = np.flatnonzero(np.diff(state)) + 1
    d = x[n] - x[n - 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(d != 0.0, (thr - x[n - 1]) / np.where(d != 0.0, d, 1.0), 0.5)
    pos = (n - 1) + np.clip(frac, 0.0, 1.0)
    direction = state[n]

    frames: list[PieFrame] = []
    lo_ratio, hi_ratio = RTCAL_TARI_RANGE
    ne, i = pos.size, 0
    while i < ne:
        if direction[i] != FALL or i + 5 >= ne:
            i += 1
            continue
        r0, r1, r2 = pos[i + 1], pos[i + 3], pos[i + 5]
        tari, rtcal = r1 - r0, r2 - r1
        if not (tari > 0 and lo_ratio * tari <= rtcal <= hi_ratio * tari):
            i += 1
            continue
        j, trcal = i + 5, math.nan
        if j + 2 < ne and rtcal < pos[j + 2] - pos[j] <= MAX_TRCAL_RTCAL * rtcal:
            trcal = pos[j + 2] - pos[j]
            j += 2
        out = []
        while j + 2 < ne and pos[j + 2] - pos[j] <= rtcal:
            out.append(1 if pos[j + 2] - pos[j] > 0.5 * rtcal else 0)
            j += 2
        if not out:
            i += 1
            continue
        frames.append(PieFrame(float(pos[i]), float(pos[j]), float(r0 - pos[i]), float(tari),
                               float(rtcal), float(trcal), np.array(out, dtype=np.uint8)))
        i = j + 1
    return frames


__all__ = ["pie_timeline_reference", "pr_ask_baseband_reference", "pie_envelope_reference",
           "two_level_threshold_reference", "pie_decode_reference"]

"""Reference twins of :mod:`rfsim.devices.reader` (the BLF-searching decoder, the reply
measurement and the known-level selection in plain NumPy/Python)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.devices.reader import (DOPPLER_BLOCKS, FINE_FIRST_BITS, FINE_PER_SIDE, SearchDecode, _search_result,
                                  _search_setup, _steady)
from rfsim.gen2.capture import fit_gain_offset
from rfsim.gen2.linecode import reply_duration_s, reply_waveform
from reference.gen2_capture import fit_gain_offset_reference
from reference.gen2_linecode import decode_reply_reference


def search_decode_reference(rs, *, m: int, trext: bool, n_bits: int, blfs_hz, fs_hz: float, lo: int,
                            hi: int) -> SearchDecode:
    """Plain NumPy/Python twin of :func:`rfsim.devices.reader.search_decode` (same steps, one window at a time;
    decoding by :func:`reference.gen2_linecode.decode_reply_reference`)."""
    r_all = np.atleast_2d(np.asarray(rs, dtype=np.complex128))
    pre_levels, state, pre_el, ratios, tpl0, lens, span0, target1, target = _search_setup(m, trext, n_bits,
                                                                                          blfs_hz, fs_hz)
    n1 = min(n_bits, FINE_FIRST_BITS)
    out = [[] for _ in range(7)]
    for r in r_all:
        n = r.size
        best = (-1.0, 0, lo)
        for k, (L, t0) in enumerate(zip(lens, tpl0)):
            t0 = t0[:L]
            for lag in range(lo, min(hi, n - L) + 1):
                seg = r[lag:lag + L]
                c = abs(seg @ t0) / (np.linalg.norm(t0) * math.sqrt(max(np.sum(np.abs(seg - seg.mean()) ** 2), 1e-300)))
                if c > best[0]:
                    best = (c, k, lag)
        c_best, k, lag = best
        L, t0 = lens[k], tpl0[k, :lens[k]]

        def cval(l):
            seg = r[l:l + L]
            return abs(seg @ t0) / (np.linalg.norm(t0) * math.sqrt(max(np.sum(np.abs(seg - seg.mean()) ** 2), 1e-300)))

        frac = 0.0
        if lo < lag < min(hi, n - L):
            cv = [cval(lag - 1), cval(lag), cval(lag + 1)]
            den = cv[0] - 2 * cv[1] + cv[2]
            frac = 0.5 * (cv[0] - cv[2]) / den if den < 0 else 0.0
        centre = lag + frac + 0.5 * pre_el.size / ratios[k]
        span, c_ratio = span0, ratios[k]
        fit = (math.inf, ratios[k], lag + frac, 0j, np.zeros(n_bits, np.uint8), None, 0)
        nh = pre_levels.size + 2 * (n_bits + 1)

        def residual(ratio, start, nb=n_bits):
            det = decode_reply_reference(r, n_bits=nb, m=m, trext=trext, blf_hz=0.5 * ratio * fs_hz,
                                         fs_hz=fs_hz, start_sample=start)
            s = reply_waveform(det.bits, m=m, trext=trext, blf_hz=0.5 * ratio * fs_hz, fs_hz=fs_hz,
                               t0_s=start / fs_hz, n_samples=n)
            end = min(n, int(math.ceil(start + ((pre_levels.size + 2 * (nb + 1)) * m) / ratio)) + 1)
            ref = np.where(s == 0, -1.0, s)  # rest level around the reply: the whole window is explained
            h2, c2 = fit_gain_offset(r, ref)
            return float(np.sum(np.abs(r - c2 - h2 * ref) ** 2)), det, ref, h2, c2, end

        shifts = []
        for d in (-1, 0, 1):
            start = centre + d / c_ratio - 0.5 * pre_el.size / c_ratio
            if 0 <= start <= n - (int(math.ceil(nh * m / c_ratio)) + 2):
                shifts.append((residual(c_ratio, start, n1)[0], d))
        if shifts:
            centre += min(shifts, key=lambda v: (v[0], v[1] + 2))[1] / c_ratio
        nb, tgt = n1, target1
        while True:
            fit = (math.inf,) + fit[1:]
            while True:
                step = max(span / FINE_PER_SIDE, tgt)
                kk = int(math.ceil(span / step))
                found = False
                for j in range(-kk, kk + 1):
                    ratio = c_ratio * (1.0 + step * j)
                    start = centre - 0.5 * pre_el.size / ratio
                    if start < 0 or start > n - (int(math.ceil(nh * m / ratio)) + 2):
                        continue
                    res, det, ref, h2, c2, end = residual(ratio, start, nb)
                    if res < fit[0]:
                        fit = (res, ratio, start, h2, det.bits.astype(np.uint8), (ref, c2), end)
                        found = True
                if not found or step <= tgt:
                    break
                span, c_ratio = step, fit[1]
            if nb == n_bits:
                break
            nb = min(n_bits, 2 * nb)
            span, tgt, c_ratio = 4.0 * tgt, 1.0 / (4.0 * (pre_el.size + 2 * m * (nb + 1))), fit[1]
        _, ratio, start, h2, bits, (ref, c2), end = fit
        idx = np.arange(max(1, int(math.ceil(start))), end - 1)
        steady = (ref[idx] == ref[idx - 1]) & (ref[idx] == ref[idx + 1])
        idx = idx[steady]
        z = r[idx] - c2
        e2 = np.abs(z - h2 * ref[idx]) ** 2
        half = np.floor((idx - start) * ratio + 1e-9).astype(np.int64) // m
        y = (z * np.conj(h2)).real / abs(h2)
        data = (half >= pre_levels.size) & (half < pre_levels.size + 2 * n_bits)
        d = np.bincount(half[data], weights=(y * ref[idx])[data], minlength=nh)
        cnt = np.bincount(half[data], minlength=nh).astype(float)
        d2 = float(np.sum((d - abs(h2) * cnt) ** 2))
        for lst, v in zip(out, (bits, ratio, start, c_best, h2, float(e2.mean()) if e2.size else math.nan,
                                2.0 * d2 / cnt.sum() if cnt.sum() > 0 else math.inf)):
            lst.append(v)
    return _search_result(np.array(out[0], np.uint8).reshape(len(r_all), n_bits), np.array(out[1]), np.array(out[2]),
                          np.array(out[3]), np.array(out[4], np.complex128), np.array(out[5]), np.array(out[6]), m,
                          fs_hz)


def measure_reference(z: np.ndarray, s: np.ndarray, fs_hz: float) -> tuple[complex, float, float]:
    """Plain-NumPy twin of the measurement kernel: ``(h, slope [rad/s], σ²)``."""
    fs = float(fs_hz)
    idx = np.flatnonzero(s)
    i0, i1 = int(idx[0]), int(idx[-1]) + 1
    t = (np.arange(i0, i1) - 0.5 * (i0 + i1 - 1)) / fs  # time from the reply centre [s]
    # only samples whose neighbours have the same reference level: the start is known to
    # 1/16 sample, so a sample next to an element boundary may carry the other level
    ref = s[i0:i1]
    steady = _steady(ref)
    z, ref, t = z[i0:i1][steady], ref[steady], t[steady]
    starts = np.linspace(0, ref.size, DOPPLER_BLOCKS + 1).astype(int)[:-1]
    counts = np.diff(np.append(starts, ref.size)).astype(float)
    g = np.add.reduceat(z * ref, starts) / np.add.reduceat(ref * ref, starts)
    tc = np.add.reduceat(t, starts) / counts
    w2 = np.abs(g) ** 2  # weights |g_k| on the residuals (numpy.polyfit's w), squared
    if np.all(w2 > 0):
        y = np.unwrap(np.angle(g))
        xm, ym = np.dot(w2, tc) / w2.sum(), np.dot(w2, y) / w2.sum()
        slope = float(np.dot(w2, (tc - xm) * (y - ym)) / np.dot(w2, (tc - xm) ** 2))
    else:
        slope = 0.0
    rot = np.exp(-1j * slope * t)
    h = np.dot(z * rot, ref) / np.dot(ref, ref)
    sigma2 = float(np.mean(np.abs(z - h * ref / rot) ** 2))
    return complex(h), slope, sigma2


def known_levels_reference(r: np.ndarray, pre: np.ndarray, full: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plain-NumPy twin of the known-level selection of :meth:`rfsim.devices.reader.Reader.receive` step 3: level
    −1 outside the reply (``full == 0``), the preamble ``pre`` inside it; samples with both
    neighbours at the same level."""
    level = np.where(full == 0, -1.0, np.where(pre != 0, pre, full))
    known = ((pre != 0) | (full == 0)) & _steady(level)
    return r[known], level[known]


def receive_reference(reader, rx, *, t0_s: float, n_bits: int, expect_crc: bool, cmd_end_s: float):
    """Plain NumPy/Python twin of :meth:`rfsim.devices.reader.Reader.receive` (``blf_search``
    off, ``rx_model`` "sample", nominal BLF), steps 1–5 one after the other with the twins of
    the decoder, the known levels, the fit and the measurements. Returns ``(success, bits,
    failure_reason, start_s, corr, h, slope, sigma2)`` (None for what a reply not found lacks)."""
    from rfsim.gen2.crc import crc16_ok

    lk, fs, blf = reader.link, reader.fs_hz, reader.link.blf_hz
    rx = np.asarray(rx, dtype=np.complex128)
    pre_n = reader.preamble_samples(blf)
    n_reply = int(math.ceil(reply_duration_s(n_bits, m=lk.m, trext=lk.trext, blf_hz=blf) * fs))
    lo, hi = reader.reply_start_lags(rx.size, n_reply, t0_s=t0_s, cmd_end_s=cmd_end_s)
    r = rx - (rx[:lo].mean() if lo >= 8 else 0.0)
    kw = dict(n_bits=n_bits, m=lk.m, trext=lk.trext, blf_hz=blf, fs_hz=fs, method=reader.config.decoder)
    det = decode_reply_reference(r[lo:], search_samples=hi - lo, **kw)
    start = lo + det.start_sample
    if det.corr < reader.detection_threshold(hi - lo + 1, blf):
        return False, None, "preamble not found", t0_s + start / fs, det.corr, None, None, None
    full = reply_waveform(det.bits, m=lk.m, trext=lk.trext, blf_hz=blf, fs_hz=fs, t0_s=start / fs, n_samples=r.size)
    pre = reply_waveform(np.zeros(0, np.uint8), m=lk.m, trext=lk.trext, blf_hz=blf, fs_hz=fs, t0_s=start / fs,
                         n_samples=r.size, dummy=False)
    h, c = fit_gain_offset_reference(*known_levels_reference(r, pre, full))
    i0 = lo + int(math.floor(det.start_sample))
    span = r[i0: i0 + n_reply + 4] - c
    bits = decode_reply_reference(span, start_sample=det.start_sample - (i0 - lo), gain=h, **kw).bits
    ref = reply_waveform(bits, m=lk.m, trext=lk.trext, blf_hz=blf, fs_hz=fs, t0_s=start / fs, n_samples=r.size)
    hm, slope, sigma2 = measure_reference(span, ref[i0: i0 + span.size], fs)
    ok = (not expect_crc) or crc16_ok(bits)
    return ok, bits, "" if ok else "crc error", t0_s + start / fs, det.corr, hm, slope, sigma2


__all__ = ["search_decode_reference", "measure_reference", "known_levels_reference", "receive_reference"]

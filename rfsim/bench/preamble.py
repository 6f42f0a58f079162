"""Benchmark of the reader's preamble search vs sample rate (issue 16 item 5: O(fs·log fs)
or better, measured at 1–64 MS/s).

The search is that of :func:`rfsim.gen2.linecode.decode_reply` (the simulated reader's
receiver, rfsim.devices.reader, and the capture decoder): the normalised correlation of the
pilot + preamble template over every lag of a window. Here: a Miller-4 RN16 with pilot at
BLF 160 kHz (the template spans 112 elements, 350 µs), searched over a 100 µs window of
lags (T1 ± FrT and margin), in noise. Both the number of lags and the template length
grow as fs, so a sample-by-sample correlation costs O(fs²) (FFT: O(fs·log fs)); the
kernel correlates over runs of equal template samples with cumulative sums, O(lags ·
elements) = O(fs).
"""

from __future__ import annotations

import math
import time

import numpy as np

from rfsim.gen2.linecode import _kernel_corr_abs, _template, corr_abs_reference, decode_reply, reply_waveform, search_arrays
from rfsim.core.rng import trial_rng


def _best_time(fn, repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def bench_preamble(*, rates_hz=(1e6, 2e6, 4e6, 8e6, 16e6, 32e6, 64e6), blf_hz: float = 160e3, m: int = 4,
                   window_s: float = 100e-6, repeats: int = 5, seed: int = 0) -> dict:
    """Time the reader's preamble search against the sample rate (module docstring).

    CPU time of the preamble search (best of ``repeats``) and of a whole ``decode_reply`` at
    each sample rate, with scipy's correlation (``correlate``: direct or FFT, whichever it
    picks) beside it.

    Parameters
    ----------
    rates_hz : sequence of float, default (1e6, 2e6, 4e6, 8e6, 16e6, 32e6, 64e6)
        Sample rates [Hz].
    blf_hz : float, default 160e3
        Backscatter link frequency [Hz].
    m : int, default 4
        Miller factor M of the RN16 (with pilot).
    window_s : float, default 100e-6
        Window of lags searched [s].
    repeats : int, default 5
        Timed repetitions (the best is kept).
    seed : int, default 0
        Seed of the bits and the noise.

    Returns
    -------
    dict
        Per rate (``<fs>MSps_…``): lags, template samples, ``search_cpu_s``,
        ``scipy_correlate_cpu_s`` and ``decode_reply_cpu_s`` [s], ``decoded_ok``; the log-log
        slopes of time vs fs over the rates (1 = linear), ``search_slope_log_time_vs_log_fs``
        and ``scipy_slope_log_time_vs_log_fs``; and ``blf_hz``, ``m``, ``window_s``.
    """
    out: dict = {"blf_hz": blf_hz, "m": m, "window_s": window_s}
    rng = trial_rng(seed, 0)
    bits = rng.integers(0, 2, 16).astype(np.uint8)
    t_k, t_s = [], []
    for fs in rates_hz:
        lags = int(window_s * fs)
        s = reply_waveform(bits, m=m, trext=True, blf_hz=blf_hz, fs_hz=fs, t0_s=0.5 * window_s)
        noise = rng.standard_normal(s.size) + 1j * rng.standard_normal(s.size)
        r = 0.3 + 0.02 * np.where(s == 0, -1.0, s) + 0.01 * noise
        r = np.concatenate([r, np.full(lags, 0.28 + 0j)])
        t0 = _template(m, True, 2.0 * blf_hz / fs, 0.0)[1]
        seg = np.ascontiguousarray(r[: lags + t0.size])
        _kernel_corr_abs(seg, t0)  # compile
        tk = _best_time(lambda: _kernel_corr_abs(seg, t0), repeats)
        ts = _best_time(lambda: corr_abs_reference(seg, t0), repeats)
        arrays = search_arrays(m, True, 2.0 * blf_hz / fs)  # kept per link, as the decoders do
        det = decode_reply(r, n_bits=16, m=m, trext=True, blf_hz=blf_hz, fs_hz=fs, search_samples=lags, arrays=arrays)
        td = _best_time(lambda: decode_reply(r, n_bits=16, m=m, trext=True, blf_hz=blf_hz, fs_hz=fs,
                                             search_samples=lags, arrays=arrays), repeats)
        key = f"{fs / 1e6:g}MSps"
        out[f"{key}_lags"] = lags
        out[f"{key}_template_samples"] = int(t0.size)
        out[f"{key}_search_cpu_s"] = tk
        out[f"{key}_scipy_correlate_cpu_s"] = ts
        out[f"{key}_decode_reply_cpu_s"] = td
        out[f"{key}_decoded_ok"] = bool(np.array_equal(det.bits, bits))
        t_k.append(tk)
        t_s.append(ts)
    lf = np.log(np.asarray(rates_hz))
    out["search_slope_log_time_vs_log_fs"] = float(np.polyfit(lf, np.log(t_k), 1)[0])
    out["scipy_slope_log_time_vs_log_fs"] = float(np.polyfit(lf, np.log(t_s), 1)[0])
    return out


__all__ = ["bench_preamble"]

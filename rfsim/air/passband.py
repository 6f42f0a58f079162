"""Real-passband signals for cross-checking the complex-baseband physics on short records.

DESIGN.md "Signal model": rfsim works in complex baseband with the carrier implicit; this
module makes the carrier explicit, at a real sample rate fs ≥ 2.5·fc, so that the baseband
models (exact carrier phase of a delayed path, the tag's envelope detector, the reader's IQ
receiver) can be checked against the physical RF signal.

Power convention: a baseband waveform x(t) [√W] is the RF signal

    x_rf(t) = √2 · Re{x(t)·e^{j2π·fc·t}}                                           [√W]

so that the mean of x_rf² over a carrier cycle is |x|² (the power in W, as in the baseband
convention |x|² = power). A path with complex gain g (amplitude and carrier phase shift)
and delay τ gives the RF signal √2·Re{g·x(t − τ)·e^{j2π·fc·(t − τ)}}: in baseband
``g·e^{−j2π·fc·τ}·x(t − τ)``, the model of :func:`rfsim.channels.paths.apply_paths`.

Receiver (:func:`iq_demodulate`):
I + jQ = LPF{x_rf(t)·√2·cos(2πfc·t)} − j·LPF{x_rf(t)·√2·sin(2πfc·t)}
= LPF{x_rf(t)·√2·e^{−j2πfc·t}} = x(t) + LPF{x*(t)·e^{−j4πfc·t}} → x(t): the mixer products
are the baseband and an image at −2·fc that the low-pass removes. Envelope
(:func:`analytic_envelope`): the peak envelope of the RF signal is the magnitude of its
analytic signal x_rf + j·H{x_rf} = √2·x(t)·e^{j2πfc·t} (exact for a band-limited x with
bandwidth < fc), i.e. √2·|x|.
"""

from __future__ import annotations

import numpy as np
from rfsim.core.lazy import lazy_import

_signal = lazy_import("scipy.signal")

#: Smallest ratio fs/fc accepted (DESIGN.md: passband mode at fs ≥ 2.5·fc).
MIN_OVERSAMPLING = 2.5


def _check_rates(fs_hz: float, fc_hz: float) -> tuple[float, float]:
    fs_hz, fc_hz = float(fs_hz), float(fc_hz)
    if not fc_hz > 0 or not fs_hz >= MIN_OVERSAMPLING * fc_hz:
        raise ValueError(f"need fc > 0 and fs >= {MIN_OVERSAMPLING}·fc, got fs={fs_hz}, fc={fc_hz}")
    return fs_hz, fc_hz


def carrier_phase_rad(fc_hz: float, t_s) -> np.ndarray:
    """Carrier phase 2π·(fc·t mod 1) [rad] of times ``t_s`` [s], reduced modulo one cycle in
    float64 (its precision is that of fc·t: ≈ 1e−7 cycles at t ≈ 1 s and 915 MHz)."""
    return 2.0 * np.pi * np.mod(float(fc_hz) * np.asarray(t_s, dtype=np.float64), 1.0)


def upconvert(x, *, fs_hz: float, fc_hz: float, t0_s: float = 0.0) -> np.ndarray:
    """RF signal x_rf[n] = √2·Re{x[n]·e^{j2π·fc·t_n}}, t_n = t0_s + n/fs_hz.

    Parameters
    ----------
    x : (n,) complex, baseband [√W] at the RF sample times, x[n] = x(t_n)
    fs_hz : RF sample rate [Hz], at least 2.5·fc
    fc_hz : carrier frequency [Hz]
    t0_s : time of sample 0 [s]. A signal delayed by τ is x(t − τ) at times t: pass the
        envelope evaluated at t_n − τ and ``t0_s − τ`` (the carrier at t − τ).

    Returns
    -------
    x_rf : (n,) float64 [√W]
    """
    fs_hz, fc_hz = _check_rates(fs_hz, fc_hz)
    x = np.asarray(x, dtype=np.complex128)
    n = np.arange(x.size)
    phase = carrier_phase_rad(fc_hz, float(t0_s) + n / fs_hz)
    return np.sqrt(2.0) * (x.real * np.cos(phase) - x.imag * np.sin(phase))


def iq_demodulate(x_rf, *, fs_hz: float, fc_hz: float, decimation: int, t0_s: float = 0.0,
                  cutoff_hz: float | None = None, numtaps: int | None = None) -> np.ndarray:
    """Reader IQ receiver: mix with √2·cos and −√2·sin at fc, low-pass, keep every
    ``decimation``-th sample (module docstring).

    Parameters
    ----------
    x_rf : (n,) float64, RF signal [√W] sampled at ``fs_hz``, sample k at t0_s + k/fs_hz
    fs_hz, fc_hz : RF sample rate and carrier [Hz] (fs ≥ 2.5·fc)
    decimation : output sample k is input sample k·decimation (output rate fs/decimation)
    cutoff_hz : low-pass cut-off [Hz]; default fs/(2·decimation) (anti-alias for the
        decimation), at most fc/4 so that the mixer image at 2·fc (aliased to |fs − 2fc|)
        lies in the stop band
    numtaps : odd length of the linear-phase Hamming-window FIR, applied centred (zero
        delay); default the odd number ≥ 4·fs/cutoff (transition band ≈ the cut-off)

    Returns
    -------
    (ceil(n/decimation),) complex128, baseband [√W]
    """
    fs_hz, fc_hz = _check_rates(fs_hz, fc_hz)
    cut = min(fs_hz / (2.0 * int(decimation)), fc_hz / 4.0) if cutoff_hz is None else float(cutoff_hz)
    if numtaps is None:
        numtaps = 2 * int(np.ceil(2.0 * fs_hz / cut)) + 1
    if int(decimation) < 1 or int(numtaps) % 2 == 0 or not 0 < cut < fs_hz / 2:
        raise ValueError(f"need decimation >= 1, odd numtaps, 0 < cutoff < fs/2; got {decimation}, "
                         f"{numtaps}, {cut}")
    x_rf = np.asarray(x_rf, dtype=np.float64)
    n = np.arange(x_rf.size)
    phase = carrier_phase_rad(fc_hz, float(t0_s) + n / fs_hz)
    mixed = np.sqrt(2.0) * x_rf * np.exp(-1j * phase)
    taps = _signal.firwin(int(numtaps), cut, fs=fs_hz)
    return _signal.fftconvolve(mixed, taps, mode="same")[:: int(decimation)]


def analytic_envelope(x_rf) -> np.ndarray:
    """Peak envelope of an RF signal divided by √2: |x_rf + j·H{x_rf}|/√2 = |x| [√W]
    (``scipy.signal.hilbert``, i.e. FFT-based: the record's ends carry edge effects)."""
    return np.abs(_signal.hilbert(np.asarray(x_rf, dtype=np.float64))) / np.sqrt(2.0)


def relative_rms_error(a, b, mask=None) -> float:
    """√(Σ|a − b|²/Σ|b|²) over ``mask`` (all samples by default): ``b`` is the reference."""
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        raise ValueError(f"shapes differ: {a.shape} and {b.shape}")
    if mask is not None:
        a, b = a[mask], b[mask]
    return float(np.sqrt(np.sum(np.abs(a - b) ** 2) / np.sum(np.abs(b) ** 2)))


__all__ = ["MIN_OVERSAMPLING", "carrier_phase_rad", "upconvert", "iq_demodulate", "analytic_envelope",
           "relative_rms_error"]

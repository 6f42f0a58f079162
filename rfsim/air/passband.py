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
    r"""Carrier phase of times ``t_s``, reduced modulo one cycle.

    :math:`\varphi = 2\pi\,(f_c t \bmod 1)`, formed in float64 (its precision is that of
    :math:`f_c t`: ≈ 1e−7 cycles at t ≈ 1 s and 915 MHz).

    Parameters
    ----------
    fc_hz : float
        Carrier frequency [Hz].
    t_s : array_like
        Times [s].

    Returns
    -------
    ndarray, float64
        Phase in [0, 2π) [rad], the shape of ``t_s``.
    """
    return 2.0 * np.pi * np.mod(float(fc_hz) * np.asarray(t_s, dtype=np.float64), 1.0)


def upconvert(x, *, fs_hz: float, fc_hz: float, t0_s: float = 0.0) -> np.ndarray:
    r"""Form the real RF signal of a complex baseband waveform.

    :math:`x_{rf}[n] = \sqrt{2}\,\mathrm{Re}\{x[n]\,e^{j 2\pi f_c t_n}\}`, :math:`t_n = t_0 + n/f_s`
    (the power convention of the module docstring).

    Parameters
    ----------
    x : array_like, shape (n,), complex
        Baseband [√W] at the RF sample times, x[n] = x(t_n).
    fs_hz : float
        RF sample rate [Hz], at least 2.5·fc.
    fc_hz : float
        Carrier frequency [Hz].
    t0_s : float, default 0.0
        Time of sample 0 [s]. A signal delayed by τ is x(t − τ) at times t: pass the envelope
        evaluated at t_n − τ and ``t0_s − τ`` (the carrier at t − τ).

    Returns
    -------
    x_rf : ndarray, shape (n,), float64
        RF signal [√W].

    Raises
    ------
    ValueError
        fc ≤ 0 or fs < 2.5·fc.
    """
    fs_hz, fc_hz = _check_rates(fs_hz, fc_hz)
    x = np.asarray(x, dtype=np.complex128)
    n = np.arange(x.size)
    phase = carrier_phase_rad(fc_hz, float(t0_s) + n / fs_hz)
    return np.sqrt(2.0) * (x.real * np.cos(phase) - x.imag * np.sin(phase))


def iq_demodulate(x_rf, *, fs_hz: float, fc_hz: float, decimation: int, t0_s: float = 0.0,
                  cutoff_hz: float | None = None, numtaps: int | None = None) -> np.ndarray:
    r"""Demodulate an RF signal as a reader's IQ receiver does.

    Mix with √2·cos and −√2·sin at fc, low-pass, keep every ``decimation``-th sample:
    :math:`I + jQ = \mathrm{LPF}\{x_{rf}(t)\,\sqrt{2}\,e^{-j 2\pi f_c t}\} \to x(t)` (module
    docstring).

    Parameters
    ----------
    x_rf : array_like, shape (n,), float64
        RF signal [√W] sampled at ``fs_hz``, sample k at t0_s + k/fs_hz.
    fs_hz : float
        RF sample rate [Hz] (fs ≥ 2.5·fc).
    fc_hz : float
        Carrier frequency [Hz].
    decimation : int
        Output sample k is input sample k·decimation (output rate fs/decimation), ≥ 1.
    t0_s : float, default 0.0
        Time of sample 0 [s] (the phase of the mixer's carrier).
    cutoff_hz : float or None, default None
        Low-pass cut-off [Hz]; default fs/(2·decimation) (anti-alias for the decimation), at
        most fc/4 so that the mixer image at 2·fc (aliased to |fs − 2fc|) lies in the stop band.
    numtaps : int or None, default None
        Odd length of the linear-phase Hamming-window FIR, applied centred (zero delay); default
        the odd number ≥ 4·fs/cutoff (transition band ≈ the cut-off).

    Returns
    -------
    ndarray, shape (ceil(n/decimation),), complex128
        Baseband [√W].

    Raises
    ------
    ValueError
        Rates out of range, decimation < 1, an even ``numtaps`` or a cut-off outside (0, fs/2).
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
    r"""Peak envelope of an RF signal divided by √2.

    :math:`|x_{rf} + j\,\mathcal{H}\{x_{rf}\}|/\sqrt{2} = |x|` for a band-limited x with bandwidth
    < fc (module docstring); ``scipy.signal.hilbert`` is FFT-based, so the record's ends carry
    edge effects.

    Parameters
    ----------
    x_rf : array_like, shape (n,), float64
        RF signal [√W].

    Returns
    -------
    ndarray, shape (n,), float64
        Envelope |x| [√W].
    """
    return np.abs(_signal.hilbert(np.asarray(x_rf, dtype=np.float64))) / np.sqrt(2.0)


def relative_rms_error(a, b, mask=None) -> float:
    r"""Relative RMS error of ``a`` against the reference ``b``.

    :math:`\sqrt{\sum |a - b|^2 / \sum |b|^2}` over ``mask``.

    Parameters
    ----------
    a : array_like
        The values checked.
    b : array_like
        The reference, the shape of ``a``.
    mask : array_like of bool or index, optional
        Samples to compare (default all).

    Returns
    -------
    float
        The relative RMS error (dimensionless).

    Raises
    ------
    ValueError
        ``a`` and ``b`` differ in shape.
    """
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        raise ValueError(f"shapes differ: {a.shape} and {b.shape}")
    if mask is not None:
        a, b = a[mask], b[mask]
    return float(np.sqrt(np.sum(np.abs(a - b) ** 2) / np.sum(np.abs(b) ** 2)))


__all__ = ["MIN_OVERSAMPLING", "carrier_phase_rad", "upconvert", "iq_demodulate", "analytic_envelope",
           "relative_rms_error"]

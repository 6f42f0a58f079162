"""Reference twin of :mod:`rfsim.channels.paths` (the exact path sum, one path at a time, with
``np.convolve``)."""

from __future__ import annotations

import numpy as np

from rfsim.channels.paths import PathSet, _validate, fractional_delay_taps


def apply_paths_reference(x, *, fs_hz: float, fc_hz: float, paths: PathSet, t0_s: float = 0.0,
                          half_width: int = 16) -> np.ndarray:
    """Plain-NumPy reference of :func:`rfsim.channels.paths.apply_paths` (``method="exact"``), one path at a time."""
    x = _validate(x, fs_hz, paths, half_width)
    n_samp = x.size
    L = int(half_width)
    n = np.arange(n_samp)
    y = np.zeros(n_samp, dtype=np.complex128)
    for g, tau, fd in zip(paths.gain, paths.delay_s, paths.doppler_hz):
        pos = tau * fs_hz
        d = int(np.floor(pos))
        h = fractional_delay_taps(np.array([pos - d]), L)[0]
        # z[m] = Σ_k h_k x[m − k] over k = −L+1 … L: full convolution shifted by L − 1
        z = np.convolve(x, h)  # index q ↔ m = q − (L − 1)
        src = n - d + (L - 1)
        ok = (src >= 0) & (src < z.size)
        yp = np.zeros(n_samp, dtype=np.complex128)
        yp[ok] = z[src[ok]]
        c = g * np.exp(-2j * np.pi * np.mod(fc_hz * tau, 1.0))
        dop = np.exp(1j * (2.0 * np.pi * np.mod(fd * t0_s, 1.0) + 2.0 * np.pi * fd / fs_hz * n))
        y += c * dop * yp
    return y


__all__ = ["apply_paths_reference"]

"""Additive white Gaussian noise: thermal kTB·F, noise from a density, complex AWGN.

Waveforms are complex baseband in √W (|x|² is power in W, DESIGN.md "Signal model"); the noise
power of a complex baseband signal sampled at ``fs`` with a noise-equivalent bandwidth ``B`` is
``N = N0·B`` with the one-sided density ``N0`` [W/Hz] (``B = fs`` for white noise at the full
sample rate). The thermal power kTB·F lives in the core (:func:`rfsim.air.noise.thermal_noise_power_w`:
devices such as the reader compute their receiver noise with it) and is exported here with the
other noise models. Source: DESIGN.md "Channel" (AWGN from a noise density or kTB·NF);
pass-paris-simulator.md §2.4 ``channel_noise`` for the PASS legacy formula.
"""

from __future__ import annotations

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.air.noise import thermal_noise_power_w
from rfsim.core.units import dbm_to_w


def noise_power_from_density_w(density_dbm_hz, bandwidth_hz) -> np.ndarray:
    """Noise power ``N = N0·B`` from a one-sided density ``N0`` and a bandwidth.

    Parameters
    ----------
    density_dbm_hz : array_like
        One-sided density N0 [dBm/Hz].
    bandwidth_hz : array_like
        Noise-equivalent bandwidth B [Hz] (≥ 0).

    Returns
    -------
    numpy.ndarray
        N [W].

    Raises
    ------
    ConfigError
        If a bandwidth is negative.
    """
    b = np.asarray(bandwidth_hz, dtype=float)
    if np.any(b < 0):
        raise ConfigError("noise.bandwidth_hz", bandwidth_hz, "a bandwidth ≥ 0 Hz")
    return dbm_to_w(density_dbm_hz) * b


def complex_awgn(shape, power_w, *, rng: np.random.Generator) -> np.ndarray:
    """Circularly-symmetric complex white Gaussian noise with ``E|n|² = power_w``.

    ``n = √(P/2)·(g₁ + j·g₂)``, ``g₁, g₂ ~ N(0, 1)`` independent, so the real and imaginary
    parts each carry ``P/2`` and ``E[n²] = 0`` (circularity).

    Parameters
    ----------
    shape : int or tuple, output shape
    power_w : float or array_like broadcastable to ``shape``, noise power per sample [W]
    rng : numpy Generator (keyword-only)

    Returns
    -------
    shape complex128 [√W]
    """
    p = np.asarray(power_w, dtype=float)
    if np.any(p < 0) or not np.all(np.isfinite(p)):
        raise ConfigError("noise.power_w", power_w, "a finite power ≥ 0 W")
    g = rng.standard_normal(tuple(np.atleast_1d(shape)) + (2,))
    n = g[..., 0] + 1j * g[..., 1]
    return n * np.sqrt(p / 2.0)


def pass_noise_variance_w(n0_dbm, n0_bandwidth_hz, fs_hz, frxs_hz) -> np.ndarray:
    """PASS ``channel_noise`` legacy variance (pass-paris-simulator.md §2.4), for golden tests.

    ``var = 10^(n0/10 − 3)/n0_bw · fs/frxs``: the density ``n0`` [dBm per ``n0_bw`` Hz]
    times ``fs/frxs`` (PASS's simulation rate over the receiver sample rate), stated as
    "noise power matching at receiver". It is dimensionally odd (a density times a ratio of
    rates, not a bandwidth) and is not used by rfsim's own noise model; the PASS default
    ``n0 = −47 dBm per 3000 Hz`` gives 3.1e−10 W at ``frxs = 65 MHz`` (PASS ``fs`` ≈ 3 GHz).

    Parameters
    ----------
    n0_dbm : array_like
        Noise power n0 in ``n0_bandwidth_hz`` [dBm].
    n0_bandwidth_hz : array_like
        Bandwidth of ``n0`` [Hz].
    fs_hz : array_like
        PASS simulation sample rate [Hz].
    frxs_hz : array_like
        Receiver sample rate [Hz].

    Returns
    -------
    numpy.ndarray
        Variance [W] (as PASS states it).
    """
    return (dbm_to_w(n0_dbm) / np.asarray(n0_bandwidth_hz, dtype=float)
            * np.asarray(fs_hz, dtype=float) / np.asarray(frxs_hz, dtype=float))


__all__ = [
    "thermal_noise_power_w",
    "noise_power_from_density_w",
    "complex_awgn",
    "pass_noise_variance_w",
]

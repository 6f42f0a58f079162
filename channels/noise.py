"""Additive white Gaussian noise: thermal kTB·F, noise from a density, complex AWGN.

Waveforms are complex baseband in √W (|x|² is power in W, DESIGN.md "Signal model"); the noise
power of a complex baseband signal sampled at ``fs`` with a noise-equivalent bandwidth ``B`` is
``N = N0·B`` with the one-sided density ``N0`` [W/Hz] (``B = fs`` for white noise at the full
sample rate). Source: DESIGN.md "Channel" (AWGN from a noise density or kTB·NF);
pass-paris-simulator.md §2.4 ``channel_noise`` for the PASS legacy formula.
"""

from __future__ import annotations

import numpy as np

from rfsim.errors import ConfigError
from rfsim.units import K_BOLTZMANN_J_K, T0_K, db_to_lin, dbm_to_w


def thermal_noise_power_w(bandwidth_hz, nf_db=0.0, temperature_k=T0_K) -> np.ndarray:
    """Thermal noise power ``N = k·T·B·F`` [W] referred to the input.

    ``F = 10^(NF/10)`` is the noise factor; at ``T0 = 290 K`` this is −174 dBm/Hz + NF
    (e.g. −114 dBm in 1 MHz with NF = 0 dB).

    Parameters
    ----------
    bandwidth_hz : array_like, noise-equivalent bandwidth B ≥ 0 [Hz]
    nf_db : array_like, noise figure [dB] (≥ 0)
    temperature_k : array_like, noise temperature [K] (default 290 K)
    """
    b = np.asarray(bandwidth_hz, dtype=float)
    if np.any(b < 0):
        raise ConfigError("noise.bandwidth_hz", bandwidth_hz, "a bandwidth ≥ 0 Hz")
    if np.any(np.asarray(nf_db, dtype=float) < 0):
        raise ConfigError("noise.nf_db", nf_db, "a noise figure ≥ 0 dB")
    return K_BOLTZMANN_J_K * np.asarray(temperature_k, dtype=float) * b * db_to_lin(nf_db)


def noise_power_from_density_w(density_dbm_hz, bandwidth_hz) -> np.ndarray:
    """Noise power ``N = N0·B`` [W] from a one-sided density ``N0`` [dBm/Hz] and bandwidth [Hz]."""
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

    ``var = 10^(n0/10 − 3)/n0_bw · fs/frxs`` [W]: the density ``n0`` [dBm per ``n0_bw`` Hz]
    times ``fs/frxs`` (PASS's simulation rate over the receiver sample rate), stated as
    "noise power matching at receiver". It is dimensionally odd (a density times a ratio of
    rates, not a bandwidth) and is not used by rfsim's own noise model; the PASS default
    ``n0 = −47 dBm per 3000 Hz`` gives 3.1e−10 W at ``frxs = 65 MHz`` (PASS ``fs`` ≈ 3 GHz).
    """
    return (dbm_to_w(n0_dbm) / np.asarray(n0_bandwidth_hz, dtype=float)
            * np.asarray(fs_hz, dtype=float) / np.asarray(frxs_hz, dtype=float))


__all__ = [
    "thermal_noise_power_w",
    "noise_power_from_density_w",
    "complex_awgn",
    "pass_noise_variance_w",
]

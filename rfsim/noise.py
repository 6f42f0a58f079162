"""Thermal receiver noise power kTB·F (the one formula devices and channels share).

A receiver's noise referred to its input is ``N = k·T·B·F`` [W] over its noise-equivalent
bandwidth B (B = fs for complex white noise at the full sample rate; DESIGN.md "Channel":
AWGN from kTB·NF). :mod:`channels.noise` exports it with the other noise models; the air
interface (:mod:`rfsim.air`) draws the complex AWGN of that power at every receiver.
"""

from __future__ import annotations

import numpy as np

from rfsim.errors import ConfigError
from rfsim.units import K_BOLTZMANN_J_K, T0_K, db_to_lin


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


__all__ = ["thermal_noise_power_w"]

"""Thermal receiver noise power kTB·F (the one formula devices and channels share).

A receiver's noise referred to its input is ``N = k·T·B·F`` [W] over its noise-equivalent
bandwidth B (B = fs for complex white noise at the full sample rate; DESIGN.md "Channel":
AWGN from kTB·NF). :mod:`rfsim.channels.noise` exports it with the other noise models; the air
interface (:mod:`rfsim.air.step`) draws the complex AWGN of that power at every receiver.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.units import K_BOLTZMANN_J_K, T0_K, db_to_lin

_k = lazy_import("rfsim.air._noise_kernels")


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


def add_awgn_reference(y: np.ndarray, noise_w: float, rng: np.random.Generator) -> np.ndarray:
    """Add complex white Gaussian noise of power ``noise_w`` [W per complex sample] to ``y``
    in place: n = √(N/2)·(a + j·b), every real part a (in ``y``'s order) drawn from ``rng``
    before every imaginary part b. Returns the scaled draws ``(2,) + y.shape`` (a, b) [√W].
    Plain NumPy; :func:`add_awgn` gives the same bits faster."""
    ab = np.empty((2,) + y.shape)
    rng.standard_normal(out=ab)
    ab *= math.sqrt(noise_w / 2.0)
    y.real += ab[0]
    y.imag += ab[1]
    return ab


def add_awgn(y: np.ndarray, noise_w: float, rng: np.random.Generator, *, keep: bool = True) -> np.ndarray | None:
    """:func:`add_awgn_reference` through a numba kernel (:mod:`rfsim.air._noise_kernels`) when
    ``y`` is a writeable, aligned, C-contiguous complex128 array and ``rng`` a PCG64 generator;
    the same draws, the same sums, the same generator state afterwards. With ``keep=False``
    the scaled draws are not kept (None is returned): one pass less, half the memory."""
    if not (isinstance(y, np.ndarray) and y.dtype == np.complex128 and y.flags.c_contiguous
            and y.flags.writeable and y.flags.aligned
            and type(rng) is np.random.Generator and type(rng.bit_generator) is np.random.PCG64):
        ab = add_awgn_reference(y, noise_w, rng)
        return ab if keep else None
    scale = math.sqrt(noise_w / 2.0)
    if not keep:
        _k.add_awgn_inplace_compiled(rng, y.reshape(-1), scale)
        return None
    ab = np.empty((2,) + y.shape)
    _k.add_awgn_compiled(rng, y.reshape(-1), ab.reshape(2, -1), scale)
    return ab


def skip_awgn(shape, rng: np.random.Generator) -> None:
    """Advance ``rng`` exactly as :func:`add_awgn` of an array of ``shape`` would (its 2·n
    standard normals), without forming the noise: a receiver whose input nobody reads
    (rfsim.air.step ``skip_unmodulated``)."""
    n = 2 * math.prod(shape) if isinstance(shape, tuple) else 2 * int(shape)
    if type(rng) is np.random.Generator and type(rng.bit_generator) is np.random.PCG64:
        _k.skip_normals_compiled(rng, n)
    else:
        rng.standard_normal(n)


__all__ += ["add_awgn", "add_awgn_reference", "skip_awgn"]

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


# ----------------------------------------------------------------------------- counter-based noise

_ck = lazy_import("rfsim.air._counter_noise_kernels")

#: How a receiver's noise is drawn (:attr:`rfsim.air.cache.Strategy.noise`): ``"pcg64"`` every
#: sample from the step's generator (:func:`add_awgn`), ``"counter"`` one key from it and the
#: samples the receiver reads from the counter-based stream of that key (:func:`add_counter_awgn`).
NOISE_METHODS = ("pcg64", "counter")


def noise_key(rng: np.random.Generator) -> int:
    """The key of one noise block: one uint64 drawn from the step's generator ``rng`` (a trial's
    own stream, spawned from the run's SeedSequence: :mod:`rfsim.core.rng`). A trial's blocks
    thus get their keys in the order its steps draw them, whether the trial runs alone, in a
    batch or in another process."""
    return int(rng.integers(0, 2**64, dtype=np.uint64))


def counter_normals(key: int, n: int, *, first_pair: int = 0) -> np.ndarray:
    """Normals 2·first_pair … 2·first_pair + n − 1 of the counter-based stream ``key``, (n,)
    float64 (n even; algorithm: :mod:`rfsim.air._counter_noise_kernels`)."""
    if n % 2:
        raise ValueError(f"n must be even (normals come in pairs), got {n}")
    out = np.empty(int(n))
    _ck.normals_kernel(np.uint64(key), np.uint64(first_pair), out)
    return out


def add_counter_awgn(y: np.ndarray, noise_w: float, key: int, *, start: int = 0) -> None:
    """Add complex white Gaussian noise of power ``noise_w`` [W per complex sample] to the
    samples ``start:`` of ``y`` (…, n) complex128 in place: sample i of row b (flat index
    f = b·n + i) gets √(N/2)·(a_f + j·b_f), (a_f, b_f) the normal pair f of the counter-based
    stream ``key`` (:mod:`rfsim.air._counter_noise_kernels`). A sample's noise does not depend on
    which other samples are drawn: the samples before ``start`` (read by nobody) cost nothing."""
    scale = math.sqrt(noise_w / 2.0)
    n = y.shape[-1]
    rows = y.reshape(-1, n)
    if not (rows.flags.c_contiguous and rows.flags.writeable and y.dtype == np.complex128):
        raise ValueError("y must be a writeable C-contiguous complex128 array")
    start = min(max(int(start), 0), n)
    for b in range(rows.shape[0]):
        _ck.add_noise_kernel(np.uint64(key), np.uint64(b * n + start), rows[b, start:], scale)


def add_receiver_noise(y: np.ndarray, noise_w: float, rng: np.random.Generator, *, method: str = "pcg64",
                       start: int = 0, keep: bool = False) -> np.ndarray | None:
    """A receiver's noise of power ``noise_w`` [W] added to its input ``y`` (…, n) in place, by
    ``method`` (:data:`NOISE_METHODS`): ``"pcg64"`` every sample from ``rng``
    (:func:`add_awgn`); ``"counter"`` one key from ``rng`` (:func:`noise_key`) and the samples
    ``start:`` that the receiver reads (:func:`add_counter_awgn`; every sample with ``keep``).
    Returns the noise (…, n) [√W] with ``keep``, else None."""
    if method == "counter":
        key = noise_key(rng)
        if not keep:
            add_counter_awgn(y, noise_w, key, start=start)
            return None
        noise = np.zeros(y.shape, dtype=np.complex128)
        add_counter_awgn(noise, noise_w, key)
        y += noise
        return noise
    ab = add_awgn(y, noise_w, rng, keep=keep)
    return ab[0] + 1j * ab[1] if keep else None


def skip_receiver_noise(n_samples: int, rng: np.random.Generator, *, method: str = "pcg64") -> None:
    """Advance ``rng`` as :func:`add_receiver_noise` of ``n_samples`` samples would, without
    forming the noise (an input nobody reads): 2·n normals (``"pcg64"``) or the one key
    (``"counter"``)."""
    if method == "counter":
        noise_key(rng)
    else:
        skip_awgn(n_samples, rng)


__all__ += ["NOISE_METHODS", "noise_key", "counter_normals", "add_counter_awgn", "add_receiver_noise",
            "skip_receiver_noise"]

"""Receiver noise: its power kTB·F (the one formula devices and channels share) and its draws.

A receiver's noise referred to its input is ``N = k·T·B·F`` [W] over its noise-equivalent
bandwidth B (B = fs for complex white noise at the full sample rate; DESIGN.md "Channel":
AWGN from kTB·NF). :mod:`rfsim.channels.noise` exports it with the other noise models; the air
interface (:mod:`rfsim.air.step`) draws the complex AWGN of that power at every receiver,
n = √(N/2)·(a + j·b) with a, b independent standard normals, by the run's
:attr:`rfsim.air.cache.Strategy.noise`:

* ``"counter"`` (the default): **counter-based normals, drawn only where read.**
  *Algorithm* (:mod:`rfsim.air._counter_noise_kernels`, NumPy twin in the tests): normal pair
  p of the stream with 64-bit key k is a function of (k, p) alone — two SplitMix64 hashes
  h(k, 2p), h(k, 2p + 1) (the finaliser of k + (c + 1)·γ, γ = 0x9E3779B97F4A7C15) give a
  uniform u ∈ (0, 1] (52 bits) and an angle (52 bits and an octant), and Box–Muller turns them
  into (a, b) = √(−2·ln u)·(cos θ, sin θ), with branch-free polynomial ln, cos and sin, so the
  loops vectorise. *Stream per trial*: every noisy receiver of an air step draws one key,
  one uint64 from the step's generator (:func:`noise_key`), in receiver order; the step's
  generator is the trial's own stream (spawned from the run's seed, :mod:`rfsim.core.rng`),
  so a trial's keys are the same whatever else runs. *Stream per sample block*: within the
  key, sample i of row r of a receiver input of n samples gets pair r·n + i
  (:func:`add_counter_awgn`); a sample's noise does not depend on which other samples are
  drawn, so only those from the receiver's first read sample on are (the samples before it
  cost nothing), and the compiled exchange (:func:`rfsim.air.fused.fused_noisy_sum`) adds
  the same numbers inside its sum. Hence a trial's records are the same, bit for bit, run
  serially, on worker processes or in a batch of any size (tests/test_batch.py,
  tests/test_scenario_detection_probability.py, tests/test_scenario_reader_detection.py).
  Overlap of two streams needs keys an exact multiple of γ apart within the streams' length
  (K streams of L normals: probability ≈ K²·L/2⁶⁴).
* ``"pcg64"``: every sample of the receiver's input from the step's generator itself
  (NumPy's ziggurat on PCG64, :func:`add_awgn`; every real part, then every imaginary part):
  the records of the versions before the counter-based default; serial, parallel and batched
  runs are bit-identical under it too (the same generator, the same draws in the same order).
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.units import K_BOLTZMANN_J_K, T0_K, db_to_lin

_k = lazy_import("rfsim.air._noise_kernels")


def thermal_noise_power_w(bandwidth_hz, nf_db=0.0, temperature_k=T0_K) -> np.ndarray:
    r"""Thermal noise power referred to a receiver's input.

    .. math:: N = k\,T\,B\,F, \qquad F = 10^{NF/10}

    with k Boltzmann's constant; at T0 = 290 K this is −174 dBm/Hz + NF (e.g. −114 dBm in 1 MHz
    with NF = 0 dB). Source: DESIGN.md "Channel" (AWGN from kTB·NF).

    Parameters
    ----------
    bandwidth_hz : array_like
        Noise-equivalent bandwidth B ≥ 0 [Hz].
    nf_db : array_like, default 0.0
        Noise figure NF ≥ 0 [dB].
    temperature_k : array_like, default 290.0
        Noise temperature T [K].

    Returns
    -------
    ndarray
        Noise power N [W], the broadcast shape of the arguments.

    Raises
    ------
    ConfigError
        A negative bandwidth or noise figure.
    """
    b = np.asarray(bandwidth_hz, dtype=float)
    if np.any(b < 0):
        raise ConfigError("noise.bandwidth_hz", bandwidth_hz, "a bandwidth ≥ 0 Hz")
    if np.any(np.asarray(nf_db, dtype=float) < 0):
        raise ConfigError("noise.nf_db", nf_db, "a noise figure ≥ 0 dB")
    return K_BOLTZMANN_J_K * np.asarray(temperature_k, dtype=float) * b * db_to_lin(nf_db)


__all__ = ["thermal_noise_power_w"]


def add_awgn_reference(y: np.ndarray, noise_w: float, rng: np.random.Generator) -> np.ndarray:
    r"""Add complex white Gaussian noise to ``y`` in place (plain NumPy reference).

    :math:`n = \sqrt{N/2}\,(a + j b)` with a, b standard normals: every real part a (in ``y``'s
    order) is drawn from ``rng`` before every imaginary part b. :func:`add_awgn` gives the same
    bits faster.

    Parameters
    ----------
    y : ndarray, complex
        Samples [√W], any shape; modified in place.
    noise_w : float
        Noise power N [W per complex sample].
    rng : numpy.random.Generator
        Source of the normals.

    Returns
    -------
    ndarray, shape (2,) + y.shape, float64
        The scaled draws (a, b) [√W].
    """
    ab = np.empty((2,) + y.shape)
    rng.standard_normal(out=ab)
    ab *= math.sqrt(noise_w / 2.0)
    y.real += ab[0]
    y.imag += ab[1]
    return ab


def add_awgn(y: np.ndarray, noise_w: float, rng: np.random.Generator, *, keep: bool = True) -> np.ndarray | None:
    """Add complex white Gaussian noise to ``y`` in place, through a numba kernel where possible.

    The same draws, sums and generator state afterwards as :func:`add_awgn_reference`; the kernel
    (:mod:`rfsim.air._noise_kernels`) is used when ``y`` is a writeable, aligned, C-contiguous
    complex128 array and ``rng`` a PCG64 generator, else the reference.

    Parameters
    ----------
    y : ndarray, complex
        Samples [√W], any shape; modified in place.
    noise_w : float
        Noise power N [W per complex sample].
    rng : numpy.random.Generator
        Source of the normals.
    keep : bool, default True
        Return the scaled draws; False saves one pass and half the memory.

    Returns
    -------
    ndarray, shape (2,) + y.shape, float64, or None
        The scaled draws (a, b) [√W] with ``keep``, else None.
    """
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
    """Advance ``rng`` exactly as :func:`add_awgn` of an array of ``shape`` would.

    Draws its 2·n standard normals without forming the noise: a receiver whose input nobody
    reads (:func:`rfsim.air.step.propagate` with ``skip_unmodulated``).

    Parameters
    ----------
    shape : int or tuple of int
        Shape of the array the noise would be added to (n = its size).
    rng : numpy.random.Generator
        The generator to advance.
    """
    n = 2 * math.prod(shape) if isinstance(shape, tuple) else 2 * int(shape)
    if type(rng) is np.random.Generator and type(rng.bit_generator) is np.random.PCG64:
        _k.skip_normals_compiled(rng, n)
    else:
        rng.standard_normal(n)


__all__ += ["add_awgn", "add_awgn_reference", "skip_awgn"]


# ----------------------------------------------------------------------------- counter-based noise

_ck = lazy_import("rfsim.air._counter_noise_kernels")

#: How a receiver's noise is drawn (:attr:`rfsim.air.cache.Strategy.noise`, default ``"counter"``):
#: ``"counter"`` one key from the step's generator and the samples the receiver reads from the
#: counter-based stream of that key (:func:`add_counter_awgn`), ``"pcg64"`` every sample from the
#: step's generator (:func:`add_awgn`).
NOISE_METHODS = ("pcg64", "counter")


def noise_key(rng: np.random.Generator) -> int:
    """Draw the key of one counter-based noise block.

    One uint64 from the step's generator ``rng`` (a trial's own stream, spawned from the run's
    SeedSequence: :mod:`rfsim.core.rng`). A trial's blocks thus get their keys in the order its
    steps draw them, whether the trial runs alone, in a batch or in another process.

    Parameters
    ----------
    rng : numpy.random.Generator
        The step's generator.

    Returns
    -------
    int
        The key, in [0, 2**64).

    Notes
    -----
    The key is ``rng.integers(0, 2**64, dtype=np.uint64)``. Over the full 64-bit range NumPy
    returns the bit generator's next 64-bit output unmasked (its bounded-integer rule takes that
    branch for the range 2⁶⁴ − 1), which for a PCG64 generator is its raw output: that is read
    directly (``bit_generator.random_raw()``, the same number, ≈ 0.2 µs against ≈ 2.5 µs).
    """
    bg = rng.bit_generator
    if type(bg) is np.random.PCG64 and type(rng) is np.random.Generator:
        return int(bg.random_raw())
    return int(rng.integers(0, 2**64, dtype=np.uint64))


def counter_normals(key: int, n: int, *, first_pair: int = 0) -> np.ndarray:
    """Return a run of standard normals of a counter-based stream.

    Parameters
    ----------
    key : int
        Key of the stream (:func:`noise_key`).
    n : int
        Number of normals; must be even (they come in pairs).
    first_pair : int, default 0
        Index of the first pair: the normals 2·first_pair … 2·first_pair + n − 1 are returned.

    Returns
    -------
    ndarray, shape (n,), float64
        The normals (algorithm: :mod:`rfsim.air._counter_noise_kernels`).

    Raises
    ------
    ValueError
        ``n`` is odd.
    """
    if n % 2:
        raise ValueError(f"n must be even (normals come in pairs), got {n}")
    out = np.empty(int(n))
    _ck.normals_kernel(np.uint64(key), np.uint64(first_pair), out)
    return out


def add_counter_awgn(y: np.ndarray, noise_w: float, key: int, *, start: int = 0) -> None:
    r"""Add counter-based complex white Gaussian noise to the samples ``start:`` of ``y`` in place.

    Sample i of row b (flat index f = b·n + i) gets :math:`\sqrt{N/2}\,(a_f + j b_f)`, with
    :math:`(a_f, b_f)` the normal pair f of the counter-based stream ``key``
    (:mod:`rfsim.air._counter_noise_kernels`). A sample's noise does not depend on which other
    samples are drawn: the samples before ``start`` (read by nobody) cost nothing.

    Parameters
    ----------
    y : ndarray, shape (..., n), complex128
        Samples [√W], writeable and C-contiguous; modified in place.
    noise_w : float
        Noise power N [W per complex sample].
    key : int
        Key of the stream (:func:`noise_key`).
    start : int, default 0
        First sample of every row that gets noise (clipped to [0, n]).

    Raises
    ------
    ValueError
        ``y`` is not a writeable C-contiguous complex128 array.
    """
    scale = math.sqrt(noise_w / 2.0)
    n = y.shape[-1]
    rows = y.reshape(-1, n)
    if not (rows.flags.c_contiguous and rows.flags.writeable and y.dtype == np.complex128):
        raise ValueError("y must be a writeable C-contiguous complex128 array")
    start = min(max(int(start), 0), n)
    for b in range(rows.shape[0]):
        _ck.add_noise_kernel(np.uint64(key), np.uint64(b * n + start), rows[b, start:], scale)


def add_receiver_noise(y: np.ndarray, noise_w: float, rng: np.random.Generator, *, method: str = "counter",
                       start: int = 0, keep: bool = False) -> np.ndarray | None:
    """Add a receiver's noise to its input in place, by the run's noise method.

    ``"pcg64"``: every sample from ``rng`` (:func:`add_awgn`); ``"counter"``: one key from ``rng``
    (:func:`noise_key`) and the samples ``start:`` that the receiver reads
    (:func:`add_counter_awgn`; every sample with ``keep``).

    Parameters
    ----------
    y : ndarray, shape (..., n), complex128
        The receiver's input [√W]; modified in place.
    noise_w : float
        Noise power [W per complex sample].
    rng : numpy.random.Generator
        The step's generator.
    method : {"counter", "pcg64"}, default "counter"
        How the noise is drawn (:data:`NOISE_METHODS`).
    start : int, default 0
        First sample the receiver reads (``"counter"`` only).
    keep : bool, default False
        Return the noise.

    Returns
    -------
    ndarray, shape (..., n), complex128, or None
        The noise added [√W] with ``keep``, else None.
    """
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


def skip_receiver_noise(n_samples: int, rng: np.random.Generator, *, method: str = "counter") -> None:
    """Advance ``rng`` as :func:`add_receiver_noise` of ``n_samples`` samples would.

    The noise is not formed (an input nobody reads): 2·n normals are drawn (``"pcg64"``) or the
    one key (``"counter"``).

    Parameters
    ----------
    n_samples : int
        Samples of the input.
    rng : numpy.random.Generator
        The step's generator.
    method : {"counter", "pcg64"}, default "counter"
        How the noise would be drawn (:data:`NOISE_METHODS`).
    """
    if method == "counter":
        noise_key(rng)
    else:
        skip_awgn(n_samples, rng)


__all__ += ["NOISE_METHODS", "noise_key", "counter_normals", "add_counter_awgn", "add_receiver_noise",
            "skip_receiver_noise"]

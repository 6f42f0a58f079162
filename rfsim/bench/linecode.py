"""Benchmark of the FM0/Miller encoder + decoder (numba kernels)."""

from __future__ import annotations

import time

import numpy as np

from rfsim.gen2.linecode import decode_reply, reply_waveform
from rfsim.core.rng import trial_rng

#: Bits encoded and decoded per block.
BLOCK_BITS = 10_000


def _run(n_bits: int, block_bits: int, encode, decode, rng, *, m: int, blf_hz: float,
         fs_hz: float) -> tuple[float, int]:
    errors = 0
    t_start = time.perf_counter()
    done = 0
    while done < n_bits:
        n = min(block_bits, n_bits - done)
        bits = rng.integers(0, 2, n).astype(np.uint8)
        s = encode(bits, m=m, trext=False, blf_hz=blf_hz, fs_hz=fs_hz)
        det = decode(s.astype(np.complex128), n_bits=n, m=m, trext=False, blf_hz=blf_hz, fs_hz=fs_hz,
                     method="viterbi", start_sample=0)
        errors += int(np.count_nonzero(det.bits != bits))
        done += n
    return time.perf_counter() - t_start, errors


def benchmark_linecode(n_bits: int = 10**6, *, m: int = 4,
                       blf_hz: float = 160e3, samples_per_element: int = 8, seed: int = 0) -> dict:
    """Time encoding, sampling and Viterbi decoding of Miller-``m`` bits.

    fs = 2·BLF·samples_per_element (8 samples per half subcarrier cycle by default); the reply
    is processed in blocks of :data:`BLOCK_BITS` bits to bound memory (10⁴ bits of Miller-4 at 8
    samples per element are 640,000 samples, ≈ 25 MB for the waveform and its decoder; blocks of
    10⁵ bits made the benchmark peak at 804 MB). The kernels are warmed up (compiled) first.

    Parameters
    ----------
    n_bits : int, default 10**6
        Bits encoded and decoded.
    m : int, default 4
        Miller factor M (1 = FM0).
    blf_hz : float, default 160e3
        Backscatter link frequency [Hz].
    samples_per_element : int, default 8
        Samples per half subcarrier cycle.
    seed : int, default 0
        Seed of the bits.

    Returns
    -------
    dict
        ``m``, ``blf_hz``, ``fs_hz`` [Hz], ``n_bits``, ``numba_s`` (wall time [s]),
        ``numba_bits_per_s`` and ``numba_bit_errors`` (0 expected: no noise).
    """
    fs_hz = 2.0 * blf_hz * samples_per_element
    kw = dict(m=m, blf_hz=blf_hz, fs_hz=fs_hz)
    _run(1000, 1000, reply_waveform, decode_reply, trial_rng(seed, 0), **kw)  # warm-up (compilation)
    t_numba, err_numba = _run(n_bits, BLOCK_BITS, reply_waveform, decode_reply, trial_rng(seed, 1), **kw)
    return {
        "m": m,
        "blf_hz": blf_hz,
        "fs_hz": fs_hz,
        "n_bits": n_bits,
        "numba_s": t_numba,
        "numba_bits_per_s": n_bits / t_numba,
        "numba_bit_errors": err_numba,
    }


__all__ = ["benchmark_linecode"]

"""numba kernels of the binary-offset-carrier (BOC) line code (wrapped and documented in
:mod:`rfsim.himr.boc`; plain-NumPy twins in the tests' ``reference.himr_boc``).

A *chip* is one half of a subcarrier half-cycle group: chip k of a bit has the subcarrier
sign ``q_k = +1`` if ``(k // half_cycle_chips)`` is even, else −1; the bit sets the
polarity ``p = +1`` (bit 1) or −1 (bit 0); the chip level is ``p·q_k``. Sample n of a
sampled waveform that starts at the fractional sample ``s0`` takes the chip
``floor((n − s0)·chips_per_sample + INDEX_EPS)`` — no cumulative drift for a non-integer
number of samples per chip.
"""

from __future__ import annotations

import math

from rfsim.core._jit import njit

#: Added to the fractional chip index before flooring: a sample that falls exactly on a
#: chip boundary (up to float64 rounding) belongs to the later chip.
INDEX_EPS = 1e-9


@njit
def chips_kernel(bits, chips_per_bit, half_cycle_chips, out):
    """Chip levels (±1, int8) of ``bits`` into ``out`` ((n_bits·chips_per_bit,)).

    Returns False when a bit is neither 0 nor 1 (``out`` is then incomplete).
    """
    for i in range(bits.size):
        b = bits[i]
        if b > 1:
            return False
        p = 1 if b == 1 else -1
        for k in range(chips_per_bit):
            q = 1 if (k // half_cycle_chips) % 2 == 0 else -1
            out[i * chips_per_bit + k] = p * q
    return True


@njit
def train_kernel(starts_samples, bits, chips_per_sample, chips_per_bit, half_cycle_chips,
                 level_plus, level_minus, out):
    """Write a train of packets into ``out`` (pre-filled with the rest level).

    Packet p starts at the fractional sample ``starts_samples[p]`` and carries the row
    ``bits[p]``; samples on a +1 chip get ``level_plus``, on a −1 chip ``level_minus``.
    Packets are written in order (a later packet overwrites an overlapping earlier one).
    """
    n_packets, n_bits = bits.shape
    n_chips = n_bits * chips_per_bit
    n_out = out.size
    for p in range(n_packets):
        s0 = starts_samples[p]
        first = int(math.floor(s0))
        if first < 0:
            first = 0
        for n in range(first, n_out):
            u = (n - s0) * chips_per_sample
            if u + INDEX_EPS < 0.0:
                continue
            k = int(math.floor(u + INDEX_EPS))
            if k >= n_chips:
                break
            i = k // chips_per_bit
            q = 1 if ((k % chips_per_bit) // half_cycle_chips) % 2 == 0 else -1
            level = q if bits[p, i] == 1 else -q
            out[n] = level_plus if level > 0 else level_minus


@njit
def bit_sums_kernel(r, start, chips_per_sample, chips_per_bit, half_cycle_chips,
                    ysum, qsum, count, rsum, r2sum):
    """Per-bit matched-filter sums of a complex baseband packet starting at sample ``start``.

    For the samples n of bit i: ``ysum[i] = Σ r[n]·q(n)``, ``qsum[i] = Σ q(n)``,
    ``count[i]`` = number of samples, ``rsum[i] = Σ r[n]``, ``r2sum[i] = Σ |r[n]|²``
    (arrays of length n_bits, zero-filled by the caller).
    """
    n_bits = ysum.size
    first = int(math.floor(start))
    if first < 0:
        first = 0
    for n in range(first, r.size):
        u = (n - start) * chips_per_sample
        if u + INDEX_EPS < 0.0:
            continue
        k = int(math.floor(u + INDEX_EPS))
        i = k // chips_per_bit
        if i >= n_bits:
            break
        q = 1.0 if ((k % chips_per_bit) // half_cycle_chips) % 2 == 0 else -1.0
        x = r[n]
        ysum[i] += x * q
        qsum[i] += q
        count[i] += 1
        rsum[i] += x
        r2sum[i] += x.real * x.real + x.imag * x.imag

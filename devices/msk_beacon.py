"""The active beacon's frame, Manchester line code and MSK modulation (and their inverses).

Özkaya's active tags (rssi-localization.md §2.1; seeds/002 L957, L1768–L1775) send their ID
once per second at 868 MHz and 5 dBm, Manchester-coded MSK at 250 kbaud in a 540 kHz
receiver bandwidth, with listen-before-talk. The thesis gives no frame layout; this one
follows the usual sub-GHz transceiver packet (preamble, sync word, payload, CRC — the
CC1101-class radio whose 541 kHz receive filter matches the quoted 540 kHz) and is recorded
here:

========  =======  ==========================================================
field     bits     value
========  =======  ==========================================================
preamble  32       1010…10 (0xAAAAAAAA)
sync      16       0xD391
tag ID    32       the tag's ID, MSB first
sequence  8        beacon counter modulo 256
CRC-16    16       CRC-16/GENIBUS of ID + sequence (rfsim.gen2.crc, reused)
========  =======  ==========================================================

104 bits; **Manchester**: bit 1 → chips (+1, −1), bit 0 → (−1, +1) (the whole frame, 208
chips); "250 kbaud" is read as the chip rate R_c = 250 kchip/s (125 kbit/s of data), so a
beacon lasts 208/250 kHz = 0.832 ms.

**MSK** (continuous-phase FSK, modulation index h = 1/2): chip a_k ∈ {±1} advances the phase
linearly by a_k·π/2 over its duration T_c = 1/R_c (frequency deviation ±R_c/4 = ±62.5 kHz)::

    φ(t) = Φ_k + a_k·(π/2)·(t/T_c − k),   k = ⌊t/T_c⌋,   Φ_k = (π/2)·Σ_{i<k} a_i
    x(t) = √P·e^{j(φ(t) + θ)}          [√W], θ the oscillator's phase at the burst start

a constant envelope; 99 % of the power lies within ±0.6·R_c (Pasupathy, IEEE Comm. Mag. 17(4),
1979), inside the 540 kHz (±270 kHz) receive filter.

**Discriminator** (the reader's FM demodulator): ``d[n] = arg(y[n]·conj(y[n−1]))``; over chip
k it sums to a_k·π/2 for a clean signal, whose sign is the chip.

Hot paths: :func:`msk_phase` and :func:`discriminate` call numba kernels
(:mod:`rfsim.devices._msk_kernels`); the tests compare them with NumPy twins.
"""

from __future__ import annotations

import numpy as np

from rfsim.gen2.bits import bits_to_int, int_to_bits
from rfsim.gen2.crc import append_crc16, crc16_ok
from rfsim.core.lazy import lazy_import

_mk = lazy_import("rfsim.devices._msk_kernels")


PREAMBLE_BITS = 32
SYNC_WORD = 0xD391
SYNC_BITS = 16
ID_BITS = 32
SEQ_BITS = 8
CRC_BITS = 16
#: Bits of one beacon frame.
FRAME_BITS = PREAMBLE_BITS + SYNC_BITS + ID_BITS + SEQ_BITS + CRC_BITS
#: Chips of one beacon frame (Manchester: two per bit).
FRAME_CHIPS = 2 * FRAME_BITS
#: Chips of the preamble + sync word (the receiver's synchronisation template).
HEADER_CHIPS = 2 * (PREAMBLE_BITS + SYNC_BITS)


def beacon_bits(tag_id: int, seq: int) -> np.ndarray:
    """Build the frame of one beacon: preamble, sync word, ID, sequence, CRC-16.

    The layout of the module docstring (the project's own frame; CRC-16/GENIBUS over ID +
    sequence).

    Parameters
    ----------
    tag_id : int
        32-bit tag ID, sent MSB first.
    seq : int
        Sequence number (taken modulo 256).

    Returns
    -------
    ndarray of uint8, shape (FRAME_BITS,)
        The frame's bits (0/1).
    """
    pre = np.tile(np.array([1, 0], np.uint8), PREAMBLE_BITS // 2)
    payload = np.concatenate([int_to_bits(int(tag_id), ID_BITS), int_to_bits(int(seq) % 256, SEQ_BITS)])
    return np.concatenate([pre, int_to_bits(SYNC_WORD, SYNC_BITS), append_crc16(payload)])


def manchester_encode(bits) -> np.ndarray:
    """Manchester-encode bits: 1 → chips (+1, −1), 0 → (−1, +1).

    Parameters
    ----------
    bits : array_like of {0, 1}, shape (n,)
        The bits (flattened).

    Returns
    -------
    ndarray of int8, shape (2n,)
        The ±1 chips.
    """
    b = np.asarray(bits, np.int8).reshape(-1)
    first = 2 * b - 1
    return np.stack([first, -first], axis=1).reshape(-1).astype(np.int8)


def manchester_decode(chips) -> tuple[np.ndarray, int]:
    """Decode Manchester chips to bits and count the code violations.

    A bit is decided by the sign of its first chip; a pair of equal chips is a code violation.

    Parameters
    ----------
    chips : array_like of float, shape (2n,)
        The chips (±1, or soft values: only the signs count).

    Returns
    -------
    bits : ndarray of uint8, shape (n,)
        The decoded bits (0/1).
    violations : int
        Number of pairs of equal chips.
    """
    c = np.asarray(chips).reshape(-1, 2)
    return (c[:, 0] > 0).astype(np.uint8), int(np.count_nonzero(c[:, 0] == c[:, 1]))


def parse_payload(bits_after_sync) -> tuple[int, int, bool]:
    """Parse the payload that follows the sync word: tag ID, sequence and the CRC check.

    Parameters
    ----------
    bits_after_sync : array_like of {0, 1}, shape (≥ 56,)
        The ID (32), sequence (8) and CRC-16 (16) bits, MSB first; further bits are ignored.

    Returns
    -------
    tag_id : int
        The decoded 32-bit ID.
    seq : int
        The decoded sequence number.
    crc_ok : bool
        The CRC-16 over ID + sequence holds.
    """
    b = np.asarray(bits_after_sync, np.uint8)
    return (bits_to_int(b[:ID_BITS]), bits_to_int(b[ID_BITS:ID_BITS + SEQ_BITS]),
            bool(crc16_ok(b[:ID_BITS + SEQ_BITS + CRC_BITS])))


def header_chips() -> np.ndarray:
    """Return the chips of the preamble and sync word, common to every beacon.

    Returns
    -------
    ndarray of int8, shape (HEADER_CHIPS,)
        The ±1 chips (the receiver's synchronisation template).
    """
    return manchester_encode(beacon_bits(0, 0)[:PREAMBLE_BITS + SYNC_BITS])


def msk_phase(chips, sps: float, offset_chips: float, n_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Compute the MSK phase and burst mask of ``n_samples`` samples (module docstring).

    .. math:: \\varphi(t) = \\Phi_k + a_k \\frac{\\pi}{2} (t/T_c - k), \\quad
              k = \\lfloor t/T_c \\rfloor, \\quad \\Phi_k = \\frac{\\pi}{2} \\sum_{i<k} a_i

    Parameters
    ----------
    chips : array_like of float, shape (K,)
        The ±1 chips a_k.
    sps : float
        Samples per chip fs/R_c (> 0, need not be an integer).
    offset_chips : float
        Time of sample 0 since the burst start, in chips (may be negative).
    n_samples : int
        Number of samples.

    Returns
    -------
    phase : ndarray of float64, shape (n_samples,)
        φ [rad] (0 outside the burst).
    on : ndarray of bool, shape (n_samples,)
        The sample lies inside the burst.
    """
    c = np.ascontiguousarray(chips, dtype=np.float64)
    phase = np.empty(int(n_samples))
    on = np.empty(int(n_samples), dtype=np.uint8)
    _mk.msk_phase_kernel(c, float(sps), float(offset_chips), phase, on)
    return phase, on.astype(bool)


def discriminate(y, y_prev: complex = 1.0 + 0.0j) -> np.ndarray:
    """Apply the FM discriminator :math:`d[n] = \\arg(y[n]\\, y^*[n-1])`.

    Over chip k of a clean MSK signal d sums to :math:`a_k \\pi/2` (module docstring).

    Parameters
    ----------
    y : array_like of complex, shape (n,)
        Complex baseband samples.
    y_prev : complex, optional
        The sample before ``y[0]``, used as ``y[-1]``; default 1 + 0j.

    Returns
    -------
    ndarray of float64, shape (n,)
        Phase increments [rad/sample].
    """

    x = np.ascontiguousarray(y, dtype=np.complex128)
    out = np.empty(x.size)
    _mk.discriminator_kernel(x, complex(y_prev), out)
    return out


__all__ = ["PREAMBLE_BITS", "SYNC_WORD", "FRAME_BITS", "FRAME_CHIPS", "HEADER_CHIPS", "beacon_bits",
           "manchester_encode", "manchester_decode", "parse_payload", "header_chips", "msk_phase",
           "discriminate"]

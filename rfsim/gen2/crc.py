"""Gen2 cyclic redundancy checks: CRC-5/EPC-C1G2 and CRC-16/GENIBUS.

Both are MSB-first (non-reflected) shift-register CRCs over bit arrays of any length
(gen2-and-validation-anchors.md §3.1, EPC Gen2 "CRC" annex):

* CRC-5: g(x) = x⁵ + x³ + 1 (0x09), preset 01001₂, no output inversion; the register
  run over data + CRC-5 ends at 00000₂. Check value on ASCII "123456789": 0x00.
* CRC-16: g(x) = x¹⁶ + x¹² + x⁵ + 1 (0x1021), preset FFFFh, transmitted as the ones'
  complement of the register; the register run over data + CRC-16 ends at the residue
  1D0Fh. Check value on "123456789": 0xD64E.

Register update per input bit b (width w, poly p): ``fb = msb(r) ^ b; r = (r << 1) mod 2^w;
if fb: r ^= p``. Byte-aligned prefixes use a 256-entry table (8 register steps at once);
the remaining bits go through the bit-serial update.
"""

from __future__ import annotations

import numpy as np

from rfsim.gen2.bits import as_bits, int_to_bits

CRC5_POLY = 0x09
CRC5_PRESET = 0b01001
CRC16_POLY = 0x1021
CRC16_PRESET = 0xFFFF
CRC16_RESIDUE = 0x1D0F


def _crc16_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        reg = byte << 8
        for _ in range(8):
            reg = ((reg << 1) ^ CRC16_POLY) if reg & 0x8000 else (reg << 1)
            reg &= 0xFFFF
        table.append(reg)
    return tuple(table)


_CRC16_TABLE = _crc16_table()


def _crc16_register(bits: np.ndarray, reg: int = CRC16_PRESET) -> int:
    """Register after shifting ``bits`` (validated uint8 0/1) into it."""
    n_bytes = bits.size // 8
    table = _CRC16_TABLE
    if n_bytes:
        for byte in np.packbits(bits[: 8 * n_bytes]).tolist():
            reg = ((reg << 8) & 0xFFFF) ^ table[(reg >> 8) ^ byte]
    for b in bits[8 * n_bytes :].tolist():
        fb = (reg >> 15) ^ b
        reg = (reg << 1) & 0xFFFF
        if fb:
            reg ^= CRC16_POLY
    return reg


def _crc5_register(bits: np.ndarray, reg: int = CRC5_PRESET) -> int:
    for b in bits.tolist():
        fb = (reg >> 4) ^ b
        reg = (reg << 1) & 0x1F
        if fb:
            reg ^= CRC5_POLY
    return reg


def crc5(bits) -> int:
    """CRC-5/EPC-C1G2 of a bit array.

    g(x) = x⁵ + x³ + 1, preset 01001₂, no output inversion (module docstring;
    gen2-and-validation-anchors.md §3.1).

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` 0/1, MSB first.

    Returns
    -------
    int
        CRC-5 in [0, 31].
    """
    return _crc5_register(as_bits(bits))


def crc16(bits) -> int:
    """CRC-16/GENIBUS of a bit array, as transmitted.

    g(x) = x¹⁶ + x¹² + x⁵ + 1, preset FFFFh; the result is the ones' complement of the
    register, the value a Gen2 tag or reader transmits (gen2-and-validation-anchors.md §3.1).

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` 0/1, MSB first.

    Returns
    -------
    int
        CRC-16 in [0, 65535].
    """
    return _crc16_register(as_bits(bits)) ^ 0xFFFF


def crc16_bytes(data: bytes) -> int:
    """CRC-16/GENIBUS of a byte string (bytes sent MSB first); same as ``crc16`` of its bits.

    Parameters
    ----------
    data : bytes
        Message bytes.

    Returns
    -------
    int
        CRC-16 in [0, 65535] (ones' complement of the register).
    """
    reg = CRC16_PRESET
    table = _CRC16_TABLE
    for byte in bytes(data):
        reg = ((reg << 8) & 0xFFFF) ^ table[(reg >> 8) ^ byte]
    return reg ^ 0xFFFF


def crc5_bits(bits) -> np.ndarray:
    """CRC-5 of ``bits`` as a bit array, MSB first.

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` 0/1, MSB first.

    Returns
    -------
    numpy.ndarray
        ``(5,) uint8`` CRC-5 bits.
    """
    return int_to_bits(crc5(bits), 5)


def crc16_bits(bits) -> np.ndarray:
    """CRC-16 of ``bits`` as a bit array, MSB first.

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` 0/1, MSB first.

    Returns
    -------
    numpy.ndarray
        ``(16,) uint8`` CRC-16 bits (as transmitted).
    """
    return int_to_bits(crc16(bits), 16)


def append_crc5(bits) -> np.ndarray:
    """``bits`` followed by their CRC-5.

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` 0/1, MSB first.

    Returns
    -------
    numpy.ndarray
        ``(n + 5,) uint8``.
    """
    arr = as_bits(bits)
    return np.concatenate([arr, crc5_bits(arr)])


def append_crc16(bits) -> np.ndarray:
    """``bits`` followed by their CRC-16.

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` 0/1, MSB first.

    Returns
    -------
    numpy.ndarray
        ``(n + 16,) uint8``.
    """
    arr = as_bits(bits)
    return np.concatenate([arr, crc16_bits(arr)])


def crc5_ok(bits_with_crc) -> bool:
    """Whether the CRC-5 register run over data + CRC-5 ends at 00000₂.

    Parameters
    ----------
    bits_with_crc : array_like or str
        Data bits followed by their CRC-5, MSB first.

    Returns
    -------
    bool
        True when the check passes; False for fewer than 5 bits.
    """
    arr = as_bits(bits_with_crc)
    return arr.size >= 5 and _crc5_register(arr) == 0


def crc16_ok(bits_with_crc) -> bool:
    """Whether the CRC-16 register run over data + CRC-16 ends at the residue 1D0Fh.

    Parameters
    ----------
    bits_with_crc : array_like or str
        Data bits followed by their transmitted CRC-16, MSB first.

    Returns
    -------
    bool
        True when the check passes; False for fewer than 16 bits.
    """
    arr = as_bits(bits_with_crc)
    return arr.size >= 16 and _crc16_register(arr) == CRC16_RESIDUE


__all__ = [
    "CRC5_POLY",
    "CRC5_PRESET",
    "CRC16_POLY",
    "CRC16_PRESET",
    "CRC16_RESIDUE",
    "crc5",
    "crc16",
    "crc16_bytes",
    "crc5_bits",
    "crc16_bits",
    "append_crc5",
    "append_crc16",
    "crc5_ok",
    "crc16_ok",
]

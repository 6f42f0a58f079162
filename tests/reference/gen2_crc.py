"""Bitwise reference of the Gen2 CRC-16 (x^16 + x^12 + x^5 + 1, preset FFFFh, ones' complement;
EPC Gen2 Annex F), one register step per bit over a '0'/'1' string — the obviously right twin
the tests lay replies and memory contents out against."""

from __future__ import annotations


def crc16_bitwise(bits: str) -> int:
    """CRC-16 of a '0'/'1' string, MSB first, as transmitted (ones' complement of the register)."""
    reg = 0xFFFF
    for c in bits:
        msb = (reg >> 15) & 1
        reg = (reg << 1) & 0xFFFF
        if msb ^ int(c):
            reg ^= 0x1021
    return reg ^ 0xFFFF

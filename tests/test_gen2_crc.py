"""CRC-5/EPC-C1G2 and CRC-16/GENIBUS against catalogue check values, published Gen2 frames
(gen2-and-validation-anchors.md §3.1–3.3) and independent implementations (crcmod, and a
bit-serial LFSR written here)."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.gen2.bits import bits_to_str, hex_to_bits, int_to_bits, str_to_bits
from rfsim.gen2.crc import (
    append_crc5,
    append_crc16,
    crc5,
    crc5_bits,
    crc5_ok,
    crc16,
    crc16_bits,
    crc16_bytes,
    crc16_ok,
)
from rfsim.core.rng import trial_rng

CHECK_BITS = np.unpackbits(np.frombuffer(b"123456789", dtype=np.uint8))


def _lfsr(bits, width: int, poly: int, preset: int) -> int:
    """Straightforward Galois LFSR, one bit at a time, written independently of rfsim."""
    reg = [(preset >> (width - 1 - i)) & 1 for i in range(width)]  # reg[0] = MSB
    taps = [(poly >> (width - 1 - i)) & 1 for i in range(width)]
    for b in bits:
        fb = reg[0] ^ int(b)
        reg = reg[1:] + [0]
        if fb:
            reg = [r ^ t for r, t in zip(reg, taps)]
    return int("".join(map(str, reg)), 2)


def test_catalogue_check_values():
    # reveng catalogue: CRC-5/EPC-C1G2 check 0x00, CRC-16/GENIBUS check 0xD64E (§3.1)
    assert crc5(CHECK_BITS) == 0x00
    assert crc16(CHECK_BITS) == 0xD64E
    assert crc16_bytes(b"123456789") == 0xD64E


def test_crc16_residue_is_1d0f():
    # register over data + CRC ends at 0x1D0F (§3.1); independent LFSR without the final inversion
    framed = append_crc16(CHECK_BITS)
    assert _lfsr(framed, 16, 0x1021, 0xFFFF) == 0x1D0F
    assert crc16_ok(framed)
    assert crc5_ok(append_crc5(CHECK_BITS))


@pytest.mark.parametrize(
    ("pc", "epc", "crc"),
    [
        ("3000", "3008 33B2 DDD9 0140 0000 0027", 0x6D3E),
        ("3000", "E280 1160 6000 0210 A392 70DA", 0x9F65),
    ],
)
def test_pc_epc_frames(pc, epc, crc):
    data = np.concatenate([hex_to_bits(pc), hex_to_bits(epc)])
    assert data.size == 112
    assert crc16(data) == crc
    assert bits_to_str(crc16_bits(data)) == format(crc, "016b")
    framed = np.concatenate([data, int_to_bits(crc, 16)])
    assert crc16_ok(framed)
    bad = framed.copy()
    bad[37] ^= 1
    assert not crc16_ok(bad)


@pytest.mark.parametrize(
    ("q", "crc"),
    [(0, "10000"), (1, "11001"), (4, "11101"), (15, "11100")],
)
def test_query_crc5_table(q, crc):
    # DR 8, FM0, TRext 0, Sel All, S0, Target A (§3.3)
    head = str_to_bits("1000" "0" "00" "0" "00" "00" "0")
    bits = np.concatenate([head, int_to_bits(q, 4)])
    assert bits_to_str(crc5_bits(bits)) == crc
    assert crc5_ok(np.concatenate([bits, str_to_bits(crc)]))


def test_query_crc5_from_command_table():
    # Query (DR 8, M 2, TRext 1, ~SL, S1, A, Q 3) of §3.3 carries CRC-5 01000
    bits = str_to_bits("1000 0 01 1 10 01 0 0011")
    assert crc5(bits) == 0b01000


def test_crc16_matches_crcmod_on_random_messages():
    crcmod_predefined = pytest.importorskip("crcmod.predefined")
    # crcmod's own catalogue entry (initCrc there is preset XOR xorOut, so use the predefined one)
    ref = crcmod_predefined.mkPredefinedCrcFun("crc-16-genibus")
    assert ref(b"123456789") == 0xD64E
    rng = trial_rng(20261122, 0)
    n_checked = 0
    for _ in range(10_000):
        n_bytes = int(rng.integers(0, 65))
        data = rng.integers(0, 256, size=n_bytes, dtype=np.uint8).tobytes()
        bits = np.unpackbits(np.frombuffer(data, dtype=np.uint8))
        expected = ref(data)
        assert crc16(bits) == expected
        assert crc16_bytes(data) == expected
        n_checked += 1
    assert n_checked == 10_000


def test_crc16_and_crc5_match_lfsr_on_unaligned_lengths():
    rng = trial_rng(20261122, 1)
    n_checked = 0
    for _ in range(500):
        bits = rng.integers(0, 2, size=int(rng.integers(0, 200)), dtype=np.uint8)
        assert crc16(bits) == _lfsr(bits, 16, 0x1021, 0xFFFF) ^ 0xFFFF
        assert crc5(bits) == _lfsr(bits, 5, 0x09, 0b01001)
        assert crc16_ok(append_crc16(bits))
        assert crc5_ok(append_crc5(bits))
        n_checked += 1
    assert n_checked == 500


def test_crc_checks_reject_single_bit_errors():
    rng = trial_rng(20261122, 2)
    bits = rng.integers(0, 2, size=117, dtype=np.uint8)
    framed16, framed5 = append_crc16(bits), append_crc5(bits[:17])
    for i in range(framed16.size):
        bad = framed16.copy()
        bad[i] ^= 1
        assert not crc16_ok(bad)
    for i in range(framed5.size):
        bad = framed5.copy()
        bad[i] ^= 1
        assert not crc5_ok(bad)
    assert not crc16_ok(bits[:10]) and not crc5_ok(bits[:3])


def test_invalid_bits_raise():
    with pytest.raises(ValueError):
        crc16(np.array([0, 2, 1]))
    with pytest.raises(ValueError):
        crc5(np.zeros((2, 3), dtype=np.uint8))

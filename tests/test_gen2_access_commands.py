"""Gen2 access commands (Write, Kill, Lock, Access, BlockWrite, BlockErase): each command's bits
laid out by hand here from the standard's field tables (EPC Gen2 v2 / ISO 18000-63
§6.3.2.12.3: command code, fields MSB first, handle, CRC-16), the CRC-16 computed by a bitwise
shift register (tests/reference/gen2_crc.py, checked first against the published Req_RN and Read
bitstreams of gen2-and-validation-anchors.md §3.3), then encode and parse compared with them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rfsim.core.errors import ConfigError
from rfsim.gen2.bits import bits_to_str
from rfsim.gen2.capture import decode_reader_commands
from rfsim.gen2.commands import (
    ACCESS_COMMANDS,
    ACK,
    Access,
    BlockErase,
    BlockWrite,
    CommandParseError,
    Kill,
    Lock,
    Query,
    Read,
    ReqRN,
    Write,
    command_fields,
    command_name,
    command_preamble,
    cover_code,
    encode,
    parse,
)
from rfsim.gen2.pie import pie_envelope

from reference.gen2_crc import crc16_bitwise


def crc16_bits(bits: str) -> str:
    """The bitwise reference CRC-16 of ``bits`` as a 16-character bit string."""
    return format(crc16_bitwise(bits), "016b")


def b(value: int, n: int) -> str:
    return format(value, f"0{n}b")


def test_the_independent_crc_gives_the_published_req_rn_and_read_bitstreams():
    # gen2-and-validation-anchors.md §3.3 (Verilog testbench with correct CRCs)
    for body, crc in (("11000001" "0000010111111100", "1111001111000010"),
                      ("11000010" "00" "00000000" "00000010" "0000101111111000", "1010101110001111")):
        assert crc16_bits(body) == crc


#: Published access commands with correct CRCs (gen2-and-validation-anchors.md §3.3, from a
#: Verilog testbench): the Lock and the two halves of a Kill.
PUBLISHED = [
    ("11000101 11000000001100000000 0000101111111000 0100001111010101",
     Lock(mask=0b1100000000, action=0b1100000000, rn16=0b0000101111111000)),
    ("11000100 1100010010100111 000 0000101111111000 0110101010101101",
     Kill(password=0b1100010010100111, recom=0, rn16=0b0000101111111000)),
    ("11000100 0010100100101100 000 0000101111111000 1110110011110110",
     Kill(password=0b0010100100101100, recom=0, rn16=0b0000101111111000)),
]


@pytest.mark.parametrize("text, cmd", PUBLISHED, ids=["Lock", "Kill-1", "Kill-2"])
def test_the_published_lock_and_kill_bitstreams(text, cmd):
    bits = text.replace(" ", "")
    assert parse(bits) == cmd
    assert bits_to_str(encode(cmd)) == bits
    body = bits[:-16]
    assert crc16_bits(body) == bits[-16:]  # the independent CRC agrees with the published one


HANDLE, COVER = 0xBEEF, 0x5A5A
CASES = [
    # Write: 11000011 | MemBank 11 (User) | WordPtr EBV 00000010 | Data = word ^ RN16 | RN | CRC-16
    (Write.cover_coded(3, 2, 0x1234, COVER, HANDLE),
     "11000011" "11" "00000010" + b(0x1234 ^ COVER, 16) + b(HANDLE, 16)),
    # Write to EPC word 2 with a two-byte EBV pointer (word 200 = 1|0000001 0|1001000)
    (Write(membank=1, word_ptr=200, data=0xFFFF, rn16=0x0001),
     "11000011" "01" "10000001" "01001000" + b(0xFFFF, 16) + b(0x0001, 16)),
    # Kill: 11000100 | Password (upper half ^ RN16) | RFU/Recom 000 | RN | CRC-16
    (Kill.cover_coded(0xDEAD, COVER, HANDLE), "11000100" + b(0xDEAD ^ COVER, 16) + "000" + b(HANDLE, 16)),
    (Kill(password=0x0F0F, recom=0b101, rn16=0x1111), "11000100" + b(0x0F0F, 16) + "101" + b(0x1111, 16)),
    # Lock: 11000101 | Mask(10) | Action(10) | RN | CRC-16; EPC pwd-write lock + User permalock:
    # mask  kill 00 access 00 epc 11 tid 00 user 11, action epc 10 user 01
    (Lock.of(HANDLE, epc=(True, False), user=(False, True)),
     "11000101" "0000110011" "0000100001" + b(HANDLE, 16)),
    # Access: 11000110 | Password (half ^ RN16) | RN | CRC-16
    (Access.cover_coded(0xC0DE, COVER, HANDLE), "11000110" + b(0xC0DE ^ COVER, 16) + b(HANDLE, 16)),
    # BlockWrite: 11000111 | MemBank | WordPtr | WordCount | Data (not cover-coded) | RN | CRC-16
    (BlockWrite(membank=3, word_ptr=0, data=(0x0102, 0xA0B0), rn16=HANDLE),
     "11000111" "11" "00000000" "00000010" + b(0x0102, 16) + b(0xA0B0, 16) + b(HANDLE, 16)),
    # BlockErase: 11001000 | MemBank | WordPtr | WordCount | RN | CRC-16
    (BlockErase(membank=3, word_ptr=4, word_count=3, rn16=HANDLE),
     "11001000" "11" "00000100" "00000011" + b(HANDLE, 16)),
]


@pytest.mark.parametrize("cmd, body", CASES, ids=lambda c: getattr(c, "NAME", ""))
def test_encode_is_the_hand_laid_bit_string_with_its_crc_and_parse_inverts_it(cmd, body):
    bits = body + crc16_bits(body)
    assert bits_to_str(encode(cmd)) == bits
    assert parse(bits) == cmd
    assert command_preamble(cmd) == "frame-sync"


def test_the_fixed_lengths_of_the_standard():
    assert len(encode(Kill())) == 8 + 16 + 3 + 16 + 16 == 59
    assert len(encode(Lock())) == 8 + 20 + 16 + 16 == 60
    assert len(encode(Access())) == 8 + 16 + 16 + 16 == 56
    assert len(encode(Write())) == 8 + 2 + 8 + 16 + 16 + 16 == 66
    assert len(encode(BlockWrite(data=(1, 2, 3)))) == 8 + 2 + 8 + 8 + 48 + 16 + 16


def test_cover_coding_is_an_involution_with_the_same_rn16():
    assert cover_code(cover_code(0x1234, COVER), COVER) == 0x1234
    assert Write.cover_coded(3, 0, 0x1234, COVER, HANDLE).data == 0x1234 ^ 0x5A5A == 0x486E


@pytest.mark.parametrize("cmd", [c for c, _ in CASES], ids=lambda c: c.NAME)
def test_a_flipped_bit_or_a_cut_is_refused(cmd):
    bits = bits_to_str(encode(cmd))
    for k in (9, len(bits) - 20, len(bits) - 1):
        flipped = bits[:k] + ("1" if bits[k] == "0" else "0") + bits[k + 1:]
        with pytest.raises(CommandParseError):
            parse(flipped)
    with pytest.raises(CommandParseError):
        parse(bits[:-1])


@pytest.mark.parametrize("make, key", [
    (lambda: Write(membank=4), "write.membank"),
    (lambda: Write(data=0x10000), "write.data"),
    (lambda: Kill(recom=8), "kill.recom"),
    (lambda: Lock(mask=0x400), "lock.mask"),
    (lambda: Lock.of(1, reserved=(True, True)), "lock.field"),
    (lambda: Access(password=-1), "access.password"),
    (lambda: BlockWrite(data=()), "block_write.data"),
    (lambda: BlockWrite(data=tuple(range(256))), "block_write.data"),
    (lambda: BlockErase(word_count=0), "block_erase.word_count"),
])
def test_out_of_range_fields_name_the_field(make, key):
    with pytest.raises(ConfigError) as err:
        make()
    assert err.value.key == key


def test_every_access_command_has_its_standard_name():
    assert [command_name(c) for c in ACCESS_COMMANDS] == ["Req_RN", "Read", "Write", "Kill", "Lock", "Access",
                                                          "BlockWrite", "BlockErase"]


@settings(max_examples=60, deadline=None)
@given(membank=st.integers(0, 3), ptr=st.integers(0, 2**20), words=st.lists(st.integers(0, 0xFFFF), min_size=1,
                                                                             max_size=8),
       rn16=st.integers(0, 0xFFFF))
def test_block_commands_round_trip(membank, ptr, words, rn16):
    for cmd in (BlockWrite(membank=membank, word_ptr=ptr, data=tuple(words), rn16=rn16),
                BlockErase(membank=membank, word_ptr=ptr, word_count=len(words), rn16=rn16),
                Write(membank=membank, word_ptr=ptr, data=words[0], rn16=rn16)):
        assert parse(encode(cmd)) == cmd


@pytest.mark.parametrize("fs_hz", [2e6, 25e6])
def test_a_capture_of_every_access_command_is_decoded_with_its_fields(fs_hz):
    """A PIE capture (magnitude only) of Query, ACK, then every access command: the capture
    decoder names each one, parses its fields and checks its CRC (issue 34 item 5, commands)."""
    kw = dict(tari_s=12.5e-6, data1_tari=1.5, pw_s=6.25e-6, delimiter_s=12.5e-6, depth=0.9, fs_hz=fs_hz,
              cw_before_s=50e-6, cw_after_s=200e-6)
    access = [ReqRN(rn16=HANDLE), Read(membank=2, word_ptr=0, word_count=2, rn16=HANDLE)] + [c for c, _ in CASES]
    parts = [pie_envelope(encode(Query(q=0)), trcal_s=66.7e-6, **kw),
             pie_envelope(encode(ACK(rn16=0x1234)), trcal_s=None, preamble="frame-sync", **kw)]
    parts += [pie_envelope(encode(c), trcal_s=None, preamble="frame-sync", **kw) for c in access]
    x = np.abs(0.02 * np.concatenate(parts)).astype(np.float32)
    records, _ = decode_reader_commands(x, fs_hz)
    assert [r.name for r in records] == ["Query", "ACK"] + [c.NAME for c in access]
    for r, c in zip(records[2:], access):
        assert r.crc_ok is True and r.error in ("", None)
        assert r.fields == {k: v for k, v in command_fields(c).items()}

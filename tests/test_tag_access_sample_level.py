"""Access commands at sample level: reader → passive tag → reader for every Gen2 access command
(issue 34, item 3).

One reader and one tag at 1 m in free space (``miller4-320k`` at 4 MS/s; the link of
tests/test_engine.py, whose budget puts the reply some 60 dB above the noise): singulation,
Req_RN (handle), Req_RN (new RN16), Read, Write, BlockWrite, BlockErase, Access, Lock and Kill,
each one exchange of the engine, the reply decoded by the reader from the samples. Expected
replies are built here from the standard's layouts (EPC Gen2 v2 §6.3.2.12.3: Read ``0 | words
| handle | CRC-16``; delayed reply ``0 | handle | CRC-16`` or ``1 | code(8) | handle |
CRC-16``; handle / RN16 ``RN16 | CRC-16``), the memory given to the tag and the bitwise CRC-16
of tests/reference/gen2_crc.py, not from the code under test.
"""

from __future__ import annotations

import numpy as np
import pytest

from reference.gen2_crc import crc16_bitwise
from test_engine import make_reader, query, tag_antenna

from rfsim.channels import Channel, Scene
from rfsim.core.rng import trial_rng
from rfsim.devices.tag import PassiveTag, TagConfig
from rfsim.gen2.access import MAX_DELAYED_REPLY_S
from rfsim.gen2.commands import (Access, BlockErase, BlockWrite, Kill, Lock, Query, Read, ReqRN, Write,
                                 cover_code)
from rfsim.gen2.link import t1
from rfsim.gen2.memory import CHIP_MODELS, TagMemory, TagMemoryConfig
from rfsim.protocols.engine import run_exchange, singulate

EPC_HEX = "300833B2DDD9014000000027"
TID_HEX = "E2801105200074C1"
USER_WORDS = (0x1111, 0x2222, 0x3333, 0x4444)
ACCESS_PASSWORD = 0x1234ABCD
KILL_PASSWORD = 0x0BADF00D
CHIP = CHIP_MODELS["generic"]  # write time 3 ms per word, write threshold 3 dB (project's assumptions)


def word_bits(*words: int, n: int = 16) -> list[int]:
    return [(w >> (n - 1 - k)) & 1 for w in words for k in range(n)]


def with_crc(bits) -> np.ndarray:
    bits = list(bits)
    return np.array(bits + word_bits(crc16_bitwise("".join(str(int(b)) for b in bits))), dtype=np.uint8)


def value(bits) -> int:
    return int("".join(str(int(b)) for b in bits), 2)


def memory() -> TagMemory:
    return TagMemory(TagMemoryConfig(chip="generic", epc=EPC_HEX, tid=TID_HEX,
                                     user="".join(f"{w:04X}" for w in USER_WORDS),
                                     access_password=ACCESS_PASSWORD, kill_password=KILL_PASSWORD))


class Session:
    """A reader and one tag at 1 m, commands sent one after another (time advancing)."""

    def __init__(self, x_m: float = 1.0, **tag_config):
        self.reader = make_reader()
        self.tag = PassiveTag(TagConfig(**tag_config), tag_antenna(x_m), rng=trial_rng(7, 1), memory=memory())
        self.channel = Channel(Scene())
        self.n = 0
        ex = singulate(self.reader, [self.tag], self.channel, t_s=0.0, rng=trial_rng(7, 3),
                       query=query(self.reader))
        assert [e.failure_reason for e in ex] == ["", ""]
        self.singulation = ex
        self.rn16 = value(ex[0].bits)
        self.t_s = ex[-1].end_s + 100e-6

    def send(self, cmd, reply_bits: int, **kw):
        self.n += 1
        ex = run_exchange(self.reader, [self.tag], self.channel, cmd, t_s=self.t_s, rng=trial_rng(7, 100 + self.n),
                          reply_bits=reply_bits, expect_crc=True, draw_channel=False, **kw)
        self.t_s = ex.end_s + 100e-6
        return ex

    def req_rn(self, rn16: int) -> int:
        """Req_RN: the reply RN16 | CRC-16 decoded; returns the RN16."""
        ex = self.send(ReqRN(rn16=rn16), 32)
        assert ex.success and ex.bits.size == 32
        assert np.array_equal(ex.bits, with_crc(ex.bits[:16]))
        return value(ex.bits[:16])


@pytest.fixture
def opened():
    s = Session()
    s.handle = s.req_rn(s.rn16)
    return s


def assert_delayed_success(ex, handle: int, t1_min_s: float, n_words: int):
    assert ex.success and ex.failure_reason == ""
    assert np.array_equal(ex.bits, with_crc([0] + word_bits(handle)))  # header 0
    delay = ex.reply_start_s[0] - ex.cmd_end_s
    assert t1_min_s + n_words * CHIP.write_time_s <= delay <= MAX_DELAYED_REPLY_S
    assert ex.timing_ok == (True,)


def assert_error(ex, handle: int, code: int):
    assert ex.success and ex.bits.size == 41
    assert np.array_equal(ex.bits, with_crc([1] + word_bits(code, n=8) + word_bits(handle)))


def test_every_access_command_round_trip(opened):
    s = opened
    t1_min_s = t1(s.reader.link).min_s
    handle = s.handle
    assert s.tag.state.state == "open"  # non-zero access password: Open
    # Req_RN with the handle: a new RN16 with CRC
    rn = s.req_rn(handle)
    # Read TID words 0-3 and User words 1-2: 0 | words | handle | CRC-16
    ex = s.send(Read(membank=2, word_ptr=0, word_count=4, rn16=handle), 33 + 64, header_bit=True)
    tid = [int(TID_HEX[k:k + 4], 16) for k in range(0, 16, 4)]
    assert ex.success and np.array_equal(ex.bits, with_crc([0] + word_bits(*tid) + word_bits(handle)))
    ex = s.send(Read(membank=3, word_ptr=1, word_count=2, rn16=handle), 33 + 32, header_bit=True)
    assert np.array_equal(ex.bits, with_crc([0] + word_bits(*USER_WORDS[1:3]) + word_bits(handle)))
    # Write User word 0, cover-coded with the last RN16: delayed success, then read back
    ex = s.send(Write(membank=3, word_ptr=0, data=cover_code(0xBEEF, rn), rn16=handle), 33, delayed_reply=True)
    assert_delayed_success(ex, handle, t1_min_s, 1)
    ex = s.send(Read(membank=3, word_ptr=0, word_count=1, rn16=handle), 33 + 16, header_bit=True)
    assert np.array_equal(ex.bits, with_crc([0] + word_bits(0xBEEF) + word_bits(handle)))
    # BlockWrite two words (not cover-coded), BlockErase one of them
    ex = s.send(BlockWrite(membank=3, word_ptr=2, data=(0xCAFE, 0xF00D), rn16=handle), 33, delayed_reply=True)
    assert_delayed_success(ex, handle, t1_min_s, 2)
    ex = s.send(BlockErase(membank=3, word_ptr=3, word_count=1, rn16=handle), 33, delayed_reply=True)
    assert_delayed_success(ex, handle, t1_min_s, 1)
    ex = s.send(Read(membank=3, word_ptr=0, word_count=4, rn16=handle), 33 + 64, header_bit=True)
    assert np.array_equal(ex.bits, with_crc([0] + word_bits(0xBEEF, USER_WORDS[1], 0xCAFE, 0) + word_bits(handle)))
    # Access, both halves, each cover-coded with a new RN16: the handle | CRC each time → Secured
    for half in (ACCESS_PASSWORD >> 16, ACCESS_PASSWORD & 0xFFFF):
        rn = s.req_rn(handle)
        ex = s.send(Access.cover_coded(half, rn, handle), 32)
        assert ex.success and np.array_equal(ex.bits, with_crc(word_bits(handle)))
    assert s.tag.state.state == "secured"
    # Lock: User memory permalocked (delayed success), then a Write to it: error 0x04 memory locked
    ex = s.send(Lock.of(handle, user=(True, True)), 33, delayed_reply=True)
    assert_delayed_success(ex, handle, t1_min_s, 1)
    rn = s.req_rn(handle)
    ex = s.send(Write(membank=3, word_ptr=0, data=cover_code(0x0001, rn), rn16=handle), 33, delayed_reply=True)
    assert_error(ex, handle, 0x04)
    assert ex.reply_start_s[0] - ex.cmd_end_s <= t1(s.reader.link).max_s + 1e-9  # refused before programming
    # Kill: first half → handle, second half → delayed success; the tag is killed
    rn = s.req_rn(handle)
    ex = s.send(Kill.cover_coded(KILL_PASSWORD >> 16, rn, handle), 32)
    assert ex.success and np.array_equal(ex.bits, with_crc(word_bits(handle)))
    rn = s.req_rn(handle)
    ex = s.send(Kill.cover_coded(KILL_PASSWORD & 0xFFFF, rn, handle), 33, delayed_reply=True)
    assert_delayed_success(ex, handle, t1_min_s, 1)
    # afterwards no reply to anything, powered (a Query of its session, a Req_RN, a Read)
    lk = s.reader.link
    for cmd, n in ((Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0, session=0, target="A"), 16),
                   (Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0, session=0, target="B"), 16),
                   (ReqRN(rn16=handle), 32), (Read(membank=3, word_ptr=0, word_count=1, rn16=handle), 49)):
        ex = s.send(cmd, n)
        assert ex.powered == (0,) and ex.replied == () and ex.failure_reason == "no reply"


def test_delayed_reply_is_sent_with_the_pilot_tone_after_the_write_time(opened):
    # the tag's own record of a delayed reply: TRext = 1 although the Query had TRext = 0, and a
    # start T1 + one word's write time after the command (the tag counts T1 = max(RTcal, 10 Tpri))
    s = opened
    assert s.reader.link.trext is False
    rn = s.req_rn(s.handle)
    cmd = Write(membank=3, word_ptr=1, data=cover_code(0x5A5A, rn), rn16=s.handle)
    tag_reply = {}
    reflect = s.tag.reflect

    def spy(incident):
        out = reflect(incident)
        tag_reply["response"] = out
        return out

    s.tag.reflect = spy
    try:
        ex = s.send(cmd, 33, delayed_reply=True)
    finally:
        del s.tag.reflect
    r = tag_reply["response"]
    assert r.trext is True and r.reply.delayed and r.reply.kind == "DELAYED"
    lk = s.reader.link
    t1_nominal_s = max(lk.rtcal_s, 10.0 / lk.blf_hz)
    assert r.reply_start_s - r.command_end_s == pytest.approx(t1_nominal_s + CHIP.write_time_s, abs=1e-6)
    # preamble 16·M Miller pilot + 10 bits, 33 bits, dummy 1, at M/BLF each (anchors §4.2)
    assert r.reply_end_s - r.reply_start_s == pytest.approx((22 + 33 + 1) * lk.m / r.blf_hz, rel=1e-12)
    assert ex.success and ex.reply_start_s == (r.reply_start_s,)


def test_without_delayed_reply_the_reader_misses_a_delayed_reply():
    # the same Write heard with the immediate reply window: the reply starts after the window
    s = Session()
    handle = s.req_rn(s.rn16)
    rn = s.req_rn(handle)
    ex = s.send(Write(membank=3, word_ptr=0, data=cover_code(0x0102, rn), rn16=handle), 33)
    assert ex.replied == (0,) and not ex.success and ex.timing_ok == (False,)


def test_insufficient_power_fails_the_write_while_the_read_succeeds():
    # the chip's sensitivity set 1.5 dB below the incident power: powered (margin 1.5 dB ≥ 0)
    # but below the chip's 3 dB write threshold → Write gets error 0x0B, Read answers
    probe = Session()
    p_inc_dbm = probe.singulation[0].incident_power_dbm[0]
    s = Session(sensitivity_dbm=p_inc_dbm - 1.5)
    margin_db = p_inc_dbm - s.tag.config.threshold_incident_dbm
    assert 0.0 < margin_db < CHIP.write_threshold_db
    assert s.tag.power_margin_db(p_inc_dbm) == pytest.approx(margin_db, abs=1e-9)
    handle = s.req_rn(s.rn16)
    ex = s.send(Read(membank=3, word_ptr=0, word_count=1, rn16=handle), 49, header_bit=True)
    assert np.array_equal(ex.bits, with_crc([0] + word_bits(USER_WORDS[0]) + word_bits(handle)))
    rn = s.req_rn(handle)
    ex = s.send(Write(membank=3, word_ptr=0, data=cover_code(0x7777, rn), rn16=handle), 33, delayed_reply=True)
    assert_error(ex, handle, 0x0B)
    ex = s.send(Read(membank=3, word_ptr=0, word_count=1, rn16=handle), 49, header_bit=True)
    assert np.array_equal(ex.bits, with_crc([0] + word_bits(USER_WORDS[0]) + word_bits(handle)))  # unchanged


def test_an_error_reply_to_a_read_is_decoded_with_its_code(opened):
    s = opened
    ex = s.send(Read(membank=2, word_ptr=200, word_count=1, rn16=s.handle), 49, header_bit=True)
    assert_error(ex, s.handle, 0x03)  # memory overrun

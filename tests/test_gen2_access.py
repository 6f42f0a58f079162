"""Tag-side execution of Gen2 access commands against the standard (EPC Gen2 v2 / ISO 18000-63
§6.3.2.12.3, Annex I error codes): every reply is laid out by hand here (header bit, fields,
handle) with its CRC-16 from a bitwise shift register (tests/reference/gen2_crc.py); the commands go
through their bit encoding and parser first, as a tag receives them."""

from __future__ import annotations

import numpy as np
import pytest
from reference.gen2_crc import crc16_bitwise

from rfsim.gen2.access import (
    MAX_DELAYED_REPLY_S,
    AccessContext,
    execute,
    state_after_req_rn,
)
from rfsim.gen2.commands import (
    ACK,
    Access,
    BlockErase,
    BlockWrite,
    Kill,
    Lock,
    Query,
    Read,
    ReqRN,
    Write,
    encode,
    parse,
)
from rfsim.gen2.memory import CHIP_MODELS, EPC, RESERVED, TID, USER, TagMemory, TagMemoryConfig

HANDLE = 0xBEEF
KILL_PWD, ACCESS_PWD = 0xDEADC0DE, 0x12345678


def crc16_str(bits: str) -> str:
    return format(crc16_bitwise(bits), "016b")


def b(value: int, n: int = 16) -> str:
    return format(value, f"0{n}b")


def with_crc(bits: str) -> str:
    return bits + crc16_str(bits)


def as_str(reply) -> str:
    return "".join(str(int(x)) for x in reply)


def ok_reply() -> str:  # delayed reply of success: header 0 | handle | CRC-16
    return with_crc("0" + b(HANDLE))


def err_reply(code: int) -> str:  # error reply: header 1 | error code | handle | CRC-16
    return with_crc("1" + b(code, 8) + b(HANDLE))


def tag(**kw) -> TagMemory:
    cfg = dict(kill_password=KILL_PWD, access_password=ACCESS_PWD, user_words=8)
    cfg.update(kw)
    return TagMemory(TagMemoryConfig(**cfg))


def ctx(state="open", cover=HANDLE) -> AccessContext:
    return AccessContext(state=state, handle=HANDLE, cover_rn16=cover)


def run(m, c, cmd, **kw):
    """Send ``cmd`` through its bits, as the tag receives it."""
    return execute(m, c, parse(encode(cmd)), **kw)


def req_rn(m, c, rng):
    """Req_RN: reply = RN16 | CRC-16; returns the RN16 as read from the reply bits and the context."""
    r = run(m, c, ReqRN(rn16=HANDLE), rng=rng)
    bits = as_str(r.reply)
    assert len(bits) == 32 and bits[16:] == crc16_str(bits[:16])
    return int(bits[:16], 2), r.context


# --------------------------------------------------------------------------- Req_RN, Read


def test_req_rn_replies_a_fresh_rn16_with_crc_and_makes_it_the_cover_code():
    m, rng = tag(), np.random.default_rng(1)
    rn, c = req_rn(m, ctx(), rng)
    assert c.cover_rn16 == rn and c.state == "open" and c.handle == HANDLE
    rn2, _ = req_rn(m, c, rng)
    assert rn2 != rn  # two draws of 16 bits (seed fixed)


def test_state_after_req_rn_is_secured_only_for_a_zero_access_password():
    assert state_after_req_rn(tag()) == "open"
    assert state_after_req_rn(tag(access_password=0)) == "secured"


def test_read_reply_is_header_zero_words_handle_crc():
    m = tag(chip="monza-r6", kill_password=0, access_password=0, user_words=None, tid_serial=0x0000DEADBEEF)
    r = run(m, ctx(), Read(membank=TID, word_ptr=0, word_count=3, rn16=HANDLE))
    # 0 | E280 | 1160 | 2000 | handle | CRC-16 over all of it
    body = "0" + "1110001010000000" + "0001000101100000" + "0010000000000000" + b(HANDLE)
    assert as_str(r.reply) == body + crc16_str(body)
    assert r.words == (0xE280, 0x1160, 0x2000) and not r.delayed and r.delay_s == 0.0
    assert r.error is None


def test_read_errors_are_immediate_error_replies():
    m = tag(lock_access_pwd="locked")
    r = run(m, ctx(), Read(membank=USER, word_ptr=7, word_count=2, rn16=HANDLE))
    assert as_str(r.reply) == err_reply(0x03) and not r.delayed  # memory overrun
    r = run(m, ctx(), Read(membank=RESERVED, word_ptr=2, word_count=2, rn16=HANDLE))
    assert as_str(r.reply) == err_reply(0x04)  # memory locked (access password read-locked in Open)
    r = run(m, ctx("secured"), Read(membank=RESERVED, word_ptr=2, word_count=2, rn16=HANDLE))
    assert r.words == (0x1234, 0x5678)


@pytest.mark.parametrize("cmd", [
    Read(membank=USER, word_ptr=0, word_count=1, rn16=HANDLE ^ 1),
    Write(membank=USER, word_ptr=0, data=0, rn16=0),
    ReqRN(rn16=0x1234),
    Lock.of(HANDLE + 1, user=(True, False)),
    Kill(password=0, rn16=HANDLE - 1),
])
def test_a_wrong_handle_gets_no_reply_and_changes_nothing(cmd):
    m = tag()
    before = [list(bank) for bank in m.banks]
    c = ctx("secured")
    r = run(m, c, cmd, rng=np.random.default_rng(0))
    assert r.reply is None and r.context == c and m.banks == before


def test_a_killed_tag_never_replies():
    r = run(tag(), ctx("killed"), Read(membank=TID, word_ptr=0, word_count=1, rn16=HANDLE))
    assert r.reply is None and r.context.state == "killed"


def test_an_unknown_access_state_is_refused():
    with pytest.raises(ValueError, match="access state"):
        AccessContext(state="reply", handle=HANDLE, cover_rn16=0)


def test_inventory_commands_are_not_access_commands():
    for cmd in (Query(), ACK(rn16=HANDLE)):
        with pytest.raises(TypeError):
            execute(tag(), ctx(), cmd)
    with pytest.raises(ValueError):
        execute(tag(), ctx(), ReqRN(rn16=HANDLE))  # no rng for the new RN16


# --------------------------------------------------------------------------- Write and cover-coding


def test_write_data_is_cover_coded_with_the_rn16_of_the_last_req_rn():
    m, rng = tag(), np.random.default_rng(7)
    rn, c = req_rn(m, ctx(), rng)
    word = 0xA5C3
    r = run(m, c, Write(membank=USER, word_ptr=2, data=word ^ rn, rn16=HANDLE))
    assert as_str(r.reply) == ok_reply() and r.delayed
    assert m.banks[USER][2] == word
    chip = CHIP_MODELS["generic"]
    assert r.delay_s == chip.write_time_s <= MAX_DELAYED_REPLY_S
    # the same on-air field under another cover code writes another word
    run(m, AccessContext("open", HANDLE, rn ^ 0x00FF), Write(membank=USER, word_ptr=3, data=word ^ rn, rn16=HANDLE))
    assert m.banks[USER][3] == word ^ 0x00FF


def test_write_errors_are_delayed_error_replies_and_write_nothing():
    m = tag(lock_epc="locked")
    before = [list(bank) for bank in m.banks]
    cases = [(Write(membank=USER, word_ptr=8, data=1, rn16=HANDLE), 0x03),  # past the 8-word User bank
             (Write(membank=EPC, word_ptr=3, data=1, rn16=HANDLE), 0x04),   # EPC pwd-write locked, Open
             (Write(membank=TID, word_ptr=0, data=1, rn16=HANDLE), 0x04)]   # TID permalocked
    for cmd, code in cases:
        r = run(m, ctx(), cmd)
        assert as_str(r.reply) == err_reply(code) and r.delayed and r.error == code and r.delay_s == 0.0
    assert m.banks == before


def test_insufficient_power_below_the_write_threshold():
    m = tag(chip="monza-r6", kill_password=0, access_password=0, user_words=None)
    threshold_db = -18.8 - (-22.1)  # Monza R6 datasheet: write −18.8 dBm, read −22.1 dBm
    cmd = Write(membank=EPC, word_ptr=2, data=0x1111 ^ HANDLE, rn16=HANDLE)
    r = run(m, ctx(), cmd, power_margin_db=threshold_db - 0.01)
    assert as_str(r.reply) == err_reply(0x0B) and r.delay_s > 0
    assert m.banks[EPC][2] == 0x3008
    r = run(m, ctx(), cmd, power_margin_db=threshold_db + 0.01)
    assert as_str(r.reply) == ok_reply() and m.banks[EPC][2] == 0x1111


def test_overrun_is_reported_before_power_is_checked():
    r = run(tag(), ctx(), Write(membank=USER, word_ptr=99, data=0, rn16=HANDLE), power_margin_db=-10.0)
    assert as_str(r.reply) == err_reply(0x03)


def test_writing_the_epc_over_the_air_updates_the_stored_crc():
    m = tag(epc="300833B2DDD9014000000027")
    run(m, ctx(), Write(membank=EPC, word_ptr=7, data=0x0099 ^ HANDLE, rn16=HANDLE))
    r = run(m, ctx(), Read(membank=EPC, word_ptr=0, word_count=2, rn16=HANDLE))
    pc_epc = b(0x3000) + "".join(b(w) for w in (0x3008, 0x33B2, 0xDDD9, 0x0140, 0x0000, 0x0099))
    assert r.words == (int(crc16_str(pc_epc), 2), 0x3000)


# --------------------------------------------------------------------------- Access and Lock


def access_sequence(m, c, password, rng):
    replies = []
    for half in (password >> 16, password & 0xFFFF):
        rn, c = req_rn(m, c, rng)
        r = run(m, c, Access(password=half ^ rn, rn16=HANDLE))
        replies.append(r.reply)
        c = r.context
        if r.reply is None:
            break
    return replies, c


def test_access_with_both_halves_secures_and_a_locked_bank_becomes_writable():
    m, rng = tag(lock_user="locked"), np.random.default_rng(3)
    cmd = BlockWrite(membank=USER, word_ptr=0, data=(0x0102, 0x0304), rn16=HANDLE)
    r = run(m, ctx(), cmd)
    assert as_str(r.reply) == err_reply(0x04)
    replies, c = access_sequence(m, ctx(), ACCESS_PWD, rng)
    assert [as_str(x) for x in replies] == [with_crc(b(HANDLE))] * 2  # handle | CRC-16, immediate
    assert c.state == "secured"
    r = run(m, c, cmd)
    assert as_str(r.reply) == ok_reply() and m.banks[USER][:2] == [0x0102, 0x0304]


@pytest.mark.parametrize("wrong", ["upper", "lower"])
def test_a_wrong_access_half_sends_the_tag_to_arbitrate_without_reply(wrong):
    m, rng = tag(), np.random.default_rng(4)
    password = ACCESS_PWD ^ (0x00010000 if wrong == "upper" else 0x00000001)
    replies, c = access_sequence(m, ctx(), password, rng)
    assert replies[-1] is None and c.state == "arbitrate"
    assert len(replies) == (1 if wrong == "upper" else 2)  # each half is checked on arrival
    assert execute(m, c, ReqRN(rn16=HANDLE), rng=rng).reply is None  # out of the access states


def test_a_command_between_the_halves_restarts_the_access_sequence():
    m, rng = tag(), np.random.default_rng(5)
    rn, c = req_rn(m, ctx(), rng)
    c = run(m, c, Access(password=(ACCESS_PWD >> 16) ^ rn, rn16=HANDLE)).context
    c = run(m, c, Read(membank=TID, word_ptr=0, word_count=1, rn16=HANDLE)).context
    rn, c = req_rn(m, c, rng)
    r = run(m, c, Access(password=(ACCESS_PWD & 0xFFFF) ^ rn, rn16=HANDLE))  # taken as a first half
    assert r.reply is None and r.context.state == "arbitrate"


def test_lock_is_ignored_in_open_and_applied_in_secured():
    m = tag()
    cmd = Lock.of(HANDLE, user=(True, True))
    assert run(m, ctx("open"), cmd).reply is None and m.lock_name("user") == "unlocked"
    r = run(m, ctx("secured"), cmd)
    assert as_str(r.reply) == ok_reply() and r.delayed and r.delay_s > 0
    assert m.lock_name("user") == "permalocked"
    r = run(m, ctx("secured"), Lock.of(HANDLE, user=(False, False)))  # cannot undo a permalock
    assert as_str(r.reply) == err_reply(0x04) and m.lock_name("user") == "permalocked"
    r = run(m, ctx("secured"), Write(membank=USER, word_ptr=0, data=1, rn16=HANDLE))
    assert as_str(r.reply) == err_reply(0x04)


def test_lock_needs_write_power_too():
    m = tag()
    r = run(m, ctx("secured"), Lock.of(HANDLE, epc=(True, False)), power_margin_db=0.0)
    assert as_str(r.reply) == err_reply(0x0B) and m.lock_name("epc") == "unlocked"


# --------------------------------------------------------------------------- Kill


def kill_sequence(m, c, password, rng, **kw):
    results = []
    for half in (password >> 16, password & 0xFFFF):
        rn, c = req_rn(m, c, rng)
        r = run(m, c, Kill(password=half ^ rn, rn16=HANDLE), **kw)
        results.append(r)
        c = r.context
    return results


def test_kill_with_both_halves_kills_the_tag_after_a_delayed_reply():
    m, rng = tag(), np.random.default_rng(6)
    first, second = kill_sequence(m, ctx(), KILL_PWD, rng)
    assert as_str(first.reply) == with_crc(b(HANDLE)) and not first.delayed
    assert as_str(second.reply) == ok_reply() and second.delayed and second.delay_s > 0
    assert second.context.state == "killed"
    assert run(m, second.context, Read(membank=TID, word_ptr=0, word_count=1, rn16=HANDLE)).reply is None


def test_a_zero_kill_password_is_an_error_and_the_tag_lives():
    m, rng = tag(kill_password=0), np.random.default_rng(8)
    _, second = kill_sequence(m, ctx(), 0, rng)
    assert as_str(second.reply) == err_reply(0x00) and second.context.state == "open"


def test_a_wrong_kill_half_sends_the_tag_to_arbitrate():
    m, rng = tag(), np.random.default_rng(9)
    first, second = kill_sequence(m, ctx(), KILL_PWD ^ 1, rng)
    assert first.reply is not None and second.reply is None and second.context.state == "arbitrate"


def test_kill_without_write_power_leaves_the_tag_alive():
    m, rng = tag(), np.random.default_rng(10)
    _, second = kill_sequence(m, ctx(), KILL_PWD, rng, power_margin_db=1.0)  # generic threshold 3 dB
    assert as_str(second.reply) == err_reply(0x0B) and second.context.state == "open"


# --------------------------------------------------------------------------- BlockWrite, BlockErase


def test_block_write_writes_every_word_and_takes_a_write_time_per_word():
    m = tag(chip="monza-4qt", user_words=None)
    data = (0x1111, 0x2222, 0x3333)
    r = run(m, ctx(), BlockWrite(membank=USER, word_ptr=29, data=data, rn16=HANDLE))
    assert as_str(r.reply) == ok_reply()
    assert m.banks[USER][29:] == list(data)  # the last 3 of the 32 words (512 bits)
    assert r.delay_s == pytest.approx(3 * 3.4e-3 / 2)  # Monza 4 datasheet: 3.4 ms per 32 bits


def test_block_write_across_the_end_of_the_bank_writes_nothing():
    m = tag()
    r = run(m, ctx(), BlockWrite(membank=USER, word_ptr=6, data=(1, 2, 3), rn16=HANDLE))
    assert as_str(r.reply) == err_reply(0x03) and m.banks[USER] == [0] * 8


def test_block_write_longer_than_the_chip_takes_is_not_supported():
    m = tag(user_words=64)
    r = run(m, ctx(), BlockWrite(membank=USER, word_ptr=0, data=(7,) * 33, rn16=HANDLE))
    assert as_str(r.reply) == err_reply(0x01) and m.banks[USER][0] == 0


def test_block_erase_zeroes_words_and_erasing_the_pc_empties_the_epc():
    m = tag(user="AAAABBBBCCCC")
    r = run(m, ctx(), BlockErase(membank=USER, word_ptr=1, word_count=2, rn16=HANDLE))
    assert as_str(r.reply) == ok_reply() and m.banks[USER][:3] == [0xAAAA, 0, 0]
    r = run(m, ctx(), BlockErase(membank=EPC, word_ptr=1, word_count=1, rn16=HANDLE))
    assert as_str(r.reply) == ok_reply()
    # StoredPC 0000h: L = 0, the StoredCRC covers the PC alone
    assert m.read(EPC, 0, 2, secured=False) == (int(crc16_str(b(0)), 2), 0)


def test_block_erase_of_the_stored_crc_or_a_locked_password_is_refused():
    m = tag(lock_kill_pwd="locked")
    assert as_str(run(m, ctx(), BlockErase(membank=EPC, word_ptr=0, word_count=2, rn16=HANDLE)).reply) == \
        err_reply(0x00)
    assert as_str(run(m, ctx(), BlockErase(membank=RESERVED, word_ptr=1, word_count=2, rn16=HANDLE)).reply) == \
        err_reply(0x04)
    assert m.kill_password == KILL_PWD

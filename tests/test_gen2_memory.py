"""Gen2 tag memory against the standard's memory map (EPC Gen2 v2 / ISO 18000-63 §6.3.2.1):
word layouts of the Reserved, EPC and TID banks written out by hand, the StoredCRC checked
against published PC + EPC + CRC-16 replies (gen2-and-validation-anchors.md §3.2) and against
a bitwise CRC-16 (tests/reference/gen2_crc.py), and the Lock action table (§6.3.2.12.3.5) case by case."""

from __future__ import annotations

import tomllib

import pytest
from reference.gen2_crc import crc16_bitwise as crc16_of_bits

from rfsim.core.config import from_dict, to_toml
from rfsim.core.errors import ConfigError
from rfsim.gen2.memory import (
    CHIP_MODELS,
    EPC,
    RESERVED,
    TID,
    USER,
    MemoryAccessError,
    TagError,
    TagMemory,
    TagMemoryConfig,
)


def words_bits(words) -> str:
    return "".join(format(w, "016b") for w in words)


def memory(**kw) -> TagMemory:
    return TagMemory(TagMemoryConfig(**kw))


def raises_code(code: TagError):
    return pytest.raises(MemoryAccessError, match=code.name.lower())


# --------------------------------------------------------------------------- layout and StoredCRC


@pytest.mark.parametrize("epc_hex, crc", [
    # ACK replies PC + EPC-96 + CRC-16 published with their CRC (anchors §3.2, carlosbg1991 test_CRC.m)
    ("300833B2DDD9014000000027", 0x6D3E),
    ("E2801160600002 10A39270DA".replace(" ", ""), 0x9F65),
])
def test_stored_crc_equals_the_published_reply_crc_and_the_bitwise_crc(epc_hex, crc):
    m = memory(epc=epc_hex)
    # StoredPC for a 6-word EPC: L = 00110 (bits 10h-14h), UMI 0, XI 0, bits 17h-1Fh 0
    assert format(m.stored_pc, "016b") == "00110" "0" "0" "000000000"
    epc = [int(epc_hex[i:i + 4], 16) for i in range(0, 24, 4)]
    assert m.epc_words == tuple(epc)
    assert m.stored_crc == crc == crc16_of_bits(words_bits([0x3000] + epc))
    assert m.banks[EPC][:8] == [crc, 0x3000, *epc]


def test_reserved_bank_holds_kill_then_access_password_msw_first():
    m = memory(kill_password=0x12345678, access_password=0x9ABCDEF0)
    assert m.banks[RESERVED] == [0x1234, 0x5678, 0x9ABC, 0xDEF0]
    assert (m.kill_password, m.access_password) == (0x12345678, 0x9ABCDEF0)


def test_stored_pc_umi_xi_and_attribute_bits_and_xpc_outside_the_crc():
    m = memory(epc="1111222233334444", umi=True, pc_attributes=0b1_0000_0001, xpc_w1=0x8000)
    # L = 4 words (00100), UMI 1, XI 1 (XPC_W1 non-zero), T|AFI = 100000001
    assert format(m.stored_pc, "016b") == "00100" "1" "1" "100000001"
    assert m.stored_crc == crc16_of_bits(words_bits([m.stored_pc, 0x1111, 0x2222, 0x3333, 0x4444]))
    assert m.read(EPC, 0x21, 1, secured=False) == (0x8000,)  # XPC_W1 at bit address 210h
    with raises_code(TagError.MEMORY_OVERRUN):  # between the EPC capacity and XPC_W1: not implemented
        m.read(EPC, 0x20, 1, secured=False)


def test_tid_words_follow_the_class_mdid_tmn_layout():
    m = memory(chip="monza-r6", tid_serial=0x0123456789AB)
    # 8-bit class E2h | 12-bit MDID field (XTID indicator + Impinj 001h) | 12-bit TMN 160h |
    # XTID header | 48-bit serial
    bits = "11100010" "100000000001" "000101100000" + format(0x2000, "016b") + format(0x0123456789AB, "048b")
    assert words_bits(m.banks[TID]) == bits
    assert m.read(TID, 0, 2, secured=False) == (0xE280, 0x1160)


def test_tid_from_hex_replaces_the_factory_tid():
    assert memory(tid="E2003412 0000 0001".replace(" ", "")).banks[TID] == [0xE200, 0x3412, 0x0000, 0x0001]


@pytest.mark.parametrize("chip, epc_bits, user_bits, passwords", [
    ("monza-r6", 96, 0, False),     # Monza R6 datasheet: up to 96-bit EPC, no User memory
    ("monza-4qt", 128, 512, True),  # Monza 4QT: 128-bit EPC, 512-bit User
    ("ucode-8", 128, 0, True),      # UCODE 8: up to 128-bit EPC, no User memory, 32-bit passwords
    ("higgs-3", 480, 512, True),    # Higgs-3: up to 480-bit EPC, 512-bit User
])
def test_chip_models_give_the_memory_sizes_of_their_datasheets(chip, epc_bits, user_bits, passwords):
    model = CHIP_MODELS[chip]
    assert (16 * model.epc_words, 16 * model.user_words, model.passwords) == (epc_bits, user_bits, passwords)
    m = memory(chip=chip, epc="")
    assert m.bank_size(USER) == user_bits // 16
    assert m.bank_size(EPC) == 2 + epc_bits // 16
    assert m.bank_size(RESERVED) == (4 if passwords else 0)
    assert 0 < model.write_threshold_db < 10


# --------------------------------------------------------------------------- read, write, erase


def test_read_with_word_count_zero_reads_to_the_end_of_the_bank():
    m = memory(user_words=4, user="000100020003")
    assert m.read(USER, 1, 0, secured=False) == (2, 3, 0)


@pytest.mark.parametrize("bank, ptr, count", [(USER, 31, 2), (USER, 32, 1), (TID, 4, 1), (RESERVED, 4, 1),
                                              (EPC, 10, 1), (USER, 40, 0)])
def test_reads_outside_a_bank_are_memory_overruns(bank, ptr, count):
    m = memory()  # generic: User 32 words, TID 4 words (2 + 32-bit serial), EPC capacity 8 words (bank 10 words)
    with raises_code(TagError.MEMORY_OVERRUN):
        m.read(bank, ptr, count, secured=True)


def test_no_user_memory_and_no_passwords_mean_overruns():
    m = memory(chip="monza-r6")
    for bank in (USER, RESERVED):
        with raises_code(TagError.MEMORY_OVERRUN):
            m.read(bank, 0, 1, secured=True)
        with raises_code(TagError.MEMORY_OVERRUN):
            m.write(bank, 0, [1], secured=True)
    assert (m.kill_password, m.access_password) == (0, 0)
    assert m.lock_name("kill_pwd") == m.lock_name("access_pwd") == "permalocked"


def test_writing_the_epc_recomputes_the_stored_crc():
    m = memory(epc="300833B2DDD9014000000027")
    m.write(EPC, 7, [0x0028], secured=False)
    assert m.stored_crc == crc16_of_bits(words_bits([0x3000, 0x3008, 0x33B2, 0xDDD9, 0x0140, 0x0000, 0x0028]))


def test_writing_the_pc_length_changes_which_words_the_crc_covers():
    m = memory(epc="300833B2DDD9014000000027")
    m.write(EPC, 1, [0x1000], secured=False)  # L = 2 words
    assert m.epc_words == (0x3008, 0x33B2)
    assert m.stored_crc == crc16_of_bits(words_bits([0x1000, 0x3008, 0x33B2]))
    m.write(EPC, 1, [0x4000], secured=False)  # L = 8 (the generic chip's capacity): words 8-9 are zero
    assert m.stored_crc == crc16_of_bits(words_bits([0x4000, 0x3008, 0x33B2, 0xDDD9, 0x0140, 0, 0x0027, 0, 0]))


def test_a_pc_longer_than_the_epc_capacity_and_the_stored_crc_word_are_refused():
    m = memory(chip="monza-r6")
    before = list(m.banks[EPC])
    with raises_code(TagError.MEMORY_OVERRUN):
        m.write(EPC, 1, [7 << 11], secured=True)  # L = 7 > 6 words
    with raises_code(TagError.OTHER):
        m.write(EPC, 0, [0x1234], secured=True)
    assert m.banks[EPC] == before


def test_erase_sets_words_to_zero_and_a_failed_block_changes_nothing():
    m = memory(user_words=4, user="AAAABBBBCCCCDDDD")
    m.erase(USER, 1, 2, secured=False)
    assert m.banks[USER] == [0xAAAA, 0, 0, 0xDDDD]
    with raises_code(TagError.MEMORY_OVERRUN):
        m.write(USER, 2, [1, 2, 3], secured=False)
    assert m.banks[USER] == [0xAAAA, 0, 0, 0xDDDD]


# --------------------------------------------------------------------------- lock


# Lock action table (§6.3.2.12.3.5): pair → (writeable in Open, writeable in Secured) for a bank,
# (readable/writeable in Open, in Secured) for a password
LOCK_TABLE = {"unlocked": (True, True), "permaunlocked": (True, True), "locked": (False, True),
              "permalocked": (False, False)}


@pytest.mark.parametrize("name", LOCK_TABLE)
@pytest.mark.parametrize("secured", [False, True])
def test_bank_write_lock_follows_the_lock_action_table(name, secured):
    m = memory(lock_user=name)
    allowed = LOCK_TABLE[name][secured]
    if allowed:
        m.write(USER, 0, [0x1234], secured=secured)
        assert m.banks[USER][0] == 0x1234
    else:
        with raises_code(TagError.MEMORY_LOCKED):
            m.write(USER, 0, [0x1234], secured=secured)
        assert m.banks[USER][0] == 0
    assert m.read(USER, 0, 1, secured=secured) == (m.banks[USER][0],)  # banks stay readable


@pytest.mark.parametrize("name", LOCK_TABLE)
@pytest.mark.parametrize("secured", [False, True])
def test_password_read_write_lock_follows_the_lock_action_table(name, secured):
    m = memory(access_password=0xCAFEF00D, lock_access_pwd=name)
    allowed = LOCK_TABLE[name][secured]
    if allowed:
        assert m.read(RESERVED, 2, 2, secured=secured) == (0xCAFE, 0xF00D)
        m.write(RESERVED, 3, [0x0001], secured=secured)
        assert m.access_password == 0xCAFE0001
    else:
        for op in (lambda: m.read(RESERVED, 2, 1, secured=secured),
                   lambda: m.write(RESERVED, 2, [0], secured=secured)):
            with raises_code(TagError.MEMORY_LOCKED):
                op()
    assert m.read(RESERVED, 0, 2, secured=False) == (0, 0)  # the kill password is not locked


def test_reading_across_both_passwords_needs_both_readable():
    m = memory(lock_kill_pwd="locked")
    with raises_code(TagError.MEMORY_LOCKED):
        m.read(RESERVED, 0, 0, secured=False)
    assert m.read(RESERVED, 0, 0, secured=True) == (0, 0, 0, 0)


# mask | action, fields kill, access, epc, tid, user (two bits each), laid out by hand
def payload(mask: str, action: str) -> tuple[int, int]:
    return int(mask.replace(" ", ""), 2), int(action.replace(" ", ""), 2)


def test_lock_sets_only_the_masked_bits():
    m = memory(lock_tid="unlocked")
    m.lock(*payload("00 00 11 00 10", "00 00 10 00 10"))  # EPC locked; User pwd-lock bit only
    assert [m.lock_name(f) for f in ("kill_pwd", "access_pwd", "epc", "tid", "user")] == \
        ["unlocked", "unlocked", "locked", "unlocked", "locked"]
    m.lock(*payload("00 00 01 00 00", "00 00 01 00 00"))  # permalock bit of EPC only → permalocked
    assert m.lock_name("epc") == "permalocked"
    m.lock(*payload("00 00 00 00 11", "00 00 00 00 00"))  # unlock User
    assert m.lock_name("user") == "unlocked"


def test_a_permalocked_or_permaunlocked_field_cannot_change_and_the_lock_is_refused_whole():
    m = memory(lock_epc="permalocked", lock_user="permaunlocked")
    for mask, action in (("00 00 11 00 00", "00 00 00 00 00"), ("00 00 00 00 11", "00 00 00 00 10"),
                         ("11 00 00 00 11", "10 00 00 00 11")):
        with raises_code(TagError.MEMORY_LOCKED):
            m.lock(*payload(mask, action))
    assert [m.lock_name(f) for f in ("kill_pwd", "epc", "user")] == ["unlocked", "permalocked", "permaunlocked"]
    # re-asserting the same pair is skipped; the rest of the payload applies
    m.lock(*payload("11 00 11 00 11", "10 00 11 00 01"))
    assert [m.lock_name(f) for f in ("kill_pwd", "epc", "user")] == ["locked", "permalocked", "permaunlocked"]


# --------------------------------------------------------------------------- config


def test_config_loads_from_toml():
    text = """
    chip = "monza-4qt"
    epc = "E2801160 60000210 A39270DA"
    access_password = 0x11223344
    kill_password = 0xDEADBEEF
    user = "0102"
    tid_serial = 0xABCDEF012345
    lock_user = "locked"
    """
    cfg = from_dict(TagMemoryConfig, tomllib.loads(text), prefix="memory")
    m = TagMemory(cfg)
    assert (m.access_password, m.kill_password) == (0x11223344, 0xDEADBEEF)
    assert m.banks[USER][:2] == [0x0102, 0] and m.bank_size(USER) == 32
    assert m.banks[TID][3:] == [0xABCD, 0xEF01, 0x2345]
    assert m.lock_name("user") == "locked" and m.lock_name("tid") == "permalocked"


def test_config_round_trips_through_its_toml_text():
    cfg = TagMemoryConfig(chip="higgs-3", xpc_w1=0x0200, access_password=5, lock_epc="permaunlocked")
    assert from_dict(TagMemoryConfig, tomllib.loads(to_toml(cfg))) == cfg


@pytest.mark.parametrize("table, key", [
    ({"chip": "monza-9"}, "memory.chip"),
    ({"epc": "30083"}, "memory.epc"),
    ({"epc": "zz00"}, "memory.epc"),
    ({"chip": "monza-r6", "epc": "0" * 28}, "memory.epc"),  # 7 words > 96 bits
    ({"user_words": 2, "user": "000100020003"}, "memory.user"),
    ({"chip": "ucode-8", "user": "0001"}, "memory.user"),
    ({"chip": "monza-r6", "access_password": 1}, "memory.access_password"),
    ({"kill_password": 2**32}, "memory.kill_password"),
    ({"lock_epc": "welded"}, "memory.lock_epc"),
    ({"tid_serial": 2**32}, "memory.tid_serial"),  # generic chip: 32-bit serial
    ({"tid": "E20"}, "memory.tid"),
    ({"pwd": 1}, "memory.pwd"),
])
def test_config_errors_are_one_line_and_name_the_key(table, key):
    with pytest.raises(ConfigError) as err:
        from_dict(TagMemoryConfig, table, prefix="memory")
    assert err.value.key == key
    assert "\n" not in str(err.value)

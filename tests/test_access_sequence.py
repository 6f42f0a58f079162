"""Access sequences (rfsim.protocols.access_program, access_sequence): the program parser, a close-range sequence
that reads back the memory the test put into the tag, and the standard's link timing."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.core.errors import UserError
from rfsim.core.rng import trial_rng
from rfsim.gen2.commands import Query
from rfsim.gen2.link import t1, t2
from rfsim.gen2.memory import TagMemory, TagMemoryConfig
from rfsim.protocols.access_program import AccessStep, parse_program, parse_step
from rfsim.protocols.access_sequence import ACCESS_RESULTS, access_columns, run_access_batch

TID_HEX = "E2801105200012345678"
USER_HEX = "0123456789ABCDEF" + "CAFE" * 4


def test_steps_parse_from_strings_and_tables():
    assert parse_step("read tid 0 4") == AccessStep("read", 2, 0, word_count=4, text="read tid 0 4")
    assert parse_step("WRITE user 2 0xBEEF") == AccessStep("write", 3, 2, data=0xBEEF, text="write user 2 0xBEEF")
    assert parse_step({"op": "read", "bank": 3, "ptr": 1, "count": 2}).word_count == 2
    assert parse_step({"op": "write", "bank": "epc", "ptr": 2, "data": 48879}).data == 0xBEEF
    assert parse_step("req_rn").op == "req_rn"
    assert parse_step("read tid 0 4").reply_bits == 1 + 4 * 16 + 16 + 16
    assert parse_step("write user 0 1").reply_bits == 33


@pytest.mark.parametrize("steps, key", [
    (["read tid 0 4"], "program[0]"),                       # no handle first
    ([], "program"),                                        # empty
    ("req_rn", "program"),                                  # not a list
    (["req_rn", "reed tid 0 4"], "program[1]"),             # unknown operation
    (["req_rn", "read flash 0 4"], "program[1].bank"),      # unknown bank
    (["req_rn", "read tid 0 0"], "program[1].count"),       # count 0 (read to the end: length unknown)
    (["req_rn", "read tid 0 256"], "program[1].count"),     # count > 255
    (["req_rn", "read tid 0"], "program[1]"),               # a field missing
    (["req_rn", "write user 2 0x10000"], "program[1].data"),  # not a 16-bit word
    (["req_rn", "write user x 1"], "program[1].ptr"),       # not a number
    (["req_rn", {"op": "read", "bank": "tid"}], "program[1]"),  # table without ptr, count
    (["req_rn", {"op": "erase"}], "program[1].op"),
])
def test_bad_steps_are_one_line_user_errors_naming_the_step(steps, key):
    with pytest.raises(UserError) as err:
        parse_program(steps)
    text = str(err.value)
    assert "\n" not in text and f"'{key}'" in text and "allowed" in text


def _devices(distances_m, *, seed=1, passwords=(0, 0)):
    from rfsim.channels.scene import Channel
    from rfsim.devices.reader import Reader
    from rfsim.devices.tag import PassiveTag
    from rfsim.scenarios import link

    c = link.Config()
    ch = link.ChannelConfig(apdp=False, floor=False)
    antenna = link.reader_antenna(c.geometry)
    readers = [Reader(c.reader, [antenna], rng=trial_rng(seed, i, 99)) for i in range(len(distances_m))]
    tags = []
    for i, d in enumerate(distances_m):
        memory = TagMemory(TagMemoryConfig(epc=c.tag.epc_hex, tid=TID_HEX, user=USER_HEX, kill_password=passwords[0],
                                           access_password=passwords[1]))
        tags.append([PassiveTag(c.tag, link.tag_antenna(c.geometry, d), rng=trial_rng(seed, i, 98), memory=memory)])
    return readers, tags, [Channel(link.scene(ch)) for _ in distances_m]


def _run(distances_m, program, passwords=(0, 0), **kw):
    readers, tags, channels = _devices(distances_m, passwords=passwords)
    lk = readers[0].link
    runs = run_access_batch(readers, tags, channels, t_s=0.0, rngs=[trial_rng(1, i, 0) for i in range(len(distances_m))],
                            query=Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0), program=parse_program(program), **kw)
    return runs, lk


def test_a_close_tag_returns_the_memory_the_test_put_into_it_with_the_standard_timing():
    runs, lk = _run([1.0, 2.0], ["req_rn", "read tid 0 5", "read user 0 4", "read user 4 2", "req_rn"])
    for run in runs:
        assert run.epc_ok
        recs = run.records
        assert [r.command for r in recs] == ["Req_RN", "Read", "Read", "Read", "Req_RN"]
        assert [r.result for r in recs] == ["ok"] * 5
        assert [r.data_hex for r in recs[1:4]] == [TID_HEX, USER_HEX[:16], USER_HEX[16:24]]
        assert all(r.error_code == -1 for r in recs)
        assert len(recs[0].data_hex) == 4 and len(recs[4].data_hex) == 4  # the handle, then a new RN16
        # T2 from each reply's end to the next command: the default 10 Tpri, inside 3–20 Tpri
        gaps = np.array([r.gap_s for r in recs])
        assert all(r.gap_kind == "T2" for r in recs)
        assert np.all(gaps >= t2(lk).min_s) and np.all(gaps <= t2(lk).max_s)
        np.testing.assert_allclose(gaps, 10 * lk.tpri_s, rtol=1e-9)
        # each reply starts T1 after its command, as the reader detected it
        delays = np.array([r.reply_delay_s for r in recs])
        assert np.all(delays >= t1(lk).min_s - 1 / lk.blf_hz) and np.all(delays <= t1(lk).max_s + 1 / lk.blf_hz)
        # commands follow one another: each starts after the previous command ended
        starts, ends = np.array([r.start_s for r in recs]), np.array([r.cmd_end_s for r in recs])
        assert np.all(starts[1:] > ends[:-1]) and starts[0] > run.singulation[-1].cmd_end_s
        assert np.all(np.diff([r.incident_power_dbm for r in recs]) == 0)  # one static channel draw


def test_t2_is_the_configured_number_of_tpri_and_outside_3_to_20_is_refused():
    runs, lk = _run([1.0], ["req_rn", "read tid 0 2"], t2_tpri=3.0)
    np.testing.assert_allclose([r.gap_s for r in runs[0].records], 3.0 * lk.tpri_s, rtol=1e-9)
    for bad in (2.9, 20.5):
        with pytest.raises(UserError, match="t2_tpri"):
            _run([1.0], ["req_rn"], t2_tpri=bad)


def test_an_overrun_read_is_an_error_reply_with_its_code_and_the_program_goes_on():
    runs, _ = _run([1.0], ["req_rn", "read tid 4 4", "read user 0 1"])
    recs = runs[0].records
    assert (recs[1].result, recs[1].error_code, recs[1].data_hex) == ("error", 0x03, "")  # memory overrun
    assert (recs[2].result, recs[2].data_hex) == ("ok", USER_HEX[:4])


def test_a_tag_out_of_range_gets_every_step_not_sent_and_the_table_is_rectangular():
    program = ["req_rn", "read tid 0 2", "write user 0 0x1234"]
    runs, _ = _run([40.0, 50.0], program)
    far = runs[1]
    assert not far.epc_ok and far.singulation[0].failure_reason == "not powered"
    assert [(r.step, r.command, r.result) for r in far.records] == [
        (0, "Req_RN", "not sent"), (1, "Read", "not sent"), (2, "Req_RN", "not sent"), (2, "Write", "not sent")]
    cols = access_columns(runs)
    assert set(cols["result"]) <= set(ACCESS_RESULTS)
    assert cols["trial"].tolist().count(1) == 4 and len({v.size for v in cols.values()}) == 1
    assert np.isnan(cols["start_s"][cols["trial"] == 1]).all()
    assert (cols["error_code"][cols["trial"] == 1] == -1).all() and (cols["gap_kind"][cols["trial"] == 1] == "").all()


def test_a_cover_coded_write_lands_in_memory_with_its_delayed_reply():
    runs, lk = _run([1.0], ["req_rn", "write user 2 0xBEEF", "read user 0 4"])
    recs = runs[0].records
    assert [(r.step, r.command, r.result) for r in recs] == [(0, "Req_RN", "ok"), (1, "Req_RN", "ok"),
                                                              (1, "Write", "ok"), (2, "Read", "ok")]
    # the word the tag wrote is the plain word: the Write's field XOR the RN16 of the Req_RN before it
    assert recs[3].data_hex == USER_HEX[:8] + "BEEF" + USER_HEX[12:16]
    # a delayed reply: after the chip's programming time (3 ms for the generic chip), within T5 <= 20 ms
    assert 3e-3 + t1(lk).min_s - 1 / lk.blf_hz <= recs[2].reply_delay_s <= 20e-3
    assert recs[3].gap_kind == "T2" and recs[3].gap_s == pytest.approx(10 * lk.tpri_s, rel=1e-9)


def test_a_program_of_every_access_command_leaves_the_tag_as_the_standard_says():
    # kill password CAFEBABEh, access password 12345678h: after the handle the tag is Open; the
    # Access halves make it Secured (Lock needs Secured); a permalocked User bank refuses a Write
    # with error 04h (memory locked); the Kill's last half is answered by a delayed success and the
    # tag answers nothing afterwards (EPC Gen2 v2 §6.3.2.12.3; error codes Annex I).
    program = ["req_rn", "blockwrite user 0 0x1111,0x2222", "blockerase user 2 1", "read user 0 4",
               "access 0x12345678", "lock user permalocked", "write user 0 0xBEEF", "read user 0 2",
               "kill 0xCAFEBABE", "read user 0 1"]
    runs, lk = _run([1.0], program, passwords=(0xCAFEBABE, 0x12345678))
    recs = runs[0].records
    got = [(r.step, r.command, r.result, r.error_code) for r in recs]
    assert got == [
        (0, "Req_RN", "ok", -1),
        (1, "BlockWrite", "ok", -1), (2, "BlockErase", "ok", -1), (3, "Read", "ok", -1),
        (4, "Req_RN", "ok", -1), (4, "Access", "ok", -1), (4, "Req_RN", "ok", -1), (4, "Access", "ok", -1),
        (5, "Lock", "ok", -1),
        (6, "Req_RN", "ok", -1), (6, "Write", "error", 0x04),
        (7, "Read", "ok", -1),
        (8, "Req_RN", "ok", -1), (8, "Kill", "ok", -1), (8, "Req_RN", "ok", -1), (8, "Kill", "ok", -1),
        (9, "Read", "no reply", -1),
    ]
    handle = recs[0].data_hex
    assert recs[3].data_hex == "1111" + "2222" + "0000" + USER_HEX[12:16]  # written, erased, untouched
    assert recs[11].data_hex == "11112222"  # the refused Write changed nothing
    assert recs[5].data_hex == handle and recs[13].data_hex == handle  # Access and the first Kill echo the handle
    # delayed replies (BlockWrite, BlockErase, Lock, the final Kill) come after the chip's write time
    for i in (1, 2, 8, 15):
        assert recs[i].reply_delay_s > 2e-3 and recs[i].reply_delay_s < 20e-3, recs[i]
    # immediate replies within T1
    for i in (0, 3, 4, 5, 7, 11):
        assert recs[i].reply_delay_s <= t1(lk).max_s + 1 / lk.blf_hz


def test_new_steps_parse_and_bad_ones_are_named():
    assert parse_step("blockwrite user 0 0x1111,0x2222").words == (0x1111, 0x2222)
    assert parse_step({"op": "blockwrite", "bank": "user", "ptr": 0, "data": [1, 2, 3]}).words == (1, 2, 3)
    assert parse_step("lock epc locked") == AccessStep("lock", field="epc", state="locked", text="lock epc locked")
    assert parse_step("kill 0xCAFEBABE").password == 0xCAFEBABE
    for step, key in [("lock flash locked", "program[1].field"), ("lock user open", "program[1].state"),
                      ("access 0x100000000", "program[1].password"), ("blockwrite user 0 0x1,0x10000", "program[1].data"),
                      ("blockerase user 0 0", "program[1].count")]:
        with pytest.raises(UserError) as err:
            parse_program(["req_rn", step])
        assert f"'{key}'" in str(err.value) and "\n" not in str(err.value)

"""``rfsim decode`` knows every Gen2 command and reply: synthetic magnitude-only captures of an
inventory and access session (Select, Query, QueryAdjust, QueryRep, ACK, NAK, Req_RN, Read,
Write, Kill ×2, Lock, Access ×2, BlockWrite, BlockErase) with every reply type (RN16, EPC,
handle, read data, immediate error, delayed success, delayed error, a reply cut short by the
next command) at 2 and 25 MS/s, with and without the Query, decoded completely.

Every expected reply is laid out here by hand from the standard's formats (EPC Gen2 v2
§6.3.2.12.3; the CRC-16 from the bitwise register of tests/reference/gen2_crc.py) and the
test's own values (RN16s, handle, EPC, words, error codes); the capture is made by
:mod:`rfsim.gen2.synthetic_capture` from those bits.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.dataset import read_table
from rfsim.gen2.capture import decode_reader_commands
from rfsim.gen2.commands import (ACK, NAK, Access, BlockErase, BlockWrite, Kill, Lock, Query, QueryAdjust, QueryRep,
                                 Read, ReqRN, Select, Write, command_fields)
from rfsim.gen2.replies import decode_tag_replies
from rfsim.gen2.synthetic_capture import Exchange, SyntheticLink, synthetic_capture

from reference.gen2_crc import crc16_bitwise


def b(value: int, n: int) -> str:
    return format(value, f"0{n}b")


def crc(body: str) -> str:
    """``body`` followed by its CRC-16 (bitwise reference)."""
    return body + b(crc16_bitwise(body), 16)


def bits(text: str) -> np.ndarray:
    return np.array([int(c) for c in text], dtype=np.uint8)


HANDLE = 0xBEEF
RN_Q, RN_ADJ, RN_REP, RN_REP2 = 0x1234, 0x4321, 0x0F1E, 0x2222
COVERS = (0x5A5A, 0x0F0F, 0x3C3C, 0x6B6B, 0x7E7E)
PC, EPC = 0x3000, 0x300833B2DDD9014000000027
WORDS = (0xCAFE, 0x0102)
#: Replies as the standard lays them out (expected kind, bits, extra fields).
RN16 = lambda rn: ("RN16", b(rn, 16), {"rn16": rn})  # noqa: E731
EPC_REPLY = ("EPC", crc(b(PC, 16) + b(EPC, 96)), {"pc": PC, "epc_hex": f"{EPC:024X}"})
HANDLE_REPLY = lambda rn: ("handle", crc(b(rn, 16)), {"rn16": rn})  # noqa: E731
READ_REPLY = ("read", crc("0" + "".join(b(w, 16) for w in WORDS) + b(HANDLE, 16)),
              {"rn16": HANDLE, "data_hex": "".join(f"{w:04X}" for w in WORDS)})
SUCCESS = ("success", crc("0" + b(HANDLE, 16)), {"rn16": HANDLE})
ERROR = lambda code, name: ("error", crc("1" + b(code, 8) + b(HANDLE, 16)),  # noqa: E731
                            {"rn16": HANDLE, "error_code": code, "error_name": name})

#: (command, expected reply or None, delayed, delay beyond T1 [s], cut after bits)
SESSION = [
    (Select(target=4, action=0, membank=1, pointer=32, mask="1010"), None, False, 0.0, None),
    (Query(dr="64/3", m=4, trext=False, q=1), RN16(RN_Q), False, 0.0, None),
    (QueryAdjust(updn=0), RN16(RN_ADJ), False, 0.0, None),
    (QueryRep(), RN16(RN_REP), False, 0.0, None),
    (ACK(rn16=RN_REP), EPC_REPLY, False, 0.0, None),
    (ReqRN(rn16=RN_REP), HANDLE_REPLY(HANDLE), False, 0.0, None),
    (Read(membank=3, word_ptr=0, word_count=2, rn16=HANDLE), READ_REPLY, False, 0.0, None),
    (Read(membank=3, word_ptr=90, word_count=2, rn16=HANDLE), ERROR(0x03, "MEMORY_OVERRUN"), False, 0.0, None),
    (ReqRN(rn16=HANDLE), HANDLE_REPLY(COVERS[0]), False, 0.0, None),
    (Write(membank=3, word_ptr=0, data=0x1234 ^ COVERS[0], rn16=HANDLE), ERROR(0x04, "MEMORY_LOCKED"), True,
     0.5e-3, None),
    (BlockWrite(membank=3, word_ptr=0, data=WORDS, rn16=HANDLE), SUCCESS, True, 1.0e-3, None),
    (BlockErase(membank=3, word_ptr=0, word_count=2, rn16=HANDLE), SUCCESS, True, 0.2e-3, None),
    (ReqRN(rn16=HANDLE), HANDLE_REPLY(COVERS[1]), False, 0.0, None),
    (Access(password=0xC0DE ^ COVERS[1], rn16=HANDLE), HANDLE_REPLY(HANDLE), False, 0.0, None),
    (ReqRN(rn16=HANDLE), HANDLE_REPLY(COVERS[2]), False, 0.0, None),
    (Access(password=0xF00D ^ COVERS[2], rn16=HANDLE), HANDLE_REPLY(HANDLE), False, 0.0, None),
    (Lock(mask=0b0000110000, action=0b0000100000, rn16=HANDLE), SUCCESS, True, 0.3e-3, None),
    (ReqRN(rn16=HANDLE), HANDLE_REPLY(COVERS[3]), False, 0.0, None),
    (Kill(password=0xDEAD ^ COVERS[3], rn16=HANDLE), HANDLE_REPLY(HANDLE), False, 0.0, None),
    (ReqRN(rn16=HANDLE), HANDLE_REPLY(COVERS[4]), False, 0.0, None),
    (Kill(password=0xBEEF ^ COVERS[4], rn16=HANDLE), SUCCESS, True, 2.0e-3, None),
    (QueryRep(), RN16(RN_REP2), False, 0.0, None),
    (ACK(rn16=RN_REP2), EPC_REPLY, False, 0.0, 50),  # cut by the NAK after 50 bits
    (NAK(), None, False, 0.0, None),
]
TRCAL_S = 64.0 / 3.0 / 256e3
BLF_HZ = 256e3 * 1.02  # the tag's clock 2 % fast (inside FrT)


def _session_capture(fs_hz: float, with_query: bool, seed: int):
    session = SESSION if with_query else SESSION[2:]  # without Select and Query: the link is unknown
    link = SyntheticLink(trcal_s=TRCAL_S, blf_hz=BLF_HZ, m=4)
    exchanges = [Exchange(cmd, None if rep is None else bits(rep[1]), delayed, delay, cut)
                 for cmd, rep, delayed, delay, cut in session]
    cap = synthetic_capture(exchanges, fs_hz=fs_hz, link=link, carrier=0.37, tag_depth=0.03, tag_phase_rad=0.4,
                            noise_rms=0.37 * 2e-3, rng=np.random.default_rng(np.random.SeedSequence(seed)))
    return session, cap


@pytest.mark.parametrize("with_query", [True, False], ids=["query", "no-query"])
@pytest.mark.parametrize("fs_hz", [2e6, 25e6])
def test_every_command_and_reply_of_a_session_is_decoded(fs_hz, with_query):
    session, cap = _session_capture(fs_hz, with_query, seed=int(fs_hz) + with_query)
    x = cap.magnitude.astype(np.float32)  # magnitude only
    records, _ = decode_reader_commands(x, fs_hz)
    assert [r.name for r in records] == [c.NAME for c, *_ in session]
    for rec, (cmd, *_), t0 in zip(records, session, cap.command_starts_s):
        assert rec.fields == command_fields(cmd) and rec.error is None
        assert rec.crc_ok is {"Query": True, "QueryRep": None, "QueryAdjust": None, "ACK": None,
                              "NAK": None}.get(cmd.NAME, True)
        assert abs(rec.start_s - t0) < 2.0 / fs_hz + 0.1e-6
    replies = decode_tag_replies(x, fs_hz, records)
    expected = [(k, rep, delayed, cut) for k, (_, rep, delayed, _, cut) in enumerate(session) if rep is not None]
    assert [r.command_index for r in replies] == [k for k, *_ in expected]
    truths = {t.index: t for t in cap.replies}
    for rep, (k, (kind, text, fields), delayed, cut) in zip(replies, expected):
        assert rep.command == session[k][0].NAME
        assert rep.kind == kind, (k, rep.kind)
        assert rep.delayed is delayed
        assert abs(rep.start_s - truths[k].start_s) < 0.25 / BLF_HZ  # a quarter subcarrier cycle
        assert abs(rep.blf_hz / BLF_HZ - 1) < 2e-3
        assert rep.m == 4 and rep.trext is delayed  # a delayed reply has the pilot
        if cut is None:
            assert rep.bits == text and not rep.truncated
            assert rep.crc_ok is (None if kind == "RN16" else True)  # an RN16 has no CRC
            assert rep.n_bits_expected == len(text)
            for key, value in fields.items():
                assert getattr(rep, key) == value, (k, key)
        else:  # cut by the next command: the bits before the cut, flagged
            assert rep.truncated and rep.crc_ok is None
            assert cut - 4 <= len(rep.bits) <= cut and text.startswith(rep.bits)
            assert rep.n_bits_expected == len(text) and rep.pc == PC
            assert rep.start_s < rep.end_s <= records[k + 1].start_s
    assert len(replies) == len(expected)


def test_a_wisp_fm0_reply_with_pilot_150us_after_a_blockwrite_at_25msps():
    """The issue's capture: a commercial reader, a WISP answering two BlockWrites with FM0 and
    the pilot at ≈ 615 kHz, ≈ 150 µs after the command, 25 MS/s magnitude only, no Query."""
    fs = 25e6
    link = SyntheticLink(tari_s=6.25e-6, trcal_s=64 / 3 / 640e3, blf_hz=615e3, m=1)
    delay = 150e-6 - max(link.rtcal_s, 10 / 615e3)  # the reply starts 150 µs after the command
    success = bits(crc("0" + b(0x7E57, 16)))
    exchanges = [Exchange(BlockWrite(membank=3, word_ptr=0, data=(0xAAAA,), rn16=0x7E57), success, True, delay),
                 Exchange(BlockWrite(membank=3, word_ptr=1, data=(0x5555, 0x1234), rn16=0x7E57), success, True,
                          delay)]
    cap = synthetic_capture(exchanges, fs_hz=fs, link=link, tag_depth=0.02, noise_rms=3e-3,
                            rng=np.random.default_rng(np.random.SeedSequence(34)))
    x = cap.magnitude.astype(np.float32)
    records, _ = decode_reader_commands(x, fs)
    assert [r.name for r in records] == ["BlockWrite", "BlockWrite"]
    replies = decode_tag_replies(x, fs, records)
    assert len(replies) == 2
    for rep in replies:
        assert (rep.kind, rep.delayed, rep.m, rep.trext, rep.crc_ok, rep.rn16) == ("success", True, 1, True, True,
                                                                                      0x7E57)
        assert rep.bits == "0" + b(0x7E57, 16) + b(crc16_bitwise("0" + b(0x7E57, 16)), 16)
        assert abs(rep.latency_s - 150e-6) < 0.5e-6
        assert abs(rep.blf_hz - 615e3) < 615e3 * 2e-3


def test_synthetic_capture_places_replies_at_t1_with_the_pilot_when_delayed():
    """The builder's own timing: T1 = max(RTcal, 10/BLF) after the command's last rising edge
    (§4.3), delayed replies later by their delay and with the pilot; the magnitude steps by
    the tag depth (noise free)."""
    link = SyntheticLink(trcal_s=TRCAL_S, tari_s=12.5e-6, data1_tari=2.0)
    rn = bits(b(0xACE1, 16))
    cap = synthetic_capture([Exchange(Query(dr="64/3", m=2), rn),
                             Exchange(Write(rn16=1), bits(crc("0" + b(1, 16))), True, 1e-3)],
                            fs_hz=4e6, link=link, tag_depth=0.04)
    blf = 256e3
    t1 = max(3 * 12.5e-6, 10 / blf)
    q, w = cap.replies
    assert q.start_s == pytest.approx(cap.command_ends_s[0] + t1, abs=1e-12)
    assert w.start_s == pytest.approx(cap.command_ends_s[1] + t1 + 1e-3, abs=1e-12)
    assert (q.trext, w.trext, q.m, q.blf_hz) == (False, True, 2, pytest.approx(blf))
    mag = cap.magnitude
    inside = mag[int(q.start_s * 4e6) + 2: int(q.end_s * 4e6) - 2]
    assert set(np.round(inside, 12)) == {1.0, 1.04}
    with pytest.raises(ValueError, match="before any Query"):
        synthetic_capture([Exchange(ReqRN(), rn)], fs_hz=4e6)
    with pytest.raises(ValueError, match="delay_s"):
        synthetic_capture([Exchange(Query(), rn), Exchange(Write(), rn, True, 0.03)], fs_hz=4e6)


def test_cli_writes_the_decoded_session_as_a_dataset(tmp_path, capsys):
    """``rfsim decode`` end to end on a .npy magnitude capture: the text lines name the delayed
    and error replies, ``-o`` writes the commands and reads tables with the new columns."""
    session, cap = _session_capture(2e6, True, seed=5)
    path = tmp_path / "session.npy"
    np.save(path, cap.magnitude.astype(np.float32))
    out_h5 = tmp_path / "log.h5"
    assert main(["decode", str(path), "--fs", "2e6", "-o", str(out_h5)]) == 0
    text = capsys.readouterr().out
    assert "success handle=0xBEEF (delayed" in text
    assert "error code=0x04 MEMORY_LOCKED handle=0xBEEF (delayed" in text
    assert "error code=0x03 MEMORY_OVERRUN handle=0xBEEF  CRC ok" in text
    commands = read_table(out_h5, "commands")
    assert list(commands["command"]) == [c.NAME for c, *_ in session]
    reads = read_table(out_h5, "reads")
    kinds = list(reads["kind"])
    assert len(kinds) == sum(rep is not None for _, rep, *_ in session)
    assert kinds.count("success") == 4 and kinds.count("error") == 2 and kinds.count("handle") == 9
    err = np.array(kinds) == "error"
    assert sorted(reads["error_code"][err]) == [3, 4]
    assert sorted(reads["error_name"][err]) == ["MEMORY_LOCKED", "MEMORY_OVERRUN"]
    assert set(reads["error_code"][~err]) == {-1}
    assert int(np.sum(reads["delayed"])) == 5 and int(np.sum(reads["truncated"])) == 1
    assert int(np.sum(reads["tag_seen_count"])) == 1  # the complete EPC reply with its CRC
    assert list(reads["epc"][np.array(kinds) == "EPC"]) == [f"{EPC:024X}", f"{EPC:024X}"[:4]]
    assert main(["decode", str(path), "--fs", "2e6", "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [r["kind"] for r in doc["replies"]] == kinds
    assert all(math.isfinite(r["latency_s"]) for r in doc["replies"])


def test_cli_bad_capture_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.npy"
    np.save(bad, np.array([1.0, np.nan, 1.0]))
    assert main(["decode", str(bad), "--fs", "25e6"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rfsim: error: ") and "Traceback" not in err


def test_the_reference_grrfid_waveform_holds_no_tag_reply(reference_data):
    """The gr-rfid reference waveform is the reader's transmission only (201 Query, 200 ACK):
    no command there has a reply to find, before or after the access-command windows."""
    from rfsim.gen2.capture import load_capture

    x = load_capture(reference_data / "gr-rfid-waveforms" / "reader_tx_query_ack.cf32")
    records, _ = decode_reader_commands(x, 250e3)
    assert len(records) == 401
    assert decode_tag_replies(x, 250e3, records) == []


@pytest.mark.parametrize("fs_hz, blf_hz, m", [(2e6, 250e3, 2), (25e6, 615e3, 1)])
def test_a_delayed_reply_late_in_its_20ms_window_and_none_in_noise(fs_hz, blf_hz, m):
    """T5 reaches 20 ms: a success reply 15 ms after the command is found (no Query: the
    link is searched blind), and a command without a reply followed by 21 ms of carrier and
    noise gives no reply in 10 noise draws (P_FA 1e−3 per window)."""
    link = SyntheticLink(blf_hz=blf_hz, m=m, tari_s=6.25e-6)
    success = bits(crc("0" + b(0x7E57, 16)))
    cmd = BlockWrite(membank=3, word_ptr=0, data=(0xAAAA,), rn16=0x7E57)
    cap = synthetic_capture([Exchange(cmd, success, True, 15e-3)], fs_hz=fs_hz, link=link, tag_depth=0.02,
                            noise_rms=3e-3, rng=np.random.default_rng(np.random.SeedSequence(7)), lead_s=21e-3)
    x = cap.magnitude
    records, _ = decode_reader_commands(x, fs_hz)
    (rep,) = decode_tag_replies(x, fs_hz, records)
    assert (rep.kind, rep.delayed, rep.crc_ok, rep.rn16, rep.m, rep.trext) == ("success", True, True, 0x7E57, m, True)
    assert abs(rep.start_s - cap.replies[0].start_s) < 0.25 / blf_hz
    found = 0
    for seed in range(10):
        cap = synthetic_capture([Exchange(cmd)], fs_hz=fs_hz, link=link, noise_rms=3e-3, lead_s=21e-3,
                                rng=np.random.default_rng(np.random.SeedSequence(100 + seed)))
        records, _ = decode_reader_commands(cap.magnitude, fs_hz)
        assert [r.name for r in records] == ["BlockWrite"]
        found += len(decode_tag_replies(cap.magnitude, fs_hz, records))
    assert found == 0


def test_modulation_onsets_finds_where_the_tag_starts():
    """White noise with a ±a square wave (period 8 samples) from sample 5000: the onset is the
    block that holds sample 5000 or the next one; pure noise has none; a short window is
    searched whole (None)."""
    from rfsim.gen2.reply_search import modulation_onsets

    rng = np.random.default_rng(np.random.SeedSequence(3))
    x = rng.standard_normal(20000)
    x[5000:7000] += 1.0 * np.where((np.arange(2000) // 4) % 2 == 0, 1.0, -1.0)
    onsets, block = modulation_onsets(x, 1e6, 25e3)
    assert block == 80
    assert onsets and 5000 - block < onsets[0] <= 5000 + block
    assert modulation_onsets(rng.standard_normal(20000), 1e6, 25e3)[0] == []
    assert modulation_onsets(x[:1000], 1e6, 25e3)[0] is None


def test_the_complex_capture_decodes_like_the_magnitude():
    """The same session as complex baseband (backscatter at 0.4 rad from the carrier, at
    25 MS/s): the same commands and reply bits as from the magnitude."""
    session, cap = _session_capture(25e6, True, seed=11)
    x = (cap.iq * np.exp(1.3j)).astype(np.complex64)  # an unknown carrier phase
    records, _ = decode_reader_commands(x, 25e6)
    assert [r.name for r in records] == [c.NAME for c, *_ in session]
    replies = decode_tag_replies(x, 25e6, records)
    expected = [(k, rep[1]) for k, (_, rep, *_) in enumerate(session) if rep is not None]
    assert [r.command_index for r in replies] == [k for k, _ in expected]
    for rep, (_, text) in zip(replies[:-1], expected[:-1]):
        assert rep.bits == text and not rep.truncated
    cut = replies[-1]  # the EPC reply cut after 50 bits
    assert cut.truncated and expected[-1][1].startswith(cut.bits) and 46 <= len(cut.bits) <= 50


def test_the_decode_benchmark_times_an_access_session():
    """``rfsim bench decode`` also decodes an access session (14 commands, 5 delayed replies):
    every reply found with the bits sent, with and without the Query."""
    from rfsim.bench.decode import bench_decode

    out = bench_decode(duration_s=0.05, reply_counts=(2,), line_codes=(4,), queries=(True, False),
                       access_rates=(2e6,))
    assert out["access_query_2_replies_exact"] == "14/14"
    assert out["access_no_query_2_replies_exact"] == "13/13"  # the session without its Query
    assert out["access_query_2_wall_s"] > 0 and out["access_query_2_capture_s"] > 0.02

"""Capture loading, reader-command decoding of the gr-rfid reader waveform, synthetic
captures, and the ``rfsim decode`` subcommand."""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest

from rfsim.cli.decode import add_parser, run
from rfsim.errors import UserError
from rfsim.gen2.capture import decode_reader_commands, load_capture
from rfsim.gen2.commands import ACK, Query, ReqRN, encode
from rfsim.gen2.pie import pie_envelope

QUERY_Q0 = "1000000000000000010000"  # anchors §3.3: Query DR=8, FM0, TRext 0, All, S0, A, Q=0


@pytest.fixture(scope="module")
def grrfid(reference_data):
    return load_capture(reference_data / "gr-rfid-waveforms" / "reader_tx_query_ack.cf32")


def test_grrfid_capture_commands(grrfid):
    """The gr-rfid reader waveform at 250 kS/s: 201 Query(Q=0) with CRC-5 ok, each but the last
    followed by an ACK (the file ends 324 samples after the last Query, before its ACK);
    Tari/RTcal/TRcal = 24/72/200 µs (6/18/50 samples)."""
    assert grrfid.dtype == np.complex64 and grrfid.size == 377_304
    records, timing = decode_reader_commands(grrfid, 250e3)
    names = [r.name for r in records]
    assert names.count("Query") == 201 and names.count("ACK") == 200 and len(records) == 401
    assert names == ["Query", "ACK"] * 200 + ["Query"]
    for rec in records:
        assert rec.error is None
        if rec.name == "Query":
            assert rec.bits == QUERY_Q0 and rec.crc_ok is True
            assert rec.fields == dict(dr="8", m=1, trext=False, sel="all", session=0, target="A", q=0)
            assert rec.trcal_s == pytest.approx(200e-6, rel=1e-9)
        else:
            assert len(rec.bits) == 18 and rec.crc_ok is None and math.isnan(rec.trcal_s)
        assert rec.tari_s == pytest.approx(24e-6, rel=1e-9) and rec.rtcal_s == pytest.approx(72e-6, rel=1e-9)
    assert (records[-1].start_s * 250e3) > grrfid.size - 600
    assert timing.n_commands == 401
    assert (timing.tari_s, timing.rtcal_s, timing.trcal_s) == pytest.approx((24e-6, 72e-6, 200e-6), rel=1e-9)


def test_grrfid_sample_rate_inference(grrfid):
    """Only 250 kS/s puts the measured timings inside the Gen2 limits (anchors §4.1):
    Tari 6.25–25 µs, delimiter 12.5 µs ± 5 % (ACKs, whose I/Q edges are aligned),
    RTcal 2.5–3.0 Tari, TRcal 1.1–3.0 RTcal."""
    frames_fs = []
    for fs in (125e3, 250e3, 500e3, 1e6):
        records, timing = decode_reader_commands(grrfid, fs)
        acks = [r for r in records if r.name == "ACK"]
        delim = float(np.median([r.delimiter_s for r in acks]))
        ok = (6.25e-6 <= timing.tari_s <= 25e-6 and 11.875e-6 <= delim <= 13.125e-6
              and 2.5 <= timing.rtcal_s / timing.tari_s <= 3.0 and 1.1 <= timing.trcal_s / timing.rtcal_s <= 3.0)
        if ok:
            frames_fs.append(fs)
    assert frames_fs == [250e3]


def test_grrfid_scale_and_offset_invariance(grrfid):
    ref, _ = decode_reader_commands(grrfid, 250e3)
    scaled, _ = decode_reader_commands(grrfid * np.complex64(3e-4 * np.exp(1j * 1.1)), 250e3)
    env, _ = decode_reader_commands(5.0 * np.abs(grrfid) - 2.0, 250e3)  # real envelope with offset
    for other in (scaled, env):
        assert [(r.name, r.bits) for r in other] == [(r.name, r.bits) for r in ref]


def test_synthetic_capture_and_crc_flags():
    """Query, ACK and Req_RN (CRC-16) through PIE; a flipped payload bit in a second Req_RN
    is reported as CRC bad."""
    kw = dict(tari_s=6.25e-6, data1_tari=1.5, pw_s=3.125e-6, delimiter_s=12.5e-6, depth=0.9, fs_hz=2e6,
              cw_before_s=50e-6, cw_after_s=100e-6)
    req = encode(ReqRN(rn16=0xABCD))
    bad = req.copy()
    bad[10] ^= 1
    parts = [pie_envelope(encode(Query(q=5, m=2, trext=True)), trcal_s=40e-6, **kw)]
    for bits in (encode(ACK(rn16=0x0F0F)), req, bad):
        parts.append(pie_envelope(bits, trcal_s=None, preamble="frame-sync", **kw))
    x = (0.01 * np.concatenate(parts) * np.exp(0.3j)).astype(np.complex64)
    records, timing = decode_reader_commands(x, 2e6)
    assert [r.name for r in records] == ["Query", "ACK", "Req_RN", "Req_RN"]
    assert records[0].fields["q"] == 5 and records[0].fields["m"] == 2 and records[0].crc_ok
    assert records[1].fields == {"rn16": 0x0F0F} and records[1].crc_ok is None
    assert records[2].crc_ok is True and records[2].fields == {"rn16": 0xABCD}
    assert records[3].crc_ok is False and records[3].error and records[3].fields == {}
    assert records[0].start_s == pytest.approx(50e-6, abs=1e-6)
    assert timing.tari_s == pytest.approx(6.25e-6, abs=0.5e-6) and timing.trcal_s == pytest.approx(40e-6, abs=0.5e-6)


# ----------------------------------------------------------------- loading


def test_load_capture_formats_and_errors(tmp_path):
    x = (np.arange(10) + 1j * np.arange(10)).astype(np.complex64)
    x.tofile(tmp_path / "a.cf32")
    np.save(tmp_path / "a.npy", x)
    assert np.array_equal(load_capture(tmp_path / "a.cf32"), x)
    assert np.array_equal(load_capture(tmp_path / "a.npy"), x)
    (tmp_path / "empty.cf32").write_bytes(b"")
    (tmp_path / "odd.cf32").write_bytes(b"123")
    (tmp_path / "a.wav").write_bytes(b"12345678")
    np.save(tmp_path / "b.npy", np.zeros((2, 2)))
    for name, text in [("missing.cf32", "not found"), ("empty.cf32", "empty"), ("odd.cf32", "whole number"),
                       ("a.wav", "unsupported file type"), ("b.npy", "1-D")]:
        with pytest.raises(UserError, match=text) as err:
            load_capture(tmp_path / name)
        assert "\n" not in str(err.value)


# ----------------------------------------------------------------- CLI


def test_cli_decode_grrfid(reference_data, capsys):
    path = reference_data / "gr-rfid-waveforms" / "reader_tx_query_ack.cf32"
    assert run(argparse.Namespace(capture=str(path), fs_hz=250e3)) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 402
    assert "Query" in lines[0] and "q=0" in lines[0] and lines[0].endswith("CRC ok")
    assert "ACK" in lines[1] and "rn16=0x" in lines[1]
    assert lines[-1] == "401 commands; Tari 24.00 µs, RTcal 72.00 µs, TRcal 200.00 µs (medians)"


def test_cli_decode_parser_and_errors(tmp_path):
    parser = argparse.ArgumentParser(prog="rfsim")
    add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["decode", "x.cf32", "--fs", "250e3"])
    assert args.func is run and args.fs_hz == 250e3 and args.capture == "x.cf32"
    (tmp_path / "empty.cf32").write_bytes(b"")
    (tmp_path / "a.txt").write_text("hello")
    good = tmp_path / "ok.cf32"
    np.ones(100, dtype=np.complex64).tofile(good)
    cases = [
        (str(tmp_path / "missing.cf32"), 1e6, "not found"),
        (str(tmp_path / "a.txt"), 1e6, "unsupported file type"),
        (str(tmp_path / "empty.cf32"), 1e6, "empty"),
        (str(good), 0.0, "--fs must be a positive"),
        (str(good), -5.0, "--fs must be a positive"),
        (str(good), float("nan"), "--fs must be a positive"),
    ]
    for capture, fs, text in cases:
        with pytest.raises(UserError, match=text) as err:
            run(argparse.Namespace(capture=capture, fs_hz=fs))
        assert "\n" not in str(err.value)


def test_cli_decode_no_commands(tmp_path, capsys):
    path = tmp_path / "cw.npy"
    np.save(path, np.ones(1000, dtype=np.complex64))
    assert run(argparse.Namespace(capture=str(path), fs_hz=1e6)) == 0
    assert capsys.readouterr().out.strip() == "0 commands; Tari n/a, RTcal n/a, TRcal n/a (medians)"

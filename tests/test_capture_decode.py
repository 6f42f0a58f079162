"""Capture loading, reader-command decoding of the gr-rfid reader waveform, synthetic
captures, tag-reply decoding in captures made by the simulator's reader/tag/channel
devices, and the ``rfsim decode`` subcommand."""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest

from scipy.stats import beta

from rfsim.cli.decode import add_parser, run
from rfsim.core.errors import ConfigError, UserError
from rfsim.gen2.bits import bits_to_int
from rfsim.gen2.replies import decode_tag_replies
from rfsim.gen2.capture import (decode_reader_commands, fit_gain_offset, load_capture,
                                preamble_threshold)
from rfsim.gen2.commands import ACK, Query, ReqRN, encode
from rfsim.gen2.link import t1
from rfsim.gen2.pie import pie_envelope
from rfsim.core.rng import trial_rng

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
    """The gr-rfid file holds only the reader's transmit waveform: no tag replies, no error."""
    path = reference_data / "gr-rfid-waveforms" / "reader_tx_query_ack.cf32"
    assert run(argparse.Namespace(capture=str(path), fs_hz=250e3)) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 402
    assert "Query" in lines[0] and "q=0" in lines[0] and lines[0].endswith("CRC ok")
    assert "ACK" in lines[1] and "rn16=0x" in lines[1]
    assert lines[-1] == ("401 commands (Tari 24.00 µs, RTcal 72.00 µs, TRcal 200.00 µs, medians); 0 tag replies "
                         "(0 RN16, 0 with CRC-16, 0 CRC ok, 0 truncated)")


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
    assert capsys.readouterr().out.splitlines() == [
        "0 commands (Tari n/a, RTcal n/a, TRcal n/a, medians); 0 tag replies (0 RN16, 0 with CRC-16, 0 CRC ok, "
        "0 truncated)"]


# ----------------------------------------------------------------- tag replies


def _link_capture(profile: str, clock_error_percent: float, seed: int):
    """A monostatic capture made by the simulator's own devices: Query → RN16, ACK → PC+EPC.

    Reader (``rfsim.devices.reader.Reader``, 30 dB TX→RX isolation, 10 dB NF, 4 MS/s), passive tag
    (``rfsim.devices.tag.PassiveTag``) at 3 m in free space (``rfsim.channels.Channel``, LoS only). The
    reader's RX is built as the engine builds it (rfsim.protocols.engine.run_exchange): carrier leakage
    L·x_tx + the tag's backscatter ((A_s − Γ(t))·incident through the backward link, exact fractional
    delays) + complex thermal noise kTB·NF. The two segments are concatenated and scaled by an
    arbitrary complex factor (unknown capture scale). Returns (capture complex64, fs, RN16 bits
    and PC+EPC+CRC bits the tag actually sent, the tag's BLF)."""
    from rfsim.channels import Antenna, Channel, HalfWaveDipole, Patch, Scene
    from rfsim.channels.paths import apply_paths
    from rfsim.devices.reader import Reader, ReaderConfig
    from rfsim.devices.tag import PassiveTag, TagConfig

    reader = Reader(ReaderConfig(link_profile=profile, hopping=False),
                    [Antenna(position_m=(0.0, 0.0, 1.0), orientation=(0.0, 0.0, 0.0), pattern=Patch(6.0, 70.0),
                             polarization="linear")], rng=trial_rng(seed, 0))
    tag = PassiveTag(TagConfig(clock_error_percent=clock_error_percent),
                     Antenna(position_m=(3.0, 0.0, 1.0), orientation=(np.pi, 0.0, 0.0), pattern=HalfWaveDipole(),
                             polarization="linear"), rng=trial_rng(seed, 1))
    channel, rng, lk = Channel(Scene()), trial_rng(seed, 2), reader.link

    def exchange(cmd, t_s, reply_bits):
        window_s = lk.reply_duration_s(reply_bits) + t1(lk).max_s + 3 * lk.tpri_s
        tx = reader.transmit(cmd, t0_s=t_s, cw_after_s=window_s)
        fwd, bwd = channel.backscatter_links(reader.antennas[0], tag.antenna, fc_hz=tx.fc_hz, rng=rng, t_s=t_s)
        kw = dict(fs_hz=tx.fs_hz, fc_hz=tx.fc_hz, t0_s=t_s, method="exact")
        incident = apply_paths(tx.samples, paths=fwd, **kw)
        resp = tag.listen(incident, t0_s=t_s, fs_hz=tx.fs_hz)
        rx = reader.leakage_gain() * tx.samples + apply_paths(resp.reradiation(incident.size) * incident,
                                                              paths=bwd, **kw)
        sigma = math.sqrt(reader.noise_power_w() / 2.0)
        return rx + sigma * (rng.standard_normal(rx.size) + 1j * rng.standard_normal(rx.size)), resp

    q = Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0)
    rx1, r1 = exchange(q, 0.0, 16)
    assert r1.reply is not None and r1.reply.kind == "RN16"
    rx2, r2 = exchange(ACK(bits_to_int(r1.reply.bits)), r1.reply_end_s + 10 * lk.tpri_s, 128)
    assert r2.reply is not None and r2.reply.kind == "EPC"
    x = (np.concatenate([rx1, rx2]) * (41.0 * np.exp(2.1j))).astype(np.complex64)
    return x, reader.fs_hz, r1.reply.bits, r2.reply.bits, r1.blf_hz


@pytest.mark.parametrize("profile, clock_error", [("miller4-320k", 0.0), ("fm0-640k", 4.0)])
def test_link_capture_tag_replies(profile, clock_error):
    """Replies in a simulated monostatic capture (Query → RN16, ACK → PC+EPC+CRC-16), decoded
    with the BLF from the TRcal measured in the capture and M/TRext from the parsed Query.
    Truth: the bits the tag device sent and the EPC it was configured with. With a +4 % tag
    clock error the fm0-640k tag's BLF is f_clk/round(N_TRcal/DR) = 665.6 kHz, 4 % above
    DR/TRcal (within FrT = 15 %): the BLF search must find it."""
    x, fs, rn16_bits, epc_bits, tag_blf = _link_capture(profile, clock_error, seed=11)
    records, _ = decode_reader_commands(x, fs)
    assert [r.name for r in records] == ["Query", "ACK"]
    replies = decode_tag_replies(x, fs, records)
    assert [(r.command_index, r.command, r.kind) for r in replies] == [(0, "Query", "RN16"), (1, "ACK", "EPC")]
    rn16, epc = replies
    assert rn16.rn16 == bits_to_int(rn16_bits) and rn16.crc_ok is None
    assert epc.bits == "".join(map(str, epc_bits)) and epc.crc_ok is True
    assert epc.pc == 0x3000 and epc.epc_hex == "300833B2DDD9014000000027"
    # decoding needs the BLF to ~1/(4 elements of the reply); detection is far above threshold
    n_el = 2 * (6 + 129) if profile.startswith("fm0") else 4 * (10 + 129) * 2
    assert abs(epc.blf_hz / tag_blf - 1) < 1 / n_el
    assert rn16.corr > 0.9 and epc.corr > 0.9


def test_cli_decode_link_capture(tmp_path, capsys):
    """``rfsim decode`` on a simulated .cf32 capture prints the RN16 and the EPC with CRC ok,
    with the line code taken from the Query or given on the command line."""
    x, fs, rn16_bits, _, _ = _link_capture("miller4-320k", 0.0, seed=5)
    path = tmp_path / "link.cf32"
    x.tofile(path)
    rn16 = f"RN16=0x{bits_to_int(rn16_bits):04X}"
    for extra in ({}, dict(blf_hz=320e3, m=4, trext=0, dr="64/3"), dict(trcal_s=66.667e-6)):
        assert run(argparse.Namespace(capture=str(path), fs_hz=fs, **extra)) == 0
        lines = capsys.readouterr().out.splitlines()
        assert len(lines) == 5, lines
        assert "Query" in lines[0] and "tag reply" in lines[1] and rn16 in lines[1]
        assert "ACK" in lines[2] and "PC=0x3000 EPC=300833B2DDD9014000000027  CRC ok" in lines[3]
        assert "corr 0." in lines[1] and "corr 0." in lines[3]
        assert lines[-1].endswith("2 tag replies (1 RN16, 1 with CRC-16, 1 CRC ok, 0 truncated)")


def test_grrfid_capture_has_no_tag_replies(grrfid):
    """The reader-only gr-rfid waveform has no replies; with complex white noise added (SNR of
    the CW 37 dB) every one of the 401 windows is a noise-only test at P_FA = 1e−3 per
    window: expected false alarms 0.4, Poisson P(N > 3) < 1e−3 (fewer still after the
    E_h/N0 gate)."""
    records, _ = decode_reader_commands(grrfid, 250e3)
    assert decode_tag_replies(grrfid, 250e3, records) == []
    rng = trial_rng(3, 0)
    noisy = grrfid + 0.02 * (rng.standard_normal(grrfid.size) + 1j * rng.standard_normal(grrfid.size))
    assert len(decode_tag_replies(noisy, 250e3, records)) <= 3


def test_fit_gain_offset_and_threshold():
    """(h, c) recovered exactly from r = h·s + c; the threshold is the Beta(1, n−2) quantile
    (corr² of a zero-mean normalised correlation on white noise) at P_FA/(2·tests)."""
    s = np.where(np.arange(50) % 3 == 0, 1.0, -1.0)
    h, c = fit_gain_offset((0.3 - 2j) * s + (5 + 1j), s)
    assert h == pytest.approx(0.3 - 2j, abs=1e-12) and c == pytest.approx(5 + 1j, abs=1e-12)
    with pytest.raises(ValueError):
        fit_gain_offset(np.ones(5), -np.ones(5))
    for n, tests, pfa in [(100, 40, 1e-3), (500, 44, 1e-3), (30, 1, 0.1)]:
        gamma2 = beta.isf(pfa / (2 * tests), 1, n - 2)
        assert preamble_threshold(n, tests, pfa) == pytest.approx(math.sqrt(gamma2), rel=1e-9)


def test_tag_reply_options_errors(tmp_path):
    x = np.ones(100, dtype=np.complex64)
    for kw, key in [(dict(blf_hz=-1.0), "blf"), (dict(trcal_s=0.0), "trcal"), (dict(m=3), "m"),
                    (dict(dr="16"), "dr"), (dict(blf_tolerance=0.7), "blf_tolerance")]:
        with pytest.raises(ConfigError, match=f"'{key}'"):
            decode_tag_replies(x, 1e6, [], **kw)
    good = tmp_path / "ok.cf32"
    x.tofile(good)
    for kw, text in [(dict(blf_hz=0.0), "--blf must be positive"), (dict(trcal_s=-1e-6), "--trcal must be positive")]:
        with pytest.raises(UserError, match=text):
            run(argparse.Namespace(capture=str(good), fs_hz=1e6, **kw))

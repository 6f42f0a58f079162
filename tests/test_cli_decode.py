"""``rfsim decode``: output formats, the HDF5 dataset, ``| head``, Gen2 timing warnings and
bad inputs (each a one-line error with exit status 2, no traceback)."""

from __future__ import annotations

import csv
import io
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.dataset import read_table
from rfsim.gen2.bits import bits_to_int
from rfsim.core.reads import READ_SCHEMA

from test_capture_replies import _rn16, query_ack_items, synth_capture


@pytest.fixture(scope="module")
def link_capture(tmp_path_factory):
    """Query → RN16 (Miller-4, 256 kHz · 1.01), ACK → PC + EPC + CRC-16 at 4 MS/s, as .cf32."""
    rn = _rn16(2)
    x, truth = synth_capture(query_ack_items(rn, 256e3 * 1.01), fs_hz=4e6, trcal_s=64 / 3 / 256e3, tari_s=12.5e-6)
    path = tmp_path_factory.mktemp("cap") / "link.cf32"
    x.astype(np.complex64).tofile(path)
    return path, rn, truth


def _run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_text_format_and_summary(link_capture, capsys):
    path, rn, _ = link_capture
    code, out, err = _run(["decode", str(path), "--fs", "4e6"], capsys)
    lines = out.splitlines()
    assert code == 0 and err == ""
    assert len(lines) == 5
    assert f"RN16=0x{bits_to_int(rn):04X}" in lines[1] and "Miller-4" in lines[1]
    assert "EPC PC=0x3000 EPC=300833B2DDD9014000000027  CRC ok" in lines[3]
    assert lines[-1].endswith("2 tag replies (1 RN16, 1 with CRC-16, 1 CRC ok, 0 truncated)")


def test_json_and_csv_formats(link_capture, capsys):
    path, rn, _ = link_capture
    code, out, _ = _run(["decode", str(path), "--fs", "4e6", "--format", "json"], capsys)
    doc = json.loads(out)
    assert code == 0 and [c["command"] for c in doc["commands"]] == ["Query", "ACK"]
    assert [r["kind"] for r in doc["replies"]] == ["RN16", "EPC"]
    assert doc["replies"][0]["rn16"] == bits_to_int(rn) and doc["replies"][1]["crc_ok"] is True
    assert doc["replies"][0]["frequency_hz"] is None  # NaN → null: valid JSON
    assert set(READ_SCHEMA) <= set(doc["replies"][0])
    assert [r["tag_seen_count"] for r in doc["replies"]] == [0, 1]  # the EPC reply (CRC ok) is the tag report
    assert "2 tag replies" in doc["summary"]
    code, out, err = _run(["decode", str(path), "--fs", "4e6", "--format", "csv"], capsys)
    rows = list(csv.DictReader(io.StringIO(out)))
    assert code == 0 and [r["record"] for r in rows] == ["command", "reply", "command", "reply"]
    assert rows[3]["epc"] == "300833B2DDD9014000000027" and rows[3]["crc_ok"] == "True"
    assert "2 tag replies" in err  # the summary goes to stderr, stdout stays a clean table


def test_output_dataset_read_table_layout(link_capture, capsys, tmp_path):
    """--output writes the replies in the per-read schema of the simulated readers (every
    READ_SCHEMA column, same units) and the commands; parent folders are made."""
    path, rn, truth = link_capture
    out = tmp_path / "new" / "dir" / "cap.h5"
    code, _, _ = _run(["decode", str(path), "--fs", "4e6", "-o", str(out), "--format", "json"], capsys)
    assert code == 0 and out.is_file()
    reads = read_table(out, "reads")
    cmds = read_table(out, "commands")
    assert list(cmds["command"]) == ["Query", "ACK"]
    assert set(READ_SCHEMA) <= set(reads)
    assert list(reads["kind"]) == ["RN16", "EPC"] and int(reads["rn16"][0]) == bits_to_int(rn)
    assert list(reads["epc"]) == ["", "300833B2DDD9014000000027"]
    assert reads["time_s"][1] == pytest.approx(truth[1][1], abs=1e-6)
    import h5py
    with h5py.File(out) as f:
        for name, field in READ_SCHEMA.items():
            assert f["reads"][name].attrs["units"] == field.units


def test_broken_pipe_is_quiet(reference_data, project_root):
    """``rfsim decode … | head -n 1``: exit status 0 and nothing on stderr."""
    path = reference_data / "gr-rfid-waveforms" / "reader_tx_query_ack.cf32"
    env = {**os.environ, "PYTHONPATH": str(project_root)}
    proc = subprocess.Popen([sys.executable, "-m", "rfsim", "decode", str(path), "--fs", "250e3"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    first = proc.stdout.readline()
    proc.stdout.close()  # as head does after its lines
    err = proc.stderr.read()
    proc.stderr.close()
    assert proc.wait(timeout=120) == 0
    assert b"Query" in first and err == b""


@pytest.mark.parametrize("fs, text", [("1e15", "Tari 6e-09 µs is outside"), ("1", "Tari 6e+06 µs is outside")])
def test_wrong_sample_rate_warns(reference_data, capsys, fs, text):
    """The gr-rfid waveform (Tari = 6 samples) at a wrong --fs: a warning naming the measured
    Tari and the sample rates 6/25 µs … 6/6.25 µs = 240–960 kHz that fit; exit 0."""
    path = reference_data / "gr-rfid-waveforms" / "reader_tx_query_ack.cf32"
    code, _, err = _run(["decode", str(path), "--fs", fs], capsys)
    assert code == 0
    warnings = [line for line in err.splitlines() if line.startswith("rfsim: warning:")]
    assert any(text in w and "2.4e+05–9.6e+05 Hz" in w for w in warnings), err


def test_right_sample_rate_no_warning(reference_data, capsys):
    path = reference_data / "gr-rfid-waveforms" / "reader_tx_query_ack.cf32"
    code, _, err = _run(["decode", str(path), "--fs", "250e3"], capsys)
    assert code == 0 and err == ""


def test_rtcal_trcal_warnings():
    """RTcal and TRcal ratios outside 2.5–3.0 Tari and 1.1–3.0 RTcal are named."""
    from rfsim.gen2.capture import ReaderTiming, timing_warnings
    w = timing_warnings(ReaderTiming(1, 10e-6, 40e-6, 150e-6, 12.5e-6), 1e6)
    assert len(w) == 2 and "RTcal 40 µs = 4 Tari" in w[0] and "TRcal 150 µs = 3.75 RTcal" in w[1]
    assert timing_warnings(ReaderTiming(1, 10e-6, 27e-6, 40e-6, 12.5e-6), 1e6) == ()


def _bad_files(tmp):
    x = np.ones(4000, dtype=np.complex64)
    files = {}
    for name, arr in [("nan.npy", np.where(np.arange(4000) == 17, np.nan, 1.0).astype(np.complex64)),
                      ("inf.npy", np.where(np.arange(4000) == 5, np.inf, 1.0)),
                      ("neginf.npy", np.where(np.arange(4000) == 5, -np.inf, 1.0).astype(np.float32)),
                      ("nanimag.npy", x + 1j * np.where(np.arange(4000) == 9, np.nan, 0.0)),
                      ("twod.npy", np.ones((2, 3))), ("bool.npy", np.ones(5, dtype=bool)),
                      ("str.npy", np.array(["a", "b"]))]:
        np.save(tmp / name, arr)
        files[name] = tmp / name
    inf = x.copy()
    inf[100] = np.inf
    inf.tofile(tmp / "inf.cf32")
    files["inf.cf32"] = tmp / "inf.cf32"
    nan = x.copy()
    nan[:] = np.nan
    nan.tofile(tmp / "allnan.cf32")
    files["allnan.cf32"] = tmp / "allnan.cf32"
    (tmp / "empty.cf32").write_bytes(b"")
    (tmp / "odd.cf32").write_bytes(b"1234567")
    (tmp / "text.npy").write_text("not numpy")
    np.save(tmp / "obj.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    (tmp / "a.wav").write_bytes(b"12345678")
    (tmp / "capdir.cf32").mkdir()
    x.tofile(tmp / "ok.cf32")
    (tmp / "afile").write_text("x")
    for name in ("empty.cf32", "odd.cf32", "text.npy", "obj.npy", "a.wav", "capdir.cf32", "ok.cf32", "afile"):
        files[name] = tmp / name
    return files


BAD_CASES = [
    # (argv after "decode", expected text in the one-line error)
    (["{nan.npy}", "--fs", "1e6"], "non-finite samples"),
    (["{inf.npy}", "--fs", "1e6"], "non-finite samples"),
    (["{neginf.npy}", "--fs", "1e6"], "non-finite samples"),
    (["{nanimag.npy}", "--fs", "1e6"], "non-finite samples"),
    (["{inf.cf32}", "--fs", "1e6"], "first at sample 100"),
    (["{allnan.cf32}", "--fs", "1e6"], "4000 non-finite samples"),
    (["{twod.npy}", "--fs", "1e6"], "1-D numeric array"),
    (["{bool.npy}", "--fs", "1e6"], "1-D numeric array"),
    (["{str.npy}", "--fs", "1e6"], "1-D numeric array"),
    (["{empty.cf32}", "--fs", "1e6"], "is empty"),
    (["{odd.cf32}", "--fs", "1e6"], "whole number of complex64"),
    (["{text.npy}", "--fs", "1e6"], "not a readable .npy"),
    (["{obj.npy}", "--fs", "1e6"], "not a readable .npy"),
    (["{a.wav}", "--fs", "1e6"], "unsupported file type"),
    (["{capdir.cf32}", "--fs", "1e6"], "not found"),
    (["missing.cf32", "--fs", "1e6"], "not found"),
    (["{ok.cf32}", "--fs", "0"], "--fs must be a positive"),
    (["{ok.cf32}", "--fs=-1e6"], "--fs must be a positive"),
    (["{ok.cf32}", "--fs", "nan"], "--fs must be a positive"),
    (["{ok.cf32}", "--fs", "inf"], "--fs must be a positive"),
    (["{ok.cf32}", "--fs", "1e6", "--blf", "0"], "--blf must be positive"),
    (["{ok.cf32}", "--fs", "1e6", "--blf", "nan"], "--blf must be positive"),
    (["{ok.cf32}", "--fs", "1e6", "--blf=-4e4"], "--blf must be positive"),
    (["{ok.cf32}", "--fs", "1e6", "--trcal=-1e-6"], "--trcal must be positive"),
    (["{ok.cf32}", "--fs", "1e6", "--trcal", "inf"], "--trcal must be positive"),
    (["{ok.cf32}", "--fs", "1e6", "-o", "{capdir.cf32}"], "is a directory"),
    (["{ok.cf32}", "--fs", "1e6", "-o", "{afile}/x.h5"], "is not a folder"),
    (["{ok.cf32}", "--fs", "1e6", "-o", "/proc/rfsim-no/x.h5"], "cannot write"),
    (["{ok.cf32}", "--fs", "1e6", "-o", "{ok.cf32}"], "is the capture being decoded"),
    (["{ok.cf32}", "--fs", "1e6", "-o", "x.txt"], "must end in .h5 or .hdf5"),
    (["{ok.cf32}", "--fs", "1e6", "--blf", "1e12"], "--blf 1e+12: outside the Gen2 range 31.2–780.8 kHz"),
    (["{ok.cf32}", "--fs", "1e6", "--blf", "1e3"], "--blf 1000: outside the Gen2 range"),
    (["{ok.cf32}", "--fs", "1e6", "--trcal", "1e-9"], "--trcal 1e-09: outside the Gen2 range 17.2–225 µs"),
]
ARGPARSE_CASES = [
    ["{ok.cf32}"],                                   # --fs missing
    ["{ok.cf32}", "--fs", "banana"],
    ["{ok.cf32}", "--fs", "1e6", "--format", "banana"],
    ["{ok.cf32}", "--fs", "1e6", "--m", "3"],
    ["{ok.cf32}", "--fs", "1e6", "--trext", "2"],
    ["{ok.cf32}", "--fs", "1e6", "--dr", "16"],
    ["{ok.cf32}", "--fs", "1e6", "--blf", "fast"],
    [],                                              # no capture
]


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory):
    return _bad_files(tmp_path_factory.mktemp("bad"))


def _fill(argv, files):
    """Replace ``{name}`` in the arguments by the path of the bad file ``name``."""
    return [re.sub(r"\{([^}]+)\}", lambda m: str(files[m.group(1)]), a) for a in argv]


@pytest.mark.parametrize("argv, text", BAD_CASES)
def test_bad_input_one_line_exit_2(bad_files, capsys, argv, text):
    code, out, err = _run(["decode", *_fill(argv, bad_files)], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("rfsim: error: ") and text in err, err
    assert "Traceback" not in err


@pytest.mark.parametrize("argv", ARGPARSE_CASES)
def test_bad_arguments_exit_2(bad_files, capsys, argv):
    with pytest.raises(SystemExit) as exc:
        main(["decode", *_fill(argv, bad_files)])
    assert exc.value.code == 2
    assert "Traceback" not in capsys.readouterr().err


def test_output_checked_before_decoding(bad_files, tmp_path, capsys):
    """A bad --output fails before the capture is read (a NaN capture would fail later)."""
    code, _, err = _run(["decode", str(bad_files["nan.npy"]), "--fs", "1e6", "-o", str(bad_files["capdir.cf32"])],
                        capsys)
    assert code == 2 and "is a directory" in err
    assert not any(p.name.startswith(".rfsim-probe") for p in tmp_path.iterdir())

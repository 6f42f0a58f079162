"""The reader's report stage (rfsim.core.records): RSSI steps, sensitivity floor, 12-bit phase codes,
per-port phase offsets, µs time stamps, EPC hex strings and the time-sorted long table.

Expected values are worked out by hand from the definitions (LLRP PeakRSSI in whole dBm,
Impinj dBm×100 and 12-bit RF phase angle), not by the functions under test.
"""

from __future__ import annotations

import contextlib
import io
import math

import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.dataset import read_table
from rfsim.core.errors import ConfigError
from rfsim.gen2.crc import append_crc16
from rfsim.core.records import (ReportConfig, epc_hex, long_table, phase_code, phase_of_code, quantize_rssi_dbm,
                           report_columns, time_stamp_us)


def test_rssi_quantization_of_known_values():
    p = [-42.49, -42.51, -60.0049, -60.0151, -89.5001, np.nan]
    np.testing.assert_array_equal(quantize_rssi_dbm(p, 1.0), [-42.0, -43.0, -60.0, -60.0, -90.0, np.nan])
    np.testing.assert_allclose(quantize_rssi_dbm(p, 0.01), [-42.49, -42.51, -60.00, -60.02, -89.50, np.nan],
                               atol=1e-12)
    np.testing.assert_array_equal(quantize_rssi_dbm(p, 0.0), p)


def test_twelve_bit_phase_codes():
    step = 2 * math.pi / 4096  # 1.5339807878856412 mrad
    phi = [0.0, math.pi / 2, math.pi, 2 * math.pi - 0.4 * step, 100.6 * step, 100.4 * step, np.nan]
    np.testing.assert_array_equal(phase_code(phi, 12), [0, 1024, 2048, 0, 101, 100, -1])
    np.testing.assert_allclose(phase_of_code([0, 1024, 4095], 12), [0.0, math.pi / 2, 4095 * step], atol=1e-15)
    assert np.isnan(phase_of_code([-1], 12)[0])


def test_time_stamps_in_whole_microseconds():
    np.testing.assert_array_equal(time_stamp_us([0.0, 1.2345674, 1.2345676, 60.0]),
                                  [0, 1234567, 1234568, 60_000_000])
    assert time_stamp_us([1.0]).dtype == np.int64


def test_epc_hex_of_a_decoded_reply():
    epc = "300833B2DDD9014000000027"
    pc = [0, 0, 1, 1, 0] + [0] * 11  # PC word: EPC length 6 words
    epc_bits = [int(b) for ch in epc for b in f"{int(ch, 16):04b}"]
    reply = append_crc16(np.array(pc + epc_bits, dtype=np.uint8))
    assert epc_hex(reply) == epc
    assert epc_hex(None) == "" and epc_hex(np.zeros(16, np.uint8)) == ""


def test_report_stage_offsets_floor_and_codes():
    cfg = ReportConfig(rssi_step_db=1.0, sensitivity_dbm=-90.0, phase_bits=12,
                       port_phase_offsets_rad=(0.5, -1.0))
    out = report_columns(cfg, t_s=[0.0025, 0.0050, 0.0075, 0.0100], antenna=[1, 2, 1, 2],
                         rssi_dbm=[-50.4, -90.0, -90.01, -40.0], phase_rad=[6.0, 0.5, 1.0, np.nan],
                         success=[True, True, True, False])
    np.testing.assert_array_equal(out["reported"], [True, True, False, False])
    np.testing.assert_array_equal(out["rssi_reported_dbm"][:2], [-50.0, -90.0])
    assert np.isnan(out["rssi_reported_dbm"][2:]).all()
    # port 1: (6.0 + 0.5) mod 2π = 0.216814692820414 rad → code round(141.33) = 141;
    # port 2: (0.5 − 1.0) mod 2π = 5.783185307179586 rad → code round(3770.17) = 3770
    np.testing.assert_array_equal(out["phase_code"], [141, 3770, -1, -1])
    np.testing.assert_allclose(out["phase_reported_rad"][:2], np.array([141, 3770]) * 2 * math.pi / 4096,
                               atol=1e-15)
    np.testing.assert_array_equal(out["t_us"], [2500, 5000, 7500, 10000])
    raw = report_columns(ReportConfig(phase_bits=0), t_s=[0.0], antenna=[1], rssi_dbm=[-50.0],
                         phase_rad=[1.25], success=[True])
    assert raw["phase_reported_rad"][0] == 1.25 and raw["phase_code"][0] == -1


def test_an_antenna_port_without_an_offset_is_a_config_error():
    cfg = ReportConfig(port_phase_offsets_rad=(0.1, 0.2))
    with pytest.raises(ConfigError, match="port_phase_offsets_rad"):
        cfg.port_offset_rad([1, 3])


def test_long_table_sorts_by_time_stably():
    t = long_table({"t_us": np.array([30, 10, 20, 10]), "antenna": np.array([1, 2, 3, 4])})
    np.testing.assert_array_equal(t["t_us"], [10, 10, 20, 30])
    np.testing.assert_array_equal(t["antenna"], [2, 4, 3, 1])


def test_link_reads_carry_the_report(tmp_path):
    path = tmp_path / "l.h5"
    argv = ["run", "link", "--no-plot", "-q", "-o", str(path), "--set", "geometry.distances_m=[1.0]",
            "--set", "rounds_per_point=3", "--set", "channel.apdp=false", "--set", "reader.report.rssi_step_db=0.01",
            "--set", "reader.report.port_phase_offsets_rad=[1.0]"]
    assert main(argv) == 0
    t = read_table(path, "reads")
    ok = t["success"].astype(bool)
    assert ok.all()
    assert set(t["epc"].astype(str)) == {"300833B2DDD9014000000027"}
    np.testing.assert_array_equal(t["first_seen_timestamp_us"], np.round(t["time_s"] * 1e6).astype(np.int64))
    assert np.all(np.diff(t["first_seen_timestamp_us"]) > 0)
    np.testing.assert_allclose(t["rssi_reported_dbm"], np.round(t["peak_rssi_dbm"] * 100) / 100, atol=1e-9)
    expect = np.mod(np.round((t["phase_angle_rad"] + 1.0) * 4096 / (2 * np.pi)), 4096)
    np.testing.assert_array_equal(t["phase_code"], expect)


def test_wrong_number_of_port_offsets_exits_2_with_one_line(tmp_path, capsys):
    argv = ["run", "link", "--no-plot", "-o", str(tmp_path / "x.h5"), "--set", "geometry.distances_m=[1.0]",
            "--set", "rounds_per_point=1", "--set", "reader.report.port_phase_offsets_rad=[0.1, 0.2]"]
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(argv) == 2
    err = capsys.readouterr().err
    assert "reader.report.port_phase_offsets_rad" in err and "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("rfsim: error:")]
    assert len(errors) == 1 and "one offset per antenna port (1 port)" in errors[0]

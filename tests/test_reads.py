"""The per-read schema (rfsim.core.reads) and ``rfsim export``: the quantizers against values
worked by hand, the schema's columns with their units in every dataset that holds reads (tiny
runs), the export's round trip (CSV and JSON lines parsed back equal the table's reported
reads) and its bad inputs (one line, exit status 2)."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.dataset import read_table
from rfsim.core.reads import (READ_SCHEMA, REPORT_KEYS, quantize_phase_12bit_rad, quantize_rssi_impinj_dbm,
                              read_columns)

from test_capture_replies import _rn16, query_ack_items, synth_capture

ONE_TAG_SCENE = Path(__file__).resolve().parents[1] / "examples" / "scenes" / "one-reader-one-tag.toml"


def test_rssi_quantizer_gives_impinj_half_db_steps():
    # by hand: -61.26 → 2·(-61.26) = -122.52 → -123 → -61.5;  -61.24 → -122.48 → -122 → -61.0;
    # -40.75 → -81.5 → -82 (ties to even) → -41.0;  -40.25 → -80.5 → -80 → -40.0;  NaN stays NaN
    got = quantize_rssi_impinj_dbm([-61.26, -61.24, -40.75, -40.25, -30.0, np.nan])
    np.testing.assert_array_equal(got, [-61.5, -61.0, -41.0, -40.0, -30.0, np.nan])


def test_phase_quantizer_is_the_12_bit_code():
    # by hand: 1 rad·4096/2π = 651.898… → code 652 → 652·2π/4096 = 1.0001554 rad;
    # 2π − 1e-4 rad → 4095.93… → 4096 → mod 4096 = 0 → 0 rad;  π → code 2048 → π exactly;
    # -0.5 rad → -325.95 → -326 → mod 4096 = 3770 → 3770·2π/4096
    got = quantize_phase_12bit_rad([1.0, 2 * math.pi - 1e-4, math.pi, -0.5, np.nan])
    step = 2 * math.pi / 4096
    np.testing.assert_array_equal(got, [652 * step, 0.0, math.pi, 3770 * step, np.nan])
    assert abs(got[0] - 1.0001554) < 1e-7


def _columns(**kw):
    base = dict(epc=["300833B2DDD9014000000027", ""], antenna_port=[1, 2], channel_index=[3, 4],
                frequency_hz=[902.75e6, 903.25e6], first_seen_timestamp_us=[1500, 4000], tag_seen_count=[True, False],
                peak_rssi_dbm=[-55.3, np.nan], phase_angle_rad=[1.0, np.nan], doppler_frequency_hz=[2.0, np.nan])
    base.update(kw)
    return read_columns(**base)


def test_read_columns_follow_the_schema_with_its_units_and_labels():
    cols = _columns(true_position_m=[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], true_distance_m=[2.5, 3.5],
                    notes={"true_distance_m": "nominal"})
    assert list(cols) == list(READ_SCHEMA)
    assert set(REPORT_KEYS) <= set(cols)
    for name, field in READ_SCHEMA.items():
        assert cols[name].units == field.units, name
        assert cols[name].description.startswith(f"{field.long_name}: "), name
    assert cols["true_distance_m"].description.endswith("(nominal)")
    np.testing.assert_array_equal(cols["last_seen_timestamp_us"].data, [1500, 4000])
    np.testing.assert_array_equal(cols["tag_seen_count"].data, [1, 0])
    assert cols["tag_seen_count"].data.dtype == np.int64
    np.testing.assert_array_equal(cols["peak_rssi_quantized_dbm"].data, [-55.5, np.nan])
    np.testing.assert_array_equal(cols["true_y_m"].data, [2.0, 5.0])
    assert np.isnan(cols["true_incident_power_dbm"].data).all()  # not given: not known
    with pytest.raises(ValueError, match="outside the read schema"):
        _columns(notes={"rssi": "x"})


# ----------------------------------------------------------------------------- every dataset with reads


def _cli(argv):
    assert main(argv) == 0, argv


@pytest.fixture(scope="module")
def datasets(tmp_path_factory):
    """Tiny runs of every dataset that holds reads: name → path."""
    out = tmp_path_factory.mktemp("reads")
    runs = {
        "link": ["run", "link", "--set", "geometry.distances_m=[1.0, 12.0]", "--set", "rounds_per_point=2"],
        "inventory": ["run", "inventory", "--set", "populations=[3]", "--set", "runs=1",
                      "--set", "capture.enabled=false", "--set", "capture_sweep.enabled=false"],
        "phase-tracking": ["run", "phase-tracking", "--set", "trajectory.duration_s=0.1",
                           "--set", "schedule.workers=1"],
        "scene": ["run", str(ONE_TAG_SCENE), "--set", "run.max_rounds=3"],
        "st-localization": ["run", "st-localization", "--set", "mode=sample-level", "--set", "landmark_grid=[3, 2]",
                            "--set", "rounds=2", "--set", "trajectory_2_speeds_mps=[0.5]",
                            "--set", "sample_level.duration_s=0.3", "--set", "workers=1"],
    }
    paths = {}
    for name, argv in runs.items():
        paths[name] = out / f"{name}.h5"
        _cli([*argv, "--no-plot", "-q", "-o", str(paths[name])])
    x, _ = synth_capture(query_ack_items(_rn16(2), 256e3 * 1.01), fs_hz=4e6, trcal_s=64 / 3 / 256e3,
                         tari_s=12.5e-6)
    cap = out / "cap.cf32"
    x.astype(np.complex64).tofile(cap)
    paths["decode"] = out / "decode.h5"
    _cli(["decode", str(cap), "--fs", "4e6", "-o", str(paths["decode"])])
    return paths


@pytest.mark.parametrize("name", ["link", "inventory", "phase-tracking", "scene", "st-localization", "decode"])
def test_every_reads_table_holds_the_schema_with_units(datasets, name):
    with h5py.File(datasets[name], "r") as f:
        g = f["reads"]
        for col, field in READ_SCHEMA.items():
            assert col in g, (name, col)
            assert g[col].attrs["units"] == field.units, (name, col)
            assert g[col].attrs["long_name"] == field.long_name, (name, col)
        for old in ("antenna", "rssi_dbm", "phase_rad", "doppler_hz", "epc_hex", "t_us"):
            assert old not in g, (name, old)  # one name per quantity
    t = read_table(datasets[name], "reads")
    seen = t["tag_seen_count"] >= 1
    assert seen.any(), name
    assert all(len(e) == 24 and int(e, 16) >= 0 for e in t["epc"][seen])  # 96-bit EPC as hex
    np.testing.assert_array_equal(t["last_seen_timestamp_us"], t["first_seen_timestamp_us"])
    np.testing.assert_array_equal(t["peak_rssi_quantized_dbm"][seen] * 2, np.round(t["peak_rssi_dbm"][seen] * 2))
    if name != "decode":  # a simulation knows the truth; a capture does not
        assert np.isfinite(t["true_distance_m"][seen]).all() and np.isfinite(t["true_x_m"][seen]).all()
        assert (t["antenna_port"][seen] >= 1).all() and (t["channel_index"][seen] >= 1).all()
    else:
        assert np.isnan(t["true_distance_m"]).all() and (t["antenna_port"] == 0).all()


def test_link_truth_is_the_geometry(datasets):
    t = read_table(datasets["link"], "reads")
    # the scenario's own columns stay beside the schema's (the round's context, the configured report)
    assert {"time_s", "point", "round", "success", "failure_reason", "snr_db", "reported", "rssi_reported_dbm",
            "phase_reported_rad", "phase_code"} <= set(t)
    np.testing.assert_array_equal(t["tag_seen_count"], t["reported"])
    np.testing.assert_array_equal(np.unique(t["true_distance_m"]), [1.0, 12.0])
    # the tag faces the reader along +x at the reader's height (geometry defaults)
    np.testing.assert_allclose(np.hypot(t["true_x_m"], t["true_y_m"]), t["true_distance_m"], rtol=1e-12)
    assert (t["tag_seen_count"][t["true_distance_m"] == 12.0] == 0).all()  # out of range: nothing reported


def test_inventory_truth_is_the_tags_table(datasets):
    reads, tags = read_table(datasets["inventory"], "reads"), read_table(datasets["inventory"], "tags")
    np.testing.assert_array_equal(reads["true_x_m"], tags["x_m"][reads["tag"]])  # one population, one run
    np.testing.assert_array_equal(reads["true_z_m"], tags["z_m"][reads["tag"]])
    assert np.all((reads["true_distance_m"] > 0) & (reads["true_distance_m"] < 20))


def test_st_localization_truth_is_the_landmark_grid(datasets):
    t = read_table(datasets["st-localization"], "reads")
    with h5py.File(datasets["st-localization"], "r") as f:
        landmarks, antennas = f.attrs["landmarks_xy_m"], f.attrs["antennas_xyz_m"]
    np.testing.assert_array_equal(np.column_stack([t["true_x_m"], t["true_y_m"]]), landmarks[t["tag"]])
    assert (t["true_z_m"] == 0).all()  # landmarks lie on the floor
    tag_m = np.column_stack([t["true_x_m"], t["true_y_m"], t["true_z_m"]])
    np.testing.assert_allclose(t["true_distance_m"], np.linalg.norm(antennas[t["antenna_port"] - 1] - tag_m, axis=1),
                               rtol=1e-12)


# ----------------------------------------------------------------------------- export


def _export(capsys, *argv):
    code = main(["export", *map(str, argv)])
    out = capsys.readouterr()
    return code, out.out, out.err


def _reported(path):
    t = read_table(path, "reads")
    keep = t["tag_seen_count"] >= 1
    return {k: t[k][keep] for k in READ_SCHEMA}


def _assert_equal_table(parsed: dict, table: dict):
    assert list(parsed) == list(table)
    for k, v in table.items():
        got = np.asarray(parsed[k], dtype=v.dtype if v.dtype.kind != "U" else str)
        if v.dtype.kind == "f":
            np.testing.assert_array_equal(got, v, err_msg=k)  # NaN equals NaN here; bits otherwise
        else:
            assert got.tolist() == v.tolist(), k


def _csv_value(text: str, dtype: np.dtype):
    if dtype.kind == "f":
        return math.nan if text == "" else float(text)
    return int(text) if dtype.kind in "iu" else text


@pytest.mark.parametrize("name", ["link", "phase-tracking", "decode"])
def test_csv_export_reads_back_to_the_table(datasets, name, tmp_path, capsys):
    out = tmp_path / "sub" / "reads.csv"
    code, stdout, err = _export(capsys, datasets[name], "--table", "reads", "--format", "csv", "-o", out)
    assert code == 0 and stdout == "" and err == ""
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    table = _reported(datasets[name])
    assert len(rows) == len(table["epc"]) > 0
    parsed = {k: [_csv_value(r[k], table[k].dtype) for r in rows] for k in rows[0]}
    _assert_equal_table(parsed, table)


@pytest.mark.parametrize("name", ["link", "inventory", "scene"])
def test_jsonl_export_reads_back_to_the_table(datasets, name, capsys):
    code, stdout, _ = _export(capsys, datasets[name], "--format", "jsonl")
    assert code == 0
    lines = [json.loads(line) for line in stdout.splitlines()]
    table = _reported(datasets[name])
    assert len(lines) == len(table["epc"]) > 0
    assert list(lines[0]) == list(READ_SCHEMA)
    parsed = {k: [math.nan if d[k] is None else d[k] for d in lines] for k in lines[0]}
    _assert_equal_table(parsed, table)
    assert isinstance(lines[0]["epc"], str) and isinstance(lines[0]["antenna_port"], int)


def test_other_tables_export_whole(datasets, capsys):
    code, stdout, _ = _export(capsys, datasets["inventory"], "--table", "slots")
    rows = list(csv.DictReader(io.StringIO(stdout)))
    slots = read_table(datasets["inventory"], "slots")
    assert code == 0 and len(rows) == len(slots["time_s"]) and set(rows[0]) == set(slots)
    assert [float(r["time_s"]) for r in rows] == slots["time_s"].tolist()


@pytest.mark.parametrize("argv, message", [
    (["{missing}"], "no such file"),
    (["{folder}"], "is a directory"),
    (["{text}"], "is not an HDF5 file"),
    (["{link}", "--table", "slots"], "--table 'slots'"),
    (["{link}", "--table", "provenance"], "--table 'provenance'"),
    (["{link}", "-o", "{folder}"], "is a folder"),
    (["{link}", "--format", "xml"], "invalid choice"),
])
def test_bad_inputs_are_one_line_exit_2(datasets, tmp_path, capsys, argv, message):
    text = tmp_path / "x.h5"
    text.write_text("not hdf5")
    subs = {"missing": tmp_path / "none.h5", "folder": tmp_path, "text": text, "link": datasets["link"]}
    argv = [a.format(**subs) for a in argv]
    try:
        code = main(["export", *argv])
    except SystemExit as usage:  # argparse's own one-line usage error
        code = usage.code
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and message in err and "Traceback" not in err

"""HDF5 datasets: columns with units, grids with dimension scales, provenance, atomicity."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest

from rfsim.core.dataset import (Dataset, column, make_provenance, read_dataset, read_provenance,
                           read_table, utc_now, write_dataset)


def _example() -> Dataset:
    ds = Dataset(title="example", scenario="unit-test")
    ds.add_table("reads", {
        "time_s": column(np.linspace(0, 1, 7), "s", "time of the read"),
        "success": column(np.array([1, 0, 1, 1, 0, 0, 1], bool), "1", "EPC decoded with CRC ok"),
        "epc": column(["3008", "", "E280", "3008", "", "", "E280"], "", "EPC as hex"),
        "antenna": column(np.arange(7, dtype=np.int16) % 2 + 1, "1", "antenna port (1-based)"),
    })
    ds.add_grid("null_map",
                {"x_m": column(np.linspace(-1, 1, 5), "m", "x"),
                 "y_m": column(np.linspace(0, 2, 3), "m", "y")},
                {"diff_v": column(np.arange(15.0).reshape(5, 3), "V", "|A1-A2|"),
                 "y_weight": column(np.ones(3), "1", "weights along y", dims=("y_m",))})
    return ds


def _provenance(seed=7):
    return make_provenance(config_toml="[a]\nb = 1\n", seed=seed, scenario="unit-test",
                           start_time_utc=utc_now())


def test_round_trip_units_and_provenance(tmp_path):
    path = write_dataset(tmp_path / "out.h5", _example(), _provenance())
    back = read_dataset(path)
    reads = back.tables["reads"]
    np.testing.assert_array_equal(reads["success"].data, [1, 0, 1, 1, 0, 0, 1])
    assert reads["success"].data.dtype == bool
    assert list(reads["epc"].data) == ["3008", "", "E280", "3008", "", "", "E280"]
    assert reads["time_s"].units == "s" and reads["antenna"].description.startswith("antenna")
    coords, variables = back.grids["null_map"]
    assert variables["diff_v"].dims == ("x_m", "y_m") and variables["y_weight"].dims == ("y_m",)
    np.testing.assert_array_equal(variables["diff_v"].data, np.arange(15.0).reshape(5, 3))
    with h5py.File(path) as f:
        for group in ("reads", "null_map"):
            for name, d in f[group].items():
                assert "units" in d.attrs and "description" in d.attrs, (group, name)
    prov = read_provenance(path)
    for key in ("config_toml", "seed", "rfsim_version", "git_revision", "start_time_utc",
                "end_time_utc", "platform", "python"):
        assert key in prov, key
    assert prov["seed"] == 7 and prov["config_toml"] == "[a]\nb = 1\n"
    assert read_table(path, "reads").keys() == {"time_s", "success", "epc", "antenna"}


def test_opens_in_xarray_with_h5netcdf(tmp_path):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    path = write_dataset(tmp_path / "out.h5", _example(), _provenance())
    with xr.open_dataset(path, engine="h5netcdf", group="reads") as reads:
        assert reads.sizes["row"] == 7
        assert reads["time_s"].attrs["units"] == "s"
        assert list(reads["epc"].values[:3]) == ["3008", "", "E280"]
    with xr.open_dataset(path, engine="h5netcdf", group="null_map") as grid:
        assert grid["diff_v"].dims == ("x_m", "y_m")
        np.testing.assert_allclose(grid["x_m"].values, np.linspace(-1, 1, 5))
    with xr.open_dataset(path, engine="h5netcdf", group="provenance") as prov:
        assert int(prov.attrs["seed"]) == 7


def test_rejects_misaligned_columns_and_grids():
    ds = Dataset()
    with pytest.raises(ValueError, match="differ in length"):
        ds.add_table("t", {"a": column(np.zeros(3), "1", "a"), "b": column(np.zeros(4), "1", "b")})
    with pytest.raises(ValueError, match="expected"):
        ds.add_grid("g", {"x": column(np.zeros(3), "m", "x")}, {"v": column(np.zeros(4), "1", "v")})
    ds.add_table("t", {"a": column(np.zeros(3), "1", "a")})
    with pytest.raises(ValueError, match="already used"):
        ds.add_table("t", {"a": column(np.zeros(3), "1", "a")})


_KILLED_WRITER = textwrap.dedent("""
    import sys, time
    import numpy as np
    import rfsim.core.dataset as d

    original = d._write_table
    def slow_write_table(f, name, cols):
        original(f, name, cols)
        f.flush()
        print("STARTED", flush=True)
        time.sleep(60)
    d._write_table = slow_write_table

    ds = d.Dataset()
    ds.add_table("big", {"x": d.column(np.arange(100000.0), "1", "x")})
    d.write_dataset(sys.argv[1], ds, d.make_provenance(config_toml="", seed=1, scenario="kill",
                    start_time_utc=d.utc_now()))
""")


def test_killed_writer_leaves_no_file_under_the_final_name(tmp_path):
    target = tmp_path / "run.h5"
    # A complete earlier file under the final name must survive a killed overwrite.
    write_dataset(target, _example(), _provenance(seed=3))
    proc = subprocess.Popen([sys.executable, "-c", _KILLED_WRITER, str(target)],
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "STARTED"
        partial = [p for p in tmp_path.iterdir() if p.name.endswith(".partial")]
        assert len(partial) == 1 and partial[0].stat().st_size > 0
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=30)
        proc.stdout.close()
    assert proc.returncode == -signal.SIGKILL
    assert read_provenance(target)["seed"] == 3  # the old, complete file is untouched
    assert [p.name for p in tmp_path.iterdir() if not p.name.startswith(".")] == ["run.h5"]


def test_non_finite_root_attributes_need_a_stated_meaning(tmp_path):
    ds = Dataset(title="t")
    ds.add_table("t", {"x": column(np.arange(3), "1", "an index of the row")}, description="a small table")
    ds.attrs["spacing_m"] = float("inf")
    with pytest.raises(ValueError, match="spacing_m"):
        write_dataset(tmp_path / "a.h5", ds, {"seed": 1})
    assert not (tmp_path / "a.h5").exists()
    ds.attrs["spacing_m_meaning"] = "inf: no nulls along this track"
    write_dataset(tmp_path / "a.h5", ds, {"seed": 1})
    back = read_dataset(tmp_path / "a.h5")
    assert back.attrs["spacing_m"] == float("inf") and back.descriptions == {"t": "a small table"}

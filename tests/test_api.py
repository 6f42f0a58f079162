"""The Python API (issue 31 item 3): ``rfsim.run`` gives the dataset of ``rfsim run`` bit for
bit, its tables come out as pandas frames with their units, every group as an xarray DataTree,
figures as PNG images; config overrides are checked like ``--set``; errors are one line;
the names are exported from ``rfsim`` without making ``import rfsim`` heavy."""

from __future__ import annotations

import base64
import json
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

import rfsim
from rfsim.cli import main
from rfsim.core.errors import ConfigError, UserError

#: A small ``link`` run (2 distances × 2 rounds), as ``--set`` texts and as ``rfsim.run`` overrides.
SMALL_SET = ["geometry.distances_m=[1.0, 3.0]", "rounds_per_point=2"]
SMALL = {"geometry.distances_m": [1.0, 3.0], "rounds_per_point": 2}
#: Provenance attributes that name a time, a host or a version (they differ between two runs).
VOLATILE = ("start_time_utc", "end_time_utc", "platform", "python", "git_revision", "command_line", "history")


def _members(path) -> dict:
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            attrs = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in obj.attrs.items()
                     if k not in ("DIMENSION_LIST", "REFERENCE_LIST") and k not in VOLATILE}
            value = obj[()] if isinstance(obj, h5py.Dataset) else None
            out[name] = (value, str(obj.dtype) if value is not None else "", attrs)
        f.visititems(visit)
        out["/"] = (None, "", {k: v for k, v in f.attrs.items() if k not in VOLATILE})
    return out


def _assert_same_file(a, b) -> None:
    ma, mb = _members(a), _members(b)
    assert sorted(ma) == sorted(mb)
    for name in ma:
        (va, da, aa), (vb, db, ab) = ma[name], mb[name]
        assert da == db, name
        if va is not None:
            assert np.asarray(va).tobytes() == np.asarray(vb).tobytes() if np.asarray(va).dtype.kind != "O" \
                else list(va) == list(vb), name
        assert sorted(aa) == sorted(ab), name
        for k in aa:
            assert np.array_equal(np.asarray(aa[k]), np.asarray(ab[k])), (name, k)


@pytest.fixture(scope="module")
def small_run():
    return rfsim.run("link", seed=1, progress=False, **SMALL)


def test_run_equals_cli_dataset_bit_for_bit(small_run, tmp_path):
    cli = tmp_path / "cli.h5"
    argv = ["run", "link", "--seed", "1", "--no-plot", "-q", "-o", str(cli)]
    for s in SMALL_SET:
        argv += ["--set", s]
    assert main(argv) == 0
    api = small_run.save(tmp_path / "api.h5")
    _assert_same_file(cli, api)
    with h5py.File(api, "r") as f:
        assert int(f["provenance"].attrs["seed"]) == 1
        assert f.attrs["scenario"] == "link"
        assert len(f["reads"]["success"]) == 4  # 2 distances x 2 rounds


def test_another_seed_gives_another_dataset(small_run):
    other = rfsim.run("link", seed=2, progress=False, **SMALL)
    a, b = small_run.dataset.tables["reads"], other.dataset.tables["reads"]
    assert not np.array_equal(a["frequency_hz"].data, b["frequency_hz"].data) or \
        not np.array_equal(a["phase_angle_rad"].data, b["phase_angle_rad"].data, equal_nan=True)


def test_default_seed_is_the_command_lines(small_run):
    assert small_run.seed == 1
    again = rfsim.run("link", progress=False, **SMALL)
    assert np.array_equal(again.dataset.tables["reads"]["phase_angle_rad"].data,
                          small_run.dataset.tables["reads"]["phase_angle_rad"].data, equal_nan=True)


def test_table_is_a_dataframe_with_units_from_the_file(small_run, tmp_path):
    pd = pytest.importorskip("pandas")
    frame = small_run.table("reads")
    assert isinstance(frame, pd.DataFrame)
    path = small_run.save(tmp_path / "x.h5")
    with h5py.File(path, "r") as f:
        g = f["reads"]
        file_units = {k: g[k].attrs["units"] for k in g if k != "row"}
        assert frame.attrs["description"] == g.attrs["description"]
        for k in file_units:
            stored = g[k].asstr()[()] if h5py.check_string_dtype(g[k].dtype) else g[k][()]
            got = frame[k].to_numpy()
            if frame[k].dtype == bool:
                assert g[k].attrs["rfsim_dtype"] == "bool"
                got = got.astype(np.uint8)
            assert np.array_equal(got, stored, equal_nan=got.dtype.kind == "f"), k
    assert frame.attrs["units"] == file_units
    assert frame.attrs["units"]["peak_rssi_dbm"] == "dBm" and frame.attrs["units"]["frequency_hz"] == "Hz"
    assert sorted(frame.columns) == sorted(file_units)  # HDF5 lists members alphabetically


def test_to_xarray_has_every_group_with_units(small_run, tmp_path):
    xr = pytest.importorskip("xarray")
    tree = small_run.to_xarray()
    assert isinstance(tree, xr.DataTree)
    assert set(tree.children) == {"reads", "provenance"}
    assert tree.attrs["scenario"] == "link"
    assert tree["provenance"].attrs["seed"] == 1
    reads = tree["reads"].to_dataset()
    assert reads["peak_rssi_dbm"].attrs["units"] == "dBm" and reads["peak_rssi_dbm"].dims == ("row",)
    assert reads["peak_rssi_dbm"].attrs["long_name"] == "peak RSSI"  # short; the sentence is the description
    assert reads["epc"].attrs["units"] == "" and reads["epc"].attrs["long_name"] == "EPC"
    # the same values as the file opened by xarray itself (h5netcdf, no rfsim code)
    path = small_run.save(tmp_path / "x.h5")
    with xr.open_dataset(path, engine="h5netcdf", group="reads") as on_disk:
        for k in ("peak_rssi_dbm", "phase_angle_rad", "frequency_hz", "time_s"):
            assert np.array_equal(reads[k].values, on_disk[k].values, equal_nan=True), k
            assert reads[k].attrs["long_name"] == on_disk[k].attrs["long_name"]


def test_grid_groups_become_xarray_nodes_with_their_dims():
    xr = pytest.importorskip("xarray")
    from rfsim.core.dataset import Dataset, column
    from rfsim.runs.api import Result

    ds = Dataset(title="t", scenario="link")
    ds.add_grid("field", {"x_m": column([0.0, 1.0, 2.0], "m", "x"), "y_m": column([5.0, 6.0], "m", "y")},
                {"p_dbm": column(np.arange(6.0).reshape(3, 2), "dBm", "power; at the point")},
                description="a grid")
    tree = Result(module=rfsim.runs.api.get_scenario("link"), dataset=ds, seed=3,
                  provenance={"seed": 3}).to_xarray()
    node = tree["field"].to_dataset()
    assert node["p_dbm"].dims == ("x_m", "y_m") and node["p_dbm"].attrs["units"] == "dBm"
    assert node["p_dbm"].attrs["long_name"] == "power"
    assert node["p_dbm"].sel(x_m=2.0, y_m=5.0).item() == 4.0
    assert isinstance(rfsim.runs.api.Result(module=rfsim.runs.api.get_scenario("link"), dataset=ds,
                                            provenance={}).grid("field"), xr.Dataset)


def test_save_writes_an_h5_file_with_provenance(small_run, tmp_path):
    path = small_run.save(tmp_path / "sub" / "r.h5")
    with h5py.File(path, "r") as f:
        prov = f["provenance"].attrs
        assert "rounds_per_point = 2" in prov["config_toml"]
        assert prov["scenario"] == "link"
    with pytest.raises(UserError, match="r.txt"):
        small_run.save(tmp_path / "r.txt")


def test_figures_are_png_images_and_files_only_when_asked(small_run, tmp_path):
    figs = small_run.figures()
    assert len(figs) >= 1 and all(f.png.startswith(b"\x89PNG\r\n\x1a\n") for f in figs)
    assert figs.paths == (None,) * len(figs)
    html = figs._repr_html_()
    assert html.count("<img") == len(figs) and base64.b64encode(figs[0].png).decode() in html
    kept = small_run.figures(tmp_path / "figs")
    assert [p.name for p in kept.paths] == [f"link-{f.name.split('link-', 1)[1]}.png" for f in kept]
    assert all(p.is_file() and p.read_bytes() == f.png for p, f in zip(kept.paths, kept))
    assert small_run.path is None  # nothing saved behind the user's back


def test_override_forms_resolve_to_the_same_config():
    from rfsim.core.config import load_config
    from rfsim.runs.api import resolve_config
    from rfsim.runs.registry import get_scenario

    module = get_scenario("link")
    cli = load_config(module.Config, None, ["reader.ptx_dbm=27", "geometry.distances_m=[1.0]"])
    dotted = resolve_config(module, None, {"reader.ptx_dbm": 27, "geometry.distances_m": [1.0]})
    nested = resolve_config(module, None, {"reader": {"ptx_dbm": 27}, "geometry": {"distances_m": [1.0]}})
    mapping = resolve_config(module, {"reader.ptx_dbm": 27}, {"geometry": {"distances_m": (1.0,)}})
    instance = resolve_config(module, module.Config(), {"reader.ptx_dbm": 27, "geometry.distances_m": [1.0]})
    assert cli == dotted == nested == mapping == instance
    assert nested.reader.fs_hz == module.Config().reader.fs_hz  # a table merges, it does not replace
    assert cli != module.Config()


def test_config_from_a_toml_file(tmp_path):
    from rfsim.runs.api import resolve_config
    from rfsim.runs.registry import get_scenario

    module = get_scenario("link")
    toml = tmp_path / "c.toml"
    toml.write_text("rounds_per_point = 3\n[reader]\nptx_dbm = 20.0\n")
    cfg = resolve_config(module, toml, {"reader.ptx_dbm": 25})
    assert cfg.rounds_per_point == 3 and cfg.reader.ptx_dbm == 25.0


@pytest.mark.parametrize("kwargs, key", [
    ({"reader.ptx_dbmm": 30}, "reader.ptx_dbmm"),
    ({"reader.ptx_dbm": 99}, "reader.ptx_dbm"),
    ({"reader": {"ptx_dbm": "loud"}}, "reader.ptx_dbm"),
    ({"rounds_per_point": 0}, "rounds_per_point"),
])
def test_bad_overrides_are_one_line_config_errors_naming_the_key(kwargs, key):
    with pytest.raises(ConfigError) as err:
        rfsim.run("link", progress=False, **kwargs)
    assert err.value.key == key and "\n" not in str(err.value) and f"'{key}'" in str(err.value)


@pytest.mark.parametrize("call, text", [
    (lambda: rfsim.run("lnk"), "did you mean 'link'"),
    (lambda: rfsim.run("link", seed=-1), "seed -1"),
    (lambda: rfsim.run("link", config=42), "config"),
    (lambda: rfsim.run("link", **{"reader..ptx": 1}), "dotted names"),
])
def test_other_mistakes_are_one_line_user_errors(call, text):
    with pytest.raises(UserError) as err:
        call()
    assert text in str(err.value) and "\n" not in str(err.value)


def test_unknown_table_and_missing_pandas_are_one_line(small_run, monkeypatch):
    with pytest.raises(UserError, match="no table 'read'.*did you mean 'reads'"):
        small_run.table("read")
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas → ImportError
    with pytest.raises(UserError) as err:
        small_run.table("reads")
    assert "rfsim[analysis]" in str(err.value) and "\n" not in str(err.value)
    monkeypatch.setitem(sys.modules, "xarray", None)
    with pytest.raises(UserError, match=r"rfsim\[analysis\]"):
        small_run.to_xarray()


def test_progress_bars_use_the_notebook_widget_when_there_is_one(monkeypatch):
    import rfsim.runs.api as api

    made = []

    class Widget:
        def __init__(self, **kw):
            made.append(kw)

        def update(self, n=1):
            made[-1]["n"] = made[-1].get("n", 0) + n

        def close(self):
            pass

    monkeypatch.setattr(api, "_notebook_tqdm", lambda: Widget)
    rfsim.run("link", seed=1, progress=True, **SMALL)
    assert [(m["desc"], m["total"], m.get("n")) for m in made] == [("rounds", 2, 2)]
    made.clear()
    rfsim.run("link", seed=1, progress=False, **SMALL)
    assert made == []


def test_exports():
    assert {"run", "run_sweep", "Result", "Simulation", "Scene"} <= set(rfsim.__all__)
    assert {"run", "Simulation", "Scene"} <= set(dir(rfsim))
    from rfsim.channels import Scene
    from rfsim.protocols.simulation import Simulation
    from rfsim.runs import api

    assert rfsim.Scene is Scene and rfsim.Simulation is Simulation and rfsim.run is api.run
    with pytest.raises(AttributeError):
        rfsim.no_such_name  # noqa: B018


def test_import_rfsim_stays_light():
    code = "import sys, rfsim, json; print(json.dumps(sorted(sys.modules)))"
    env = dict(os.environ)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    mods = json.loads(out.stdout)
    assert not [m for m in mods if m.startswith(("rfsim.runs", "rfsim.channels", "numba", "h5py", "pandas",
                                                 "xarray", "matplotlib"))]


def test_run_sweep_returns_the_merged_dataset(tmp_path):
    out = tmp_path / "sw.h5"
    spec = {"scenario": "link", "seed": 5, "output": str(out),
            "base": {"geometry": {"distances_m": [2.0]}, "rounds_per_point": 2},
            "axes": [{"kind": "grid", "key": "reader.ptx_dbm", "values": [20.0, 30.0]}]}
    result = rfsim.run_sweep(spec, executor="serial", progress=False)
    assert result.path == out and out.is_file()
    reads = result.dataset.tables["reads"]
    assert len(reads["success"].data) == 4  # 2 points x 1 distance x 2 rounds
    # point 1 is the run of its seed and config
    from rfsim.sweep.spec import point_seed

    one = rfsim.run("link", seed=point_seed(5, 1, 0), progress=False, geometry={"distances_m": [2.0]},
                    rounds_per_point=2, **{"reader.ptx_dbm": 30.0})
    point = reads["sweep_point"].data
    assert list(reads["sweep.reader.ptx_dbm"].data) == [20.0, 20.0, 30.0, 30.0]
    assert np.array_equal(reads["phase_angle_rad"].data[point == 1], one.dataset.tables["reads"]["phase_angle_rad"].data,
                          equal_nan=True)
    with pytest.raises(UserError, match="no link figures"):
        result.figures()
    with pytest.raises(UserError, match="executor 'fast'"):
        rfsim.run_sweep(spec, executor="fast")


def test_sweep_progress_uses_the_notebook_widget(tmp_path, monkeypatch):
    import rfsim.runs.api as api

    made = []

    class Widget:
        def __init__(self, **kw):
            made.append(dict(kw, n=0))

        def update(self, n=1):
            made[-1]["n"] += n

        def close(self):
            made[-1]["closed"] = True

    monkeypatch.setattr(api, "_notebook_tqdm", lambda: Widget)
    spec = {"scenario": "link", "seed": 5, "output": str(tmp_path / "sw.h5"),
            "base": {"geometry": {"distances_m": [2.0]}, "rounds_per_point": 1},
            "axes": [{"kind": "grid", "key": "reader.ptx_dbm", "values": [20.0, 25.0, 30.0]}]}
    rfsim.run_sweep(spec, executor="serial", progress=True)
    sweep_bars = [m for m in made if m["desc"] == "sweep"]
    assert [(m["total"], m["initial"], m["n"], m.get("closed")) for m in sweep_bars] == [(3, 0, 3, True)]


def test_the_sweep_package_is_callable_like_run_sweep(tmp_path):
    """``rfsim.sweep(spec, executor=...)`` (the issue's spelling) is the same call as
    :func:`rfsim.run_sweep`, and ``rfsim.sweep.<name>`` stays the package's API."""
    spec = {"scenario": "link", "seed": 5, "output": str(tmp_path / "a.h5"),
            "base": {"geometry": {"distances_m": [2.0]}, "rounds_per_point": 1},
            "axes": [{"kind": "grid", "key": "reader.ptx_dbm", "values": [20.0, 30.0]}]}
    a = rfsim.sweep(spec, executor="serial", progress=False)
    b = rfsim.run_sweep({**spec, "output": str(tmp_path / "b.h5")}, executor="serial", progress=False)
    for name in ("phase_angle_rad", "peak_rssi_dbm", "sweep_point"):
        assert np.array_equal(a.dataset.tables["reads"][name].data, b.dataset.tables["reads"][name].data,
                              equal_nan=True)
    assert rfsim.sweep.load_spec is not None and "sweep" in rfsim.__all__

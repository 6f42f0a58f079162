"""The root of ``Result.to_xarray()`` carries the root attributes of the saved HDF5 file."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

import rfsim

#: A small ``link`` run: 1 distance x 2 rounds.
SMALL = {"geometry.distances_m": [1.0], "rounds_per_point": 2}


def _file_root_attrs(path) -> dict:
    with h5py.File(path, "r") as f:
        return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}


def _same_value(a, b) -> bool:
    return type(a) is type(b) and np.array_equal(np.asarray(a), np.asarray(b), equal_nan=np.asarray(a).dtype.kind == "f")


def _without_time(history: str) -> list[str]:
    """The history lines with their leading ISO time stamp removed (the command lines)."""
    return [line.split(" ", 1)[1] for line in history.splitlines()]


def test_run_to_xarray_root_has_the_saved_files_root_attrs(tmp_path):
    pytest.importorskip("xarray")
    result = rfsim.run("link", seed=1, progress=False, **SMALL)
    tree = result.to_xarray()
    on_disk = _file_root_attrs(result.save(tmp_path / "run.h5"))
    got = dict(tree.attrs)
    for key in ("Conventions", "source", "history", "rfsim_version", "title", "scenario"):
        assert key in on_disk, key  # the writer's own root attributes
    assert sorted(got) == sorted(on_disk)
    assert got["Conventions"] == "rfsim-dataset-1"
    assert got["source"] == f"rfsim {rfsim.__version__}, scenario link"
    # the history line is stamped when it is made: compare the command lines, not the times
    assert _without_time(got["history"]) == _without_time(on_disk["history"])
    assert len(got["history"].splitlines()) == 1
    for key in on_disk:
        if key != "history":
            assert _same_value(got[key], on_disk[key]), (key, got[key], on_disk[key])


def test_sweep_to_xarray_root_is_the_merged_files(tmp_path):
    pytest.importorskip("xarray")
    out = tmp_path / "sw.h5"
    spec = {"scenario": "link", "seed": 5, "output": str(out),
            "base": {"geometry": {"distances_m": [2.0]}, "rounds_per_point": 1},
            "axes": [{"kind": "grid", "key": "reader.ptx_dbm", "values": [20.0, 30.0]}]}
    result = rfsim.run_sweep(spec, executor="serial", progress=False)
    got, on_disk = dict(result.to_xarray().attrs), _file_root_attrs(out)
    assert "Conventions" in on_disk and "source" in on_disk and "history" in on_disk
    assert sorted(got) == sorted(on_disk)
    for key in on_disk:
        assert _same_value(got[key], on_disk[key]), (key, got[key], on_disk[key])

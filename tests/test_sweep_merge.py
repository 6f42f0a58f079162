"""Merging point datasets: grids stacked along (point, repetition) when their shapes agree,
kept per run otherwise; swept-key columns with units; name clashes refused."""

from __future__ import annotations

import dataclasses
import sys
import types

import numpy as np
import pytest

from rfsim.core.config import param
from rfsim.core.dataset import Dataset, column, read_dataset
from rfsim.core.rng import trial_rng
from rfsim.sweep import SerialExecutor, parse_spec, run_sweep
from rfsim.sweep import runner as sweep_runner


@dataclasses.dataclass(frozen=True)
class _Inner:
    gain_db: float = param(0.0, lo=-10.0, hi=10.0, unit="dB", doc="a gain")


@dataclasses.dataclass(frozen=True)
class _Config:
    n: int = param(3, lo=1, hi=10, doc="grid length")
    inner: _Inner = param(_Inner(), doc="nested")
    clash: bool = param(False, doc="add a column named 'sweep_point'")


def _run(config: _Config, *, seed: int) -> Dataset:
    rng = trial_rng(seed, 0)  # a stand-in scenario: its values come from the seed
    ds = Dataset(title="toy")
    x = np.arange(config.n, dtype=float)
    ds.add_grid("field", {"x_m": column(x, "m", "position")},
                {"p_w": column(rng.random(config.n) * 10 ** (config.inner.gain_db / 10), "W", "power")})
    cols = {"v": column(rng.random(2), "V", "voltage")}
    if config.clash:
        cols["sweep_point"] = column([1, 2], "1", "clashes with the merge column")
    ds.add_table("reads", cols)
    ds.attrs["first"] = float(cols["v"].data[0])
    return ds


@pytest.fixture
def toy(monkeypatch):
    module = types.ModuleType("rfsim_sweep_toy_scenario")
    module.NAME, module.DESCRIPTION, module.Config, module.run = "toy", "toy", _Config, _run
    module.plot = lambda path, out_dir: []
    monkeypatch.setitem(sys.modules, module.__name__, module)
    monkeypatch.setattr(sweep_runner, "get_scenario", lambda name: module)
    return module


def spec(tmp_path, *axes, reps=2):
    return parse_spec({"scenario": "toy", "seed": 3, "repetitions": reps,
                       "output": str(tmp_path / "toy.h5"), "axes": list(axes)})


def test_grids_of_equal_shape_are_stacked(toy, tmp_path):
    s = spec(tmp_path, {"kind": "grid", "key": "inner.gain_db", "values": [0.0, 3.0, 6.0]})
    out = run_sweep(s, SerialExecutor()).output
    ds = read_dataset(out)
    coords, variables = ds.grids["field"]
    assert list(coords["sweep_point"].data) == [0, 1, 2] and list(coords["sweep_repetition"].data) == [0, 1]
    p = variables["p_w"]
    assert p.data.shape == (3, 2, 3) and p.dims == ("sweep_point", "sweep_repetition", "x_m")
    gain = variables["sweep.inner.gain_db"]
    assert list(gain.data) == [0.0, 3.0, 6.0] and gain.units == "dB" and gain.dims == ("sweep_point",)
    # each stacked slice is exactly the run's own grid (independent re-run of point 2, rep 1)
    from rfsim.sweep import point_seed
    alone = _run(_Config(inner=_Inner(6.0)), seed=point_seed(3, 2, 1))
    assert np.array_equal(p.data[2, 1], alone.grids["field"][1]["p_w"].data)
    reads = ds.tables["reads"]
    assert list(reads["sweep_point"].data) == [0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2]
    assert list(reads["sweep_repetition"].data) == [0, 0, 1, 1] * 3
    assert list(reads["sweep.inner.gain_db"].data) == [0.0] * 4 + [3.0] * 4 + [6.0] * 4
    assert reads["sweep.inner.gain_db"].units == "dB" and reads["v"].units == "V"
    assert list(ds.tables["sweep_runs"]["inner.gain_db"].data) == [0.0] * 2 + [3.0] * 2 + [6.0] * 2
    runs = ds.tables["sweep_runs"]
    assert np.array_equal(runs["first"].data, reads["v"].data[::2])


def test_grids_of_different_shape_are_kept_per_run(toy, tmp_path):
    s = spec(tmp_path, {"kind": "grid", "key": "n", "values": [2, 4]}, reps=1)
    ds = read_dataset(run_sweep(s, SerialExecutor()).output)
    assert "field" not in ds.grids
    assert ds.grids["field__point-000000-rep-00"][0]["x_m"].data.shape == (2,)
    assert ds.grids["field__point-000001-rep-00"][0]["x_m"].data.shape == (4,)


def test_a_column_named_like_a_merge_column_is_refused(toy, tmp_path):
    s = spec(tmp_path, {"kind": "grid", "key": "clash", "values": [True]}, reps=1)
    with pytest.raises(ValueError, match="already has a column 'sweep_point'"):
        run_sweep(s, SerialExecutor())
    assert not (tmp_path / "toy.h5").exists()


def test_a_swept_sub_table_is_stored_as_text(toy, tmp_path):
    s = spec(tmp_path, {"kind": "grid", "key": "inner", "values": [{"gain_db": 1.0}, {"gain_db": 2.0}]},
             reps=1)
    ds = read_dataset(run_sweep(s, SerialExecutor()).output)
    # text values are in sweep_runs and on every row of the tables (variable-length UTF-8)
    assert list(ds.tables["sweep_runs"]["inner"].data) == ["{'gain_db': 1.0}", "{'gain_db': 2.0}"]
    assert list(ds.tables["reads"]["sweep.inner"].data) == ["{'gain_db': 1.0}"] * 2 + ["{'gain_db': 2.0}"] * 2
    assert ds.grids["field"][1]["p_w"].data.shape == (2, 1, 3)

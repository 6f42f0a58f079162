"""Sweeps without friction: every swept key (text too) on every row; ``sweep_point`` /
``sweep_repetition`` as the one name of the run index; a relative output beside the spec;
``--output``; ``rfsim sweep extract`` giving a file that ``rfsim info`` / ``rfsim plot``
accept; the SLURM options partition, account, time and memory."""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.dataset import read_dataset, read_provenance, read_table
from rfsim.sweep import parse_spec, point_seed
from test_sweep_errors import exit_code, one_line
from test_sweep_merge import _Config, _Inner, _run, toy  # noqa: F401  (toy is a fixture)
from test_sweep_run import write_spec

LINK_SPEC = """\
scenario = "link"
seed = 1
output = "results/link2.h5"

[base]
rounds_per_point = 1

[base.geometry]
distances_m = [1.0, 2.0]

[[axes]]
kind = "zip"
keys = ["reader.link_profile", "reader.fs_hz"]
values = [["fm0-40k", "miller4-320k"], [2e6, 4e6]]
"""
PROFILES = ["fm0-40k", "miller4-320k"]


@pytest.fixture(scope="module")
def link_sweep(tmp_path_factory) -> tuple[Path, Path]:
    """A 2-point link sweep (link profile swept as text), run from another folder."""
    root = tmp_path_factory.mktemp("link")
    (root / "specs").mkdir()
    (root / "elsewhere").mkdir()
    spec = root / "specs" / "link2.toml"
    spec.write_text(LINK_SPEC)
    cwd = os.getcwd()
    os.chdir(root / "elsewhere")
    try:
        assert main(["sweep", "run", "../specs/link2.toml", "--serial", "-q"]) == 0
    finally:
        os.chdir(cwd)
    return root, root / "specs" / "results" / "link2.h5"


def test_relative_output_lands_beside_the_spec(link_sweep):
    root, merged = link_sweep
    assert merged.is_file()
    assert not (root / "elsewhere" / "results").exists()


def test_a_string_swept_key_is_a_column_of_every_row(link_sweep):
    _, merged = link_sweep
    reads = read_table(merged, "reads")
    assert len(reads["sweep_point"]) == 4  # 2 points x 2 distances x 1 round
    assert list(reads["sweep.reader.link_profile"]) == [PROFILES[p] for p in reads["sweep_point"]]
    assert list(reads["sweep.reader.fs_hz"]) == [[2e6, 4e6][p] for p in reads["sweep_point"]]
    with h5py.File(merged, "r") as f:
        kind = h5py.check_string_dtype(f["reads/sweep.reader.link_profile"].dtype)
        assert kind.encoding == "utf-8" and kind.length is None  # variable-length UTF-8
    runs = read_table(merged, "sweep_runs")
    assert list(runs["reader.link_profile"]) == PROFILES


def test_sweep_runs_names_the_point_sweep_point(link_sweep):
    _, merged = link_sweep
    runs = read_table(merged, "sweep_runs")
    assert list(runs["sweep_point"]) == [0, 1] and list(runs["sweep_repetition"]) == [0, 0]
    assert "point" not in runs and "repetition" not in runs
    assert list(runs["seed"]) == [point_seed(1, 0, 0), point_seed(1, 1, 0)]


def test_extract_gives_the_points_rows_and_info_and_plot_accept_it(link_sweep, tmp_path, capsys):
    _, merged = link_sweep
    out = tmp_path / "p1.h5"
    assert main(["sweep", "extract", str(merged), "--point", "1", "-o", str(out)]) == 0
    whole, alone = read_table(merged, "reads"), read_table(out, "reads")
    rows = whole["sweep_point"] == 1
    assert sorted(alone) == sorted(whole) and len(alone["sweep_point"]) == 2
    for name, data in alone.items():
        expected = whole[name][rows]
        if data.dtype.kind == "f":
            assert np.array_equal(data, expected, equal_nan=True), name
        else:
            assert list(data) == list(expected), name
    prov = read_provenance(out)
    assert prov["scenario"] == "link" and prov["seed"] == point_seed(1, 1, 0)
    assert 'link_profile = "miller4-320k"' in prov["config_toml"] and "spec_toml" not in prov
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    assert "sweep point 1, repetition 0" in capsys.readouterr().out
    assert main(["plot", str(out), "--out-dir", str(tmp_path), "-q"]) == 0
    assert list(tmp_path.glob("p1-*.png"))
    # the merged file itself is refused by plot, pointing to extract
    assert exit_code(["plot", str(merged)]) == 2
    one_line(capsys, "rfsim sweep extract")


@pytest.mark.parametrize("argv,fragment", [
    (["--point", "2"], "--point 2: expected an integer in [0, 1]"),
    (["--point", "0", "--repetition", "1"], "--repetition 1: expected an integer in [0, 0]"),
])
def test_extract_out_of_range_is_one_line(link_sweep, tmp_path, capsys, argv, fragment):
    _, merged = link_sweep
    assert exit_code(["sweep", "extract", str(merged), *argv, "-o", str(tmp_path / "x.h5")]) == 2
    one_line(capsys, fragment)
    assert not (tmp_path / "x.h5").exists()


def test_extract_of_a_run_gives_back_its_grid_and_attributes(toy, tmp_path, monkeypatch):
    monkeypatch.setattr("rfsim.sweep.extract.get_scenario", lambda name: toy)
    spec = parse_spec({"scenario": "toy", "seed": 3, "repetitions": 2, "output": str(tmp_path / "toy.h5"),
                       "axes": [{"kind": "grid", "key": "inner.gain_db", "values": [0.0, 3.0]}]})
    from rfsim.sweep import SerialExecutor, run_sweep
    merged = run_sweep(spec, SerialExecutor()).output
    assert main(["sweep", "extract", str(merged), "--point", "1", "--repetition", "1", "-q",
                 "-o", str(tmp_path / "p.h5")]) == 0
    alone = _run(_Config(inner=_Inner(3.0)), seed=point_seed(3, 1, 1))  # an independent run of point 1
    got = read_dataset(tmp_path / "p.h5")
    coords, variables = got.grids["field"]
    assert list(coords) == ["x_m"] and variables["p_w"].dims == ("x_m",)
    assert np.array_equal(variables["p_w"].data, alone.grids["field"][1]["p_w"].data)
    assert got.attrs["first"] == alone.attrs["first"]
    assert "n = 3" in read_provenance(tmp_path / "p.h5")["config_toml"]  # rebuilt from the stored mapping
    assert "gain_db = 3.0" in read_provenance(tmp_path / "p.h5")["config_toml"]
    assert list(got.tables["reads"]["v"].data) == list(alone.tables["reads"]["v"].data)
    # without --repetition: both repetitions, the grid keeps its sweep_repetition dimension
    assert main(["sweep", "extract", str(merged), "--point", "1", "-q", "-o", str(tmp_path / "both.h5")]) == 0
    both = read_dataset(tmp_path / "both.h5")
    assert both.grids["field"][1]["p_w"].dims == ("sweep_repetition", "x_m")
    assert list(both.tables["reads"]["sweep_repetition"].data) == [0, 0, 1, 1]


TOY_SPEC = """\
scenario = "toy"
seed = 3
output = "rel/a.h5"

[[axes]]
kind = "grid"
key = "n"
values = [2, 3]
"""


def test_output_option_wins_over_the_spec(toy, tmp_path, monkeypatch):
    (tmp_path / "specs").mkdir()
    (tmp_path / "specs" / "t.toml").write_text(TOY_SPEC)
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", "run", "specs/t.toml", "--serial", "-q", "--output", "b.h5"]) == 0
    assert (tmp_path / "b.h5").is_file() and not (tmp_path / "specs" / "rel").exists()
    assert main(["sweep", "merge", "specs/t.toml", "-q", "--output", "b.h5"]) == 0
    assert main(["sweep", "run", "specs/t.toml", "--serial", "-q"]) == 0
    assert (tmp_path / "specs" / "rel" / "a.h5").is_file() and not (tmp_path / "rel").exists()


def test_a_spec_mapping_resolves_output_against_the_working_directory():
    spec = parse_spec({"scenario": "toy", "seed": 1, "output": "rel/a.h5"})
    assert spec.output == Path("rel/a.h5")
    assert parse_spec({"scenario": "toy", "seed": 1}, output="x.h5").output == Path("x.h5")


def test_bad_output_option_is_one_line(tmp_path, capsys):
    spec = write_spec(tmp_path, "s")
    assert exit_code(["sweep", "run", str(spec), "--output", "x.csv"]) == 2
    one_line(capsys, "--output 'x.csv': expected a file name ending in .h5 or .hdf5")


def test_sbatch_script_has_partition_account_time_memory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    spec = write_spec(tmp_path, "s")
    assert main(["sweep", "plan", str(spec), "--slurm", "--shards", "2", "--out", "job.sbatch",
                 "--partition", "gpu,short", "--account", "proj-42", "--time", "01:30:00", "--mem", "4G",
                 "--output", "elsewhere.h5"]) == 0
    text = (tmp_path / "job.sbatch").read_text()
    for line in ("#SBATCH --partition=gpu,short", "#SBATCH --account=proj-42", "#SBATCH --time=01:30:00",
                 "#SBATCH --mem=4G"):
        assert line + "\n" in text
    out = tmp_path / "elsewhere.h5"
    assert f"sweep run {spec.resolve()} --output {out} --shard" in text
    assert f"sweep merge {spec.resolve()} --output {out}" in text


def test_slurm_verb_is_plan_slurm_and_plan_needs_slurm(tmp_path, capsys):
    spec = write_spec(tmp_path, "s")
    assert main(["sweep", "slurm", str(spec), "--shards", "2", "--partition", "p1", "--mem", "512M"]) == 0
    text = capsys.readouterr().out
    assert "#SBATCH --array=0-1\n" in text and "#SBATCH --partition=p1\n" in text and "#SBATCH --mem=512M\n" in text
    assert exit_code(["sweep", "plan", str(spec), "--shards", "2"]) == 2
    one_line(capsys, "add --slurm")


@pytest.mark.parametrize("option,value", [
    ("--partition", "gpu short"), ("--account", "a;b"), ("--time", "1h"), ("--mem", "4GB"), ("--mem", "0"),
])
def test_bad_slurm_values_are_one_line(tmp_path, capsys, option, value):
    spec = write_spec(tmp_path, "s")
    assert exit_code(["sweep", "plan", str(spec), "--slurm", "--shards", "2", option, value]) == 2
    one_line(capsys, f"{option} {value!r}")

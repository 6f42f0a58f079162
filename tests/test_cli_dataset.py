"""``rfsim plot DATASET``, ``rfsim info DATASET``, ``-v/--verbose`` and figure names after the
dataset's stem."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from rfsim.cli import main

GEN2 = ["--set", "profiles=['fm0-40k']", "--set", "fs_hz=1e6"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """gen2-waveforms run twice into one folder: the default name and ``-o x.h5``."""
    out = tmp_path_factory.mktemp("runs")
    assert main(["run", "gen2-waveforms", *GEN2, "-q", "--out-dir", str(out)]) == 0
    assert main(["run", "gen2-waveforms", *GEN2, "-q", "--seed", "9", "--out-dir", str(out),
                 "-o", str(out / "x.h5")]) == 0
    return out


def test_figures_are_named_after_the_dataset_stem(run_dir):
    """``-o x.h5`` writes ``x-*.png``; the default run's figures are not overwritten."""
    assert sorted(p.name for p in run_dir.glob("*.png")) == ["gen2-waveforms-exchange.png", "x-exchange.png"]
    assert (run_dir / "gen2-waveforms-exchange.png").read_bytes() != (run_dir / "x-exchange.png").read_bytes()


def test_plot_redraws_the_figures_from_the_file_alone(run_dir, tmp_path, capsys):
    original = (run_dir / "x-exchange.png").read_bytes()
    assert main(["plot", str(run_dir / "x.h5"), "--out-dir", str(tmp_path)]) == 0
    out = capsys.readouterr()
    assert out.out.strip() == f"figure:  {tmp_path / 'x-exchange.png'}"
    assert "rfsim: drawing the gen2-waveforms figures" in out.err
    assert (tmp_path / "x-exchange.png").read_bytes() == original  # same data, same figure
    # default folder: beside the dataset; -q prints nothing
    copy = tmp_path / "copy.h5"
    copy.write_bytes((run_dir / "x.h5").read_bytes())
    assert main(["plot", str(copy), "-q"]) == 0
    assert capsys.readouterr() == ("", "")
    assert (tmp_path / "copy-exchange.png").stat().st_size > 1000


def test_plot_refuses_what_it_cannot_plot(tmp_path, capsys):
    (tmp_path / "not.h5").write_text("plain text")
    with h5py.File(tmp_path / "foreign.h5", "w") as f:
        f["x"] = np.arange(3)
    with h5py.File(tmp_path / "sweep.h5", "w") as f:
        f.attrs["scenario"] = "gen2-waveforms"
        f.create_group("provenance").attrs["spec_toml"] = "scenario = 'gen2-waveforms'"
    cases = {"missing.h5": "no such file", "not.h5": "is not an HDF5 file", ".": "is a directory",
             "foreign.h5": "has no 'scenario' attribute", "sweep.h5": "is a merged sweep"}
    for name, message in cases.items():
        assert main(["plot", str(tmp_path / name)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("rfsim: error: ") and message in err and err.count("\n") == 1


def test_info_lists_groups_columns_units_descriptions_and_provenance(run_dir, capsys):
    assert main(["info", str(run_dir / "x.h5")]) == 0
    text = capsys.readouterr().out
    assert text.startswith(f"{run_dir / 'x.h5'}: gen2-waveforms — EPC Gen2 link profiles")
    assert "provenance: seed 9, rfsim " in text
    for group in ("[profiles] (table, 1 rows): one row per named link profile",
                  "[timing] (table, 1 rows)", "[frames] (table, 4 rows)", "[exchange_fm0-40k] (table, "):
        assert group in text
    line = next(row for row in text.splitlines() if row.strip().startswith("blf_hz"))
    assert line.split()[1:3] == ["float64", "Hz"] and "backscatter link frequency" in line
    assert "attributes:" in text and "rn16 = " in text
    assert "resolved config" not in text
    assert main(["info", str(run_dir / "x.h5"), "-v"]) == 0
    verbose = capsys.readouterr().out
    assert "resolved config (provenance/config_toml):" in verbose and "fs_hz = 1000000.0" in verbose
    assert "provenance attributes:" in verbose and "numpy = " in verbose


def test_info_of_a_grid_names_its_dimensions(tmp_path, capsys):
    from rfsim.core.dataset import Dataset, column, write_dataset

    ds = Dataset(title="grid test", scenario="none")
    ds.add_grid("g", {"a_m": column([1.0, 2.0], "m", "first axis of the grid"),
                      "b_s": column([0.0, 1.0, 2.0], "s", "second axis of the grid")},
                {"v": column(np.zeros((2, 3)), "V", "a value on the grid")}, description="a small grid")
    write_dataset(tmp_path / "g.h5", ds, {"seed": 4})
    assert main(["info", str(tmp_path / "g.h5")]) == 0
    text = capsys.readouterr().out
    assert "[g] (grid a_m[2] x b_s[3]): a small grid" in text
    assert "(a_m, b_s) a value on the grid" in text


def test_run_verbose_prints_the_resolved_config_and_quiet_prints_nothing(tmp_path, capsys):
    assert main(["run", "gen2-waveforms", *GEN2, "--out-dir", str(tmp_path), "--no-plot", "-v"]) == 0
    out = capsys.readouterr()
    assert "rfsim: resolved config:\nprofiles = [\"fm0-40k\"]" in out.err
    assert out.out.startswith("dataset: ")
    assert main(["run", "gen2-waveforms", *GEN2, "--out-dir", str(tmp_path), "--no-plot", "-q"]) == 0
    assert capsys.readouterr() == ("", "")
    with pytest.raises(SystemExit) as exc:  # one or the other
        main(["run", "gen2-waveforms", "-q", "-v"])
    assert exc.value.code == 2 and "not allowed with argument" in capsys.readouterr().err

"""The rfsim command line: help, version, list, run, and one-line errors (exit 2)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

import rfsim
from rfsim.cli import main


def test_help_version_and_list(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"rfsim {rfsim.__version__}"
    assert main([]) == 0
    assert "run" in capsys.readouterr().out
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "gen2-waveforms" in out and "link-profile" in out


def test_config_prints_resolved_toml(capsys):
    assert main(["config", "gen2-waveforms", "--set", "q=3"]) == 0
    out = capsys.readouterr().out
    assert "q = 3" in out
    assert main(["config", "gen2-waveforms", "--keys"]) == 0
    assert "fs_hz = 8000000.0" in capsys.readouterr().out


BAD_RUNS = [
    (["run", "gen2-wavefroms"], "did you mean 'gen2-waveforms'"),
    (["run", "gen2-waveforms", "--set", "fs_hz=-1"], "'fs_hz'"),
    (["run", "gen2-waveforms", "--set", "fs_hz=1e6"], ">= 8 x BLF"),
    (["run", "gen2-waveforms", "--set", "q=16"], "'q'"),
    (["run", "gen2-waveforms", "--set", "qq=1"], "did you mean 'q'"),
    (["run", "gen2-waveforms", "--set", "profiles=['fm0-40']"], "did you mean 'fm0-40k'"),
    (["run", "gen2-waveforms", "--set", "epc_hex=XYZ"], "hex digits"),
    (["run", "gen2-waveforms", "--set", "rn16=70000"], "'rn16'"),
    (["run", "gen2-waveforms", "--set", "session"], "KEY=VALUE"),
    (["run", "gen2-waveforms", "--config", "missing.toml"], "cannot be read"),
    (["run", "gen2-waveforms", "--output", "x.txt"], "must end in .h5"),
]


@pytest.mark.parametrize("argv,fragment", BAD_RUNS)
def test_user_mistakes_exit_2_with_one_line(argv, fragment, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rfsim: error: ")
    assert fragment in err
    assert not list(tmp_path.glob("**/*.h5"))


def test_console_script_end_to_end(tmp_path):
    """The installed entry point runs the scenario and writes a dataset and a figure."""
    exe = [sys.executable, "-m", "rfsim"]
    bad = subprocess.run(exe + ["run", "gen2-waveforms", "--set", "fs_hz=oops"], cwd=tmp_path,
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr and bad.stderr.count("\n") == 1
    ok = subprocess.run(exe + ["run", "gen2-waveforms", "--out-dir", "out", "--set",
                               "profiles=['fm0-40k', 'miller4-320k']", "--seed", "3"],
                        cwd=tmp_path, capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    assert (tmp_path / "out" / "gen2-waveforms.h5").stat().st_size > 0
    assert (tmp_path / "out" / "gen2-waveforms-exchange.png").stat().st_size > 0
    xr = pytest.importorskip("xarray")
    with xr.open_dataset(tmp_path / "out" / "gen2-waveforms.h5", engine="h5netcdf",
                         group="profiles") as prof:
        assert list(prof["profile"].values) == ["fm0-40k", "miller4-320k"]
        assert prof["blf_hz"].attrs["units"] == "Hz"
    with xr.open_dataset(tmp_path / "out" / "gen2-waveforms.h5", engine="h5netcdf",
                         group="provenance") as prov:
        assert int(prov.attrs["seed"]) == 3
        assert "profiles = [\"fm0-40k\", \"miller4-320k\"]" in prov.attrs["config_toml"]


def test_bench_writes_json_and_rejects_unknown_names(tmp_path, capsys):
    import json

    assert main(["bench", "nope"]) == 2
    assert "unknown benchmark 'nope'" in capsys.readouterr().err
    out = tmp_path / "bench.json"
    assert main(["bench", "linecode", "--quick", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    result = doc["linecode"]
    assert doc["machine"]["logical_cores"] >= 1 and len(doc["machine"]["load_average_at_start"]) == 3
    assert result["numba_bit_errors"] == 0 and result["numba_bits_per_s"] > 0
    assert result["peak_rss_mb"] > 0


def test_bench_repeat_reports_the_median_min_and_max_of_its_runs(tmp_path, capsys, monkeypatch):
    """``rfsim bench --repeat 3``: every figure the median of the 3 runs (values chosen here, not
    by rfsim), its min and max, the runs in order; a text figure that differs is kept per run."""
    import json
    import sys
    import types

    from rfsim.cli import bench

    figures = iter([{"rate": 3.0, "count": 5, "label": "a", "ok": True, "odd": "x"},
                    {"rate": 1.0, "count": 9, "label": "a", "ok": True, "odd": "y"},
                    {"rate": 8.0, "count": 6, "label": "a", "ok": True, "odd": "z"}])
    import gc

    from rfsim.core.procs import RUN_GC_THRESHOLD

    seen = []
    fake = types.ModuleType("fake_bench_module")
    fake.fake_bench = lambda: seen.append(gc.get_threshold()[0]) or next(figures)
    monkeypatch.setitem(sys.modules, "fake_bench_module", fake)
    monkeypatch.setitem(bench.BENCHMARKS, "fake", ("fake_bench_module", "fake_bench", {}))
    out = tmp_path / "bench.json"
    assert main(["bench", "fake", "--repeat", "3", "--json", str(out)]) == 0
    result = json.loads(out.read_text())["fake"]
    assert (result["rate"], result["min"]["rate"], result["max"]["rate"]) == (3.0, 1.0, 8.0)  # mean would be 4
    assert (result["count"], result["min"]["count"], result["max"]["count"]) == (6, 5, 9)
    assert result["label"] == "a" and result["ok"] is True and result["odd"] == ["x", "y", "z"]
    assert result["repeat"] == 3 and [r["rate"] for r in result["runs"]] == [3.0, 1.0, 8.0]
    assert seen == [RUN_GC_THRESHOLD] * 3 and gc.get_threshold()[0] != RUN_GC_THRESHOLD  # as a run, then restored
    printed = capsys.readouterr().out
    assert "rate" in printed and "[1 – 8]" in printed and "median of 3 runs" in printed
    with pytest.raises(SystemExit) as stop:
        main(["bench", "fake", "--repeat", "0"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "--repeat" in err and "'0' is not an integer >= 1" in err and len(err.strip().splitlines()) == 1


def test_bench_repeat_gives_nan_when_a_run_gave_nan(monkeypatch):
    """A figure that is NaN in any run is NaN in the summary (never the median of the others)."""
    import math

    from rfsim.cli.bench import summarize_runs

    s = summarize_runs([{"x": 1.0}, {"x": math.nan}, {"x": 3.0}])
    assert math.isnan(s["x"]) and math.isnan(s["min"]["x"]) and math.isnan(s["max"]["x"])


# ----------------------------------------------------------------------------- bad input, part 2


def exit_code(argv) -> int:
    """Exit status of ``rfsim argv`` run in this process (argparse exits via SystemExit)."""
    try:
        return main(argv)
    except SystemExit as info:
        return info.code


def assert_one_line_error(err: str, fragment: str) -> None:
    assert err.count("\n") == 1 and err.startswith("rfsim"), err
    assert "error: " in err and "Traceback" not in err, err
    assert fragment in err, err


MORE_BAD_RUNS = [
    (["--seed", str(2**64)], "expected an integer in [0, 2**64)"),
    (["--seed", "-1"], "expected an integer in [0, 2**64)"),
    (["--seed", "1.5"], "expected an integer in [0, 2**64)"),
    (["--seed", "banana"], "expected an integer in [0, 2**64)"),
    (["--set", "fs_hz=nan"], "a finite number"),
    (["--set", "q=1e400"], "config key 'q': got inf"),
    (["--set", "q=99999999999999999999999"], "an integer in [0, 15]"),
    (["--set", "q.x=1"], "config key 'q'"),
    (["--set", "profiles={a=1}"], "a list of str"),
    (["--set", "profiles=[]"], "a non-empty list"),
    (["--set", "=1"], "the key must be dotted names"),
    (["--bogus"], "unrecognized arguments: --bogus"),
]


@pytest.mark.parametrize("extra,fragment", MORE_BAD_RUNS)
def test_more_user_mistakes_exit_2_with_one_line(extra, fragment, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert exit_code(["run", "gen2-waveforms", *extra]) == 2
    assert_one_line_error(capsys.readouterr().err, fragment)
    assert not list(tmp_path.glob("**/*.h5"))


@pytest.mark.parametrize("scenario,override,fragment", [
    ("link", "geometry.distances_m=[]", "config key 'geometry.distances_m': got []; allowed: a non-empty list"),
    ("link", "reader.link_profile=miller4-32k", "config key 'reader.link_profile': got 'miller4-32k'"),
    ("detection-probability", "reader.link_profile=bogus", "config key 'reader.link_profile'"),
    ("reader-detection", "campaign.distances_m=[]", "config key 'campaign.distances_m'"),
])
def test_empty_lists_and_bad_profiles_are_refused_at_load(scenario, override, fragment, capsys, tmp_path,
                                                           monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert exit_code(["config", scenario, "--set", override]) == 2
    assert_one_line_error(capsys.readouterr().err, fragment)


def test_binary_and_folder_config_files(tmp_path, capsys):
    binary = tmp_path / "b.toml"
    binary.write_bytes(bytes(range(256)) * 4)
    assert exit_code(["run", "gen2-waveforms", "-c", str(binary)]) == 2
    assert_one_line_error(capsys.readouterr().err, "not UTF-8 text")
    assert exit_code(["config", "link", "-c", str(tmp_path)]) == 2
    assert_one_line_error(capsys.readouterr().err, "cannot be read")


@pytest.fixture
def no_simulation(monkeypatch):
    """Make the scenario's simulation fail loudly: output checks must come before it."""
    import rfsim.scenarios.gen2_waveforms as gw

    def refuse(*args, **kwargs):
        raise AssertionError("the simulation started before the outputs were checked")
    monkeypatch.setattr(gw, "run", refuse)


OUTPUT_MISTAKES = [
    (["--out-dir", "afile"], "'afile' is a file, not a folder"),
    (["--out-dir", "afile/sub"], "'afile' is a file, not a folder"),
    (["-o", "adir.h5"], "is a folder; expected a file name"),
    (["-o", "afile/x.h5"], "'afile' is a file, not a folder"),
    (["-o", "adir"], "must end in .h5 or .hdf5"),
    (["--out-dir", "res"], "'res/gen2-waveforms.h5': is a folder"),
    (["-o", "afile/x.h5", "--no-plot"], "'afile' is a file, not a folder"),
    (["--out-dir", "ok", "-o", "afile/deeper/x.h5"], "'afile' is a file, not a folder"),
]


@pytest.mark.parametrize("extra,fragment", OUTPUT_MISTAKES)
def test_output_paths_are_checked_before_the_simulation(extra, fragment, tmp_path, monkeypatch, capsys,
                                                         no_simulation):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir.h5").mkdir()
    (tmp_path / "res" / "gen2-waveforms.h5").mkdir(parents=True)
    assert exit_code(["run", "gen2-waveforms", *extra]) == 2
    assert_one_line_error(capsys.readouterr().err, fragment)


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux /proc")
@pytest.mark.parametrize("extra", [["--out-dir", "/proc/rfsim-out"], ["-o", "/proc/rfsim-out/x.h5"],
                                   ["-o", "/proc/x.h5", "--no-plot"]])
def test_outputs_on_a_virtual_file_system_are_refused(extra, tmp_path, monkeypatch, capsys, no_simulation):
    monkeypatch.chdir(tmp_path)
    assert exit_code(["run", "gen2-waveforms", *extra]) == 2
    assert_one_line_error(capsys.readouterr().err, "/proc")


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into read-only folders")
def test_unwritable_folder_is_refused(tmp_path, monkeypatch, capsys, no_simulation):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        assert exit_code(["run", "gen2-waveforms", "-o", str(ro / "x.h5"), "--no-plot"]) == 2
        assert_one_line_error(capsys.readouterr().err, "cannot write into the folder")
    finally:
        ro.chmod(0o700)


def test_missing_output_folders_are_created(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "gen2-waveforms", "--set", "profiles=['fm0-640k']", "-o", "a/b/c/x.h5", "--no-plot",
                 "-q"]) == 0
    assert (tmp_path / "a" / "b" / "c" / "x.h5").stat().st_size > 0
    assert not list(tmp_path.glob("**/.rfsim-write-probe-*"))


def test_a_figure_that_cannot_be_saved_keeps_the_dataset(tmp_path, monkeypatch, capsys):
    import rfsim.scenarios.gen2_waveforms as gw

    def plot(path, out_dir):
        raise IsADirectoryError(21, "Is a directory")
    monkeypatch.setattr(gw, "plot", plot)
    assert main(["run", "gen2-waveforms", "--set", "profiles=['fm0-640k']", "--out-dir", str(tmp_path), "-q"]) == 2
    assert_one_line_error(capsys.readouterr().err, "written, but a figure could not be saved")
    assert (tmp_path / "gen2-waveforms.h5").stat().st_size > 0


def test_bench_json_path_is_checked_first(tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    assert main(["bench", "linecode", "--quick", "--json", str(tmp_path / "f" / "b.json")]) == 2
    assert_one_line_error(capsys.readouterr().err, "is a file, not a folder")
    assert "[linecode]" not in capsys.readouterr().out


@pytest.mark.parametrize("argv", [["config", "link", "--keys"], ["list"], ["config", "inventory"]])
def test_output_piped_into_head_is_a_quiet_exit_0(argv, tmp_path):
    """The reader of the pipe is gone before rfsim writes (like `| head` that has its lines)."""
    proc = subprocess.Popen([sys.executable, "-m", "rfsim", *argv], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()
    with proc.stderr:
        err = proc.stderr.read().decode()
    proc.wait(timeout=60)
    assert proc.returncode == 0 and err == ""

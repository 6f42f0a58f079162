"""The rfsim command line: help, version, list, run, and one-line errors (exit 2)."""

from __future__ import annotations

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
    result = json.loads(out.read_text())["linecode"]
    assert result["numba_bit_errors"] == 0 and result["numba_bits_per_s"] > 0
    assert result["peak_rss_mb"] > 0

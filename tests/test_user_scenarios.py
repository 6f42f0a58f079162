"""User scenario files and plug-ins (issue 31 item 2): ``rfsim run path.py`` and
``rfsim.run("path.py")`` run a module with the scenario contract outside the package, with
the same config, ``--set`` and sweep machinery; installed distributions add scenarios through
the entry point group ``rfsim.scenarios``, listed by ``rfsim list``; a bad file is one line."""

from __future__ import annotations

import pickle
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

import rfsim
from rfsim.cli import main
from rfsim.core.errors import ConfigError, UserError
from rfsim.runs import registry

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "my_scenario.py"
SMALL_SET = ["--set", "distances_m=[2.0, 20.0]", "--set", "rounds=2"]


def test_example_is_short_and_has_the_contract():
    assert len(EXAMPLE.read_text().splitlines()) <= 60
    module = registry.get_scenario(str(EXAMPLE))
    assert module.NAME == "my-read-rate" and module.__name__ == registry.file_module_name(EXAMPLE)


def test_cli_run_of_a_file_equals_rfsim_run(tmp_path, capsys):
    out = tmp_path / "mine.h5"
    assert main(["run", str(EXAMPLE), "--seed", "3", "-q", "--out-dir", str(tmp_path), "-o", str(out),
                 *SMALL_SET]) == 0
    fig = tmp_path / "mine-read-rate.png"
    assert fig.read_bytes().startswith(b"\x89PNG")
    result = rfsim.run(str(EXAMPLE), seed=3, progress=False, distances_m=[2.0, 20.0], rounds=2)
    with h5py.File(out, "r") as f:
        assert f.attrs["scenario"] == "my-read-rate"
        assert int(f["provenance"].attrs["seed"]) == 3
        assert np.array_equal(f["rounds"]["distance_m"][()], [2.0, 2.0, 20.0, 20.0])
        for k in ("distance_m", "success"):
            assert f["rounds"][k][()].tobytes() == result.dataset.tables["rounds"][k].data.astype(
                f["rounds"][k].dtype).tobytes()
        assert f.attrs["read_rate"] == result.attrs["read_rate"]
    # 2 m is well inside the range at 30 dBm, 20 m far beyond it (forward link limited)
    ok = result.dataset.tables["rounds"]["success"].data
    assert ok[:2].all() and not ok[2:].any()


def test_cli_config_of_a_file(capsys):
    assert main(["config", str(EXAMPLE), "--set", "rounds=7"]) == 0
    text = capsys.readouterr().out
    assert "rounds = 7" in text and "[reader]" in text and "distances_m = [1.0, 4.0, 8.0]" in text


def test_cli_config_keys_of_a_file(capsys):
    assert main(["config", str(EXAMPLE), "--keys"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(line.startswith("rounds = 4  #") and "inventory rounds per distance" in line for line in lines)
    assert any(line.startswith("reader.ptx_dbm = 30.0") for line in lines)


def test_a_bad_override_of_a_file_scenario_names_the_key():
    with pytest.raises(ConfigError, match="'rounds'"):
        rfsim.run(str(EXAMPLE), rounds=0)


@pytest.mark.parametrize("source, text", [
    (None, "no such file"),
    ("x = 1\n", "lacks NAME, DESCRIPTION, Config, run, plot"),
    ("def run(:\n", "syntax error at line 1"),
    ("import no_such_module_xyz\n", "cannot be imported"),
])
def test_bad_files_are_one_line_errors_with_exit_2(tmp_path, capsys, source, text):
    path = tmp_path / "bad.py"
    if source is not None:
        path.write_text(source)
    assert main(["run", str(path), "--no-plot", "-o", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and text in err and str(path) in err
    assert not (tmp_path / "x.h5").exists()


def test_the_module_name_is_the_same_for_every_spelling_and_process(tmp_path, monkeypatch):
    monkeypatch.chdir(EXAMPLE.parent)
    assert registry.file_module_name("my_scenario.py") == registry.file_module_name(EXAMPLE)
    assert registry.load_scenario(registry.file_module_name(EXAMPLE)) is registry.get_scenario(str(EXAMPLE))
    # a fresh process (a sweep worker) that imported the registry unpickles the file's Config
    cfg = rfsim.runs.api.resolve_config(registry.get_scenario(str(EXAMPLE)), None, {"rounds": 9})
    blob = tmp_path / "cfg.pickle"
    blob.write_bytes(pickle.dumps(cfg))
    code = ("import pickle, sys, rfsim.runs.registry\n"
            f"cfg = pickle.loads(open({str(blob)!r}, 'rb').read())\n"
            "print(type(cfg).__module__ == rfsim.runs.registry.file_module_name(sys.argv[1]), cfg.rounds)")
    out = subprocess.run([sys.executable, "-c", code, str(EXAMPLE)], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "9"]


def test_a_sweep_of_a_file_scenario_on_worker_processes(tmp_path):
    from rfsim.sweep.executors import PoolExecutor

    spec = {"scenario": str(EXAMPLE), "seed": 4, "output": str(tmp_path / "sw.h5"),
            "base": {"rounds": 1},
            "axes": [{"kind": "grid", "key": "distances_m", "values": [[2.0], [20.0]]}]}
    result = rfsim.run_sweep(spec, executor=PoolExecutor(2), progress=False)
    rounds = result.dataset.tables["rounds"]
    assert list(rounds["sweep_point"].data) == [0, 1]
    assert list(rounds["distance_m"].data) == [2.0, 20.0]
    assert list(rounds["success"].data) == [True, False]


# ----------------------------------------------------------------------------- plug-ins

_PLUGIN = '''
"""A plug-in scenario."""
from dataclasses import dataclass
from rfsim.core.config import param
from rfsim.core.dataset import Dataset, column

NAME = {name!r}
DESCRIPTION = "a plug-in scenario for the tests"


@dataclass(frozen=True)
class Config:
    n: int = param(3, lo=1, hi=10, doc="rows")


def run(config, *, seed):
    ds = Dataset(title="plug-in")
    ds.add_table("t", {{"k": column(list(range(config.n)), "1", "row number")}})
    return ds


def plot(dataset_path, out_dir):
    return []
'''


@pytest.fixture
def plugin_site(tmp_path, monkeypatch):
    """A folder on sys.path with an installed distribution ``fake-rfsim-plugin`` whose entry
    points (group ``rfsim.scenarios``) are given by the test."""

    def install(entries: dict[str, str], modules: dict[str, str]) -> Path:
        site = tmp_path / "site"
        pkg = site / "fakeplug"
        pkg.mkdir(parents=True)
        (pkg / "__init__.py").write_text("")
        for mod, name in modules.items():
            (pkg / f"{mod}.py").write_text(textwrap.dedent(_PLUGIN.format(name=name)))
        info = site / "fake_rfsim_plugin-0.1.dist-info"
        info.mkdir()
        (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fake-rfsim-plugin\nVersion: 0.1\n")
        (info / "entry_points.txt").write_text(
            "[rfsim.scenarios]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items()))
        monkeypatch.syspath_prepend(str(site))
        for mod in list(sys.modules):
            if mod == "fakeplug" or mod.startswith("fakeplug."):
                monkeypatch.delitem(sys.modules, mod)
        return site

    return install


def test_a_plugin_is_listed_and_runs(plugin_site, capsys, tmp_path):
    plugin_site({"fake": "fakeplug.scen"}, {"scen": "fake-plugin"})
    assert registry.scenario_descriptions()["fake-plugin"] == "a plug-in scenario for the tests"
    assert main(["list"]) == 0
    assert any(line.split()[0] == "fake-plugin" for line in capsys.readouterr().out.splitlines())
    module = registry.get_scenario("fake-plugin")
    assert module.__name__ == "fakeplug.scen" and "fake-plugin" in registry.scenario_modules()
    assert list(rfsim.run("fake-plugin", n=4, progress=False).dataset.tables["t"]["k"].data) == [0, 1, 2, 3]
    assert main(["run", "fake-plugin", "--no-plot", "-q", "-o", str(tmp_path / "p.h5"), "--set", "n=2"]) == 0
    with h5py.File(tmp_path / "p.h5", "r") as f:
        assert list(f["t"]["k"][()]) == [0, 1] and f.attrs["scenario"] == "fake-plugin"


def test_a_plugin_cannot_replace_a_builtin(plugin_site):
    plugin_site({"shadow": "fakeplug.shadow"}, {"shadow": "link"})
    assert registry.get_scenario("link").__name__ == "rfsim.scenarios.link"
    assert registry.scenario_modules()["link"].__name__ == "rfsim.scenarios.link"
    assert registry.scenario_descriptions()["link"] != "a plug-in scenario for the tests"


@pytest.mark.parametrize("target", ["fakeplug.missing", "no_such_package_xyz.scen"])
def test_a_broken_plugin_is_a_one_line_error(plugin_site, capsys, target):
    plugin_site({"broken": target}, {})
    with pytest.raises(UserError) as err:
        registry.scenario_modules()
    assert "scenario plug-in 'broken'" in str(err.value) and "fake-rfsim-plugin" in str(err.value)
    assert "\n" not in str(err.value)
    assert main(["list"]) == 2
    assert capsys.readouterr().err.count("\n") == 1

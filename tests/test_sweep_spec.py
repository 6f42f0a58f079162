"""Sweep specs: expansion (grid x zip x random), determinism, run seeds, bad specs."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.errors import UserError
from rfsim.runs.registry import get_scenario
from rfsim.sweep import parse_spec, point_configs, point_seed, point_values, shard_runs

BASE = {"scenario": "gen2-waveforms", "seed": 11, "output": "results/s.h5",
        "base": {"profiles": ["fm0-640k"]}}


def spec_of(*axes, **top):
    return parse_spec({**BASE, **top, "axes": list(axes)})


def test_grid_zip_random_expansion_counts_and_order():
    grid_q = {"kind": "grid", "key": "q", "values": [1, 2, 3]}
    zip_ = {"kind": "zip", "keys": ["session", "rn16"], "values": [[0, 1], [5, 6]]}
    r1 = {"kind": "random", "key": "pie_rise_fall_tari", "distribution": "uniform",
          "low": 0.05, "high": 0.3, "n": 4}
    r2 = {"kind": "random", "key": "fs_hz", "distribution": "loguniform", "low": 6e6, "high": 2e7, "n": 4}
    spec = spec_of(grid_q, zip_, r1, r2, repetitions=3)
    # groups: grid(3) x zip(2) x random-n4(4, the two random axes move together)
    assert spec.group_sizes == (3, 2, 4)
    assert spec.n_points == 24 and spec.n_runs == 72
    vals = point_values(spec)
    assert len(vals) == 24
    r_draws = [v["pie_rise_fall_tari"] for v in vals[:4]]
    f_draws = [v["fs_hz"] for v in vals[:4]]
    # product order, last group fastest
    expected = list(itertools.product([1, 2, 3], [(0, 5), (1, 6)], range(4)))
    for v, (q, (s, rn), j) in zip(vals, expected):
        assert (v["q"], v["session"], v["rn16"]) == (q, s, rn)
        assert v["pie_rise_fall_tari"] == r_draws[j] and v["fs_hz"] == f_draws[j]
    # random axis a draws from Generator(PCG64(SeedSequence(seed, spawn_key=(a,)))) (a = 2, 3)
    g2 = np.random.Generator(np.random.PCG64(np.random.SeedSequence(11, spawn_key=(2,))))
    assert r_draws == list(g2.uniform(0.05, 0.3, 4))
    g3 = np.random.Generator(np.random.PCG64(np.random.SeedSequence(11, spawn_key=(3,))))
    assert np.allclose(f_draws, np.exp(g3.uniform(np.log(6e6), np.log(2e7), 4)), rtol=1e-15)
    assert all(6e6 <= f <= 2e7 for f in f_draws)
    # deterministic: the same spec expands to the same values; another seed does not
    assert point_values(spec_of(grid_q, zip_, r1, r2, repetitions=3)) == vals
    assert point_values(spec_of(grid_q, zip_, r1, r2, seed=12))[0]["fs_hz"] != vals[0]["fs_hz"]


def test_random_axes_of_different_n_multiply_and_choice_normal():
    a = {"kind": "random", "key": "q", "distribution": "choice", "values": [1, 7, 9], "n": 5}
    b = {"kind": "random", "key": "pie_rise_fall_tari", "distribution": "normal", "mean": 0.15,
         "std": 0.01, "n": 2}
    spec = spec_of(a, b)
    assert spec.group_sizes == (5, 2) and spec.n_points == 10
    vals = point_values(spec)
    assert {v["q"] for v in vals} <= {1, 7, 9}
    assert all(abs(v["pie_rise_fall_tari"] - 0.15) < 0.08 for v in vals)  # 8 sigma
    configs = point_configs(spec, get_scenario("gen2-waveforms").Config)
    assert [c.q for c in configs] == [v["q"] for v in vals]
    assert all(c.profiles == ("fm0-640k",) for c in configs)


def test_no_axes_is_one_point_and_nested_base_keys():
    spec = spec_of()
    assert spec.n_points == 1 and point_values(spec) == [{}]


def test_point_seed_is_the_spawned_child_state():
    for seed, i, k in [(0, 0, 0), (11, 5, 2), (2**40, 123456, 0)]:
        ss = np.random.SeedSequence(seed).spawn(i + 1)[i].spawn(k + 1)[k]
        assert point_seed(seed, i, k) == int(ss.generate_state(1, np.uint64)[0] >> np.uint64(1))
    seeds = {point_seed(3, i, k) for i in range(50) for k in range(4)}
    assert len(seeds) == 200 and all(0 <= s < 2**63 for s in seeds)


def test_shards_partition_the_runs():
    parts = [list(shard_runs(23, i, 4)) for i in range(4)]
    assert sorted(sum(parts, [])) == list(range(23))
    with pytest.raises(UserError):
        shard_runs(23, 4, 4)


BAD_SPECS = [
    ({"sceanrio": "x"}, "did you mean 'scenario'"),
    ({"seed": -1}, "config key 'seed': got -1"),
    ({"output": "results/x.csv"}, "ending in .h5"),
    ({"repetitions": 0}, "config key 'repetitions'"),
    ({"axes": [{"kind": "grd", "key": "q", "values": [1]}]}, "did you mean 'grid'"),
    ({"axes": [{"kind": "grid", "key": "q", "values": []}]}, "'axes[0].values'"),
    ({"axes": [{"kind": "zip", "keys": ["q", "session"], "values": [[1, 2], [0]]}]}, "equal length"),
    ({"axes": [{"kind": "random", "key": "q", "distribution": "gauss", "n": 3}]}, "'axes[0].distribution'"),
    ({"axes": [{"kind": "random", "key": "q", "distribution": "uniform", "low": 1, "n": 3}]},
     "'axes[0].high'"),
    ({"axes": [{"kind": "random", "key": "fs_hz", "distribution": "loguniform", "low": 0, "high": 1,
                "n": 2}]}, "'axes[0].low'"),
    ({"axes": [{"kind": "grid", "key": "q", "values": [1]}, {"kind": "grid", "key": "q", "values": [2]}]},
     "already swept by axes[0]"),
    ({"axes": [{"kind": "grid", "key": "q", "values": [1, 2, 99]}]}, "sweep point 2 (q=99): config key 'q'"),
    ({"axes": [{"kind": "grid", "key": "qq", "values": [1]}]}, "did you mean 'q'"),
    ({"axes": [{"kind": "grid", "key": "fs_hz", "values": [8e6, 1e6]}]}, "sweep point 1"),
    ({"scenario": "gen2-wavefroms"}, "did you mean 'gen2-waveforms'"),
    ({"axes": [{"kind": "grid", "key": "q", "valeus": [1]}]}, "did you mean 'values'"),
]


@pytest.mark.parametrize("change,fragment", BAD_SPECS)
def test_bad_specs_fail_with_one_line(change, fragment, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    data = {**BASE, **change}
    if "sceanrio" in change:
        del data["scenario"]
    lines = []
    for k, v in data.items():
        if k not in ("base", "axes"):
            lines.append(f"{k} = {v!r}".replace("'", '"'))
    lines.append("[base]\nprofiles = [\"fm0-640k\"]")
    for ax in data.get("axes", []):
        lines.append("[[axes]]")
        lines += [f"{k} = {v!r}".replace("'", '"') for k, v in ax.items()]
    (tmp_path / "s.toml").write_text("\n".join(lines) + "\n")
    assert main(["sweep", "dry-run", "s.toml"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rfsim: error: "), err
    assert fragment in err, err
    assert not list(tmp_path.glob("**/*.h5"))


def test_missing_spec_file_and_bad_toml(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", "missing.toml"]) == 2
    assert "cannot be read" in capsys.readouterr().err
    (tmp_path / "b.toml").write_text("seed = = 1\n")
    assert main(["sweep", "run", "b.toml", "--serial"]) == 2
    assert "not valid TOML" in capsys.readouterr().err


def test_dry_run_prints_count_and_configs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(
        'scenario = "gen2-waveforms"\nseed = 1\nrepetitions = 2\noutput = "out.h5"\n'
        '[base]\nprofiles = ["fm0-640k"]\n[[axes]]\nkind = "grid"\nkey = "q"\nvalues = [1, 2, 3, 4, 5]\n')
    assert main(["sweep", "s.toml", "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "5 points x 2 repetitions = 10 runs" in out
    assert out.count("# ---- point") == 3 and "q = 3" in out and "2 more points" in out
    assert not (tmp_path / "out.h5").exists() and not (tmp_path / "out.h5.points").exists()


def test_sweep_help_lists_the_verbs(capsys):
    with pytest.raises(SystemExit) as info:
        main(["sweep", "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert all(v in out for v in ("run", "dry-run", "plan", "merge"))
    assert main(["sweep"]) == 0 and "VERB" in capsys.readouterr().out


def test_every_dataset_scenario_has_a_valid_example_spec(project_root):
    from rfsim.runs.registry import scenario_modules
    from rfsim.sweep import load_spec, plan_sweep

    examples = sorted((project_root / "examples" / "sweeps").glob("*.toml"))
    scenarios = {load_spec(p).scenario for p in examples}
    assert set(scenario_modules()) <= scenarios
    for path in examples:
        plan = plan_sweep(load_spec(path))  # every point validates
        assert len(plan.tasks) >= 8 and plan.spec.swept_keys

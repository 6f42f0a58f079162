"""Sweep execution: bit-identical merges across executors and shards, SIGKILL + resume,
no partial file under the final name, progress lines, the SLURM script."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.dataset import read_provenance, read_table
from rfsim.core.errors import UserError
from rfsim.sweep import (PoolExecutor, Progress, SerialExecutor, StoreIndex, load_spec, merge_sweep, point_seed,
                         points_dir, run_sweep)

SPEC = """\
scenario = "gen2-waveforms"
seed = 5
repetitions = 2
output = "{output}"

[base]
profiles = {profiles}
fs_hz = {fs_hz}

[[axes]]
kind = "grid"
key = "q"
values = {q}

[[axes]]
kind = "random"
key = "pie_rise_fall_tari"
distribution = "uniform"
low = 0.05
high = 0.3
n = 2
"""


def write_spec(folder: Path, name: str, *, q=(1, 2, 3), profiles=("fm0-640k",), fs_hz=8e6) -> Path:
    path = folder / f"{name}.toml"
    path.write_text(SPEC.format(output=str(folder / f"{name}.h5"), q=list(q),
                                profiles=str(list(profiles)).replace("'", '"'), fs_hz=fs_hz))
    return path


def arrays(path: Path) -> dict[str, np.ndarray]:
    """Every dataset array in the file except provenance (which holds times)."""
    out: dict[str, np.ndarray] = {}

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset):
            out[name] = obj[()]
    with h5py.File(path, "r") as f:
        f.visititems(visit)
        out["/point_seeds"] = f["provenance"].attrs["point_seeds"]
    return out


def assert_identical(a: Path, b: Path) -> int:
    x, y = arrays(a), arrays(b)
    assert sorted(x) == sorted(y)
    for k in x:
        assert x[k].dtype == y[k].dtype and np.array_equal(x[k], y[k]), k
    return len(x)


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """The serial run every other executor is compared with."""
    folder = tmp_path_factory.mktemp("ref")
    report = run_sweep(load_spec(write_spec(folder, "s")), SerialExecutor())
    assert report.computed == 12 and report.reused == 0
    return report.output


def test_merged_layout_seeds_and_provenance(reference):
    runs = read_table(reference, "sweep_runs")
    assert list(runs["sweep_point"]) == [0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5]
    assert list(runs["sweep_repetition"]) == [0, 1] * 6
    assert "point" not in runs and "repetition" not in runs  # one name for the index in every table
    assert list(runs["seed"]) == [point_seed(5, i, k) for i in range(6) for k in range(2)]
    assert list(runs["q"]) == [1] * 4 + [2] * 4 + [3] * 4
    # the drawn RN16 depends on the run seed only
    assert len(set(runs["rn16"])) > 1
    frames = read_table(reference, "frames")
    assert len(frames["frame"]) == 12 * 4 and list(frames["sweep_point"][:9]) == [0] * 8 + [1]
    assert list(frames["sweep_repetition"][:5]) == [0, 0, 0, 0, 1]
    with h5py.File(reference, "r") as f:
        assert f["frames/sweep.pie_rise_fall_tari"].attrs["units"] == "Tari"
        assert f["exchange_fm0-640k/sweep.q"].shape == f["exchange_fm0-640k/time_s"].shape
    prov = read_provenance(reference)
    assert prov["seed"] == 5 and prov["sweep_points"] == 6 and prov["sweep_runs"] == 12
    assert 'scenario = "gen2-waveforms"' in prov["spec_toml"]
    assert prov["point_seeds"].shape == (6, 2)


@pytest.mark.parametrize("workers", [1, 2])
def test_process_pool_is_bit_identical_to_serial(reference, tmp_path, workers):
    report = run_sweep(load_spec(write_spec(tmp_path, "s")), PoolExecutor(workers))
    assert report.computed == 12
    assert assert_identical(reference, report.output) > 20


def test_shards_then_merge_are_bit_identical(reference, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    spec = write_spec(tmp_path, "s")
    assert main(["sweep", "run", str(spec), "--shard", "0/2", "--serial", "-q"]) == 0
    assert not (tmp_path / "s.h5").exists()
    assert main(["sweep", "merge", str(spec)]) == 2  # shard 1 is missing
    assert "6 of 12 runs are missing" in capsys.readouterr().err
    assert main(["sweep", "run", str(spec), "--shard", "1/2", "--workers", "2", "-q"]) == 0
    store = points_dir(tmp_path / "s.h5")
    assert len(StoreIndex(store)) == 12
    # one segment per writing process (shard 0: this process; shard 1: two pool workers)
    assert len(list(store.glob("seg-*.log"))) == 3 and len(list(store.glob("seg-*.idx"))) == 3
    assert main(["sweep", "merge", str(spec), "-q"]) == 0
    assert_identical(reference, tmp_path / "s.h5")


def test_resume_skips_valid_points_and_recomputes_changed_ones(tmp_path):
    spec = load_spec(write_spec(tmp_path, "s"))
    run_sweep(spec, SerialExecutor())
    again = run_sweep(spec, SerialExecutor(), resume=True)
    assert (again.computed, again.reused) == (0, 12)
    # a changed point config (q=3 -> 4) invalidates exactly that point's 4 runs
    changed = run_sweep(load_spec(write_spec(tmp_path, "s", q=(1, 2, 4))), SerialExecutor(), resume=True)
    assert (changed.computed, changed.reused) == (4, 8)
    assert {r.point for r in changed.results} == {4, 5}


def test_no_partial_file_under_the_final_name(tmp_path, monkeypatch):
    spec = load_spec(write_spec(tmp_path, "s"))
    with pytest.raises(UserError, match="12 of 12 runs are missing"):
        merge_sweep(spec)  # nothing to merge yet: a user error before any write
    run_sweep(spec, SerialExecutor(), merge=False)

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")
    monkeypatch.setattr("rfsim.sweep.merge.write_provenance", boom)  # the last step of the merge
    with pytest.raises(RuntimeError, match="disk full"):
        merge_sweep(spec)
    assert not spec.output.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert not (tmp_path / "s.h5.lock").exists()  # the lock went with the failed merge


def test_sigkill_mid_sweep_then_resume_recomputes_only_missing(tmp_path):
    """SIGKILL a running `python -m rfsim sweep run`; --resume computes only the rest."""
    spec_path = write_spec(tmp_path, "big", q=tuple(range(8)), profiles=("fm0-40k",), fs_hz=1e6)
    spec = load_spec(spec_path)
    store = points_dir(spec.output)
    cmd = [sys.executable, "-m", "rfsim", "sweep", "run", str(spec_path), "--serial"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path)
    deadline = time.monotonic() + 120
    while len(StoreIndex(store)) < 6 and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.005)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL
    finished = len(StoreIndex(store))
    segments = {p.name: (p.stat().st_mtime_ns, p.stat().st_size) for p in store.glob("seg-*")}
    assert 6 <= finished < 32, finished
    assert not spec.output.exists()  # never a file under the final name before the merge
    out = subprocess.run(cmd + ["--resume"], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert out.returncode == 0, out.stderr
    assert f"32 runs, {32 - finished} computed, {finished} reused" in out.stdout
    for name, stat in segments.items():  # the killed run's segment was not rewritten
        assert ((store / name).stat().st_mtime_ns, (store / name).stat().st_size) == stat
    assert len(list(store.glob("seg-*.log"))) == 2  # the killed process's and the resume's
    assert not list(tmp_path.glob("**/.*.partial"))
    (tmp_path / "ref").mkdir()
    uninterrupted = run_sweep(load_spec(write_spec(tmp_path / "ref", "big", q=tuple(range(8)),
                                                   profiles=("fm0-40k",), fs_hz=1e6)), SerialExecutor())
    assert_identical(uninterrupted.output, spec.output)


def test_progress_lines_when_not_a_tty():
    stream = io.StringIO()
    p = Progress(10, done=2, stream=stream, tty=False, log_interval_s=0.0)
    p.start()
    for _ in range(8):
        p.update()
    p.close()
    text = stream.getvalue()
    lines = text.splitlines()
    assert "\r" not in text and "\x1b" not in text
    assert lines[0].startswith("sweep: 2/10 runs (20.0 %)")
    assert lines[-1].startswith("sweep: 10/10 runs (100.0 %)")
    assert "runs/s, elapsed " in lines[-1] and "ETA 00:00" in lines[-1]
    # interval 0: the start and one line per finished run (the close may repeat the last)
    assert [int(line.split()[1].split("/")[0]) for line in lines][:9] == list(range(2, 11))
    slow = io.StringIO()  # a 1 h interval: the first line and the last only
    q = Progress(10, stream=slow, tty=False, log_interval_s=3600.0)
    q.start()
    q.update(10)
    q.close()
    assert [line.split(" (")[0] for line in slow.getvalue().splitlines()] == ["sweep: 0/10 runs", "sweep: 10/10 runs"]


def test_progress_bar_on_a_tty_and_quiet():
    stream = io.StringIO()
    p = Progress(4, stream=stream, tty=True)
    p.start()
    p.update()
    p.update()
    p._bar.refresh()
    text = stream.getvalue()
    assert "\r" in text and "2/4 runs" in text and "sweep:  50%|" in text
    quiet = io.StringIO()
    q = Progress(4, stream=quiet, quiet=True)
    q.start()
    q.update(4)
    q.close()
    assert quiet.getvalue() == ""


def test_cli_run_prints_progress_in_batch_logs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    spec = write_spec(tmp_path, "s", q=(1,))
    assert main(["sweep", str(spec), "--serial"]) == 0  # captured stderr is not a TTY
    captured = capsys.readouterr()
    out, err = captured.out, captured.err
    assert "\r" not in err
    # progress on stderr (as for 'rfsim run'), results on stdout
    assert "sweep: 0/4 runs (0.0 %)" in err and "sweep: 4/4 runs (100.0 %)" in err
    assert "runs (" not in out
    assert f"dataset: {tmp_path / 's.h5'}" in out
    assert main(["sweep", "-q", str(spec), "--serial", "--resume"]) == 0  # options before the spec too
    assert capsys.readouterr() == ("", "")


def test_sbatch_script(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    spec = write_spec(tmp_path, "s")
    assert main(["sweep", "plan", str(spec), "--slurm", "--shards", "4", "--out", "job.sbatch",
                 "--time", "00:30:00"]) == 0
    text = (tmp_path / "job.sbatch").read_text()
    assert text.startswith("#!/bin/bash\n")
    assert "#SBATCH --array=0-3\n" in text and "#SBATCH --time=00:30:00\n" in text
    assert f"#SBATCH --chdir={tmp_path.resolve()}" in text
    assert f'-m rfsim sweep run {spec.resolve()} --shard "${{SLURM_ARRAY_TASK_ID}}/4"' in text
    assert "--resume" in text and "sweep merge" in text
    assert main(["sweep", "plan", str(spec), "--slurm", "--shards", "13"]) == 2
    assert "more shards than runs" in capsys.readouterr().err

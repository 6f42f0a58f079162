"""Fault injection over seeded trials (slow tier): a small sweep is killed (its leader or a
pool worker, SIGKILL at a random moment), runs out of disk in the middle of a write, or has one
byte of one of its files flipped (a point-store index or log, the merged dataset). Each trial
is seeded by its index (no clock) and checks:

* no traceback: an error is one line on stderr;
* no corrupt final file: the output is absent or opens and holds the uninterrupted result;
* every finished result kept: what the store held after the fault is reused, not recomputed;
* the recovery the message names (``--resume``, after ``rfsim sweep repair`` or moving a
  damaged segment away when it says so) gives a merged result identical to an uninterrupted
  run, array for array.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import rfsim.sweep.merge as merge_module
import rfsim.sweep.store as store_module
from rfsim.cli import main
from rfsim.sweep import StoreIndex, points_dir
from test_sweep_run import SPEC as RUN_SPEC
from test_sweep_run import arrays

#: 3 q values x 2 random PIE edge times x 2 repetitions of gen2-waveforms: 12 runs
SPEC = RUN_SPEC.format(output="out.h5", profiles='["fm0-40k"]', fs_hz=1e6, q=[0, 1, 2])
N_RUNS = 12
SUMMARY = re.compile(r"sweep: (\d+) runs, (\d+) computed, (\d+) reused")


def new_folder(root: Path, name: str) -> Path:
    folder = root / name
    folder.mkdir()
    (folder / "s.toml").write_text(SPEC)
    return folder


def cli(folder: Path, argv: list[str], capsys) -> tuple[int, str, str]:
    """``rfsim ARGV`` in this process, in ``folder``: (exit status, stdout, stderr)."""
    here = os.getcwd()
    os.chdir(folder)
    try:
        try:
            code = main(argv)
        except SystemExit as info:
            code = info.code
    finally:
        os.chdir(here)
    out, err = capsys.readouterr()
    return code, out, err


def assert_no_traceback(err: str, code: int) -> None:
    assert "Traceback" not in err, err
    if code != 0:
        lines = [line for line in err.splitlines() if line.startswith("rfsim: error: ")]
        assert len(lines) == 1, err


def assert_same(reference: dict, path: Path) -> None:
    got = arrays(path)
    assert sorted(got) == sorted(reference)
    for k, v in reference.items():
        assert got[k].dtype == v.dtype and np.array_equal(got[k], v), k


def assert_absent_or_whole(reference: dict, folder: Path) -> None:
    """The final file is absent or the whole, uninterrupted result (never a torn one)."""
    out = folder / "out.h5"
    if out.exists():
        assert_same(reference, out)


def stored(folder: Path) -> int:
    return len(StoreIndex(points_dir(folder / "out.h5")))


def resume_until_whole(folder: Path, capsys, reference: dict, *, kept: int) -> None:
    """Recover as the one-line messages say, then compare with the uninterrupted result;
    ``kept`` runs (those finished before the fault) must be reused."""
    store = points_dir(folder / "out.h5")
    for _ in range(3):
        code, out, err = cli(folder, ["sweep", "run", "s.toml", "--serial", "--resume"], capsys)
        assert_no_traceback(err, code)
        if code == 0:
            total, computed, reused = map(int, SUMMARY.search(out).groups())
            assert total == N_RUNS and computed + reused == N_RUNS
            assert reused >= kept, (reused, kept)
            break
        assert code == 2, err
        if "rfsim sweep repair" in err:
            code, _, err = cli(folder, ["sweep", "repair", "s.toml"], capsys)
            assert code == 0 and "Traceback" not in err, err
        elif "move that segment" in err:
            log = folder / re.search(r"in '([^']+\.log)'", err).group(1)
            aside = folder / "damaged"
            aside.mkdir(exist_ok=True)
            for part in (log, log.with_suffix(".idx")):
                shutil.move(str(part), aside / part.name)
            kept = 0  # the records of a segment moved away are computed again
        else:
            raise AssertionError(err)
    else:
        raise AssertionError("no recovery in three steps")
    assert_same(reference, folder / "out.h5")
    assert not list(folder.glob("**/.*.partial"))
    assert store.is_dir()


@pytest.fixture(scope="module")
def pristine(tmp_path_factory) -> tuple[Path, dict]:
    """An uninterrupted serial sweep (its folder) and the arrays of its merged result."""
    root = tmp_path_factory.mktemp("pristine")
    folder = new_folder(root, "whole")
    out = subprocess.run([sys.executable, "-m", "rfsim", "sweep", "run", "s.toml", "--serial"], cwd=folder,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    return folder, arrays(folder / "out.h5")


# ----------------------------------------------------------------------------- kills


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(p) for p in text.split()]


KILL_TRIALS = 16


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(KILL_TRIALS))
def test_a_killed_leader_or_worker(trial, pristine, tmp_path, capsys):
    """Even trials kill the leader of a serial sweep, odd ones a worker of a 2-worker pool,
    once a random number of runs (0 … all) is in the store, after a random extra delay."""
    _, reference = pristine
    rng = np.random.default_rng(trial)
    folder = new_folder(tmp_path, "s")
    leader = trial % 2 == 0
    how = ["--serial"] if leader else ["--workers", "2"]
    target, delay_s = int(rng.integers(0, N_RUNS + 1)), float(rng.uniform(0.0, 0.3))
    proc = subprocess.Popen([sys.executable, "-m", "rfsim", "sweep", "run", "s.toml", *how], cwd=folder,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    store = points_dir(folder / "out.h5")
    victim = None
    limit = time.monotonic() + 300
    while proc.poll() is None and time.monotonic() < limit:
        workers = _children(proc.pid)
        if (store.is_dir() and stored(folder) >= target) and (leader or workers):
            time.sleep(delay_s)
            workers = _children(proc.pid)
            victim = proc.pid if leader or not workers else workers[int(rng.integers(0, len(workers)))]
            try:
                os.kill(victim, signal.SIGKILL)
            except ProcessLookupError:
                victim = None
            break
        time.sleep(0.005)
    try:
        _, err = proc.communicate(timeout=180)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        who = "its leader" if victim == proc.pid else f"worker {victim}"
        raise AssertionError(f"the sweep did not end within 180 s after SIGKILL of {who} at {target} stored runs"
                             ) from None
    assert "Traceback" not in err, err
    if victim is not None and victim != proc.pid and proc.returncode != 0:
        # a worker died: the leader stops with one line naming the kill
        assert proc.returncode == 1, err
        assert re.search(r"killed|SIGKILL|ended abruptly", err), err
        assert_no_traceback(err, proc.returncode)
    assert_absent_or_whole(reference, folder)
    kept = stored(folder) if store.is_dir() else 0
    resume_until_whole(folder, capsys, reference, kept=kept)


# ----------------------------------------------------------------------------- disk full


FULL_TRIALS = 14


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(FULL_TRIALS))
def test_a_full_disk_mid_write(trial, pristine, tmp_path, capsys, monkeypatch):
    """The k-th write to the point store (k random; part of it reaches the disk) or to the
    merged dataset fails with ENOSPC: one line, exit 1, the runs before it kept, no file under
    the final name."""
    _, reference = pristine
    rng = np.random.default_rng(1000 + trial)
    folder = new_folder(tmp_path, "s")
    if trial % 2 == 0:  # a store write: the log or index append of a run
        fail_at, calls = int(rng.integers(1, 2 * N_RUNS + 1)), [0]
        real = store_module._write_all

        def write_all(fd, data):
            calls[0] += 1
            if calls[0] == fail_at:
                os.write(fd, bytes(data)[: int(rng.integers(0, len(data)))])  # part of it reached the disk
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            real(fd, data)

        monkeypatch.setattr(store_module, "_write_all", write_all)
    else:  # the merged dataset: the k-th of its array writes (58 in all) meets a full disk
        fail_at, calls = int(rng.integers(1, 59)), [0]
        real_create = merge_module.create_array

        def create_array(*args, **kwargs):
            calls[0] += 1
            if calls[0] == fail_at:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            return real_create(*args, **kwargs)

        monkeypatch.setattr(merge_module, "create_array", create_array)
    code, _, err = cli(folder, ["sweep", "run", "s.toml", "--serial"], capsys)
    monkeypatch.undo()
    assert code == 1, err
    assert_no_traceback(err, code)
    assert "No space left on device" in err, err
    assert not (folder / "out.h5").exists()
    kept = stored(folder)
    if trial % 2 == 1:
        assert kept == N_RUNS  # every run finished before the merge failed
    resume_until_whole(folder, capsys, reference, kept=kept)


@pytest.mark.slow
def test_a_real_full_disk_under_a_sweep(pristine, tmp_path, capsys):
    """On a small tmpfs (root only; else skipped) the sweep stops with one line; once space is
    freed (here: the tmpfs grown) ``--resume`` finishes it in place."""
    _, reference = pristine
    where = tmp_path / "tiny"
    where.mkdir()
    if not shutil.which("mount") or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", str(where)],
                                                   capture_output=True).returncode != 0:
        pytest.skip("cannot mount a small tmpfs here")
    try:
        (where / "s.toml").write_text(SPEC)
        code, _, err = cli(where, ["sweep", "run", "s.toml", "--serial"], capsys)
        assert code == 1, err
        assert_no_traceback(err, code)
        assert "No space left on device" in err
        assert not (where / "out.h5").exists()
        kept = stored(where)
        subprocess.run(["mount", "-o", "remount,size=20m", str(where)], check=True)
        resume_until_whole(where, capsys, reference, kept=kept)
    finally:
        subprocess.run(["umount", str(where)], capture_output=True)


# ----------------------------------------------------------------------------- flipped bytes


FLIP_TRIALS = 24


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(FLIP_TRIALS))
def test_a_flipped_byte(trial, pristine, tmp_path, capsys):
    """One bit of one byte (random) of an index, a log or the merged dataset of a finished
    sweep is flipped; ``--resume`` (after the repair the message names) restores the result."""
    whole, reference = pristine
    rng = np.random.default_rng(2000 + trial)
    folder = tmp_path / "s"
    shutil.copytree(whole, folder)
    files = {"idx": sorted(points_dir(folder / "out.h5").glob("seg-*.idx")),
             "log": sorted(points_dir(folder / "out.h5").glob("seg-*.log")),
             "h5": [folder / "out.h5"]}
    kind = ("idx", "log", "h5")[trial % 3]
    target = files[kind][int(rng.integers(0, len(files[kind])))]
    raw = bytearray(target.read_bytes())
    at = int(rng.integers(0, len(raw)))
    raw[at] ^= 1 << int(rng.integers(0, 8))
    target.write_bytes(bytes(raw))
    if kind == "h5":  # the damaged dataset: reading it is one line or a result, never a traceback
        code, _, err = cli(folder, ["info", "out.h5"], capsys)
        assert_no_traceback(err, code)
    # a flipped record is run again, every other run kept; a flipped index entry fails its
    # checksum (or its bounds) and the index is rebuilt from its log, losing none
    resume_until_whole(folder, capsys, reference, kept=N_RUNS - 1 if kind == "log" else N_RUNS)
    with h5py.File(folder / "out.h5", "r") as f:
        assert "provenance" in f


def test_resume_runs_a_record_that_fails_its_crc_again_and_keeps_the_others(tmp_path):
    """A damaged record is found by ``--resume`` (not first by the merge, which would ask to
    move its whole segment away): that run alone is computed again."""
    import rfsim.bench.sweep_scale as toy
    from rfsim.sweep import SerialExecutor, run_sweep
    from rfsim.sweep.store import read_index
    from test_sweep_store import toy_spec

    (tmp_path / "whole").mkdir()
    (tmp_path / "flip").mkdir()
    whole = run_sweep(toy_spec(tmp_path / "whole", n_points=4, reps=2), SerialExecutor(), module=toy)
    spec = toy_spec(tmp_path / "flip", n_points=4, reps=2)
    run_sweep(spec, SerialExecutor(), merge=False, module=toy)
    [(log, entries)] = list(read_index(points_dir(spec.output)))
    data = bytearray(log.read_bytes())
    data[int(entries["offset"][5]) + int(entries["length"][5]) - 20] ^= 0x10  # in the payload of run 5
    log.write_bytes(bytes(data))
    again = run_sweep(spec, SerialExecutor(), resume=True, module=toy)
    assert (again.computed, again.reused) == (1, 7)
    assert_same(arrays(whole.output), again.output)

"""Every file operation fails in one line, and nothing is lost.

A refused write (full disk: a small tmpfs or an injected ``ENOSPC``; ``EIO``; a full
stdout: ``/dev/full``) is one line and exit status 1 with the previous file intact; a child
killed by a signal is named; output paths are checked before any work; every writer of an
output holds its lock; leftovers of killed writers are removed; a damaged point-store index
is named with the command that repairs it, and ``--resume`` after the repair gives the
result of an uninterrupted sweep.
"""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

import rfsim.bench.sweep_scale as toy
import rfsim.core.dataset as dataset_module
from rfsim.cli import main
from rfsim.core.dataset import Dataset, column, write_dataset
from rfsim.core.errors import ResourceError
from rfsim.core.locks import output_lock
from rfsim.sweep import SerialExecutor, StoreIndex, points_dir, run_sweep
from rfsim.sweep.lock import OutputLock
from rfsim.sweep.store import INDEX_DTYPE, INDEX_MAGIC, DamagedIndexError, index_entries, repair_store
from test_sweep_errors import SPEC
from test_sweep_run import assert_identical
from test_sweep_store import toy_spec

PREVIOUS = b"the previous file\n"


def run_cli(argv, capsys) -> tuple[int, str, str]:
    try:
        code = main(argv)
    except SystemExit as info:
        code = info.code
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line(err: str, fragment: str) -> None:
    assert err.count("\n") == 1 and err.startswith("rfsim: error: "), err
    assert fragment in err, err
    assert "Traceback" not in err


def big_dataset(n_tables: int = 20, rows: int = 3000) -> Dataset:
    ds = Dataset(title="t", scenario="s")
    for i in range(n_tables):
        ds.add_table(f"t{i}", {"a": column(np.arange(rows, dtype=float), "1", "a"),
                               "b": column(np.ones(rows), "1", "b")})
    return ds


@pytest.fixture
def tiny_disk(tmp_path):
    """A 200 kB tmpfs (needs root and a kernel that allows the mount), else skipped."""
    where = tmp_path / "tiny"
    where.mkdir()
    if not shutil.which("mount") or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=200k", "tmpfs", str(where)],
                                                   capture_output=True).returncode != 0:
        pytest.skip("cannot mount a small tmpfs here")
    try:
        yield where
    finally:
        subprocess.run(["umount", str(where)], capture_output=True)


def test_a_full_disk_is_one_error_and_the_previous_dataset_stays(tiny_disk):
    # in a process of its own, as 'rfsim run' writes its dataset in a child process: HDF5
    # is left unusable in a process where a file could not be closed
    target = tiny_disk / "d.h5"
    target.write_bytes(PREVIOUS)
    code = ("import sys\n"
            "from rfsim.core.errors import ResourceError\n"
            "from rfsim.core.dataset import write_dataset\n"
            "from test_write_failures import big_dataset\n"
            "try:\n"
            f"    write_dataset({str(target)!r}, big_dataset(), {{'seed': 1}})\n"
            "except ResourceError as err:\n"
            "    print(err)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          cwd=Path(__file__).parent)
    assert done.stderr == ""  # none of HDF5's per-object reports
    message = done.stdout
    assert message.count("\n") == 1 and "No space left on device" in message and str(target) in message
    assert target.read_bytes() == PREVIOUS
    assert sorted(p.name for p in tiny_disk.iterdir()) == ["d.h5"]  # no .partial left


@pytest.fixture
def capture(tmp_path):
    path = tmp_path / "cap.cf32"
    np.ones(4000, np.complex64).tofile(path)
    return path


@pytest.mark.parametrize("number, text", [(errno.ENOSPC, "No space left on device"),
                                          (errno.EIO, "Input/output error"),
                                          (errno.EDQUOT, "quota exceeded")])
def test_an_injected_write_error_in_decode_is_exit_1(number, text, capture, tmp_path, capsys, monkeypatch):
    def refuse(*args, **kwargs):
        raise OSError(number, os.strerror(number))

    monkeypatch.setattr(dataset_module, "_write_table", refuse)
    target = tmp_path / "out.h5"
    target.write_bytes(PREVIOUS)
    code, out, err = run_cli(["decode", str(capture), "--fs", "1e6", "-o", str(target)], capsys)
    assert code == 1
    assert_one_line(err, text)
    assert target.read_bytes() == PREVIOUS
    assert not list(tmp_path.glob(".*.partial"))


def cli_subprocess(args, stdout) -> subprocess.CompletedProcess:
    code = "import sys; from rfsim.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], stdout=stdout, stderr=subprocess.PIPE, text=True,
                          timeout=300)


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
@pytest.mark.parametrize("args", [["list"], ["decode", "{capture}", "--fs", "1e6"],
                                  ["decode", "{capture}", "--fs", "1e6", "--format", "json"]])
def test_a_full_stdout_is_one_line_exit_1(args, capture):
    with open("/dev/full", "w") as full:
        done = cli_subprocess([a.replace("{capture}", str(capture)) for a in args], full)
    assert done.returncode == 1, done.stderr
    assert done.stderr == "rfsim: error: cannot write the standard output: No space left on device\n"


def test_a_figure_that_cannot_be_written_leaves_the_previous_one(tmp_path, monkeypatch):
    from rfsim.core.plots import pyplot, save_figure

    target = tmp_path / "x-fig.png"
    target.write_bytes(PREVIOUS)
    fig = pyplot().figure()

    def refuse(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(fig, "savefig", refuse)
    with pytest.raises(ResourceError, match="cannot write the figure .*No space left on device"):
        save_figure(fig, target)
    assert target.read_bytes() == PREVIOUS
    assert [p.name for p in tmp_path.iterdir()] == ["x-fig.png"]


@pytest.mark.parametrize("signal_name, cause", [("SIGKILL", "ran out of memory"), ("SIGSEGV", "crash")])
def test_a_child_killed_by_a_signal_is_named(signal_name, cause):
    code = ("import os, signal, sys\n"
            "from rfsim.core.errors import ResourceError\n"
            "from rfsim.core.procs import run_in_child\n"
            "try:\n"
            f"    run_in_child(lambda: os.kill(os.getpid(), signal.{signal_name}))\n"
            "except ResourceError as err:\n"
            "    print(err)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.stdout.count("\n") == 1, (done.stdout, done.stderr)
    assert f"killed by {signal_name}" in done.stdout and cause in done.stdout


# ----------------------------------------------------------------------------- checked first


def foreign_dataset(path: Path, scenario: str = "link") -> Path:
    with h5py.File(path, "w") as f:
        f.attrs["scenario"] = scenario
        f.create_group("a").create_group("nested").create_dataset("x", data=np.arange(3))
        f["a"].create_dataset("y", data=np.arange(4.0))
    return path


@pytest.mark.parametrize("out_dir, text", [("/proc/rfsim-figures", "cannot create the folder"),
                                           ("{afile}", "is a file, not a folder"),
                                           ("{afile}/under", "is a file, not a folder")])
def test_plot_out_dir_is_checked_before_drawing(out_dir, text, tmp_path, capsys):
    data = foreign_dataset(tmp_path / "d.h5")
    (tmp_path / "afile").write_text("x")
    code, out, err = run_cli(["plot", str(data), "--out-dir", out_dir.replace("{afile}", str(tmp_path / "afile"))],
                             capsys)
    assert code == 2 and out == ""
    assert_one_line(err, text)


def test_info_on_a_foreign_file_with_nested_groups(tmp_path, capsys):
    code, out, err = run_cli(["info", str(foreign_dataset(tmp_path / "d.h5"))], capsys)
    assert code == 0 and err == ""
    assert "[a] (group, 1 nested group: nested)" in out
    assert "  y  " in out


def test_figures_go_beside_the_output_dataset(tmp_path, capsys, monkeypatch):
    seen = {}

    def fake_run_scenario(module, config, *, seed, out_dir, output=None, make_plots=True, **options):
        seen["out_dir"] = out_dir
        raise ResourceError("stop here")

    monkeypatch.setattr("rfsim.runs.runner.run_scenario", fake_run_scenario)
    monkeypatch.chdir(tmp_path)
    run_cli(["run", "gen2-waveforms", "-o", str(tmp_path / "elsewhere" / "x.h5")], capsys)
    assert seen["out_dir"] == tmp_path / "elsewhere"
    run_cli(["run", "gen2-waveforms"], capsys)
    assert seen["out_dir"] == Path("results")
    run_cli(["run", "gen2-waveforms", "-o", "y.h5", "--out-dir", "figs"], capsys)
    assert seen["out_dir"] == Path("figs")


# ----------------------------------------------------------------------------- nothing lost


def test_every_writer_respects_the_lock_of_an_output(capture, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    target = tmp_path / "out.h5"
    target.write_bytes(PREVIOUS)
    with OutputLock(target):  # a sweep writing out.h5
        code, _, err = run_cli(["decode", str(capture), "--fs", "1e6", "-o", str(target)], capsys)
        assert code == 2
        assert_one_line(err, f"--output {str(target)!r} is in use by another sweep: pid {os.getpid()}")
        code, _, err = run_cli(["run", "gen2-waveforms", "--no-plot", "-o", str(target)], capsys)
        assert code == 2
        assert_one_line(err, "is in use by another sweep")
    assert target.read_bytes() == PREVIOUS
    (tmp_path / "s.toml").write_text(SPEC.format(seed=1, output="out.h5"))
    with output_lock(target, what="dataset", kind="run"):  # 'rfsim run -o out.h5' running
        code, _, err = run_cli(["sweep", "run", "s.toml", "--serial"], capsys)
        assert code == 2
        assert_one_line(err, "sweep output 'out.h5' is in use by another run")
    assert target.read_bytes() == PREVIOUS


def test_leftovers_of_killed_writers_are_removed(capture, tmp_path, capsys, monkeypatch):
    target = tmp_path / "out.h5"
    dead = [tmp_path / ".out.h5.999999999.partial", tmp_path / ".out.h5.12.partial"]
    for path in dead:
        path.write_bytes(b"x" * 1000)
    other = tmp_path / ".other.h5.77.partial"
    other.write_bytes(b"y")
    keep = tmp_path / ".busy.h5.78.partial"
    keep.write_bytes(b"z")
    code, _, _ = run_cli(["decode", str(capture), "--fs", "1e6", "-o", str(target), "--format", "json"], capsys)
    assert code == 0 and target.exists()
    assert not any(p.exists() for p in dead)  # the next writer of out.h5 removed them
    assert other.exists()
    with output_lock(tmp_path / "busy.h5", what="dataset", kind="run"):
        code, out, _ = run_cli(["clean", str(tmp_path)], capsys)
    assert code == 0
    assert not other.exists() and keep.exists()  # an output being written keeps its file
    assert out.splitlines()[-1] == "1 temporary file of killed runs, 0.0 MB"


def test_a_damaged_index_is_named_and_resume_after_repair_is_exact(tmp_path):
    (tmp_path / "whole").mkdir()
    (tmp_path / "cut").mkdir()
    whole = run_sweep(toy_spec(tmp_path / "whole", n_points=8, reps=3), SerialExecutor(), module=toy)
    spec = toy_spec(tmp_path / "cut", n_points=8, reps=3)
    run_sweep(spec, SerialExecutor(), merge=False, module=toy)
    store = points_dir(spec.output)
    [index] = store.glob("seg-*.idx")
    raw = bytearray(index.read_bytes())
    assert raw.startswith(INDEX_MAGIC) and len(raw) == len(INDEX_MAGIC) + 24 * INDEX_DTYPE.itemsize

    def entry(k: int) -> slice:
        start = len(INDEX_MAGIC) + k * INDEX_DTYPE.itemsize
        return slice(start, start + INDEX_DTYPE.itemsize)

    sound = bytes(raw)
    wrong = np.frombuffer(raw[entry(5)], INDEX_DTYPE).copy()  # entry 5: a wrong offset, checksum right
    wrong["offset"] = 12345
    raw[entry(5)] = index_entries([wrong[0].tolist()[:-1]]).tobytes()
    index.write_bytes(bytes(raw))
    with pytest.raises(DamagedIndexError, match="entry 5 of 24 points at byte 12345, where the records"):
        run_sweep(spec, SerialExecutor(), resume=True, module=toy)
    raw = bytearray(sound)
    raw[entry(3).start + 16] ^= 0x04  # entry 3: one bit of its seed (in bounds, only the checksum sees it)
    raw[entry(9).start + 8:entry(9).start + 16] = (2**62).to_bytes(8, "little")  # entry 9: repetition 2**62
    raw[entry(11)] = np.random.default_rng(3).bytes(INDEX_DTYPE.itemsize)  # entry 11: random bytes
    index.write_bytes(bytes(raw))
    with pytest.raises(DamagedIndexError) as info:
        run_sweep(spec, SerialExecutor(), resume=True, module=toy)
    message = str(info.value)
    assert "\n" not in message and str(index) in message and "rfsim sweep repair" in message
    assert "entry 3 of 24 has a checksum that fails" in message
    assert [(p, n) for p, n in repair_store(store)] == [(index, 24)]
    assert index.read_bytes() == sound  # the rebuilt index is the one its writer appended
    assert repair_store(store) == []  # a sound store is left alone
    again = run_sweep(spec, SerialExecutor(), resume=True, module=toy)
    assert (again.computed, again.reused) == (0, 24)
    assert assert_identical(whole.output, again.output) > 5


def test_the_cli_names_the_repair_command_with_the_spec(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(SPEC.format(seed=1, output="out.h5"))
    store = tmp_path / "out.h5.points"
    store.mkdir()
    (store / "seg-20260101T000000.000000Z-h-1-abc.log").write_bytes(b"")
    (store / "seg-20260101T000000.000000Z-h-1-abc.idx").write_bytes(np.random.default_rng(1).bytes(56 * 4))
    code, _, err = run_cli(["sweep", "run", "s.toml", "--resume", "--serial"], capsys)
    assert code == 2
    assert_one_line(err, "seg-20260101T000000.000000Z-h-1-abc.idx' is damaged")
    assert "rebuild it from its log with: rfsim sweep repair s.toml" in err
    code, out, err = run_cli(["sweep", "repair", "s.toml"], capsys)
    assert code == 0 and err == ""
    assert "rebuilt: " in out and "(0 records)" in out
    assert len(StoreIndex(store)) == 0


def _kill_myself(task):
    import signal

    os.kill(os.getpid(), signal.SIGKILL)


def test_a_pool_worker_killed_by_a_signal_is_one_line():
    """A pool worker killed by a signal is one line naming the kill and the likely cause. The
    pool reports the signal when it saw the worker's exit status, and says "ended abruptly
    (killed ...)" when the broken pool was noticed first (a race of the pool's threads)."""
    from rfsim.core.procs import worker_pool

    with pytest.raises(ResourceError, match=r"(killed by SIGKILL|ended abruptly \(killed).*ran out of memory") as info:
        with worker_pool(1) as pool:
            list(pool.map(_kill_myself, [1]))
    assert "\n" not in str(info.value)


def test_a_full_disk_under_a_sweep_names_the_segment(tmp_path, monkeypatch):
    import rfsim.sweep.store as store_module

    def refuse(fd, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(store_module, "_write_all", refuse)
    spec = toy_spec(tmp_path, n_points=2, reps=1)
    with pytest.raises(ResourceError, match=r"cannot write the point store segment '.*seg-.*\.log': No space left "
                                            r"on device .*continue with --resume") as info:
        run_sweep(spec, SerialExecutor(), module=toy)
    assert "\n" not in str(info.value)
    assert not spec.output.exists()


def test_a_text_output_that_cannot_be_written_leaves_the_previous_one(tmp_path, monkeypatch):
    from rfsim.core.outputs import write_text_atomic

    target = tmp_path / "plan.sh"
    target.write_bytes(PREVIOUS)
    real_fsync = os.fsync

    def refuse(fd):
        raise OSError(errno.EIO, os.strerror(errno.EIO))

    monkeypatch.setattr(os, "fsync", refuse)
    with pytest.raises(ResourceError, match=r"cannot write --out '.*plan.sh': Input/output error; the previous"):
        write_text_atomic(target, "new text", "--out")
    monkeypatch.setattr(os, "fsync", real_fsync)
    assert target.read_bytes() == PREVIOUS and [p.name for p in tmp_path.iterdir()] == ["plan.sh"]
    write_text_atomic(target, "new text", "--out")
    assert target.read_text() == "new text"

"""Bad input to `rfsim sweep`: one line, exit 2, checked before anything runs; the output
lock; the --max-runs guard; dry-run of a 10**7-point spec; BrokenPipe."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rfsim.cli import main
from rfsim.sweep import load_spec, points_dir
from test_sweep_run import write_spec

SPEC = """\
scenario = "gen2-waveforms"
seed = {seed}
output = "{output}"

[base]
profiles = ["fm0-640k"]

[[axes]]
kind = "grid"
key = "q"
values = [1, 2]
"""


def exit_code(argv) -> int:
    try:
        return main(argv)
    except SystemExit as info:
        return info.code


def one_line(capsys, fragment: str) -> None:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rfsim") and "error: " in err, err
    assert fragment in err, err


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir.h5").mkdir()
    (tmp_path / "f.h5.points").write_text("not a folder")
    (tmp_path / "ok.toml").write_text(SPEC.format(seed=1, output="ok.h5"))
    return tmp_path


def spec_file(folder: Path, *, seed=1, output="out.h5") -> str:
    (folder / "s.toml").write_text(SPEC.format(seed=seed, output=output))
    return "s.toml"


@pytest.mark.parametrize("kw,fragment", [
    ({"seed": 2**64}, "config key 'seed': got 18446744073709551616; allowed: an integer in [0, 2**64)"),
    ({"seed": -1}, "an integer in [0, 2**64)"),
    ({"output": "adir.h5"}, "sweep output 'adir.h5': is a folder"),
    ({"output": "afile/s.h5"}, "'afile' is a file, not a folder"),
    ({"output": "f.h5"}, "sweep point store 'f.h5.points': 'f.h5.points' is a file"),
    ({"output": "/proc/rfsim-sweep/s.h5"}, "cannot create the folder '/proc/rfsim-sweep'"),
])
@pytest.mark.parametrize("verb", ["run", "merge"])
def test_bad_spec_values_and_outputs(kw, fragment, verb, folder, capsys, monkeypatch):
    if "/proc" in str(kw.get("output", "")) and not os.path.isdir("/proc/self"):
        pytest.skip("needs Linux /proc")
    monkeypatch.setattr("rfsim.sweep.store.run_point", _no_run)
    assert exit_code(["sweep", verb, spec_file(folder, **kw), "--serial"][:4 if verb == "run" else 3]) == 2
    one_line(capsys, fragment)
    assert not list(folder.glob("**/seg-*"))


def _no_run(task):
    raise AssertionError("a run started before the sweep's outputs were checked")


@pytest.mark.parametrize("argv,fragment", [
    (["run", "ok.toml", "--dask", "banana"], "--dask 'banana': expected a scheduler address"),
    (["run", "ok.toml", "--dask", "tcp://"], "expected a scheduler address"),
    (["run", "ok.toml", "--dask", "local:0"], "local:N with N >= 1"),
    (["run", "ok.toml", "--workers", "0"], "argument --workers: '0' is not an integer >= 1"),
    (["run", "ok.toml", "--shard", "2/2"], "expected I/N with 0 <= I < N"),
    (["run", "ok.toml", "--shard", "a/b"], "expected I/N"),
    (["run", "ok.toml", "--max-runs", "1"], "2 runs to do, more than --max-runs 1; add --yes"),
    (["run", "ok.toml", "--serial", "--workers", "2"], "not allowed with argument"),
    (["dry-run", "ok.toml", "--show", "-1"], "'-1' is not an integer >= 0"),
    (["plan", "ok.toml", "--slurm", "--shards", "2", "--time", "banana"], "--time 'banana': expected a SLURM time"),
    (["plan", "ok.toml", "--slurm", "--shards", "2", "--time", "1:00:00; rm -rf ~"], "expected a SLURM time"),
    (["plan", "ok.toml", "--slurm", "--shards", "2", "--job-name", "a b"], "--job-name 'a b'"),
    (["plan", "ok.toml", "--slurm", "--shards", "2", "--job-name", "x\n#SBATCH --mem=1T"], "--job-name"),
    (["plan", "ok.toml", "--slurm", "--shards", "2", "--out", "adir.h5"], "--out 'adir.h5': is a folder"),
    (["plan", "ok.toml", "--slurm", "--shards", "2", "--out", "afile/x.sbatch"], "'afile' is a file"),
    (["plan", "ok.toml", "--slurm", "--shards", "0"], "'0' is not an integer >= 1"),
    (["plan", "ok.toml", "--slurm", "--shards", "3"], "more shards than runs (2)"),
    (["merge", "ok.toml"], "2 of 2 runs are missing"),
    (["run", "missing.toml"], "cannot be read"),
    (["run", "adir.h5"], "cannot be read"),
])
def test_bad_options_exit_2_with_one_line(argv, fragment, folder, capsys, monkeypatch):
    monkeypatch.setattr("rfsim.sweep.store.run_point", _no_run)
    assert exit_code(["sweep", *argv]) == 2
    one_line(capsys, fragment)
    assert not list(folder.glob("*.sbatch")) and not (folder / "ok.h5").exists()


def test_binary_spec_file(tmp_path, capsys):
    (tmp_path / "b.toml").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(200))
    assert exit_code(["sweep", "dry-run", str(tmp_path / "b.toml")]) == 2
    one_line(capsys, "not UTF-8 text")


def test_a_random_axis_with_too_many_draws(tmp_path, capsys):
    (tmp_path / "r.toml").write_text(SPEC.format(seed=1, output="o.h5") + (
        '[[axes]]\nkind = "random"\nkey = "pie_rise_fall_tari"\ndistribution = "uniform"\n'
        'low = 0.1\nhigh = 0.2\nn = 10000000000\n'))
    assert exit_code(["sweep", "dry-run", str(tmp_path / "r.toml")]) == 2
    one_line(capsys, "'axes[1].n'")


def test_a_second_sweep_on_a_locked_output_names_the_holder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    spec = write_spec(tmp_path, "s", q=tuple(range(8)), profiles=("fm0-40k",), fs_hz=1e6)
    store = points_dir(load_spec(spec).output)
    first = subprocess.Popen([sys.executable, "-m", "rfsim", "sweep", "run", str(spec), "--serial", "-q"],
                             cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while not list(store.glob("seg-*.idx")) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert exit_code(["sweep", "run", str(spec), "--serial"]) == 2
        one_line(capsys, f"is in use by another sweep: pid {first.pid} on {os.uname().nodename}")
        assert exit_code(["sweep", "merge", str(spec)]) == 2
        one_line(capsys, f"pid {first.pid}")
    finally:
        first.kill()
        first.wait()
    # the kernel dropped the killed holder's lock: the next sweep runs
    assert main(["sweep", "run", str(spec), "--serial", "--resume", "-q"]) == 0


def test_shards_do_not_lock_each_other_out(tmp_path, monkeypatch):
    from rfsim.sweep.lock import OutputLock

    out = tmp_path / "s.h5"
    with OutputLock(out, shard=(0, 2)), OutputLock(out, shard=(1, 2)), OutputLock(out):
        pass
    with OutputLock(out, shard=(0, 2)):
        from rfsim.core.errors import UserError
        with pytest.raises(UserError, match="in use by another sweep"):
            OutputLock(out, shard=(0, 2)).acquire()


HUGE = """\
scenario = "link"
seed = 3
output = "huge.h5"

[[axes]]
kind = "grid"
key = "geometry.angle_deg"
values = [{angles}]

[[axes]]
kind = "random"
key = "reader.ptx_dbm"
distribution = "uniform"
low = 10.0
high = 30.0
n = 10000
"""


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads VmHWM from /proc")
def test_dry_run_of_ten_million_points_is_small(tmp_path):
    """10**3 grid values x 10**4 random draws: counts and the first points within 200 MB, so the
    ten million points are never materialised (10**7 configs would take gigabytes); the memory is
    the process's peak resident set, imports included. Its time is not asserted (a machine-
    dependent figure).
    """
    angles = ", ".join(f"{-90 + 0.18 * i:.2f}" for i in range(1000))
    (tmp_path / "huge.toml").write_text(HUGE.format(angles=angles))
    # peak RSS from VmHWM: ru_maxrss would include the forking pytest process's own RSS
    code = ("import re, sys, time; import rfsim.scenarios.link; from rfsim.cli import main; "
            "rc = main(['sweep', 'dry-run', 'huge.toml']); "
            "hwm = re.search(r'VmHWM:\\s*(\\d+)', open('/proc/self/status').read()).group(1); "
            "print('RSS', hwm, file=sys.stderr); sys.exit(rc)")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])})
    assert out.returncode == 0, out.stderr
    assert "# link: 10000000 points x 1 repetitions = 10000000 runs" in out.stdout
    assert out.stdout.count("# ---- point") == 3 and "# ... 9999997 more points" in out.stdout
    rss_kb = out.stderr.split()[-1]
    assert int(rss_kb) / 1024 <= 200, out.stderr


def test_dry_run_into_a_closed_pipe_is_a_quiet_exit_0(tmp_path):
    angles = ", ".join(str(a) for a in range(-90, 91))
    (tmp_path / "huge.toml").write_text(HUGE.format(angles=angles))
    proc = subprocess.Popen([sys.executable, "-m", "rfsim", "sweep", "dry-run", "huge.toml", "--show", "50"],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()
    with proc.stderr:
        err = proc.stderr.read().decode()
    proc.wait(timeout=60)
    assert proc.returncode == 0 and err == ""


def test_max_runs_yes_lets_a_large_sweep_start(folder, capsys):
    assert main(["sweep", "run", "ok.toml", "--serial", "--max-runs", "1", "--yes", "-q"]) == 0
    assert (folder / "ok.h5").exists()

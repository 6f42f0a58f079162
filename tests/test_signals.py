"""Real signals on real processes: SIGTERM is handled like Ctrl-C (one line, exit 143, no
partial files, --resume recovers) and pool workers never outlive their leader (SIGKILL)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rfsim.sweep import SerialExecutor, StoreIndex, load_spec, points_dir, run_sweep
from test_sweep_run import assert_identical, write_spec

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc for child processes")


def children(pid: int) -> set[int]:
    """Direct child processes of ``pid`` (Linux /proc)."""
    out: set[int] = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            out |= {int(c) for c in (task / "children").read_text().split()}
        except OSError:
            pass
    return out


def descendants(pid: int) -> set[int]:
    """Every process below ``pid``: its children, theirs, and so on (Linux /proc)."""
    out: set[int] = set()
    todo = [pid]
    while todo:
        new = children(todo.pop()) - out
        out |= new
        todo.extend(new)
    return out


def alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie waiting to be reaped counts as gone)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X")


def last_line(err: str) -> str:
    """The final line on stderr (stage and progress lines may come before it)."""
    lines = err.strip().splitlines()
    return lines[-1] if lines else ""


def wait_for(condition, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return condition()


def _default_sigint() -> None:
    # a shell without job control starts background commands with SIGINT ignored, and a child
    # inherits that: give the command the disposition it has in a terminal, where Ctrl-C reaches it
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start(args: list[str], cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "rfsim", *args], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=_default_sigint)


SWEEP = dict(q=tuple(range(8)), profiles=("fm0-40k", "miller4-320k", "pass-miller2-48k"), fs_hz=4e6)  # 32 runs


def start_sweep(tmp_path: Path, min_done: int):
    """A 32-run sweep on 2 workers, once ``min_done`` runs are in its store: (spec, store, proc, workers)."""
    spec_path = write_spec(tmp_path, "big", **SWEEP)
    store = points_dir(load_spec(spec_path).output)
    proc = start(["sweep", "run", str(spec_path), "--workers", "2"], tmp_path)
    assert wait_for(lambda: len(StoreIndex(store)) >= min_done or proc.poll() is not None, 120)
    return spec_path, store, proc, children(proc.pid)


def test_sigterm_mid_sweep_exits_143_with_one_line_and_resume_recovers(tmp_path):
    spec_path, store, proc, workers = start_sweep(tmp_path, 4)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143, err
    assert last_line(err).startswith("rfsim: terminated (SIGTERM)") and "--resume" in last_line(err)
    assert "Traceback" not in err and err.count("rfsim: terminated") == 1
    assert wait_for(lambda: not any(alive(p) for p in workers), 5)
    assert not (tmp_path / "big.h5").exists()
    assert not list(tmp_path.glob("**/.*.partial")) and not (tmp_path / "big.h5.lock").exists()
    done = len(StoreIndex(store))
    assert 4 <= done < 32
    again = subprocess.run([sys.executable, "-m", "rfsim", "sweep", "run", str(spec_path), "--serial", "--resume"],
                           cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert f"32 runs, {32 - done} computed, {done} reused" in again.stdout
    (tmp_path / "ref").mkdir()
    ref = run_sweep(load_spec(write_spec(tmp_path / "ref", "big", **SWEEP)), SerialExecutor())
    assert_identical(ref.output, tmp_path / "big.h5")


def test_sigkill_of_the_leader_ends_its_pool_workers(tmp_path):
    """The pool workers notice the leader's death and exit (waited for with a generous bound: a
    liveness check, not a speed figure)."""
    spec_path, store, proc, workers = start_sweep(tmp_path, 2)
    assert len(workers) >= 2, workers
    proc.kill()
    proc.communicate(timeout=30)
    assert wait_for(lambda: not any(alive(p) for p in workers), 60.0), [p for p in workers if alive(p)]
    # the lock of the killed sweep is released by the kernel: a new sweep may run at once
    again = subprocess.run([sys.executable, "-m", "rfsim", "sweep", "run", str(spec_path), "--serial", "--resume",
                            "-q"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr


def test_sigkill_of_a_scenario_run_ends_its_monte_carlo_workers(tmp_path):
    """A scenario's own process pool (reader-detection's campaign) dies with `rfsim run`: the
    run's child process and the pool's two workers below it."""
    proc = start(["run", "reader-detection", "--no-plot", "--set", "campaign.workers=2"], tmp_path)
    assert wait_for(lambda: len(descendants(proc.pid)) >= 3 or proc.poll() is not None, 120)
    workers = descendants(proc.pid)
    assert len(workers) >= 3 and proc.poll() is None
    proc.kill()
    proc.communicate(timeout=30)
    assert wait_for(lambda: not any(alive(p) for p in workers), 5.0)


def test_sigterm_of_a_scenario_run_leaves_no_file(tmp_path):
    proc = start(["run", "reader-detection", "--set", "campaign.workers=2", "--out-dir", "out"], tmp_path)
    assert wait_for(lambda: len(descendants(proc.pid)) >= 3 or proc.poll() is not None, 120)
    workers = descendants(proc.pid)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143 and last_line(err) == "rfsim: terminated (SIGTERM)", err
    assert "Traceback" not in err
    assert wait_for(lambda: not any(alive(p) for p in workers), 5.0)
    assert not [p for p in (tmp_path / "out").rglob("*") if p.is_file()]  # no dataset, no temporary


#: A serial sweep of 3,200 runs that Ctrl-C reaches long before it ends, even on a busy machine
#: where the store index is seen late (it is synced about once a second).
LONG_SWEEP_SPEC = """\
scenario = "gen2-waveforms"
seed = 5
repetitions = 1
output = "{output}"

[base]
profiles = ["fm0-40k"]
fs_hz = 1e6

[[axes]]
kind = "random"
key = "pie_rise_fall_tari"
distribution = "uniform"
low = 0.05
high = 0.3
n = 3200
"""


def test_ctrl_c_of_a_sweep_says_how_to_resume(tmp_path):
    spec_path = tmp_path / "long.toml"
    spec_path.write_text(LONG_SWEEP_SPEC.format(output=str(tmp_path / "long.h5")))
    store = points_dir(load_spec(spec_path).output)
    proc = start(["sweep", "run", str(spec_path), "--serial"], tmp_path)
    assert wait_for(lambda: len(StoreIndex(store)) >= 1 or proc.poll() is not None, 120)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130
    assert last_line(err).startswith("rfsim: interrupted; finished runs are kept") and "--resume" in err
    assert "Traceback" not in err

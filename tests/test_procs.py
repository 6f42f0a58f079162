"""rfsim.core.procs.run_in_child: a scenario's simulation runs in a forked child that returns its
memory to the system when it exits; its errors are raised in the leader."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")

_CHILD = """
import json, os, sys
from rfsim.core.errors import UserError
from rfsim.core.procs import run_in_child

state = {"set_by_child": False}
out = {"leader": os.getpid()}

def work():
    state["set_by_child"] = True
    with open(sys.argv[1], "w") as f:
        f.write(str(os.getpid()))

waited = []
run_in_child(work, while_waiting=lambda: waited.append(os.getpid()))
out["child"] = int(open(sys.argv[1]).read())
out["set_here"] = state["set_by_child"]
out["waited_in"] = waited

def refuse():
    raise UserError("bad key 'x'")

try:
    run_in_child(refuse)
except UserError as err:
    out["user_error"] = [type(err).__name__, str(err), getattr(err, "__notes__", [])]

def crash():
    raise ValueError("boom")

try:
    run_in_child(crash)
except ValueError as err:
    out["value_error"] = [str(err), "".join(getattr(err, "__notes__", []))]
print(json.dumps(out))
"""


def test_the_child_runs_elsewhere_and_its_errors_are_raised_here(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run = subprocess.run([sys.executable, "-c", _CHILD, str(tmp_path / "pid")], capture_output=True, text=True,
                         env=env, check=True)
    out = json.loads(run.stdout.strip().splitlines()[-1])
    assert out["child"] != out["leader"] and out["set_here"] is False
    assert out["waited_in"] == [out["leader"]]  # while_waiting runs once, in the leader
    assert out["user_error"] == ["UserError", "bad key 'x'", []]
    message, note = out["value_error"]
    assert message == "boom" and note.startswith("in the child process") and "crash" in note


def test_rfsim_run_simulates_in_a_child_and_draws_the_figures_here(tmp_path):
    """The leader of `rfsim run` never imports the kernel modules: the run and the dataset
    happen in the child, the figures (read from the file) here."""
    code = ("import json, sys\nfrom rfsim.cli import main\n"
            f"rc = main(['run', 'gen2-waveforms', '-q', '--out-dir', {str(tmp_path)!r}, "
            "'--set', \"profiles=['fm0-640k']\"])\n"
            "print(json.dumps([rc, sorted(m for m in sys.modules if m.endswith('_kernels'))]))")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    rc, kernel_modules = json.loads(run.stdout.strip().splitlines()[-1])
    assert rc == 0 and kernel_modules == []
    assert (tmp_path / "gen2-waveforms.h5").is_file() and list(tmp_path.glob("gen2-waveforms-*.png"))


_TASKS = """
import os
import time


def task(i):
    time.sleep(0.2 if i in (1, 4) else 0.0)  # the leader is busy with task 1, a later task ends before task 4
    if i == 99:
        raise ValueError("task 99 failed")
    return i, i * i, os.getpid()
"""

_MAP = """
import json, os
import kmap
from rfsim.core.procs import map_in_order

out = map_in_order(kmap.task, range(9), 2, desc="t", unit="tasks")
try:
    map_in_order(kmap.task, [0, 2, 99, 3], 2, desc="t", unit="tasks")
    failed = None
except ValueError as err:
    failed = str(err)
print(json.dumps(dict(leader=os.getpid(), out=out, failed=failed)))
"""


def test_map_in_order_keeps_task_order_across_the_pilot_and_the_pool(tmp_path):
    """The leader runs the second task while the pilot runs the first, the pilot runs the
    next one queued behind it while the workers start: the results come back in task order
    even when a later task ends first, the first and third tasks in the pilot, the others in
    at most the two workers, and a task's error is raised in the leader."""
    (tmp_path / "kmap.py").write_text(_TASKS)
    env = dict(os.environ, PYTHONPATH=f"{tmp_path}{os.pathsep}{ROOT}")
    run = subprocess.run([sys.executable, "-c", _MAP], capture_output=True, text=True, env=env, check=True)
    got = json.loads(run.stdout.strip().splitlines()[-1])
    assert [(i, sq) for i, sq, _ in got["out"]] == [(i, i * i) for i in range(9)]
    pids = [pid for _, _, pid in got["out"]]
    assert pids[1] == got["leader"] and got["leader"] not in pids[:1] + pids[2:]
    assert pids[2] == pids[0] and pids[0] not in pids[3:]
    assert 1 <= len(set(pids[3:])) <= 2  # the asked two workers at most
    assert got["failed"] == "task 99 failed"



_KILL_IDLE = """
import json, os, signal, threading, time
from pathlib import Path
from rfsim.core.procs import worker_pool

def task_queue_reader(pids):
    # the idle worker blocked reading the task queue holds the queue's lock while it waits
    for pid in pids:
        try:
            if "pipe_read" in Path(f"/proc/{pid}/wchan").read_text():
                return pid
        except OSError:
            pass
    return None

def kill_when_closing(pool, pid):
    # once the pool is asked to end (its workers told by one message each in the task queue),
    # the worker that holds the queue's lock dies without reading its message
    while not pool._shutdown_thread:
        time.sleep(0.01)
    time.sleep(0.3)
    os.kill(pid, signal.SIGKILL)

found = None
with worker_pool(2) as pool:
    results = [f.result() for f in [pool.submit(pow, 2, k) for k in range(8)]]
    pids = list(pool._processes)
    for _ in range(300):
        found = task_queue_reader(pids)
        if found is not None and len(pids) == 2:
            break
        time.sleep(0.01)
    if found is not None:
        os.kill(found, signal.SIGSTOP)
        threading.Thread(target=kill_when_closing, args=(pool, found), daemon=True).start()
alive = [pid for pid in pids if os.path.exists(f"/proc/{pid}")]
print(json.dumps(dict(found=found, results=results, alive=alive)))
"""


@pytest.mark.skipif(not Path("/proc/self/wchan").exists(), reason="needs /proc/PID/wchan")
def test_a_worker_killed_while_it_waits_for_a_task_does_not_hang_the_pool():
    """A worker killed (SIGKILL) while the pool ends, as it waits for a task holding the task
    queue's lock: leaving the pool ends the other worker instead of joining it for ever
    (ProcessPoolExecutor.shutdown(wait=True) hangs there). The worker is stopped (SIGSTOP)
    until the pool is asked to end, so that it dies before it reads its request to end. The
    child's run has a timeout well above the pool's grace: a hang is the failure."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    try:
        run = subprocess.run([sys.executable, "-c", _KILL_IDLE], capture_output=True, text=True, env=env,
                             timeout=120)
    except subprocess.TimeoutExpired:
        pytest.fail("leaving the pool hung after a worker was killed while it waited for a task")
    assert run.returncode == 0, run.stderr
    got = json.loads(run.stdout.strip().splitlines()[-1])
    if got["found"] is None:
        pytest.skip("no worker seen blocked reading the task queue (/proc/PID/wchan)")
    assert got["results"] == [2**k for k in range(8)]
    assert got["alive"] == []


def test_few_collections_sets_the_youngest_threshold_and_restores_every_threshold():
    """Inside the block the first threshold is the one asked for, the others kept; after it,
    also after an exception, the thresholds are those from before."""
    import gc

    from rfsim.core.procs import RUN_GC_THRESHOLD, few_collections

    before = gc.get_threshold()
    try:
        gc.set_threshold(700, 11, 12)
        with few_collections():
            assert gc.get_threshold() == (RUN_GC_THRESHOLD, 11, 12)
        assert gc.get_threshold() == (700, 11, 12)
        with pytest.raises(RuntimeError):
            with few_collections(1234):
                assert gc.get_threshold() == (1234, 11, 12)
                raise RuntimeError("inside")
        assert gc.get_threshold() == (700, 11, 12)
    finally:
        gc.set_threshold(*before)

"""rfsim.core._jit.compiling_elsewhere: during a run, a kernel missing from the on-disk cache is
compiled in a short-lived child process, which writes it to the cache; the run's process only
loads cached kernels, so the compiler's memory is never added to the run's peak."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")

#: A kernel, a kernel calling it, and a kernel numba cannot type.
_KERNELS = ("from rfsim.core._jit import njit\n\n\n@njit\ndef twice(x):\n    return 2 * x\n\n\n"
            "@njit\ndef twice_plus_one(x):\n    return twice(x) + 1\n\n\n"
            "@njit\ndef untypable(x):\n    return x.no_such_attribute\n")

_CALL = """
import contextlib, json, sys
from rfsim.core._jit import compiling_elsewhere
from rfsim.core.procs import run_in_child
import kmod

elsewhere = sys.argv[1] == "elsewhere"
with compiling_elsewhere(run_in_child) if elsewhere else contextlib.nullcontext():
    values = [kmod.twice_plus_one(20), kmod.twice(21)]
    try:
        kmod.untypable(1)
        error = None
    except Exception as err:
        error = type(err).__name__
stats = {name: [len(getattr(kmod, name).stats.cache_misses), len(getattr(kmod, name).stats.cache_hits)]
         for name in ("twice", "twice_plus_one")}
print(json.dumps([values, stats, error]))
"""


def _call(tmp_path: Path, mode: str, cache: Path) -> list:
    src = tmp_path / "src"
    src.mkdir(exist_ok=True)
    (src / "kmod.py").write_text(_KERNELS)
    env = dict(os.environ, PYTHONPATH=f"{src}{os.pathsep}{ROOT}", NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", _CALL, mode], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_kernel_the_cache_lacks_is_compiled_in_a_child_and_loaded_here(tmp_path):
    """With an empty cache, inside the block: the values are right, this process had no cache
    miss (it compiled nothing: numba counts a miss for each kernel it compiles itself) and
    loaded both kernels from the cache (one hit each: the callee was written by the child that
    compiled its caller); a kernel numba cannot type still raises numba's TypingError here.
    Outside the block (control): one miss per kernel, no hit."""
    values, stats, error = _call(tmp_path, "elsewhere", tmp_path / "cache1")
    assert values == [41, 42] and error == "TypingError"
    assert stats == {"twice": [0, 1], "twice_plus_one": [0, 1]}
    (folder,) = (tmp_path / "cache1").iterdir()
    assert {p.name.split("-")[0] for p in folder.rglob("*.nbi")} >= {"kmod.twice", "kmod.twice_plus_one"}
    values, stats, error = _call(tmp_path, "here", tmp_path / "cache2")
    assert values == [41, 42] and error == "TypingError"
    assert stats == {"twice": [1, 0], "twice_plus_one": [1, 0]}


_PEAK = """
import json, resource, subprocess, sys
run = subprocess.run(sys.argv[1:], capture_output=True, text=True)
# the largest resident set of any process of the tree (each waited for by its parent) [KiB]
print(json.dumps([run.returncode, run.stderr[-2000:], resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss]))
"""


@pytest.mark.slow
def test_a_cold_run_of_link_keeps_every_process_under_300_mib(tmp_path):
    """``rfsim run link`` with an empty kernel cache (a first run after install): every process
    of the run (the leader, the run's child, the compiling children) peaks under 300 MiB of
    resident memory (324 MiB before the kernels were compiled in children), and the run
    leaves the kernels it used in the cache."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    cmd = [sys.executable, "-m", "rfsim", "run", "link", "--seed", "1", "--no-plot", "-q", "-o", str(tmp_path / "link.h5")]
    out = subprocess.run([sys.executable, "-c", _PEAK, *cmd], capture_output=True, text=True, env=env, cwd=tmp_path,
                         check=True)
    returncode, stderr, peak_kib = json.loads(out.stdout.strip().splitlines()[-1])
    assert returncode == 0, stderr
    assert peak_kib < 300 * 1024
    assert len(list((tmp_path / "cache").rglob("*.nbi"))) >= 20

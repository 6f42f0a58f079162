"""Start-up of the ``rfsim`` command: ``--help`` and ``list`` import no scenario physics, no
numba and no scipy.signal (issue 16 item 4); ``config NAME`` imports the scenario module and
the modules that declare its config dataclasses, but no device, air, channel-assembly or
dataset module, no kernel module, numba, scipy.signal/stats/optimize or h5py (the physics is
declared with :func:`rfsim.core.lazy.lazy_import`, the packages export their names on first use);
the scenario metadata read from the sources equals the modules' own."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from rfsim.cli.decode import SUFFIXES as CLI_SUFFIXES
from rfsim.gen2.capture import SUFFIXES
from rfsim.runs.registry import scenario_descriptions, scenario_modules

ROOT = Path(__file__).resolve().parents[1]


def _module_folder(tmp_path: Path, name: str, source: str) -> Path:
    """A folder ``tmp_path/src`` holding the module ``name`` with ``source`` (for a child process's PYTHONPATH)."""
    src = tmp_path / "src"
    src.mkdir()
    (src / f"{name}.py").write_text(source)
    return src


HEAVY = ("numba", "scipy.signal", "scipy.stats", "h5py", "rfsim.devices", "rfsim.channels", "matplotlib")


def _imported_after(argv: list[str]) -> list[str]:
    code = ("import sys, io, contextlib\nfrom rfsim.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    try:\n        main(%r)\n    except SystemExit:\n        pass\n"
            "import json; print(json.dumps(sorted(sys.modules)))" % (argv,))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("argv", [["--help"], ["list"]])
def test_help_and_list_import_no_physics(argv):
    mods = _imported_after(argv)
    heavy = [m for m in mods if m.split(".")[0] in ("numba", "h5py", "matplotlib")
             or m.startswith(("scipy.signal", "scipy.stats", "rfsim.scenarios.", "rfsim.devices", "rfsim.channels"))]
    assert heavy == []


@pytest.mark.parametrize("name", sorted(scenario_descriptions()))
def test_config_runs_no_kernel_module_nor_heavy_library(name):
    """``rfsim config NAME`` loads no numba (so no kernel module ran: each imports numba),
    no scipy.signal / scipy.stats / scipy.optimize / scipy.ndimage, no h5py and no matplotlib."""
    mods = _imported_after(["config", name])
    assert f"rfsim.scenarios.{name.replace('-', '_')}" in mods  # the command did resolve the scenario
    heavy = [m for m in mods if m.split(".")[0] in ("numba", "llvmlite", "h5py", "matplotlib")
             or m.startswith(("scipy.signal", "scipy.stats", "scipy.optimize", "scipy.ndimage"))
             or m.endswith("_kernels")]
    assert heavy == []


#: Signal processing that no scenario's config needs: the sample-level devices, the air and
#: the engine, the assembly and application of channels, the capture decoders, the dataset
#: file and the detection fits (each costs start-up; together they made 'rfsim config
#: reader-detection' twice as slow as 'rfsim --help').
PHYSICS = ("rfsim.devices.reader", "rfsim.devices.reader_tx", "rfsim.gen2.blf_search",
           "rfsim.devices.reader_measure", "rfsim.devices.tag", "rfsim.devices.tag_response",
           "rfsim.devices.sense_a_tag", "rfsim.devices.tag_population",
           "rfsim.devices.gen2_tag_state", "rfsim.devices.active_reader", "rfsim.devices.active_tag", "rfsim.channels.scene",
           "rfsim.channels.bulk", "rfsim.channels.paths", "rfsim.channels.small_scale", "rfsim.channels.rss", "rfsim.air.step",
           "rfsim.air.links", "rfsim.air.groups", "rfsim.air.fused", "rfsim.air.batch",
           "rfsim.protocols.engine", "rfsim.protocols.batch", "rfsim.core.dataset", "rfsim.gen2.pie", "rfsim.gen2.capture",
           "rfsim.gen2.replies", "rfsim.gen2.reply_search", "rfsim.gen2.reply_decoding", "rfsim.devices.gen2_tag_arrays",
           "rfsim.detection.fit", "rfsim.estimators.kalman", "rfsim.estimators.particle")


@pytest.mark.parametrize("name", sorted(scenario_descriptions()))
def test_config_imports_no_scenario_physics(name):
    """``rfsim config NAME`` imports none of :data:`PHYSICS`: the config dataclasses live in
    modules that import only numpy and the config machinery (e.g. :mod:`rfsim.devices.reader_config`),
    and the scenario declares its physics lazily."""
    mods = _imported_after(["config", name])
    assert f"rfsim.scenarios.{name.replace('-', '_')}" in mods
    assert sorted(set(mods) & set(PHYSICS)) == []


@pytest.mark.parametrize("package", ["rfsim.devices", "rfsim.channels", "rfsim.gen2", "rfsim.estimators"])
def test_a_package_imports_a_module_for_the_first_name_read_from_it(package):
    """Importing a package imports none of its modules; reading a public name imports the module
    that provides it (the name is the module's own object), and every name of ``__all__``
    resolves; an unknown name is an AttributeError."""
    code = ("import importlib, json, sys\n"
            f"pkg = importlib.import_module({package!r})\n"
            f"before = sorted(m for m in sys.modules if m.startswith({package + '.'!r}))\n"
            "name = pkg.__all__[0]\n"
            "value = getattr(pkg, name)\n"
            "source = pkg.__dict__['_SOURCES']\n"
            "module = next(m for m, names in source.items() if name in names)\n"
            f"same = value is getattr(importlib.import_module({package!r} + '.' + module), name)\n"
            "every = all(getattr(pkg, n) is not None for n in pkg.__all__)\n"
            "listed = set(pkg.__all__) <= set(dir(pkg))\n"
            "try:\n    pkg.no_such_name\nexcept AttributeError:\n    unknown = True\nelse:\n    unknown = False\n"
            "print(json.dumps([before, same, every, listed, unknown]))")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert json.loads(out.stdout) == [[], True, True, True, True]


def test_a_run_loads_the_lazily_declared_physics_before_asking_for_cached_kernels():
    """Before a run asks numba which kernels are cached (the first-run notice), the scenario's
    lazily declared modules are imported, so that the kernel modules they declare are declared
    too: after it, the reader's kernel module is loaded for reader-detection (whose module
    imports no device)."""
    code = ("import sys\nimport rfsim.scenarios.reader_detection\n"
            "print('rfsim.devices.reader' in sys.modules)\n"
            "from rfsim.runs.runner import _announce_compilation\n_announce_compilation()\n"
            "print('rfsim.devices.reader' in sys.modules, 'rfsim.gen2._measure_kernels' in sys.modules)")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.split() == ["False", "True", "True"]


def test_a_lazily_declared_module_is_whole_for_threads_that_first_use_it_together(tmp_path):
    """Four threads read an attribute of a lazily declared module at the same time while
    its import is still running (it sleeps before defining the attribute): each gets the
    attribute (the import runs once; the others wait for it) — a module whose import had
    merely started would lack it."""
    src = _module_folder(tmp_path, "slowmod", "import time\nCOUNT = [0]\ntime.sleep(0.3)\nVALUE = 42\nCOUNT[0] += 1\n")
    code = ("import threading\nfrom rfsim.core.lazy import lazy_import\nm = lazy_import('slowmod')\n"
            "out = []\nb = threading.Barrier(4)\n"
            "def use():\n    b.wait()\n    out.append(m.VALUE)\n"
            "ts = [threading.Thread(target=use) for _ in range(4)]\n"
            "[t.start() for t in ts]\n[t.join() for t in ts]\nprint(out, m.COUNT[0])")
    env = dict(os.environ, PYTHONPATH=f"{src}{os.pathsep}{ROOT}")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split("]")[0] == "[42, 42, 42, 42" and run.stdout.split()[-1] == "1"


def test_scenario_metadata_from_sources_equals_modules():
    descriptions = scenario_descriptions()
    assert len(descriptions) >= 9
    assert descriptions == {name: module.DESCRIPTION for name, module in scenario_modules().items()}


def test_decode_cli_lists_the_capture_endings_of_the_loader():
    assert CLI_SUFFIXES == SUFFIXES


def test_numba_cache_folder_choice(tmp_path):
    """The folder is named after the kernel sources' hash, inside: the user's NUMBA_CACHE_DIR;
    the package's ``__pycache__`` when writable; $XDG_CACHE_HOME/rfsim/numba, or
    ~/.cache/rfsim/numba, when the package folder cannot be written (non-editable install). A
    NUMBA_CACHE_DIR that is already an rfsim-kernels folder (exported by an rfsim parent
    process) gives that folder for the same sources and a sibling for other sources, never a
    folder nested in it."""
    from rfsim.core._jit import cache_dir

    pkg = tmp_path / "site-packages" / "rfsim"
    assert cache_dir("ab12", {"NUMBA_CACHE_DIR": "/x"}, pkg, writable=lambda p: False) == os.path.join(
        "/x", "rfsim-kernels-ab12")
    assert cache_dir("ab12", {}, pkg, writable=lambda p: True) == str(pkg / "__pycache__" / "rfsim-kernels-ab12")
    assert cache_dir("ab12", {"XDG_CACHE_HOME": str(tmp_path / "c")}, pkg, writable=lambda p: False) == str(
        tmp_path / "c" / "rfsim" / "numba" / "rfsim-kernels-ab12")
    assert cache_dir("ab12", {}, pkg, writable=lambda p: False).endswith(
        os.path.join(".cache", "rfsim", "numba", "rfsim-kernels-ab12"))
    inherited = {"NUMBA_CACHE_DIR": os.path.join("/x", "rfsim-kernels-ab12") + os.sep}
    assert cache_dir("ab12", inherited, pkg, writable=lambda p: True) == os.path.join("/x", "rfsim-kernels-ab12")
    assert cache_dir("cd34", inherited, pkg, writable=lambda p: True) == os.path.join("/x", "rfsim-kernels-cd34")


def test_sources_hash_changes_with_any_byte_name_or_boundary():
    """The hash of ``(name, bytes)`` pairs is 16 hex digits and changes when a byte, a name, or
    the split of the same text between two files changes."""
    from rfsim.core._jit import sources_hash

    base = sources_hash([("a/_x_kernels.py", b"K = 1\n"), ("a/_y_kernels.py", b"L = 2\n")])
    assert len(base) == 16 and int(base, 16) >= 0
    others = [sources_hash([("a/_x_kernels.py", b"K = 2\n"), ("a/_y_kernels.py", b"L = 2\n")]),
              sources_hash([("a/_z_kernels.py", b"K = 1\n"), ("a/_y_kernels.py", b"L = 2\n")]),
              sources_hash([("a/_x_kernels.py", b"K = 1\nL"), ("a/_y_kernels.py", b" = 2\n")])]
    assert base not in others and len(set(others)) == 3


def test_every_module_declaring_kernels_is_hashed_and_imports_only_hashed_modules():
    """Every file of the package folders that mentions ``njit`` is a kernel module by name (so
    its source is in the cache folder's hash), the list includes the kernel modules of
    rfsim.channels, rfsim.devices and rfsim.scenarios, and each kernel module imports, of the
    project, only other kernel modules: a constant or kernel compiled into a kernel cannot come
    from a file whose edit would leave the cache folder unchanged."""
    import ast

    from rfsim.core._jit import is_kernel_module, kernel_source_dirs, kernel_sources

    dirs = kernel_source_dirs()
    mentions = sorted(f"{d.name}/{p.relative_to(d).as_posix()}" for d in dirs for p in d.rglob("*.py")
                      if "__pycache__" not in p.parts and b"njit" in p.read_bytes())
    hashed = kernel_sources(dirs)
    assert [name for name, _ in hashed] == mentions
    assert {name.split("/")[0] for name, _ in hashed} >= {"rfsim", "channels", "devices"}  # scenarios hold no kernel (tests/test_house.py)
    for name, data in hashed:
        for node in ast.walk(ast.parse(data)):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "rfsim":
                assert is_kernel_module(node.module.rsplit(".", 1)[-1] + ".py"), (name, node.module)
            elif isinstance(node, ast.Import):
                assert all(a.name.split(".")[0] != "rfsim" for a in node.names), name


_CALLEE = "from rfsim.core._jit import njit\n\nSCALE = 3\n\n\n@njit\ndef scaled(x):\n    return SCALE * x\n"
_CALLER = ("from rfsim.core._jit import njit\nfrom rfsim.core._probe_callee_kernels import scaled\n\n\n"
           "@njit\ndef caller(x):\n    return scaled(x) + 1\n")
_CALL_AND_ANNOUNCE = """
import io, json
from rfsim.core import _jit
from rfsim.core.progress import COMPILE_NOTICE, Reporter, reporting
from rfsim.runs.runner import _announce_compilation
from rfsim.core._probe_caller_kernels import caller

out = io.StringIO()
with reporting(Reporter(out, tty=False)):
    _announce_compilation()
    value = caller(2)
print(json.dumps([value, out.getvalue().count(COMPILE_NOTICE), _jit.CACHE_DIR]))
"""


def test_editing_a_callee_kernel_recompiles_its_callers_and_announces_it_once(tmp_path):
    """A kernel calling a kernel of another file compiles the callee (and its constants) into
    itself, and numba checks only the caller's own file. In a copy of the package: run 1
    compiles ``caller`` (2·3 + 1 = 7) and prints the compile notice once; run 2 loads it (no
    notice); after the callee's constant is edited (3 → 5, same file size), run 3 uses a new
    cache folder, so ``caller`` sees the new value (2·5 + 1 = 11) and the notice appears once
    again. With the folder keyed on the caller's file alone, run 3 would return 7."""
    import shutil

    pkg = tmp_path / "pkg"
    shutil.copytree(ROOT / "rfsim", pkg / "rfsim", ignore=shutil.ignore_patterns("__pycache__"))
    callee = pkg / "rfsim" / "core" / "_probe_callee_kernels.py"
    callee.write_text(_CALLEE)
    (pkg / "rfsim" / "core" / "_probe_caller_kernels.py").write_text(_CALLER)
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env["PYTHONPATH"] = f"{pkg}{os.pathsep}{ROOT}"

    def run():
        out = subprocess.run([sys.executable, "-c", _CALL_AND_ANNOUNCE], capture_output=True, text=True, env=env,
                             cwd=tmp_path)  # not the checkout: "-c" puts the working folder first on sys.path
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout.strip().splitlines()[-1])

    first, again = run(), run()
    callee.write_text(_CALLEE.replace("SCALE = 3", "SCALE = 5"))
    edited = run()
    assert [first[:2], again[:2], edited[:2]] == [[7, 1], [7, 0], [11, 1]]
    assert first[2] == again[2] != edited[2]
    assert Path(first[2]).parent == Path(edited[2]).parent == (pkg / "rfsim" / "__pycache__").resolve()
    assert Path(first[2]).is_dir()  # the earlier sources' folder is left for a process still using it


def test_kernels_cached_in_a_chosen_folder_are_loaded_by_the_next_process(tmp_path):
    """With the cache in a folder of its own (what a non-editable install gets), the first
    process compiles and writes the kernel there, the second finds it cached
    (uncached_kernels() is empty before any call) — the mechanism the first-run notice and
    the worker processes rely on. A NUMBA_CACHE_DIR of the user's holds the folder named
    after the kernel sources' hash. (As root, a read-only package folder cannot be simulated
    here; the folder choice itself is tested above.)"""
    src = _module_folder(tmp_path, "kmod", "from rfsim.core._jit import njit\n\n\n@njit\ndef twice(x):\n    return 2 * x\n")
    code = ("import kmod\nfrom rfsim.core import _jit\nprint(len(_jit.uncached_kernels()))\n"
            "assert kmod.twice(21) == 42\nprint(len(_jit.uncached_kernels()))")
    env = dict(os.environ, PYTHONPATH=f"{src}{os.pathsep}{ROOT}", NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
            .stdout.split() for _ in range(2)]
    assert runs == [["1", "0"], ["0", "0"]]
    (folder,) = (tmp_path / "cache").iterdir()
    assert folder.name.startswith("rfsim-kernels-") and any(folder.rglob("*twice*.nbi"))


def test_cache_folder_applies_when_numba_was_imported_first(tmp_path):
    """A script that imports numba before rfsim: numba has read the environment already, yet a
    kernel declared afterwards is cached in the folder rfsim chose for an unwritable package
    ($XDG_CACHE_HOME/rfsim/numba/rfsim-kernels-<hash>). The unwritable folder is simulated by making the write probe
    fail while rfsim.core._jit is imported (as root, permissions cannot stop the write)."""
    src = _module_folder(tmp_path, "kfirst", "from rfsim.core._jit import njit\n\n\n@njit\ndef thrice(x):\n    return 3 * x\n")
    code = ("import numba, tempfile\n"
            "real = tempfile.NamedTemporaryFile\n"
            "def refuse(*a, **k):\n    raise OSError('read-only')\n"
            "tempfile.NamedTemporaryFile = refuse\n"
            "import rfsim.core._jit\n"
            "tempfile.NamedTemporaryFile = real\n"
            "import kfirst\nassert kfirst.thrice(14) == 42\n"
            "print(numba.config.CACHE_DIR)")
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(PYTHONPATH=f"{src}{os.pathsep}{ROOT}", XDG_CACHE_HOME=str(tmp_path / "xdg"))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    chosen = Path(out.stdout.strip())
    assert chosen.parent == tmp_path / "xdg" / "rfsim" / "numba" and chosen.name.startswith("rfsim-kernels-")
    assert any(chosen.rglob("*thrice*.nbi"))
    assert not list(src.rglob("*.nbi"))  # not beside the source


_PILOT_TASK = """
import os
from rfsim.core._jit import njit


@njit
def twice(x):
    return 2 * x


def task(i):
    n = len(twice.signatures)  # overloads this process held before the task called it
    assert twice(i) == 2 * i
    return os.getpid(), n
"""

_PILOT_RUN = """
import json, os
import kpilot
from rfsim.core.procs import map_in_order

out = map_in_order(kpilot.task, range(4), 2, desc="t", unit="tasks")
print(json.dumps(dict(leader=os.getpid(), out=out, leader_signatures=len(kpilot.twice.signatures),
                      hits=sum(kpilot.twice._cache_hits.values()), misses=sum(kpilot.twice._cache_misses.values()))))
"""


def test_first_task_runs_in_a_pilot_and_the_leader_loads_its_kernels_before_the_pool(tmp_path):
    """With an empty cache, map_in_order runs the first task alone in a pilot process, which
    compiles the kernel; the leader then loads it from the cache (a cache hit, no compilation
    in the leader) before the other workers start, so the forked workers hold it when their
    tasks begin."""
    import multiprocessing

    if multiprocessing.get_start_method() != "fork":
        pytest.skip("workers inherit the leader's kernels only when forked")
    (tmp_path / "kpilot.py").write_text(_PILOT_TASK)
    env = dict(os.environ, PYTHONPATH=f"{tmp_path}{os.pathsep}{ROOT}", NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    run = subprocess.run([sys.executable, "-c", _PILOT_RUN], capture_output=True, text=True, env=env, check=True)
    got = json.loads(run.stdout.strip().splitlines()[-1])
    (pilot, pilot_held), *rest = got["out"]
    assert pilot != got["leader"] and pilot_held == 0
    # the later tasks run in the pilot (its kernel compiled) or in workers forked after the
    # leader loaded it: every one holds the kernel when it starts
    assert all(pid != got["leader"] for pid, _ in rest) and any(pid != pilot for pid, _ in rest)
    assert all(held >= 1 for _, held in rest)
    assert got["leader_signatures"] == 1 and got["hits"] == 1 and got["misses"] == 0


def test_bench_runs_a_command_as_a_child_and_reads_its_usage():
    """rfsim.bench.startup times a whole command in its own process: a user error's exit
    status comes back (2), and a command that ran reports CPU time and its own peak — at
    least the interpreter's size (≥ 5 MB), and not the benchmark's: with 150 MB held here,
    ``rfsim --help`` (≈ 18 MB) must stay below 100 MB (a child forked from this process
    directly would report this process's high-water mark)."""
    import numpy as np

    from rfsim.bench.startup import run_measured

    held = np.ones(150 * 2**20 // 8)  # 150 MB, written
    assert run_measured(["config", "no-such-scenario"])["exit_status"] == 2
    r = run_measured(["--help"])
    assert r["exit_status"] == 0 and r["cpu_s"] > 0 and r["wall_s"] > 0 and 5 <= r["peak_rss_mb"] < 100
    assert held.sum() == held.size

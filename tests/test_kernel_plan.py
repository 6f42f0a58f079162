"""rfsim.runs.kernel_plan: a scenario's kernels listed with their argument types, compiled in
several child processes at once before a cold run; the run then compiles nothing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from numba.core import types

from rfsim.runs import kernel_plan as kp

ROOT = Path(__file__).resolve().parents[1]
needs_fork = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")


@pytest.mark.parametrize("t, text", [
    (types.float64, "float64"),
    (types.int64, "int64"),
    (types.boolean, "bool"),
    (types.complex128, "complex128"),
    (types.Array(types.float64, 1, "C"), "float64[::1]"),
    (types.Array(types.uint8, 1, "A"), "uint8[:]"),
    (types.Array(types.complex128, 1, "C", readonly=True), "readonly complex128[::1]"),
    (types.Array(types.float64, 2, "C", readonly=True), "readonly float64[:, ::1]"),
    (types.Array(types.int64, 2, "A"), "int64[:, :]"),
])
def test_a_type_is_written_as_its_text_and_read_back(t, text):
    assert kp.text_of_type(t) == text
    assert kp.type_of_text(text) == t


def test_types_a_plan_does_not_hold_are_left_out():
    assert kp.text_of_type(types.UniTuple(types.float64, 2)) is None
    assert kp.text_of_type(types.Array(types.float64, 1, "F")) is None
    entries = kp.entries_of([("m", "k", (types.float64, types.UniTuple(types.float64, 2))),
                             ("m", "j", (types.int64,)), ("m", "j", (types.int64,))])
    assert entries == [kp.PlanEntry("m", "j", ("int64",))]  # the tuple's overload left out, j once


@pytest.mark.parametrize("line", ["m.k(float64)", "m:k float64", "m:k(float65)", "m:k(readonly float64)",
                                  "m:k(float64[::1, :])", "m:k(float64[::2])"])
def test_a_bad_entry_is_refused(line):
    with pytest.raises(ValueError):
        kp.PlanEntry.parse(line)


def test_an_entry_with_a_2d_array_reads_back_whole():
    line = "a.b:k(readonly float64[:, ::1], int64)"
    entry = kp.PlanEntry.parse(line)
    assert entry.signature == ("readonly float64[:, ::1]", "int64")
    assert entry.text() == line


def test_the_shipped_plans_name_declared_kernels_with_types_they_read():
    plans = kp.read_plans()
    assert "link" in plans and plans["link"]
    for name, entries in plans.items():
        for entry in entries:
            assert kp._kernel(entry) is not None, f"{name}: {entry.text()} is not a declared kernel"
            for t in entry.signature:
                kp.type_of_text(t)


def test_plans_file_round_trip(tmp_path):
    plans = {"b": [kp.PlanEntry("m", "k", ("float64[::1]",), compile_s=1.25)], "a": []}
    kp.write_plans(plans, tmp_path / "p.json")
    assert kp.read_plans(tmp_path / "p.json") == plans
    assert kp.read_plans(tmp_path / "p.json")["b"][0].compile_s == 1.25
    assert list(json.loads((tmp_path / "p.json").read_text())["plans"]) == ["a", "b"]
    assert kp.read_plans(tmp_path / "absent.json") == {}
    (tmp_path / "bad.json").write_text(json.dumps({"format": 99, "plans": {}}))
    with pytest.raises(ValueError):
        kp.read_plans(tmp_path / "bad.json")


def test_shares_deal_the_longest_compilations_first_onto_the_least_loaded_share():
    times = {"a": 7.0, "b": 3.0, "c": 3.0, "d": 2.0, "e": 1.0, "f": 0.0}
    items = [(kp.PlanEntry("m", k, (), compile_s=t), None) for k, t in times.items()]
    out = kp.shares(items, 2)
    names = [[e.name for e, _ in share] for share in out]
    # LPT: a(7) → 0; b(3) → 1; c(3) → 1 (3 < 7); d(2) → 0 (7 < 6? no: 1 holds 6) → 1 ... by hand:
    # loads 0: a=7; 1: b+c=6, then d → 1 (6 < 7): 8; e(1) → 0: 8; f (no time: weighs 1) → 0 (8 ≤ 8): 9
    assert names == [["a", "e", "f"], ["b", "c", "d"]]
    assert kp.shares(items, 1) == [items] and len(kp.shares(items[:1], 4)) == 1


_KERNELS = ("from rfsim.core._jit import njit\n\n\n@njit\ndef twice(x):\n    return 2 * x\n\n\n"
            "@njit\ndef twice_plus_one(x):\n    return twice(x) + 1\n\n\n"
            "@njit\ndef scaled(a, s):\n    return a * s\n")

_PRECOMPILE = """
import json, sys
import numpy as np
from rfsim.core._jit import compiling_elsewhere
from rfsim.core.procs import run_in_child
from rfsim.runs import kernel_plan as kp
import kmod

plan = [kp.PlanEntry.parse(line) for line in ("kmod:twice_plus_one(int64)", "kmod:scaled(float64[::1], float64)")]
given = kp.precompile(plan, processes=int(sys.argv[1]))
asked = []
def run(task, while_waiting=None):  # a compilation the run still needs: recorded, done in a child
    asked.append(1)
    run_in_child(task)
with compiling_elsewhere(run):
    values = [kmod.twice_plus_one(20), float(kmod.scaled(np.ones(3), 2.0).sum())]
stats = {n: [len(getattr(kmod, n).stats.cache_misses), len(getattr(kmod, n).stats.cache_hits)]
         for n in ("twice_plus_one", "scaled")}
print(json.dumps([given, len(asked), values, stats, kp.precompile(plan, processes=2)]))
"""


def _precompile(tmp_path: Path, processes: int) -> list:
    src = tmp_path / "src"
    src.mkdir(exist_ok=True)
    (src / "kmod.py").write_text(_KERNELS)
    env = dict(os.environ, PYTHONPATH=f"{src}{os.pathsep}{ROOT}", NUMBA_CACHE_DIR=str(tmp_path / f"cache{processes}"))
    out = subprocess.run([sys.executable, "-c", _PRECOMPILE, str(processes)], capture_output=True, text=True, env=env,
                         cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


@needs_fork
def test_a_plan_is_compiled_in_children_before_the_run_which_then_compiles_nothing(tmp_path):
    """Two children compile the plan's two kernels (one module: one share, since they may share
    helpers): the run asks for no compilation and loads both kernels from the cache (a hit, no
    miss); a second precompile finds them cached and gives nothing to do."""
    given, asked, values, stats, again = _precompile(tmp_path, 2)
    assert given == 2 and asked == 0 and again == 0
    assert values == [41, 6.0]
    assert stats == {"twice_plus_one": [0, 1], "scaled": [0, 1]}


@needs_fork
def test_with_one_process_nothing_is_precompiled_and_the_run_compiles_as_before(tmp_path):
    """Control: with one process the plan is left alone; the run asks for both kernels."""
    given, asked, values, _, _ = _precompile(tmp_path, 1)
    assert given == 0 and asked == 2 and values == [41, 6.0]


_LINK_COMPLETE = """
import json
from rfsim.core._jit import compiling_elsewhere
from rfsim.core.procs import run_in_child
from rfsim.runs import kernel_plan as kp
from rfsim.runs.registry import builtin_modules

given = kp.precompile(kp.read_plans()["link"], processes=2)
asked = []
def run(task, while_waiting=None):
    asked.append(1)
    run_in_child(task)
module = builtin_modules()["link"]
with compiling_elsewhere(run):
    module.run(module.Config(), seed=1)
print(json.dumps([given, len(asked)]))
"""


@pytest.mark.slow
@needs_fork
def test_the_link_plan_leaves_its_default_run_nothing_to_compile(tmp_path):
    """The shipped plan of ``link`` is complete: after it is compiled into an empty cache, the
    scenario's default run compiles no kernel (a stale plan — a kernel added to the run's path
    but not to the plan — fails here; remake it with ``python -m rfsim.runs.kernel_plan link``)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    out = subprocess.run([sys.executable, "-c", _LINK_COMPLETE], capture_output=True, text=True, env=env,
                         cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    given, asked = json.loads(out.stdout.strip().splitlines()[-1])
    assert given == len(kp.read_plans()["link"]) and asked == 0


def _names(dealt):
    return [[e.name for e, _ in share] for share in dealt]


def test_a_callee_is_dealt_to_one_share_and_a_caller_elsewhere_waits_for_it():
    """x is called by a and b (x's two overloads weigh 2.5 + 1.5 s); c and d call nothing.
    Ranks (weight + largest rank of a caller): x 4 + 3 = 7, c 5, a 3, b 2, d 1. Dealt in that
    order onto the share where each ends first, a callee in another share ending before its
    caller starts there: x → 0 (ends 4; tie with 1 → lower share); c → 1 (5 < 4 + 5);
    a → 0 (4 + 3 = 7 < max(5, 4) + 3 = 8); b → 1 (max(5, x's 4) + 2 = 7 < 7 + 2); d → 0
    (7 + 1 = 8, tie with 7 + 1 → lower share). Share 1 waits for x (share 0) before b."""
    t = {"a": 3.0, "x": 2.5, "b": 2.0, "c": 5.0, "d": 1.0}
    items = [(kp.PlanEntry("m", k, (), compile_s=t[k]), None) for k in ("a", "x", "b", "c", "d")]
    items.insert(4, (kp.PlanEntry("m", "x", ("int64",), compile_s=1.5), None))
    calls = {("m", "a"): {("m", "x")}, ("m", "b"): {("m", "x")}}
    dealt = kp.shares(items, 2, calls)
    assert _names(dealt) == [["x", "x", "a", "d"], ["c", "b"]]
    assert [e.signature for e, _ in dealt[0][:2]] == [(), ("int64",)]  # overloads in the plan's order
    assert kp.waits(dealt, calls) == [[[], [], [], []], [[], [(("m", "x"), 0)]]]
    # without the call graph: LPT over kernels; b would compile x itself in share 0
    assert _names(kp.shares(items, 2)) == [["c", "b", "d"], ["x", "x", "a"]]


def test_a_chain_is_dealt_callees_first_even_against_the_plan_order():
    """top → mid → leaf, listed callers first: ranks leaf 1 + 2 + 4 = 7, mid 6, top 4; one
    share compiles them leaf, mid, top (the other share has nothing to gain: each would wait)."""
    items = [(kp.PlanEntry("m", k, (), compile_s=w), None) for k, w in (("top", 4.0), ("mid", 2.0), ("leaf", 1.0))]
    calls = {("m", "top"): {("m", "mid")}, ("m", "mid"): {("m", "leaf")}}
    assert _names(kp.shares(items, 2, calls)) == [["leaf", "mid", "top"]]
    assert kp.reached(("m", "top"), calls) == {("m", "mid"), ("m", "leaf")}
    assert kp.reached(("m", "x"), {("m", "x"): {("m", "x")}}) == set()  # a cycle back to itself left out


def _runs_to_the_end(dealt, share_waits) -> bool:
    """Step the shares as the children do (an entry starts once its waits are compiled): True
    when every entry is reached, False on a deadlock."""
    done, pos = set(), [0] * len(dealt)
    while True:
        moved = False
        for s, share in enumerate(dealt):
            while pos[s] < len(share) and all(c in done for c, _ in share_waits[s][pos[s]]):
                e = share[pos[s]][0]
                done.add((e.module, e.name))
                pos[s] += 1
                moved = True
        if not moved:
            return all(p == len(share) for p, share in zip(pos, dealt))


@pytest.mark.parametrize("scenario", ["link", "phase-cancellation", "detection-probability", "reader-detection"])
@pytest.mark.parametrize("n", [2, 3, 4])
def test_the_shipped_plans_compile_each_kernel_once_without_deadlock(scenario, n):
    """Every kernel of a shipped plan is in one share; every plan kernel an entry reaches is an
    earlier entry of its own share or one it waits for; and the waits never block for good."""
    plan = kp.read_plans()[scenario]
    items = [(e, kp._kernel(e)) for e in plan]
    calls = kp.call_graph()
    dealt = kp.shares(items, n, calls)
    share_waits = kp.waits(dealt, calls)
    keys = [[(e.module, e.name) for e, _ in share] for share in dealt]
    assert sorted(k for share in keys for k in set(share)) == sorted({(e.module, e.name) for e in plan})
    planned = {(e.module, e.name) for e in plan}
    for s, share in enumerate(keys):
        for i, key in enumerate(share):
            have = set(share[:i]) | {c for c, _ in share_waits[s][i]}
            assert kp.reached(key, calls) & planned <= have, (scenario, key)
    assert _runs_to_the_end(dealt, share_waits)


def test_the_call_graph_of_the_receiver_names_its_callees():
    """Read by hand from ``receive_kernel``'s source (its calls at the preamble search, the
    preamble fit, the signed half-bit sums, the known levels, the fit and the measurement) and
    from the inline ``signed_sum_decisions`` → ``halfbit_decisions`` it calls (Viterbi)."""
    plan = kp.read_plans()["link"]
    for e in plan:
        kp._kernel(e)
    calls = kp.call_graph()
    receive = calls[("rfsim.gen2._receive_kernels", "receive_kernel")]
    assert {("rfsim.gen2._linecode_kernels", "preamble_search_runs_kernel"),
            ("rfsim.gen2._receive_kernels", "_preamble_fit"),
            ("rfsim.gen2._linecode_kernels", "signed_halfbit_sums_kernel"),
            ("rfsim.gen2._measure_kernels", "known_levels_kernel"),
            ("rfsim.gen2._measure_kernels", "measure_kernel"),
            ("rfsim.gen2._fit_kernels", "fit_gain_offset_kernel"),
            ("rfsim.gen2._linecode_kernels", "viterbi_kernel")} <= receive
    assert ("rfsim.gen2._decode_reply_kernels", "decisions_kernel") not in receive


_GRAPH_KERNELS = ("from rfsim.core._jit import njit, njit_inline\nimport kleaf\nfrom kleaf import leaf\n\n\n"
                  "@njit_inline\ndef helper(x):\n    return leaf(x) + 1\n\n\n"
                  "@njit\ndef by_name(x):\n    return leaf(x)\n\n\n"
                  "@njit\ndef by_attribute(x):\n    return kleaf.other(x)\n\n\n"
                  "@njit\ndef by_inline(x):\n    return helper(x)\n\n\n"
                  "def make(f):\n    @njit\n    def by_closure(x):\n        return f(x)\n    return by_closure\n\n\n"
                  "by_closure = make(kleaf.other)\n\n\n"
                  "@njit\ndef alone(x):\n    return x\n")
_GRAPH_LEAF = ("from rfsim.core._jit import njit\n\n\n@njit\ndef leaf(x):\n    return x\n\n\n"
               "@njit\ndef other(x):\n    return leaf(x) * 2\n")
_GRAPH = """
import json
import kgraph
from rfsim.runs import kernel_plan as kp
print(json.dumps({k[1]: sorted(v[1] for v in vs) for k, vs in kp.call_graph().items() if k[0] in ("kgraph", "kleaf")}))
"""


def test_the_call_graph_reads_calls_by_name_attribute_inlined_helper_and_closure(tmp_path):
    (tmp_path / "kgraph.py").write_text(_GRAPH_KERNELS)
    (tmp_path / "kleaf.py").write_text(_GRAPH_LEAF)
    env = dict(os.environ, PYTHONPATH=f"{tmp_path}{os.pathsep}{ROOT}", NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    out = subprocess.run([sys.executable, "-c", _GRAPH], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout.strip().splitlines()[-1]) == {
        "leaf": [], "other": ["leaf"], "by_name": ["leaf"], "by_attribute": ["other"], "by_inline": ["leaf"],
        "make.<locals>.by_closure": ["other"], "alone": []}


def test_a_wait_ends_at_the_mark_at_the_end_of_its_share_or_for_a_share_that_never_started(tmp_path, monkeypatch):
    folder = str(tmp_path)
    kp._mark(folder, "k0.done")
    kp._wait_for(folder, [("k0.done", 1)])  # the mark is there
    kp._mark(folder, "s1.started")
    kp._mark(folder, "s1.ended")
    kp._wait_for(folder, [("k1.done", 1)])  # its share ended without it (its kernel failed to compile)
    monkeypatch.setattr(kp, "START_S", 0.0)
    kp._wait_for(folder, [("k2.done", 2)])  # share 2 never started (tasks run one after the other)
    monkeypatch.setattr(kp, "START_S", 1e9)
    monkeypatch.setattr(kp, "WAIT_S", 0.0)
    kp._mark(folder, "s3.started")
    kp._wait_for(folder, [("k3.done", 3)])  # share 3 started and never ended (killed): waited no longer

"""Caches live in the run's objects, not in modules (issue 30 item 2).

An ``ast`` scan of the exchange path (rfsim/air, rfsim/protocols, devices/reader*.py,
devices/tag*.py, channels/) fails on a ``functools.lru_cache`` / ``functools.cache`` /
``cached_property`` memo and on a named module memo (:class:`rfsim.core.memo.PureCache`) that is
not on the allow-list below with its reason. The run's cache (:class:`rfsim.air.cache.AirCache`)
holds the link-timing table of its exchanges: two runs with their own caches share no entry.
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import pytest

from rfsim.air.cache import AirCache, TimingKey
from rfsim.channels import Antenna, Channel, HalfWaveDipole, Patch, Scene
from rfsim.core.memo import PureCache
from rfsim.core.rng import trial_rng
from rfsim.devices.reader import Reader, ReaderConfig
from rfsim.devices.tag import PassiveTag, TagConfig
from rfsim.gen2.commands import Query
from rfsim.gen2.link import reply_window_s, t1
from rfsim.protocols.engine import singulate

ROOT = Path(__file__).resolve().parents[1]
#: The exchange path: packages scanned whole, and file patterns of devices/.
SCANNED_DIRS = ("rfsim/air", "rfsim/protocols", "channels")
SCANNED_GLOBS = ("devices/reader*.py", "devices/tag*.py")
#: Names of decorators (bare, ``functools.``-qualified, called or not) that make a hidden memo.
MEMO_DECORATORS = {"lru_cache", "cache", "cached_property"}

#: Memos kept on the exchange path, ``(path, name) → reason``.
ALLOWED = {
    ("channels/antennas.py", "rotation"): "per-instance: an antenna's rotation matrix from its own immutable "
                                         "orientation, made with the antenna and gone with it",
    ("channels/antennas.py", "_boresight_and_up"): "per-instance: the panel's axes from its own rotation",
    ("channels/geometry.py", "rotation"): "per-instance: an orientation's rotation matrix from its own angles",
    ("devices/tag_chip.py", "_table"): "per-instance: a chip's impedance table as arrays from its own immutable data",
    ("channels/small_scale.py", "AVERAGE_PROFILE_CACHE"): "PureCache of a pure function of K, τrms and the profile "
                                                         "options (an iterative fit, not run state); a channel "
                                                         "keeps its tap terms itself",
}


def _scanned() -> list[Path]:
    paths = [p for d in SCANNED_DIRS for p in (ROOT / d).rglob("*.py")]
    paths += [p for g in SCANNED_GLOBS for p in ROOT.glob(g)]
    return sorted(p for p in set(paths) if "__pycache__" not in p.parts)


def _decorator_name(node: ast.AST) -> str | None:
    if isinstance(node, ast.Call):
        node = node.func
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Name):
        return node.id
    return None


def memos(tree: ast.AST) -> list[tuple[str, str]]:
    """``(name, kind)`` of every memo in a module: functions and methods with a memo decorator,
    module-level names bound to a memo call (``f = lru_cache(...)(g)``, ``X = PureCache(g, n)``)."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for dec in node.decorator_list:
                if _decorator_name(dec) in MEMO_DECORATORS:
                    found.append((node.name, _decorator_name(dec)))
    for node in getattr(tree, "body", []):
        if isinstance(node, (ast.Assign, ast.AnnAssign)) and isinstance(node.value, ast.Call):
            call = node.value
            inner = call.func if isinstance(call.func, ast.Call) else call
            kind = _decorator_name(inner)
            if kind in MEMO_DECORATORS | {"PureCache"}:
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                found += [(t.id, kind) for t in targets if isinstance(t, ast.Name)]
    return found


def test_the_scan_finds_every_kind_of_memo():
    src = (
        "import functools\nfrom functools import lru_cache, cached_property\n"
        "@functools.lru_cache(maxsize=8)\ndef a(x): return x\n"
        "@lru_cache\ndef b(x): return x\n"
        "@functools.cache\ndef c(x): return x\n"
        "class K:\n    @cached_property\n    def d(self): return 1\n"
        "e = functools.lru_cache(maxsize=4)(a)\n"
        "F = PureCache(a, 4)\n"
        "def plain(x): return x\n"
    )
    assert sorted(memos(ast.parse(src))) == [("F", "PureCache"), ("a", "lru_cache"), ("b", "lru_cache"),
                                             ("c", "cache"), ("d", "cached_property"), ("e", "lru_cache")]


def test_no_hidden_memo_on_the_exchange_path():
    paths = _scanned()
    rels = {p.relative_to(ROOT).as_posix() for p in paths}
    assert {"rfsim/protocols/engine.py", "devices/reader.py", "devices/tag.py", "devices/tag_frontend.py",
            "channels/small_scale.py", "rfsim/air/cache.py"} <= rels
    found = {(p.relative_to(ROOT).as_posix(), name): kind
             for p in paths for name, kind in memos(ast.parse(p.read_text(), filename=str(p)))}
    assert not sorted(set(found) - set(ALLOWED)), "memos outside the run's objects (put them in its cache)"
    assert not sorted(set(ALLOWED) - set(found)), "allow-list entries that are gone: remove them"


def test_pure_cache_gives_the_function_value_and_is_bounded():
    calls = []

    def square(x):
        calls.append(x)
        return x * x

    memo = PureCache(square, 2)
    assert [memo(3), memo(3), memo(4)] == [9, 9, 16] and calls == [3, 4]
    memo(5)  # beyond 2 entries: the oldest (3) dropped
    assert list(memo.entries) == [(4,), (5,)]
    assert memo(3) == 9 and calls == [3, 4, 5, 3]
    memo.clear()
    assert not memo.entries
    with pytest.raises(ValueError):
        PureCache(square, 0)


READER_ANTENNA = Antenna(position_m=(0.0, 0.0, 1.0), orientation=(0.0, 0.0, 0.0), pattern=Patch(6.0, 70.0),
                         polarization="circular")


def _round(cache: AirCache, seed: int):
    reader = Reader(ReaderConfig(hopping=False), [READER_ANTENNA], rng=trial_rng(seed, 0), air_cache=cache)
    tag = PassiveTag(TagConfig(), Antenna(position_m=(1.5, 0.0, 1.0), orientation=(math.pi, 0.0, 0.0),
                                          pattern=HalfWaveDipole(), polarization="linear"), rng=trial_rng(seed, 1))
    lk = reader.link
    rounds = singulate(reader, [tag], Channel(Scene()), t_s=0.0, rng=trial_rng(seed, 2),
                       query=Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0))
    return reader, rounds


def test_each_run_keeps_its_link_timing_in_its_own_cache():
    a, b = AirCache(), AirCache()
    reader, rounds = _round(a, 3)
    assert rounds[-1].read is not None and rounds[-1].read.success  # Query and ACK both ran
    assert not b.timings  # another run's cache: nothing from run a
    keys = list(a.timings)
    assert keys and all(isinstance(k, TimingKey) and k.link == reader.link for k in keys)
    rules = {k.rule.__name__ for k in keys}
    assert {"t1", "_listen_window_s", "_ack_delays"} <= rules
    # the values are the rules' own, computed here from the link functions
    lk = reader.link
    assert a.timings[TimingKey(t1, lk, ())] == t1(lk)
    window = next(v for k, v in a.timings.items() if k.rule.__name__ == "_listen_window_s" and k.args[0] == 16)
    assert window == reply_window_s(lk, 16)  # no BLF search: the nominal window
    ack = next(v for k, v in a.timings.items() if k.rule.__name__ == "_ack_delays")
    assert (ack.reply_s, ack.t2_s) == (lk.reply_duration_s(16), 10.0 * lk.tpri_s)

    _round(b, 3)
    assert set(b.timings) == set(a.timings)  # the same keys (the profile by value) ...
    a.timings.clear()
    assert b.timings  # ... held by each run on its own
    assert all(b.timings[k] is not None for k in b.timings)


def test_link_timing_is_computed_once_per_key():
    cache, calls = AirCache(), []

    def rule(link, n):
        calls.append((link, n))
        return 2.0 * n

    assert cache.link_timing(rule, "lk", 3) == cache.link_timing(rule, "lk", 3) == 6.0
    assert cache.link_timing(rule, "lk", 4) == 8.0
    assert calls == [("lk", 3), ("lk", 4)]
    assert list(cache.timings) == [TimingKey(rule, "lk", (3,)), TimingKey(rule, "lk", (4,))]

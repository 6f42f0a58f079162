"""The exchange is written once and the air step reads as stages (issue "One exchange core",
items 1 and 2), checked on the source: the single exchange is the batch of one, every function
of the air step is short, the air step keeps no module-level caches, and the caches of the
links, scenes and channel hold named entries that keep the objects whose id() keys them."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import rfsim.air
from rfsim.air import step
from rfsim.protocols import batch, engine

from code_lines import code_lines, docstring_lines

AIR_DIR = Path(rfsim.air.__file__).parent


def _calls(func) -> set[str]:
    tree = ast.parse(inspect.getsource(func).lstrip())
    return {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}


def test_one_exchange_function():
    # run_exchange and singulate delegate to their batches and do nothing else of their own
    assert "run_exchanges" in _calls(engine.run_exchange)
    assert "singulate_batch" in _calls(engine.singulate)
    for single in (engine.run_exchange, engine.singulate):
        body = ast.parse(inspect.getsource(single)).body[0].body
        assert len(body) == 2 and isinstance(body[1], ast.Return), single.__name__  # docstring, return
    # the batch module holds no second implementation: it re-exports the engine's
    assert batch.run_exchanges is engine.run_exchanges and batch.singulate_batch is engine.singulate_batch
    assert not [n for n in ast.parse(inspect.getsource(batch)).body if isinstance(n, (ast.FunctionDef, ast.ClassDef))]


def test_air_step_functions_are_short():
    long = []
    for path in sorted(AIR_DIR.glob("*.py")):
        tree = ast.parse(path.read_text())
        docs = docstring_lines(tree)  # lines of code: the numpydoc text does not count
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and code_lines(node, docs) >= 80:
                long.append(f"{path.name}:{node.name}")
    assert not long


def test_air_keeps_no_module_level_caches():
    # a module-level dict or list filled at run time is a cache shared by every run: the air
    # step's caches live in the run's AirCache (rfsim.air.cache)
    found = []
    for path in sorted(AIR_DIR.glob("*.py")):
        for node in ast.parse(path.read_text()).body:
            targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
            value = getattr(node, "value", None)
            if isinstance(value, (ast.Dict, ast.List)) and not (isinstance(value, ast.List) and value.elts) \
                    and not (isinstance(value, ast.Dict) and value.keys):
                found += [f"{path.name}:{t.id}" for t in targets if isinstance(t, ast.Name) and t.id != "__all__"]
    # the numba wrappers' compiled entry points and tables are not caches of run data
    assert sorted(found) == ["_noise_kernels.py:_ENTRY", "_noise_kernels.py:_TABLES"]


STAGES = ["emit", "draw_links", "reflect", "superpose", "noise", "receive"]


def test_air_step_reads_as_six_stages():
    # propagate's body calls the six stages of the air step, in this order; it and each
    # stage (superpose_noise: stages 4 and 5 in one) is a module-level function of under 80 lines
    # of code whose numpydoc says its shapes
    tree = ast.parse(inspect.getsource(step.propagate))
    calls = sorted((n.lineno, n.col_offset, n.func.id) for n in ast.walk(tree)
                   if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in STAGES)
    assert [name for _, _, name in calls] == STAGES
    source = Path(step.__file__).read_text()
    module = ast.parse(source)
    docs = docstring_lines(module)
    defs = {n.name: n for n in module.body if isinstance(n, ast.FunctionDef)}
    for name in ["propagate", *STAGES, "superpose_noise"]:  # the step itself and its stages
        node = defs[name]
        assert code_lines(node, docs) < 80, name
        doc = ast.get_docstring(node)
        assert "Parameters\n----------" in doc and "Returns\n-------" in doc, name
        assert "(…, n)" in doc and "complex128" in doc and "[√W]" in doc, name  # the shapes and units


def _id_keyed_module_dicts(path: Path) -> list[str]:
    """Module-level names of ``path`` that are subscripted or ``.get``/``.setdefault``-ed with a key
    built from ``id(...)`` anywhere in the module (a cache shared by every run, keyed by identity)."""
    tree = ast.parse(path.read_text())
    module_names = set()
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
        module_names |= {t.id for t in targets if isinstance(t, ast.Name)}

    def has_id_call(expr) -> bool:
        return any(isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == "id"
                   for n in ast.walk(expr))

    found = []
    for n in ast.walk(tree):
        if isinstance(n, ast.Subscript) and isinstance(n.value, ast.Name) and n.value.id in module_names:
            if has_id_call(n.slice):
                found.append(f"{path.name}:{n.value.id}")
        elif (isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute) and isinstance(n.func.value, ast.Name)
              and n.func.value.id in module_names and n.func.attr in ("get", "setdefault", "pop") and n.args
              and has_id_call(n.args[0])):
            found.append(f"{path.name}:{n.func.value.id}")
    return found


def test_no_module_level_dict_keyed_by_id():
    # the core and the top-level folders it installs as rfsim.channels, .devices, .scenarios
    root = Path(rfsim.__file__).parent
    dirs = [root] + [root.parent / name for name in ("channels", "devices", "scenarios")]
    paths = sorted(p for d in dirs for p in d.rglob("*.py"))
    assert len(paths) > 100
    found = [hit for path in paths for hit in _id_keyed_module_dicts(path)]
    assert not found


def test_id_keyed_dict_check_can_fail(tmp_path):
    # the check above finds a module-level cache keyed by identity (by subscript and by .get)
    bad = tmp_path / "bad.py"
    bad.write_text("_CACHE = {}\n\ndef f(x):\n    hit = _CACHE.get(id(x))\n    _CACHE[(id(x), 1)] = x\n")
    assert _id_keyed_module_dicts(bad) == ["bad.py:_CACHE", "bad.py:_CACHE"]


# ---------------------------------------------------------------- cache entries: named, kept alive

_LOOKUPS = ("get", "pop", "setdefault")
_HOLDING = ("held", "cache", "memo")


def _id_args(expr) -> list:
    """The arguments of the ``id(...)`` calls in ``expr``."""
    return [n.args[0] for n in ast.walk(expr) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)
            and n.func.id == "id" and len(n.args) == 1]


def _keeps(entry, objects) -> bool:
    """Whether ``entry`` is a constructor call that is given every one of ``objects``."""
    if not isinstance(entry, ast.Call):
        return False
    given = {ast.dump(a) for a in [*entry.args, *(k.value for k in entry.keywords)]}
    return all(ast.dump(o) in given for o in objects)


def cache_entry_problems(path: Path) -> list[str]:
    """Cache entries of ``path`` that are tuples read by position or keyed by id() without their object.

    Per function: a tuple stored as a dict entry (except in a dict of the function's own not
    keyed by id()); a dict entry or dict display keyed by ``id(x)`` whose value is not a
    constructor call given ``x``; a tuple or a set of ids held in ``self.<held/cache/memo…>``;
    and a value looked up in a dict (``.get``/``.pop``/``.setdefault``) or held in such an
    attribute read by an integer index or unpacked.
    """
    tree = ast.parse(path.read_text())
    found = []
    for func in ast.walk(tree):
        if not isinstance(func, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        local_dicts, assigned, looked_up = set(), {}, set()
        for n in ast.walk(func):
            if isinstance(n, (ast.Assign, ast.AnnAssign)) and n.value is not None:
                targets = n.targets if isinstance(n, ast.Assign) else [n.target]
                for t in targets:
                    if isinstance(t, ast.Name):
                        assigned.setdefault(t.id, []).append(n.value)
                        if isinstance(n.value, (ast.Dict, ast.DictComp)):
                            local_dicts.add(t.id)

        def is_lookup(expr) -> bool:
            for n in ast.walk(expr):
                if (isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute) and n.func.attr in _LOOKUPS
                        and not (isinstance(n.func.value, ast.Name) and n.func.value.id in local_dicts)):
                    return True
            return False

        for name, values in assigned.items():
            if any(map(is_lookup, values)):
                looked_up.add(name)
        where = f"{path.name}:{func.name}"
        for n in ast.walk(func):
            if isinstance(n, ast.Assign):
                for t in n.targets:
                    if isinstance(t, ast.Subscript):
                        if isinstance(t.slice, ast.Constant) and isinstance(t.slice.value, str):
                            continue  # a named slot of an object
                        keys = assigned.get(t.slice.id, [t.slice]) if isinstance(t.slice, ast.Name) else [t.slice]
                        ids = [a for k in keys for a in _id_args(k)]
                        own = isinstance(t.value, ast.Name) and t.value.id in local_dicts
                        if isinstance(n.value, ast.Tuple) and (ids or not own):
                            found.append(f"{where}: tuple entry")
                        if ids and not _keeps(n.value, ids):
                            found.append(f"{where}: id() key without its object")
                    elif (isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name) and t.value.id == "self"):
                        if isinstance(n.value, ast.Tuple) and any(w in t.attr for w in _HOLDING):
                            found.append(f"{where}: tuple held in self.{t.attr}")
                        if isinstance(n.value, (ast.Set, ast.SetComp)) and _id_args(n.value):
                            found.append(f"{where}: set of id() in self.{t.attr}")
                    if isinstance(t, ast.Tuple) and (
                            (isinstance(n.value, ast.Name) and n.value.id in looked_up) or
                            (isinstance(n.value, ast.Call) and isinstance(n.value.func, ast.Attribute)
                             and n.value.func.attr in _LOOKUPS and is_lookup(n.value)) or
                            (isinstance(n.value, ast.Attribute) and any(w in n.value.attr for w in _HOLDING))):
                        found.append(f"{where}: entry unpacked by position")
            if isinstance(n, (ast.Dict, ast.DictComp)):
                pairs = zip(n.keys, n.values) if isinstance(n, ast.Dict) else [(n.key, n.value)]
                for k, v in pairs:
                    ids = _id_args(k) if k is not None else []
                    if ids and not _keeps(v, ids):
                        found.append(f"{where}: id() key without its object")
            if (isinstance(n, ast.Subscript) and isinstance(n.ctx, ast.Load) and isinstance(n.slice, ast.Constant)
                    and isinstance(n.slice.value, int)
                    and ((isinstance(n.value, ast.Name) and n.value.id in looked_up) or is_lookup(n.value))):
                found.append(f"{where}: entry read by position")
    return found


ROOT = Path(rfsim.__file__).parent
#: The files whose caches were made named and kept alive (issue 30, item 2).
CACHE_FILES = ([ROOT / "air" / "links.py", ROOT / "air" / "cache.py", ROOT / "protocols" / "inventory.py",
                ROOT / "sweep" / "runner.py", ROOT.parent / "devices" / "tag.py",
                ROOT.parent / "devices" / "tag_population.py", ROOT.parent / "devices" / "reader_tx.py"]
               + sorted((ROOT / "scenes").glob("*.py")) + sorted((ROOT.parent / "channels").glob("*.py")))


def test_cache_entries_are_named_and_keep_their_id_keys_alive():
    assert len(CACHE_FILES) > 30
    found = [hit for path in CACHE_FILES for hit in cache_entry_problems(path)]
    assert not found


BAD_CACHES = """
class Table:
    def __init__(self, antennas):
        self.ids = {id(a) for a in antennas}
        self.by_id = {id(a): 1.0 for a in antennas}

    def add(self, tx, rx, paths):
        self._table[(id(tx), id(rx))] = (tx, rx, paths)

    def gain(self, paths, fc_hz):
        key = (id(paths), fc_hz)
        self.memo[key] = paths.constant_gain(fc_hz)

    def paths(self, tx, rx):
        hit = self._table.get((id(tx), id(rx)))
        return hit[2]

    def hold(self, j, tag):
        self._held = (j, tag)

    def held(self):
        j, tag = self._held
        a, b = self.links.get(j)
        return self.links.get(tag)[0]
"""

GOOD_CACHES = """
class Table:
    def add(self, tx, rx, paths):
        self._table[(id(tx), id(rx))] = HeldLink(tx, rx, paths)
        self.motions = {id(m.antenna): AntennaMotion(m.antenna, m.motion) for m in ()}

    def check(self, antennas):
        seen = {}
        for a in antennas:
            other = seen.get(a.key)
            seen[a.key] = (a.name, a)
            if other is not None and other[1] is not a:
                raise ValueError(other[0])

    def paths(self, tx, rx):
        hit = self._table.get((id(tx), id(rx)))
        return hit.paths
"""


def test_cache_entry_check_can_fail(tmp_path):
    bad, good = tmp_path / "bad.py", tmp_path / "good.py"
    bad.write_text(BAD_CACHES)
    good.write_text(GOOD_CACHES)
    assert sorted(cache_entry_problems(bad)) == sorted([
        "bad.py:__init__: set of id() in self.ids", "bad.py:__init__: id() key without its object",
        "bad.py:add: tuple entry", "bad.py:add: id() key without its object",
        "bad.py:gain: id() key without its object", "bad.py:paths: entry read by position",
        "bad.py:hold: tuple held in self._held", "bad.py:held: entry unpacked by position",
        "bad.py:held: entry unpacked by position", "bad.py:held: entry read by position"])
    assert cache_entry_problems(good) == []

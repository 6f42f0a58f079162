"""The exchange is written once and the air step reads as stages (issue "One exchange core",
items 1 and 2), checked on the source: the single exchange is the batch of one, every function
of the air step is short, and the air step keeps no module-level caches."""

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
    # propagate's body calls the six stages of the air step, in this order; each is a
    # module-level function of under 80 lines of code whose numpydoc says its shapes
    tree = ast.parse(inspect.getsource(step.propagate))
    calls = sorted((n.lineno, n.col_offset, n.func.id) for n in ast.walk(tree)
                   if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in STAGES)
    assert [name for _, _, name in calls] == STAGES
    source = Path(step.__file__).read_text()
    module = ast.parse(source)
    docs = docstring_lines(module)
    defs = {n.name: n for n in module.body if isinstance(n, ast.FunctionDef)}
    for name in STAGES:
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

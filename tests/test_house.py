"""The house rules of the tree (DESIGN.md "Layout"), scanned with ``ast``:

* no module of the core (``rfsim/``), ``channels/`` or ``devices/`` over 700 lines of code, and
  no function there over 120, but for the exceptions listed below, each with its reason (lines
  of code: docstrings, the API reference's numpydoc text, are not counted; every limit here);
* scenarios only compose: no scenario over 400 lines counting every ``scenarios/_*.py`` helper it
  imports (directly or through another helper) except its figure modules, and no numba kernel in
  ``scenarios/``; the figures live in ``scenarios/_*_figures.py`` modules (and the shared
  ``_captions.py``), each at most 400 lines too: a scenario module holds the config, the
  composition and the tables, its figure module only draws from the dataset;
* every room of the core says in its ``__init__`` docstring what it holds.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from code_lines import code_lines, docstring_lines

ROOT = Path(__file__).resolve().parents[1]
MAX_MODULE_LINES = 700
MAX_FUNCTION_LINES = 120
MAX_SCENARIO_LINES = 400

#: (path, function) → why it stays longer than MAX_FUNCTION_LINES.
LONG_FUNCTIONS: dict[tuple[str, str], str] = {}
#: path → why it stays longer than MAX_MODULE_LINES.
LONG_MODULES: dict[str, str] = {}


def _lines(path: Path) -> int:
    """Lines of code of a module: its lines but its docstrings (the API reference's numpydoc
    text is documentation, not code; the limit is on code)."""
    text = path.read_text(encoding="utf-8")
    return len(text.splitlines()) - len(docstring_lines(ast.parse(text)))


def _library_files():
    for folder in ("rfsim", "channels", "devices"):
        yield from sorted((ROOT / folder).rglob("*.py"))


def test_no_long_modules():
    long = {str(p.relative_to(ROOT)): _lines(p) for p in _library_files() if _lines(p) > MAX_MODULE_LINES}
    assert {k: v for k, v in long.items() if k not in LONG_MODULES} == {}
    assert set(LONG_MODULES) <= set(long), "an exception is no longer needed: drop it"


def test_no_long_functions():
    long = {}
    for p in _library_files():
        tree = ast.parse(p.read_text(encoding="utf-8"))
        docs = docstring_lines(tree)
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = code_lines(node, docs)
                if n > MAX_FUNCTION_LINES:
                    long[(str(p.relative_to(ROOT)), node.name)] = n
    assert {k: v for k, v in long.items() if k not in LONG_FUNCTIONS} == {}
    assert set(LONG_FUNCTIONS) <= set(long), "an exception is no longer needed: drop it"


def _helpers_of(path: Path, folder: Path, seen: set[str]) -> set[str]:
    """Names of the ``_*.py`` helper modules of ``folder`` imported by ``path``, transitively."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        names = []
        if isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level:  # from . import _x / from ._x import y
                names = [mod] if mod else [a.name for a in node.names]
            elif mod.startswith("rfsim.scenarios."):
                names = [mod.split(".")[2]]
            elif mod == "rfsim.scenarios":
                names = [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name.split(".")[2] for a in node.names if a.name.startswith("rfsim.scenarios.")]
        elif isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", "")) == "lazy_import" \
                and node.args and isinstance(node.args[0], ast.Constant) \
                and str(node.args[0].value).startswith("rfsim.scenarios."):
            names = [str(node.args[0].value).split(".")[2]]
        for n in names:
            if n.startswith("_") and n not in seen and (folder / f"{n}.py").is_file():
                seen.add(n)
                _helpers_of(folder / f"{n}.py", folder, seen)
    return seen


def _is_figure_module(name: str) -> bool:
    """Helpers that only draw: ``_<name>_figures`` modules and the shared caption helpers."""
    return name.endswith("_figures") or name == "_captions"


def _scenario_sizes() -> dict[str, int]:
    """Lines of each scenario's composition: its module plus the non-figure helpers it imports."""
    folder = ROOT / "scenarios"
    sizes = {}
    for p in sorted(folder.glob("[!_]*.py")):
        helpers = [h for h in _helpers_of(p, folder, set()) if not _is_figure_module(h)]
        sizes[p.stem] = _lines(p) + sum(_lines(folder / f"{h}.py") for h in helpers)
    return sizes


def _figure_module_sizes() -> dict[str, int]:
    folder = ROOT / "scenarios"
    return {p.stem: _lines(p) for p in sorted(folder.glob("_*.py")) if _is_figure_module(p.stem)}


def test_the_scenario_count_includes_helpers():
    sizes = _scenario_sizes()
    assert "link" in sizes and all(not name.startswith("_") for name in sizes)


@pytest.mark.parametrize("name", sorted(_scenario_sizes()))
def test_scenarios_only_compose(name):
    assert _scenario_sizes()[name] <= MAX_SCENARIO_LINES


@pytest.mark.parametrize("name", sorted(_figure_module_sizes()))
def test_figure_modules_are_short(name):
    assert _figure_module_sizes()[name] <= MAX_SCENARIO_LINES


def test_the_composition_count_leaves_out_only_figure_modules():
    # a figure module imported by a scenario is not counted; every other helper is
    folder = ROOT / "scenarios"
    helpers = set().union(*(_helpers_of(p, folder, set()) for p in folder.glob("[!_]*.py")))
    assert {h for h in helpers if _is_figure_module(h)}, "no scenario imports a figure module"
    assert {h for h in helpers if not _is_figure_module(h)}, "no scenario has a composition helper"


def test_no_numba_kernel_in_scenarios():
    bad = []
    for p in sorted((ROOT / "scenarios").glob("*.py")):
        text = p.read_text(encoding="utf-8")
        if "njit" in text or "import numba" in text or "from numba" in text:
            bad.append(p.name)
    assert bad == []


@pytest.mark.parametrize("room", sorted(p.parent.name for p in (ROOT / "rfsim").glob("*/__init__.py")))
def test_every_room_says_what_it_holds(room):
    doc = ast.get_docstring(ast.parse((ROOT / "rfsim" / room / "__init__.py").read_text(encoding="utf-8")))
    assert doc and len(doc.split()) >= 12

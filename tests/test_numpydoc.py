"""The API reference is complete: in every public module of rfsim (:data:`COMPLETE`), every public function
and method (the definition of ``docs/numpydoc_coverage.py``: public names defined in the module,
public functions of its public classes) has a numpydoc ``Parameters`` section naming each of its
parameters (but ``self``/``cls``) and, when it returns a value, a ``Returns`` section (``Yields``
for a generator). The docstrings are parsed here with plain text rules, so the test runs without
numpydoc installed; with the ``docs`` extra, numpydoc's own parser reads them too.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import re
import sys
import textwrap
import types

import pytest

#: Packages whose every public module is checked (the API reference's scope,
#: ``docs/numpydoc_coverage.py``): every public function and method of every module.
PACKAGES = ("rfsim", "rfsim.channels", "rfsim.devices", "rfsim.scenarios")


def _module_names() -> list[str]:
    """Every public module (no ``_`` in its last name) under :data:`PACKAGES`, imported to walk."""
    sys.modules.setdefault("rfsim.__main__", types.ModuleType("rfsim.__main__"))  # importing it runs the CLI
    names: list[str] = []

    def walk(name: str) -> None:
        if name in names:
            return
        names.append(name)
        module = importlib.import_module(name)
        for info in pkgutil.iter_modules(getattr(module, "__path__", [])):
            if not info.name.startswith("_"):
                walk(f"{name}.{info.name}")

    for package in PACKAGES:
        walk(package)
    return names


COMPLETE = tuple(_module_names())


def test_every_module_is_checked():
    """The checked set is the whole public API (not a hand-kept list that can miss a module)."""
    assert {"rfsim.scenes.scene_file", "rfsim.devices.reader", "rfsim.air.step", "rfsim.gen2.commands",
            "rfsim.scenarios.link", "rfsim.sweep.store"} <= set(COMPLETE)
    assert len(COMPLETE) > 150


_HEADER = re.compile(r"^(\w[\w ]*)\n-{3,}[ \t]*$", re.M)


def _public_functions(module):
    for name, obj in vars(module).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isfunction(obj):
            yield name, obj
        elif inspect.isclass(obj):
            for attr, f in vars(obj).items():
                if inspect.isfunction(f) and not attr.startswith("_"):
                    yield f"{name}.{attr}", f


def _sections(doc: str) -> dict[str, str]:
    """Section title → body of a numpydoc docstring (``inspect.getdoc`` text, dedented)."""
    heads = list(_HEADER.finditer(doc))
    return {m.group(1).strip(): doc[m.end(): heads[i + 1].start() if i + 1 < len(heads) else len(doc)]
            for i, m in enumerate(heads)}


def _documented_names(body: str) -> set[str]:
    """Parameter names of a ``Parameters`` section: the unindented lines ``a, b : type`` or ``a``."""
    names = set()
    for line in body.splitlines():
        if line and not line[0].isspace():
            for name in line.split(" : ")[0].split(","):
                names.add(name.strip().lstrip("*"))
    return names


def _returns_value(function) -> tuple[bool, bool]:
    """(returns a value, is a generator) from the function's own body (nested defs skipped)."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(function)))
    node = tree.body[0]
    value = generator = False
    stack = list(node.body)
    while stack:
        n = stack.pop()
        if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda)):
            continue
        if isinstance(n, (ast.Yield, ast.YieldFrom)):
            generator = True
        if isinstance(n, ast.Return) and n.value is not None and not (
                isinstance(n.value, ast.Constant) and n.value.value is None):
            value = True
        stack.extend(ast.iter_child_nodes(n))
    return value, generator


def _problems(module_name: str) -> list[str]:
    module = importlib.import_module(module_name)
    out = []
    for name, function in _public_functions(module):
        doc = inspect.getdoc(function) or ""
        if not doc:
            out.append(f"{name}: no docstring")
            continue
        sections = _sections(doc)
        params = [p.name for p in inspect.signature(function).parameters.values() if p.name not in ("self", "cls")]
        if params:
            missing = set(params) - _documented_names(sections.get("Parameters", ""))
            if "Parameters" not in sections:
                out.append(f"{name}: no Parameters section")
            elif missing:
                out.append(f"{name}: Parameters does not name {sorted(missing)}")
        value, generator = _returns_value(function)
        if generator and "Yields" not in sections:
            out.append(f"{name}: a generator without a Yields section")
        elif value and not generator and "Returns" not in sections:
            out.append(f"{name}: returns a value but has no Returns section")
    return out


@pytest.mark.parametrize("module_name", COMPLETE)
def test_numpydoc_sections(module_name):
    assert _problems(module_name) == []


def test_section_parser_can_fail():
    """The checks flag a docstring without sections and one that leaves a parameter out."""

    def bare(x, y):
        """Sum."""
        return x + y

    def partial(x, y):
        """Sum.

        Parameters
        ----------
        x : float
            First.

        Returns
        -------
        float
            The sum.
        """
        return x + y

    assert "Parameters" not in _sections(inspect.getdoc(bare))
    assert _returns_value(bare) == (True, False)
    assert _documented_names(_sections(inspect.getdoc(partial))["Parameters"]) == {"x"}


@pytest.mark.parametrize("module_name", COMPLETE)
def test_numpydoc_parser_agrees(module_name):
    """Where numpydoc is installed (the ``docs`` extra), its own parser reads every docstring of
    the module without a warning and finds the same parameter names as the plain rules above."""
    docscrape = pytest.importorskip("numpydoc.docscrape")
    import warnings

    module = importlib.import_module(module_name)
    for name, function in _public_functions(module):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            doc = docscrape.FunctionDoc(function)
        names = {n.strip().lstrip("*") for p in doc["Parameters"] for n in p.name.split(",")}
        expected = _documented_names(_sections(inspect.getdoc(function) or "").get("Parameters", ""))
        assert names == expected, name

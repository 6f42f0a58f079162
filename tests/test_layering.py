"""Layering of the packages (DESIGN.md "Layout"): scenarios → devices, channels → rfsim core.

An AST scan of every import — at module level and inside functions — asserts that

* ``channels`` and ``devices`` do not import each other (nor ``scenarios``);
* the core (``rfsim`` minus its edges ``rfsim/cli``, ``rfsim/runs/registry.py``, ``rfsim/bench``)
  imports none of ``channels``, ``devices``, ``scenarios``;
* the project's modules have no import cycles (a function-level import counts: it is a
  dependency all the same).
"""

from __future__ import annotations

import ast
from pathlib import Path

#: Folder of the checkout → the package it installs as (pyproject.toml ``package-dir``).
PACKAGES = {"rfsim": "rfsim", "channels": "rfsim.channels", "devices": "rfsim.devices",
            "scenarios": "rfsim.scenarios"}
CORE_EDGES = ("rfsim.cli", "rfsim.runs", "rfsim.bench")
OUTER = ("rfsim.channels", "rfsim.devices", "rfsim.scenes", "rfsim.scenarios")


def _modules(root: Path) -> dict[str, Path]:
    mods = {}
    for folder, package in PACKAGES.items():
        for path in sorted((root / folder).rglob("*.py")):
            parts = [package, *path.relative_to(root / folder).with_suffix("").parts]
            if parts[-1] == "__init__":
                parts = parts[:-1]
            mods[".".join(parts)] = path
    return mods


def _imports(name: str, path: Path, mods: dict[str, Path]) -> set[str]:
    """Project modules imported anywhere in the module ``name``."""
    is_pkg = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = name.split(".") if is_pkg else name.split(".")[:-1]
                pkg = pkg[: len(pkg) - (node.level - 1)]
                base = ".".join(pkg + ([base] if base else []))
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
        else:
            continue
        for t in targets:
            while t and t not in mods:
                t = t.rpartition(".")[0]
            if t and t != name and not name.startswith(t + "."):  # a parent package is imported anyway
                out.add(t)
    return out


def _graph(project_root: Path) -> dict[str, set[str]]:
    mods = _modules(project_root)
    return {name: _imports(name, path, mods) for name, path in mods.items()}


def _top(mod: str) -> str:
    """The layer of a module: ``rfsim.channels``, ``rfsim.devices``, ``rfsim.scenarios`` or ``rfsim`` (the core)."""
    return next((o for o in OUTER if mod == o or mod.startswith(o + ".")), "rfsim")


def test_the_scan_sees_the_packages(project_root):
    g = _graph(project_root)
    assert {"rfsim.air.step", "rfsim.protocols.engine", "rfsim.channels.paths", "rfsim.devices.tag", "rfsim.scenarios.link"} <= set(g)
    assert "rfsim.air.step" in g["rfsim.protocols.engine"] and "rfsim.channels.paths" in g["rfsim.channels.scene"]
    assert "rfsim.devices.tag" in g["rfsim.devices.sense_a_tag"]  # relative and absolute imports resolved


def test_channels_and_devices_do_not_import_each_other(project_root):
    g = _graph(project_root)
    bad = sorted((m, t) for m, ts in g.items() for t in ts
                 if (_top(m), _top(t)) in {("rfsim.channels", "rfsim.devices"), ("rfsim.devices", "rfsim.channels"),
                                           ("rfsim.channels", "rfsim.scenarios"), ("rfsim.devices", "rfsim.scenarios"),
                                           ("rfsim.channels", "rfsim.scenes"), ("rfsim.devices", "rfsim.scenes"),
                                           ("rfsim.scenes", "rfsim.scenarios")})
    assert bad == []


def test_core_imports_no_channels_devices_or_scenarios(project_root):
    g = _graph(project_root)
    core = [m for m in g if _top(m) == "rfsim" and not any(m == e or m.startswith(e + ".") for e in CORE_EDGES)]
    assert "rfsim.protocols.engine" in core and "rfsim.bench.inventory" not in core
    bad = sorted((m, t) for m in core for t in g[m] if _top(t) in OUTER)
    assert bad == []


def test_no_import_cycles(project_root):
    g = _graph(project_root)
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in g.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    assert cycles == []

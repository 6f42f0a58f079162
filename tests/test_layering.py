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
#: Edges of the core: they run scenarios (and so may reach them through the registry).
CORE_EDGES = ("rfsim.cli", "rfsim.runs", "rfsim.bench", "rfsim.sweep")

#: Every import by a name computed at run time, with why it is not a hidden edge. A new one fails
#: :func:`test_every_dynamic_import_is_registered` until it is listed here with its reason.
DYNAMIC_IMPORTS = {
    "rfsim.core.lazy": "the lazy-import mechanism; its names are the literal lazy_import(...) "
                       "arguments, which this scan reads as edges of the declaring module",
    "rfsim.runs.registry": "scenario discovery: the one place that imports rfsim.scenarios by name",
    "rfsim.runs.runner": "loads the modules declared lazily (literal, scanned) and a scenario's own "
                         "FIGURE_IMPORTS before drawing; an edge of the core",
    "rfsim.core.procs": "warm-up before forking workers: imports in the leader the modules a pilot "
                        "task already imported, adding no dependency the task does not have",
    "rfsim.core._jit": "loads kernels compiled in another process from the modules that declared them",
    "rfsim.runs.kernel_plan": "imports the kernel modules a shipped kernel plan names (modules the "
                              "scenario's run imports anyway), to compile them before a cold run",
    "rfsim.cli": "the subcommand modules of rfsim.cli, listed as literals in _SUBCOMMANDS",
    "rfsim.cli.bench": "the benchmark functions of rfsim.bench, listed as literals in the bench table",
}
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
        elif isinstance(node, ast.Call) and _called(node) in ("lazy_import", "import_module") \
                and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
            targets = [node.args[0].value]  # lazy_import("x.y") / import_module("x.y"): an edge all the same
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


def _called(node: ast.Call) -> str:
    f = node.func
    return f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""


def _dynamic_sites(path: Path) -> int:
    """Number of import_module/__import__ calls in ``path`` whose module name is not a literal."""
    n = 0
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call) and _called(node) in ("import_module", "__import__"):
            if not (node.args and isinstance(node.args[0], ast.Constant)):
                n += 1
    return n


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


def test_lazy_imports_are_edges(project_root):
    g = _graph(project_root)
    lazy = [(m, t) for m, ts in g.items() for t in ts if t.startswith("rfsim.devices.")]
    assert lazy, "the scan sees no lazily imported device module"
    assert any(m.startswith("rfsim.scenarios.") for m, _ in lazy)


def test_every_dynamic_import_is_registered(project_root):
    mods = _modules(project_root)
    found = {name for name, path in mods.items() if _dynamic_sites(path)}
    assert found - set(DYNAMIC_IMPORTS) == set()
    assert set(DYNAMIC_IMPORTS) - found == set(), "a listed site has no dynamic import any more: drop it"


def test_the_core_does_not_import_its_edges(project_root):
    g = _graph(project_root)
    def edge(m):
        return any(m == e or m.startswith(e + ".") for e in CORE_EDGES)
    core = [m for m in g if _top(m) == "rfsim" and not edge(m) and m not in ("rfsim", "rfsim.__main__")]
    bad = sorted((m, t) for m in core for t in g[m] if edge(t))
    assert bad == []

"""Scenario discovery: every module of the ``rfsim.scenarios`` package that defines ``NAME``.

The ``rfsim`` core never imports ``rfsim.scenarios`` at module level; the CLI asks this
registry at run time, so the dependency direction stays scenarios → devices, channels
→ rfsim.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import pkgutil
from pathlib import Path
from types import ModuleType

from rfsim.core.errors import UserError, did_you_mean

_REQUIRED = ("NAME", "DESCRIPTION", "Config", "run", "plot")


def scenario_modules() -> dict[str, ModuleType]:
    """Map scenario name → module, in alphabetical order of names."""
    package = importlib.import_module("rfsim.scenarios")
    found: dict[str, ModuleType] = {}
    for info in pkgutil.iter_modules(package.__path__):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"rfsim.scenarios.{info.name}")
        if all(hasattr(module, attr) for attr in _REQUIRED):
            found[module.NAME] = module
    return dict(sorted(found.items()))


def _literal_metadata(path: Path) -> tuple[str, str] | None:
    """``(NAME, DESCRIPTION)`` of a scenario source file when both are top-level string
    literals and the module defines ``Config``, ``run`` and ``plot`` at top level; None
    otherwise. Nothing is executed: the two assignments are parsed alone
    (:func:`ast.literal_eval`), the definitions are recognised by their first line."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    values, defined = {}, set()
    for k, line in enumerate(lines):
        if not line or line[0] in " \t#)":
            continue
        head = line.split("(", 1)[0].split(":", 1)[0].split()
        if len(head) >= 2 and head[0] in ("class", "def"):
            defined.add(head[1])
        name = line.split("=", 1)[0].strip()
        if name in ("NAME", "DESCRIPTION") and "=" in line:
            stmt = line
            for nxt in lines[k + 1:]:  # continuation lines of a parenthesised value
                if nxt and nxt[0] not in " \t)":
                    break
                stmt += "\n" + nxt
            try:
                value = ast.literal_eval(stmt.split("=", 1)[1].strip())
            except (ValueError, SyntaxError):
                return None
            if not isinstance(value, str):
                return None
            values[name] = value
            defined.add(name)
    if "NAME" in values and "DESCRIPTION" in values and set(_REQUIRED) <= defined:
        return values["NAME"], values["DESCRIPTION"]
    return None


def scenario_descriptions() -> dict[str, str]:
    """Map scenario name → one-line description, in alphabetical order of names, without
    importing the scenarios' physics: ``NAME`` and ``DESCRIPTION`` are read from each
    module's source (:func:`_literal_metadata`); a module whose metadata is not written as
    string literals is imported instead."""
    spec = importlib.util.find_spec("rfsim.scenarios")
    found: dict[str, str] = {}
    for info in pkgutil.iter_modules(spec.submodule_search_locations):
        if info.name.startswith("_"):
            continue
        meta = None
        origin = Path(info.module_finder.path) / f"{info.name}.py"
        if origin.is_file():
            meta = _literal_metadata(origin)
        if meta is None:
            module = importlib.import_module(f"rfsim.scenarios.{info.name}")
            if not all(hasattr(module, attr) for attr in _REQUIRED):
                continue
            meta = (module.NAME, module.DESCRIPTION)
        found[meta[0]] = meta[1]
    return dict(sorted(found.items()))


def get_scenario(name: str) -> ModuleType:
    """The scenario module called ``name``; unknown names are a one-line user error.

    Tries the module named after the scenario first (``gen2-waveforms`` →
    ``rfsim.scenarios.gen2_waveforms``), so one scenario's imports are paid, not all of them.
    """
    if name and name.replace("-", "_").isidentifier():
        try:
            module = importlib.import_module(f"rfsim.scenarios.{name.replace('-', '_')}")
        except ModuleNotFoundError as err:
            if err.name != f"rfsim.scenarios.{name.replace('-', '_')}":
                raise
        else:
            if getattr(module, "NAME", None) == name and all(hasattr(module, a) for a in _REQUIRED):
                return module
    modules = scenario_modules()
    if name not in modules:
        raise UserError(f"unknown scenario {name!r}{did_you_mean(name, modules)}; "
                        f"available: {', '.join(modules)} (see 'rfsim list')")
    return modules[name]


def load_scenario(module_name: str) -> ModuleType:
    """The scenario module of the importable name ``module_name`` (a built-in scenario's
    ``rfsim.scenarios.<name>`` or any module with the scenario contract: ``NAME``,
    ``DESCRIPTION``, ``Config``, ``run``, ``plot``), e.g. in a sweep worker that received the
    name of its scenario's module. A module without the contract is a one-line user error."""
    module = importlib.import_module(module_name)
    missing = [a for a in _REQUIRED if not hasattr(module, a)]
    if missing:
        raise UserError(f"module {module_name!r} is not a scenario: it lacks {', '.join(missing)}")
    return module


__all__ = ["scenario_modules", "scenario_descriptions", "get_scenario", "load_scenario"]

"""Scenario discovery: every module of the ``scenarios`` package that defines ``NAME``.

The ``rfsim`` core never imports ``scenarios`` at module level; the CLI asks this
registry at run time, so the dependency direction stays scenarios → devices, channels
→ rfsim.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType

from rfsim.errors import UserError, did_you_mean

_REQUIRED = ("NAME", "DESCRIPTION", "Config", "run", "plot")


def scenario_modules() -> dict[str, ModuleType]:
    """Map scenario name → module, in alphabetical order of names."""
    package = importlib.import_module("scenarios")
    found: dict[str, ModuleType] = {}
    for info in pkgutil.iter_modules(package.__path__):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"scenarios.{info.name}")
        if all(hasattr(module, attr) for attr in _REQUIRED):
            found[module.NAME] = module
    return dict(sorted(found.items()))


def get_scenario(name: str) -> ModuleType:
    """The scenario module called ``name``; unknown names are a one-line user error.

    Tries the module named after the scenario first (``gen2-waveforms`` →
    ``scenarios.gen2_waveforms``), so one scenario's imports are paid, not all of them.
    """
    if name and name.replace("-", "_").isidentifier():
        try:
            module = importlib.import_module(f"scenarios.{name.replace('-', '_')}")
        except ModuleNotFoundError as err:
            if err.name != f"scenarios.{name.replace('-', '_')}":
                raise
        else:
            if getattr(module, "NAME", None) == name and all(hasattr(module, a) for a in _REQUIRED):
                return module
    modules = scenario_modules()
    if name not in modules:
        raise UserError(f"unknown scenario {name!r}{did_you_mean(name, modules)}; "
                        f"available: {', '.join(modules)} (see 'rfsim list')")
    return modules[name]


__all__ = ["scenario_modules", "get_scenario"]

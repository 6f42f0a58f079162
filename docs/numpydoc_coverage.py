"""How many public functions and methods of rfsim have a docstring, and how many have numpydoc
sections (``Parameters`` / ``Returns`` / ``Yields`` / ``Raises`` / ``Attributes`` with their
dashed underline). Run from the project root with rfsim installed:
``python docs/numpydoc_coverage.py``."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import sys
import types

# rfsim/__main__.py runs the command line when imported; this walk skips it.
sys.modules.setdefault("rfsim.__main__", types.ModuleType("rfsim.__main__"))
PACKAGES = ("rfsim", "rfsim.channels", "rfsim.devices", "rfsim.scenarios")
SECTION = re.compile(r"^\s*(Parameters|Returns|Yields|Raises|Attributes)\s*\n\s*-{3,}\s*$", re.M)


def modules(name: str):
    module = importlib.import_module(name)
    yield module
    for info in pkgutil.iter_modules(getattr(module, "__path__", [])):
        if not info.name.startswith("_"):
            yield from modules(f"{name}.{info.name}")


def main() -> None:
    seen, total, documented, numpydoc = set(), 0, 0, 0
    for package in PACKAGES:
        for module in modules(package):
            if module.__name__ in seen:
                continue
            seen.add(module.__name__)
            for name, obj in vars(module).items():
                if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
                    continue
                functions = [obj] if inspect.isfunction(obj) else []
                if inspect.isclass(obj):
                    functions = [f for n, f in vars(obj).items() if inspect.isfunction(f) and not n.startswith("_")]
                for function in functions:
                    doc = inspect.getdoc(function) or ""
                    total += 1
                    documented += bool(doc)
                    numpydoc += bool(SECTION.search(doc))
    print(f"{len(seen)} modules, {total} public functions and methods: {documented} with a docstring "
          f"({100 * documented / total:.0f} %), {numpydoc} with numpydoc sections ({100 * numpydoc / total:.0f} %)")


if __name__ == "__main__":
    main()

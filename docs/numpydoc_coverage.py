"""How many public functions and methods of rfsim have a docstring, and how many have numpydoc
sections (``Parameters`` / ``Returns`` / ``Yields`` / ``Raises`` / ``Attributes`` with their
dashed underline), and how many are complete by the rules ``tests/test_numpydoc.py`` holds
(every parameter named in ``Parameters``; ``Returns``/``Yields`` when a value is returned; a
function without parameters or result may be a summary alone). Run from the project root with
rfsim installed: ``python docs/numpydoc_coverage.py``."""

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
    sys.path.insert(0, "tests")
    from test_numpydoc import _problems  # the rules the tests hold, not a copy of them

    seen, total, documented, numpydoc, complete = set(), 0, 0, 0, 0
    for package in PACKAGES:
        for module in modules(package):
            if module.__name__ in seen:
                continue
            seen.add(module.__name__)
            flagged = {p.split(":")[0] for p in _problems(module.__name__)}
            for name, obj in vars(module).items():
                if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
                    continue
                functions = [obj] if inspect.isfunction(obj) else []
                if inspect.isclass(obj):
                    functions = [f for n, f in vars(obj).items() if inspect.isfunction(f) and not n.startswith("_")]
                for function in functions:
                    doc = inspect.getdoc(function) or ""
                    qualified = name if inspect.isfunction(obj) else f"{name}.{function.__name__}"
                    complete += bool(doc) and qualified not in flagged
                    total += 1
                    documented += bool(doc)
                    numpydoc += bool(SECTION.search(doc))
    print(f"{len(seen)} modules, {total} public functions and methods: {documented} with a docstring "
          f"({100 * documented / total:.0f} %), {numpydoc} with numpydoc sections ({100 * numpydoc / total:.0f} %), "
          f"{complete} complete by the rules of tests/test_numpydoc.py ({100 * complete / total:.0f} %)")


if __name__ == "__main__":
    main()

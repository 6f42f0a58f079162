"""Modules loaded on first use, so that start-up (``rfsim config NAME``) stays light.

numba (through the kernel modules) and scipy's signal, stats and optimize sub-packages
cost about a second of start-up together, while a scenario's config only needs the
dataclasses of the modules that declare them. A module that calls a kernel or a scipy
routine inside its functions declares the module with :func:`lazy_import` instead of an
``import`` statement; the module object is created at once, its code runs when one of
its attributes is first read (:class:`importlib.util.LazyLoader`).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import threading
from types import ModuleType

_LOCK = threading.Lock()
#: Names of the modules declared with :func:`lazy_import`, in declaration order.
DECLARED: list[str] = []


def lazy_import(name: str) -> ModuleType:
    """The module ``name`` (absolute dotted name), executed on first attribute access.

    An already imported module is returned as it is. The parent packages are imported
    now (they are light: rfsim's packages import their sub-modules on demand, scipy's
    ``__init__`` does not import its sub-packages).
    """
    with _LOCK:
        module = sys.modules.get(name)
        if module is not None:
            return module
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        spec.loader = importlib.util.LazyLoader(spec.loader)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        DECLARED.append(name)
        parent, _, child = name.rpartition(".")
        if parent:
            setattr(sys.modules[parent], child, module)
        return module


def load_declared() -> None:
    """Run the code of every module declared so far (e.g. so that every kernel a run may
    call is declared before the run asks numba which kernels are cached)."""
    for name in list(DECLARED):
        getattr(sys.modules[name], "__name__", None)


__all__ = ["lazy_import", "load_declared", "DECLARED"]

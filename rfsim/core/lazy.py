"""Modules loaded on first use, so that start-up (``rfsim config NAME``) stays light.

numba (through the kernel modules) and scipy's signal, stats and optimize sub-packages
cost about a second of start-up together, while a scenario's config only needs the
dataclasses of the modules that declare them. A module that calls a kernel or a scipy
routine inside its functions declares the module with :func:`lazy_import` instead of an
``import`` statement: it gets a stand-in at once; the first attribute read through the
stand-in imports the real module (an ordinary import, so concurrent first uses from
several threads wait for one import) and copies its namespace into the stand-in.

A package whose ``__init__`` gathers the public names of its modules does so with
:func:`lazy_exports`: each name is imported from its module on first use (PEP 562), so that
importing one module of the package does not import all the others.
"""

from __future__ import annotations

import importlib
import threading
import types

_LOCK = threading.Lock()
#: Names of the modules declared with :func:`lazy_import`, in declaration order.
DECLARED: list[str] = []


class _Deferred(types.ModuleType):
    """Stand-in of a module not imported yet; attributes not found on it come from the
    real module, imported on the first such read."""

    def __getattr__(self, attr: str):
        module = importlib.import_module(self.__name__)  # thread-safe: the import lock
        with _LOCK:
            for key, value in vars(module).items():
                self.__dict__.setdefault(key, value)
        return getattr(module, attr)


def lazy_import(name: str) -> types.ModuleType:
    """A stand-in of the module ``name`` that imports it on the first attribute read.

    See the module docstring; nothing is imported now. The name is recorded in
    :data:`DECLARED`.

    Parameters
    ----------
    name : str
        Absolute dotted module name.

    Returns
    -------
    types.ModuleType
        The stand-in.
    """
    with _LOCK:
        DECLARED.append(name)
    return _Deferred(name)


def load_declared() -> None:
    """Import every module declared so far (e.g. so that every kernel a run may call is
    declared before the run asks numba which kernels are cached)."""
    for name in list(DECLARED):
        importlib.import_module(name)


def lazy_exports(namespace: dict, sources: dict[str, tuple[str, ...]]):
    """``(__getattr__, __dir__)`` for a package's ``__init__`` (PEP 562).

    The first read of an exported name imports its module and keeps the value in the
    package's namespace.

    Parameters
    ----------
    namespace : dict
        The package's ``globals()``.
    sources : dict of str to tuple of str
        A module of the package (name relative to it) → the public names it provides.

    Returns
    -------
    __getattr__, __dir__ : callable
        The module-level hooks.
    """
    package = namespace["__name__"]
    where = {name: f"{package}.{module}" for module, names in sources.items() for name in names}

    def __getattr__(name: str):
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(where[name]), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(where))

    return __getattr__, __dir__


__all__ = ["lazy_import", "lazy_exports", "load_declared", "DECLARED"]

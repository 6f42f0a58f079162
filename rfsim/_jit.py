"""The one numba policy of rfsim.

Every compiled kernel is declared with :data:`njit` from here, so the caching and
fastmath choices live in one place. Kernels are plain loops over preallocated
arrays; the validating, allocating wrapper lives next to them in a public module,
and each kernel has a plain-NumPy reference used by the tests.

Every kernel declared here is remembered in :data:`KERNELS`, so a run can tell before it
starts that numba will have to compile: :func:`uncached_kernels` lists the kernels without an
on-disk cache index; when none has one, this is the first run after install
(:func:`first_compilation`). Kernels a run never calls are never cached, so a partial list
alone says nothing.
"""

from __future__ import annotations

import os

import numba

_NJIT = numba.njit(cache=True, nogil=True)

#: Every kernel declared with :func:`njit`, in declaration order.
KERNELS: list = []


def njit(func):
    """``@njit`` with on-disk caching; no fastmath, so results are bit-reproducible."""
    dispatcher = _NJIT(func)
    KERNELS.append(dispatcher)
    return dispatcher


def uncached_kernels() -> list[str]:
    """Names of the declared kernels that have no on-disk cache index yet.

    Reads numba's cache locator (``Dispatcher._cache._cache_file._index_path``, the
    ``__pycache__/<module>.<name>-<line>.py3XX.nbi`` file); a kernel whose cache cannot be
    located counts as cached (nothing is announced for it).
    """
    missing = []
    for d in KERNELS:
        index = getattr(getattr(getattr(d, "_cache", None), "_cache_file", None), "_index_path", None)
        if index and not os.path.exists(index):
            missing.append(d.py_func.__qualname__)
    return missing


def first_compilation() -> bool:
    """True when no declared kernel has an on-disk cache yet (first run after install)."""
    return bool(KERNELS) and len(uncached_kernels()) == len(KERNELS)


__all__ = ["njit", "KERNELS", "uncached_kernels", "first_compilation"]

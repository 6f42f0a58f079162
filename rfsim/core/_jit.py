"""The one numba policy of rfsim.

Every compiled kernel is declared with :data:`njit` from here, so the caching and
fastmath choices live in one place. Kernels are plain loops over preallocated
arrays; the validating, allocating wrapper lives next to them in a public module,
and each kernel has a plain-NumPy reference used by the tests.

Every kernel declared here is remembered in :data:`KERNELS`, so a run can tell before it
starts that numba will have to compile: :func:`uncached_kernels` lists the kernels without an
on-disk cache index; when none has one, this is the first run after install
(:func:`first_compilation`). Kernels a run never calls are never cached, so a partial list
alone says nothing. Where the cache lives: :func:`cache_dir` (beside the sources, or a
per-user folder when the installed package cannot be written).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

#: Folder of the rfsim package (numba caches beside the sources, in ``__pycache__``).
PACKAGE_DIR = Path(__file__).resolve().parents[1]


def _writable(folder: Path) -> bool:
    """True when a file can be created in ``folder`` (or in the folder that would hold it)."""
    probe_dir = folder if folder.is_dir() else folder.parent
    try:
        with tempfile.NamedTemporaryFile(dir=probe_dir, prefix=".rfsim-probe-"):
            return True
    except OSError:
        return False


def cache_dir(environ=os.environ, package_dir: Path = PACKAGE_DIR, writable=_writable) -> str | None:
    """The numba cache folder rfsim chooses, or None for numba's own choice (``__pycache__``
    beside each kernel's source).

    ``NUMBA_CACHE_DIR`` set by the user wins (None: numba reads it itself). Otherwise, when
    the package folder's ``__pycache__`` cannot be written (a non-editable install into a
    system or read-only site-packages), the kernels are cached in
    ``$XDG_CACHE_HOME/rfsim/numba`` (default ``~/.cache/rfsim/numba``), so the compiled
    kernels survive the process there instead of being compiled again on every run.
    """
    if environ.get("NUMBA_CACHE_DIR"):
        return None
    if writable(package_dir / "__pycache__"):
        return None
    base = environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "rfsim", "numba")


_CACHE_DIR = cache_dir()
if _CACHE_DIR is not None:  # numba reads it when first imported
    os.environ["NUMBA_CACHE_DIR"] = _CACHE_DIR

import numba  # noqa: E402  (after choosing the cache folder)

if _CACHE_DIR is not None:
    # If a script imported numba before rfsim, numba read the environment before the folder
    # was chosen: re-read it now, before any kernel is declared (its cache locator is fixed then).
    numba.core.config.reload_config()

_NJIT = numba.njit(cache=True, nogil=True)

#: Every kernel declared with :func:`njit`, in declaration order.
KERNELS: list = []


def njit(func):
    """``@njit`` with on-disk caching; no fastmath, so results are bit-reproducible."""
    dispatcher = _NJIT(func)
    KERNELS.append(dispatcher)
    return dispatcher


_INLINE = numba.njit(cache=True, nogil=True, inline="always")


def njit_inline(func):
    """A helper of kernels, inlined into each kernel that calls it (numba IR inlining: a
    step of a per-sample loop that must not cost a call); not a kernel of its own (it is
    compiled only inside its callers, so it is not in :data:`KERNELS`)."""
    return _INLINE(func)


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


def compiled_signatures() -> list[tuple[str, str, tuple]]:
    """``(module, qualified name, signature)`` of every overload the declared kernels hold in
    this process (compiled or loaded from the cache), for :func:`load_signatures` elsewhere."""
    return [(d.py_func.__module__, d.py_func.__qualname__, sig) for d in KERNELS for sig in d.signatures]


def load_signatures(kernels) -> None:
    """Give this process the overloads listed by :func:`compiled_signatures` (in another process):
    each kernel's module is imported and each signature it lacks is loaded from the on-disk
    cache (numba compiles it only where the cache has no entry)."""
    import importlib

    for module, _, _ in kernels:
        importlib.import_module(module)
    declared = {(d.py_func.__module__, d.py_func.__qualname__): d for d in KERNELS}
    for module, name, sig in kernels:
        d = declared[(module, name)]
        if sig not in d.signatures:
            d.compile(sig)


__all__ = ["njit", "KERNELS", "uncached_kernels", "first_compilation", "cache_dir", "PACKAGE_DIR",
           "compiled_signatures", "load_signatures"]

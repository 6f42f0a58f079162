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

Where the cache lives: numba invalidates a cached kernel only when *its own* source file
changes, yet a kernel that calls a kernel of another file compiles that callee (and the
constants it reads) into itself. So the cache folder is named after a hash of the source of
every kernel module (:func:`kernel_sources`, :func:`sources_hash`): an edit to any kernel file
(or to this policy) selects a new, empty folder and every kernel is compiled afresh, and
:func:`first_compilation` is true again, so the run prints the compile notice once for the new
cache. The folder (:func:`cache_dir`) is ``rfsim-kernels-<hash>`` inside the package's
``__pycache__``, or inside ``$XDG_CACHE_HOME/rfsim/numba`` when the installed package cannot be
written, or inside the user's own ``NUMBA_CACHE_DIR``. It is chosen when this module is imported,
before any kernel is declared, and exported as ``NUMBA_CACHE_DIR`` (so it applies to every
``cache=True`` function of the process, and child processes find the same folder). Folders of
earlier sources are left in place (a process started before the edit may still read its own);
delete the ``rfsim-kernels-*`` folders that are not the current one (:data:`CACHE_DIR`) to free
the space.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import os
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

#: Folder of the rfsim package.
PACKAGE_DIR = Path(__file__).resolve().parents[1]

#: Packages whose folders hold kernel modules (rfsim.channels, rfsim.devices and
#: rfsim.scenarios are folders of their own in a source checkout, inside rfsim when installed).
KERNEL_PACKAGES = ("rfsim.channels", "rfsim.devices", "rfsim.scenarios")

#: Start of the name of a cache folder; the rest is :func:`sources_hash` of the kernel sources.
CACHE_PREFIX = "rfsim-kernels-"


def kernel_source_dirs(package_dir: Path = PACKAGE_DIR, packages=KERNEL_PACKAGES) -> list[Path]:
    """The folders searched for kernel modules: ``package_dir`` and the folders of ``packages``
    (found with :func:`importlib.util.find_spec`, which does not import them), without a
    folder that lies inside another (an installed package holds its subpackages).

    Parameters
    ----------
    package_dir : pathlib.Path, optional
        The rfsim package folder (default :data:`PACKAGE_DIR`).
    packages : tuple of str, optional
        Packages whose folders are searched too (default :data:`KERNEL_PACKAGES`).

    Returns
    -------
    list of pathlib.Path
        The folders, resolved, shortest first.
    """
    dirs = [package_dir.resolve()]
    for name in packages:
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.submodule_search_locations:
            dirs.extend(Path(d).resolve() for d in spec.submodule_search_locations)
    kept: list[Path] = []
    for d in sorted(set(dirs), key=lambda p: len(p.parts)):
        if not any(d.is_relative_to(k) for k in kept):
            kept.append(d)
    return kept


def is_kernel_module(filename: str) -> bool:
    """True for the file name of a kernel module (``_<topic>_kernels.py``) or of this policy
    (``_jit.py``). Kernels are declared only there (a test checks that every file of the
    package that mentions ``njit`` is one of these).

    Parameters
    ----------
    filename : str
        A file name without folder.

    Returns
    -------
    bool
        Whether it names a kernel module or this policy.
    """
    return filename == "_jit.py" or (filename.startswith("_") and filename.endswith("kernels.py"))


def kernel_sources(dirs) -> list[tuple[str, bytes]]:
    """``(name, source bytes)`` of every kernel module under ``dirs`` (:func:`is_kernel_module`),
    sorted by name; ``name`` is the path relative to its folder, prefixed by the folder's name.

    Kernel modules import only other kernel modules and the libraries (a test checks), so these
    files hold every source a compiled kernel depends on within rfsim. Only the file names of
    the other modules are read (≈ 2 ms for the 17 kernel files among 175).

    Parameters
    ----------
    dirs : iterable of pathlib.Path
        The folders searched (:func:`kernel_source_dirs`).

    Returns
    -------
    list of (str, bytes)
        Name and content of each kernel module.
    """
    found = []
    for root in dirs:
        for folder, subdirs, files in os.walk(root):
            subdirs[:] = [s for s in subdirs if s != "__pycache__" and not s.startswith(".")]
            for f in files:
                if is_kernel_module(f):
                    path = os.path.join(folder, f)
                    with open(path, "rb") as fh:
                        data = fh.read()
                    rel = os.path.relpath(path, root).replace(os.sep, "/")
                    found.append((f"{root.name}/{rel}", data))
    return sorted(found)


def sources_hash(sources) -> str:
    """16 hex digits of a BLAKE2b digest of ``(name, bytes)`` pairs (names and lengths are
    included, so moving text between files changes it too).

    Parameters
    ----------
    sources : iterable of (str, bytes)
        What :func:`kernel_sources` returns.

    Returns
    -------
    str
        The digest, 16 lower-case hex digits.
    """
    h = hashlib.blake2b(digest_size=8)
    for name, data in sources:
        for part in (name.encode(), data):
            h.update(len(part).to_bytes(8, "little"))
            h.update(part)
    return h.hexdigest()


def _writable(folder: Path) -> bool:
    """True when a file can be created in ``folder`` (or in the folder that would hold it)."""
    probe_dir = folder if folder.is_dir() else folder.parent
    try:
        with tempfile.NamedTemporaryFile(dir=probe_dir, prefix=".rfsim-probe-"):
            return True
    except OSError:
        return False


def cache_dir(digest: str, environ=os.environ, package_dir: Path = PACKAGE_DIR, writable=_writable) -> str:
    """The numba cache folder for kernel sources whose :func:`sources_hash` is ``digest``:
    ``<base>/rfsim-kernels-<digest>``.

    ``<base>`` is the user's ``NUMBA_CACHE_DIR`` when set; when that folder is itself an
    ``rfsim-kernels-*`` folder (exported by an rfsim parent process), its parent, so a child
    process uses the same folder, or a sibling if the sources changed since, never a folder
    nested in it. Otherwise the package folder's ``__pycache__``, or, when that cannot be
    written (a non-editable install into a system or read-only site-packages),
    ``$XDG_CACHE_HOME/rfsim/numba`` (default ``~/.cache/rfsim/numba``), so the compiled
    kernels survive the process there instead of being compiled again on every run.

    Parameters
    ----------
    digest : str
        :func:`sources_hash` of the kernel sources.
    environ : mapping, optional
        The environment read (default ``os.environ``).
    package_dir : pathlib.Path, optional
        The rfsim package folder (default :data:`PACKAGE_DIR`).
    writable : callable, optional
        ``writable(folder)``: whether a file can be created there.

    Returns
    -------
    str
        The cache folder (not created here).
    """
    name = CACHE_PREFIX + digest
    user = environ.get("NUMBA_CACHE_DIR")
    if user:
        user = os.path.normpath(user)
        if os.path.basename(user).startswith(CACHE_PREFIX):
            return os.path.join(os.path.dirname(user), name)
        return os.path.join(user, name)
    pycache = package_dir / "__pycache__"
    if writable(pycache):
        return str(pycache / name)
    base = environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "rfsim", "numba", name)


#: :func:`sources_hash` of the kernel sources of this process, read when this module is imported.
SOURCES_HASH = sources_hash(kernel_sources(kernel_source_dirs()))
#: The numba cache folder of this process (:func:`cache_dir`).
CACHE_DIR = cache_dir(SOURCES_HASH)
os.environ["NUMBA_CACHE_DIR"] = CACHE_DIR  # numba reads it when first imported

import numba  # noqa: E402  (after choosing the cache folder)

# If a script imported numba before rfsim, numba read the environment before the folder
# was chosen: re-read it now, before any kernel is declared (its cache locator is fixed then).
numba.core.config.reload_config()

_NJIT = numba.njit(cache=True, nogil=True)

#: Every kernel declared with :func:`njit`, in declaration order.
KERNELS: list = []


class _Elsewhere:
    """Where a kernel missing from the on-disk cache is compiled: ``run`` is None (here, numba's
    own way) or a function that calls a task in a short-lived process and waits for it
    (:func:`compiling_elsewhere`)."""

    run: Callable[[Callable[[], None]], None] | None = None


class _CacheCompilingElsewhere:
    """The on-disk cache of one kernel (numba's ``Dispatcher._cache``), which, while
    :func:`compiling_elsewhere` is active, fills itself from another process when it lacks an
    entry: that process compiles the kernel (with the kernels it calls that the cache lacks)
    and writes it to the cache, and this one loads it as any cached kernel, so numba's compiler
    never runs here and its memory (LLVM's, which a process keeps once it has used it) ends
    with the other process. Every other attribute is the wrapped cache's."""

    def __init__(self, dispatcher, cache):
        self._dispatcher = dispatcher
        self._cache = cache

    def __getattr__(self, name):
        return getattr(self._cache, name)

    def load_overload(self, sig, target_context):
        """The cached overload of ``sig`` (numba's ``Cache.load_overload``), compiled and written
        by another process first where the cache lacks it; None when still missing (numba then
        compiles it here, raising its errors here)."""
        cres = self._cache.load_overload(sig, target_context)
        run = _Elsewhere.run
        if cres is not None or run is None or threading.current_thread() is not threading.main_thread():
            return cres

        def compile_and_save() -> None:  # in the other process
            _Elsewhere.run = None  # the kernels it calls are compiled in that process too
            self._dispatcher.compile(sig)

        try:
            run(compile_and_save)
        except Exception:  # a kernel that does not compile: numba's error is raised here, below
            pass
        finally:
            _Elsewhere.run = run  # (when ``run`` called the task in this process)
        return self._cache.load_overload(sig, target_context)


@contextlib.contextmanager
def compiling_elsewhere(run: Callable[[Callable[[], None]], None]) -> Iterator[None]:
    """Within the block, a kernel missing from the on-disk cache is compiled by ``run``.

    ``run(task)`` calls ``task()`` in a short-lived process (e.g.
    :func:`rfsim.core.procs.run_in_child`) and returns when it ended; the task compiles the kernel
    and writes it to the cache (:data:`CACHE_DIR`), from which this process then loads it. The
    compiler's memory (≈ 130 MB for the kernels of one scenario, which a process does not give
    back) is then spent in a process that ends after each kernel, not added to the peak of this
    one. A kernel found in the cache is loaded as before (nothing changes for a warm run). Where
    the task fails or writes nothing, the kernel is compiled here as numba does (so its errors
    are raised here). Only the main thread sends compilations away; a kernel compiled while
    another is being compiled here is compiled here too.

    Parameters
    ----------
    run : callable
        ``run(task)``: calls ``task()`` (no arguments) in another process and waits for it.

    Yields
    ------
    None
        The block runs with the policy active; the previous policy is restored afterwards.
    """
    previous = _Elsewhere.run
    _Elsewhere.run = run
    try:
        yield
    finally:
        _Elsewhere.run = previous


def _declared(dispatcher):
    """Remember ``dispatcher`` in :data:`KERNELS`, its cache wrapped by :class:`_CacheCompilingElsewhere`."""
    dispatcher._cache = _CacheCompilingElsewhere(dispatcher, dispatcher._cache)
    KERNELS.append(dispatcher)
    return dispatcher


def njit(func):
    """``@njit`` with on-disk caching; no fastmath, so results are bit-reproducible.

    Parameters
    ----------
    func : function
        The kernel's Python source.

    Returns
    -------
    numba.core.registry.CPUDispatcher
        The kernel, remembered in :data:`KERNELS`.
    """
    return _declared(_NJIT(func))


_VECTOR = numba.njit(cache=True, nogil=True, error_model="numpy")


def njit_vector(func):
    """:func:`njit` with numba's ``error_model="numpy"``: a float division by zero gives inf/nan
    as NumPy does instead of raising, so no zero check is compiled into every division and a
    loop of divisions can be vectorised. For kernels whose divisors cannot be zero (say why
    in the kernel's docstring); no fastmath, results stay bit-reproducible.

    Parameters
    ----------
    func : function
        The kernel's Python source, whose divisors are never zero.

    Returns
    -------
    numba.core.registry.CPUDispatcher
        The kernel, in :data:`KERNELS` as those of :func:`njit` are.
    """
    return _declared(_VECTOR(func))


_INLINE = numba.njit(cache=True, nogil=True, inline="always")


def njit_inline(func):
    """A helper of kernels, inlined into each kernel that calls it (numba IR inlining: a
    step of a per-sample loop that must not cost a call); not a kernel of its own (it is
    compiled only inside its callers, so it is not in :data:`KERNELS`).

    Parameters
    ----------
    func : function
        The helper's Python source.

    Returns
    -------
    numba.core.registry.CPUDispatcher
        The helper (not in :data:`KERNELS`).
    """
    return _INLINE(func)


def uncached_kernels() -> list[str]:
    """Names of the declared kernels that have no on-disk cache index yet.

    Reads numba's cache locator (``Dispatcher._cache._cache_file._index_path``, the
    ``<module>.<name>-<line>.py3XX.nbi`` file in :data:`CACHE_DIR`); a kernel whose cache cannot be
    located counts as cached (nothing is announced for it).

    Returns
    -------
    list of str
        Qualified names, in declaration order.
    """
    missing = []
    for d in KERNELS:
        index = getattr(getattr(getattr(d, "_cache", None), "_cache_file", None), "_index_path", None)
        if index and not os.path.exists(index):
            missing.append(d.py_func.__qualname__)
    return missing


def first_compilation() -> bool:
    """True when no declared kernel has an on-disk cache yet (first run after install).

    Returns
    -------
    bool
        Whether kernels are declared and none of them is cached.
    """
    return bool(KERNELS) and len(uncached_kernels()) == len(KERNELS)


def compiled_signatures() -> list[tuple[str, str, tuple]]:
    """``(module, qualified name, signature)`` of every overload the declared kernels hold in
    this process (compiled or loaded from the cache), for :func:`load_signatures` elsewhere.

    Returns
    -------
    list of (str, str, tuple)
        One entry per overload, kernels in declaration order.
    """
    return [(d.py_func.__module__, d.py_func.__qualname__, sig) for d in KERNELS for sig in d.signatures]


def load_signatures(kernels) -> None:
    """Give this process the overloads listed by :func:`compiled_signatures` (in another process):
    each kernel's module is imported and each signature it lacks is loaded from the on-disk
    cache (numba compiles it only where the cache has no entry).

    Parameters
    ----------
    kernels : list of (str, str, tuple)
        What :func:`compiled_signatures` returned in the other process.
    """
    import importlib

    for module, _, _ in kernels:
        importlib.import_module(module)
    declared = {(d.py_func.__module__, d.py_func.__qualname__): d for d in KERNELS}
    for module, name, sig in kernels:
        d = declared[(module, name)]
        if sig not in d.signatures:
            d.compile(sig)


__all__ = ["njit", "KERNELS", "compiling_elsewhere", "uncached_kernels", "first_compilation", "cache_dir", "PACKAGE_DIR", "CACHE_DIR",
           "SOURCES_HASH", "kernel_source_dirs", "kernel_sources", "is_kernel_module", "sources_hash",
           "compiled_signatures", "load_signatures"]

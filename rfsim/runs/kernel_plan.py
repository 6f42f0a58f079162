"""Kernel plans: the compiled kernels a scenario's run calls, compiled side by side before a cold run.

The first run after an install (or after an edit of a kernel source, :mod:`rfsim.core._jit`)
compiles every kernel it calls, one after the other, each in a short-lived child process
(:func:`rfsim.core._jit.compiling_elsewhere`): ≈ 27 s of CPU for the ``link`` scenario's
kernels, one core busy while the others wait. A *plan* lists the kernels (module, name and
argument types) that a scenario's default run calls from Python; :func:`precompile` compiles the
plan's kernels that have no cache yet in several child processes at once (one per usable CPU,
at most :data:`MAX_PROCESSES`), each writing its kernels (and the kernels they call) to the
on-disk cache, before the run starts. The run then loads them; a kernel the plan does not list
(another config) is compiled as before. Nothing changes for a warm run (every kernel of the plan
has its cache index: nothing to do).

The plans are package data (``kernel_plans.json`` beside this module), written by
``python -m rfsim.runs.kernel_plan SCENARIO ...``, which runs each scenario's default config in
a process of its own and records the signatures its kernels hold afterwards
(:func:`rfsim.core._jit.compiled_signatures`), then, in another new process with an empty cache,
the CPU time each entry's compilation takes in the plan's order (:func:`compile_times`): the
weights by which :func:`shares` deals the kernels to the children. A kernel compiles the
kernels it calls that the cache lacks into itself, so the children share the work along the
call graph (:func:`call_graph`, read from the kernels' source): each kernel is dealt to one
child, callees before callers, and a child waits for a callee another child compiles rather
than compiling it a second time. A signature is written as text, one argument type
per item: a scalar by its numba name (``float64``, ``int64``, ``complex128``, ``bool``, ...), an
array as ``float64[::1]`` (C-contiguous), ``float64[:]`` (any layout), ``float64[:, ::1]``
(2-D, C-contiguous), prefixed ``readonly`` when numba saw a read-only array. A kernel with a
type of another kind is left out of the plan (compiled when called, as before).
"""

from __future__ import annotations

import dataclasses
import importlib
import json
import os
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import CodeType, ModuleType

#: The plans file (package data): ``{"format": 1, "plans": {scenario: [entry, ...]}}``.
PLANS_FILE = Path(__file__).with_name("kernel_plans.json")
#: Version of the plans file's layout (2: each entry with its compile time [s]).
PLANS_FORMAT = 2
#: Child processes compiling at once at most (each holds ≈ 230 MB while it compiles).
MAX_PROCESSES = 4
#: numba scalar type names allowed in a plan (their numba ``str`` is the name, ``bool`` is
#: ``types.boolean``).
SCALARS = ("bool", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32", "uint64", "float32",
           "float64", "complex64", "complex128")
_LAYOUT_SUFFIX = {"C": "::1", "A": ":"}


@dataclasses.dataclass(frozen=True)
class PlanEntry:
    """One kernel overload of a plan.

    Parameters
    ----------
    module : str
        The kernel's module (``rfsim.gen2._linecode_kernels``).
    name : str
        The kernel's qualified name in its module.
    signature : tuple of str
        Its argument types as text (module docstring).
    compile_s : float, default 0.0
        CPU time its compilation took when the plan was recorded [s] (its callees that an
        earlier entry had not compiled included): the weight by which :func:`shares` deals it.
    """

    module: str
    name: str
    signature: tuple[str, ...]
    compile_s: float = dataclasses.field(default=0.0, compare=False)

    def text(self) -> str:
        """Return the entry as one line of a plan: ``module:name(type, type, ...)``.

        Returns
        -------
        str
            The line.
        """
        return f"{self.module}:{self.name}({', '.join(self.signature)})"

    @classmethod
    def parse(cls, line: str) -> "PlanEntry":
        """Read a line written by :meth:`text`.

        Parameters
        ----------
        line : str
            ``module:name(type, type, ...)``.

        Returns
        -------
        PlanEntry
            The entry.

        Raises
        ------
        ValueError
            A line of another form, or a type :func:`type_of_text` does not read.
        """
        head, sep, rest = line.partition("(")
        module, colon, name = head.partition(":")
        if not (sep and colon and module and name and rest.endswith(")")):
            raise ValueError(f"kernel plan entry {line!r}: expected 'module:name(type, ...)'")
        items = tuple(t.strip() for t in rest[:-1].split(",")) if rest[:-1].strip() else ()
        # a 2-D array's text holds a comma: join the pieces of one bracket back together
        joined: list[str] = []
        for item in items:
            if joined and joined[-1].count("[") > joined[-1].count("]"):
                joined[-1] = f"{joined[-1]}, {item}"
            else:
                joined.append(item)
        for t in joined:
            type_of_text(t)  # raises on a type it cannot read
        return cls(module, name, tuple(joined))


def text_of_type(t) -> str | None:
    """Return the plan text of a numba type, or None for a kind plans do not hold.

    Parameters
    ----------
    t : numba.core.types.Type
        An argument type of a compiled signature.

    Returns
    -------
    str or None
        ``float64``, ``readonly complex128[::1]``, ``float64[:, ::1]``, ... (module docstring).
    """
    from numba.core import types

    if isinstance(t, types.Array):
        dtype = text_of_type(t.dtype)
        if dtype is None or t.layout not in _LAYOUT_SUFFIX or t.ndim < 1 or not t.aligned:
            return None
        dims = [":"] * (t.ndim - 1) + [_LAYOUT_SUFFIX[t.layout]]
        return ("readonly " if not t.mutable else "") + f"{dtype}[{', '.join(dims)}]"
    name = "bool" if t == types.boolean else str(t)
    return name if name in SCALARS else None


def type_of_text(text: str):
    """Return the numba type of a plan's type text (the inverse of :func:`text_of_type`).

    Parameters
    ----------
    text : str
        A type as :func:`text_of_type` writes it.

    Returns
    -------
    numba.core.types.Type
        The type.

    Raises
    ------
    ValueError
        Text of no type a plan holds.
    """
    from numba.core import types

    readonly = text.startswith("readonly ")
    body = text[len("readonly "):] if readonly else text
    dtype_name, bracket, dims = body.partition("[")
    if dtype_name not in SCALARS:
        raise ValueError(f"kernel plan type {text!r}: scalar must be one of {', '.join(SCALARS)}")
    dtype = types.boolean if dtype_name == "bool" else getattr(types, dtype_name)
    if not bracket:
        if readonly:
            raise ValueError(f"kernel plan type {text!r}: only an array can be read-only")
        return dtype
    parts = [p.strip() for p in dims.rstrip("]").split(",")] if dims.endswith("]") else []
    if not parts or any(p != ":" for p in parts[:-1]) or parts[-1] not in ("::1", ":"):
        raise ValueError(f"kernel plan type {text!r}: array dimensions must be ':' and a last ':' or '::1'")
    layout = "C" if parts[-1] == "::1" else "A"
    return types.Array(dtype, len(parts), layout, readonly=readonly)


def entries_of(kernels: Sequence[tuple[str, str, tuple]]) -> list[PlanEntry]:
    """Return the plan entries of compiled overloads, leaving out those with a type a plan does not hold.

    Parameters
    ----------
    kernels : sequence of (str, str, tuple)
        ``(module, qualified name, signature)``, as :func:`rfsim.core._jit.compiled_signatures`.

    Returns
    -------
    list of PlanEntry
        In the order given, each overload once.
    """
    out: list[PlanEntry] = []
    for module, name, sig in kernels:
        texts = [text_of_type(t) for t in sig]
        if all(t is not None for t in texts):
            entry = PlanEntry(module, name, tuple(texts))
            if entry not in out:
                out.append(entry)
    return out


def read_plans(path: Path = PLANS_FILE) -> dict[str, list[PlanEntry]]:
    """Return the plans of a plans file, by scenario name ({} when the file is absent).

    Parameters
    ----------
    path : pathlib.Path, optional
        The plans file (default :data:`PLANS_FILE`).

    Returns
    -------
    dict of str to list of PlanEntry
        Each scenario's entries.

    Raises
    ------
    ValueError
        A file of another format or with an entry :meth:`PlanEntry.parse` does not read.
    """
    if not path.is_file():
        return {}
    data = json.loads(path.read_text(encoding="utf-8"))
    if data.get("format") != PLANS_FORMAT:
        raise ValueError(f"{path.name}: format {data.get('format')!r}, expected {PLANS_FORMAT}")
    return {name: [dataclasses.replace(PlanEntry.parse(line), compile_s=float(seconds)) for line, seconds in rows]
            for name, rows in data["plans"].items()}


def write_plans(plans: dict[str, list[PlanEntry]], path: Path = PLANS_FILE) -> None:
    """Write plans to a plans file (scenarios sorted by name, entries in their order).

    Parameters
    ----------
    plans : dict of str to list of PlanEntry
        Each scenario's entries.
    path : pathlib.Path, optional
        The plans file (default :data:`PLANS_FILE`).
    """
    data = {"format": PLANS_FORMAT,
            "plans": {k: [[e.text(), round(e.compile_s, 2)] for e in plans[k]] for k in sorted(plans)}}
    path.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")


def usable_cpus() -> int:
    """Return the CPUs this process may run on (its affinity where the system tells it).

    Returns
    -------
    int
        At least 1.
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # no affinity on this system
        return max(1, os.cpu_count() or 1)


def _kernel(entry: PlanEntry):
    """The declared kernel of an entry (its module imported), or None when it is not declared."""
    from rfsim.core._jit import KERNELS

    try:
        importlib.import_module(entry.module)
    except ImportError:
        return None
    for d in KERNELS:
        if d.py_func.__module__ == entry.module and d.py_func.__qualname__ == entry.name:
            return d
    return None


def uncached(entries: Sequence[PlanEntry]) -> list[tuple[PlanEntry, object]]:
    """Return the entries whose kernel is declared but has no on-disk cache index yet, with the kernel.

    Parameters
    ----------
    entries : sequence of PlanEntry
        A plan.

    Returns
    -------
    list of (PlanEntry, numba dispatcher)
        In the plan's order; entries of kernels no longer declared are left out.
    """
    out = []
    for entry in entries:
        d = _kernel(entry)
        index = getattr(getattr(getattr(d, "_cache", None), "_cache_file", None), "_index_path", None)
        if d is not None and index and not os.path.exists(index):
            out.append((entry, d))
    return out


def kernel_key(kernel) -> tuple[str, str]:
    """Return the ``(module, qualified name)`` of a kernel, as a plan entry names it.

    Parameters
    ----------
    kernel : numba dispatcher
        A declared kernel.

    Returns
    -------
    tuple of (str, str)
        Its module and qualified name.
    """
    return kernel.py_func.__module__, kernel.py_func.__qualname__


def _called_dispatchers(func) -> list:
    """The numba dispatchers a Python function's source may call: the global names, closure
    cells and ``module.attribute`` names its code (and the code nested in it) reads."""
    from numba.core.dispatcher import Dispatcher

    codes, names = [func.__code__], set()
    while codes:
        code = codes.pop()
        names.update(code.co_names)
        codes.extend(c for c in code.co_consts if isinstance(c, CodeType))
    found = [func.__globals__.get(n) for n in names]
    found += [cell.cell_contents for cell in (func.__closure__ or ()) if cell.cell_contents is not None]
    modules = [v for v in found if isinstance(v, ModuleType)]
    found += [getattr(m, n, None) for m in modules for n in names]
    return [v for v in found if isinstance(v, Dispatcher)]


def call_graph(kernels: Sequence | None = None) -> dict[tuple[str, str], frozenset]:
    """Return the declared kernels each kernel calls, read from its Python source.

    numba compiles a kernel together with every kernel it calls that the cache lacks (and
    writes each to the cache), so whichever process compiles a caller first compiles its
    callees too. The calls are read statically, without compiling: the names the kernel's
    code reads (global names, ``module.attribute`` names, closure cells) that are numba
    dispatchers; a dispatcher not declared as a kernel (a helper inlined into its callers,
    :mod:`rfsim.core._jit`) is compiled into its caller, so the kernels *it*
    reads count as the caller's. This can only list too many calls (a name read in a branch a
    signature never compiles), never too few for code that calls kernels by name — the only
    way rfsim's kernels call each other — and too many only makes a child of
    :func:`precompile` wait for a kernel it would not have compiled.
    It needs no record in the plans file, so it is always the call graph of the code that runs.

    Parameters
    ----------
    kernels : sequence of numba dispatcher, optional
        The kernels to read (default every declared kernel,
        :data:`rfsim.core._jit.KERNELS`).

    Returns
    -------
    dict of (str, str) to frozenset of (str, str)
        For each kernel's :func:`kernel_key`, the keys of the declared kernels it calls
        directly (itself left out).
    """
    from rfsim.core._jit import KERNELS

    declared = {id(d) for d in KERNELS}
    graph = {}
    for d in (KERNELS if kernels is None else kernels):
        seen, todo, calls = {id(d)}, [d.py_func], set()
        while todo:
            for c in _called_dispatchers(todo.pop()):
                if id(c) in declared:
                    calls.add(kernel_key(c))
                elif id(c) not in seen:  # an inlined helper: its calls are the caller's
                    seen.add(id(c))
                    todo.append(c.py_func)
        calls.discard(kernel_key(d))
        graph[kernel_key(d)] = frozenset(calls)
    return graph


def reached(key, calls: Mapping) -> set:
    """Return the kernels a kernel compiles with it: every kernel it calls, directly or through
    other kernels.

    Parameters
    ----------
    key : hashable
        The kernel (a key of ``calls``).
    calls : mapping of hashable to iterable of hashable
        The kernels each kernel calls directly (:func:`call_graph`); a key it lacks calls nothing.

    Returns
    -------
    set
        The kernels reached, ``key`` itself left out (also where a cycle returns to it).
    """
    out: set = set()
    todo = [key]
    while todo:
        for callee in calls.get(todo.pop(), ()):
            if callee not in out and callee != key:
                out.add(callee)
                todo.append(callee)
    return out


def shares(items: Sequence, n: int, calls: Mapping | None = None) -> list[list]:
    """Deal items to ``n`` shares, each kernel to one share, so that the last share ends first
    when a share waits for the callees it lacks (list scheduling of the call graph).

    A kernel's overloads weigh the sum of their recorded compile times (an entry without a
    recorded time one second). Its *rank* is its weight plus the largest rank of the kernels
    that call it (the longest chain of compilations that must follow it). Kernels are dealt
    by rank, highest first — so every callee before its callers — each onto the share where
    it would finish first: it starts when that share is free and every callee it reaches
    (:func:`reached`) that another share compiles is done. With no calls this is the LPT rule
    (longest compilation first onto the least loaded share).

    Each kernel is compiled by one share only: a caller whose callee another share compiles
    waits for it (:func:`precompile`) and then loads it from the cache, instead of compiling
    it a second time as it would while the callee's share is still at work.

    Parameters
    ----------
    items : sequence of (PlanEntry, object)
        What :func:`uncached` returned.
    n : int
        Shares (≥ 1).
    calls : mapping, optional
        The call graph by ``(module, name)`` (:func:`call_graph`); default: no calls.

    Returns
    -------
    list of list
        At most ``n`` non-empty shares, each in the order dealt (callees before callers; a
        kernel's overloads together, in the plan's order).
    """
    calls = calls or {}
    keys: list = []
    weight: dict = {}
    for e, _ in items:
        key = (e.module, e.name)
        if key not in weight:
            keys.append(key)
            weight[key] = 0.0
        weight[key] += e.compile_s if e.compile_s > 0 else 1.0
    reach = {k: reached(k, calls) & weight.keys() for k in keys}
    rank: dict = {}
    callers = {k: [c for c in keys if k in reach[c]] for k in keys}

    def rank_of(k, path=()):
        if k not in rank:
            rank[k] = weight[k] + max((rank_of(c, path + (k,)) for c in callers[k] if c not in path), default=0.0)
        return rank[k]

    order = sorted(keys, key=lambda k: (-rank_of(k), keys.index(k)))
    load = [0.0] * max(1, int(n))
    owner: dict = {}
    finish: dict = {}
    for k in order:  # onto the share where it ends first (the lowest of equal ones)
        ends = [max([load[s]] + [finish[c] for c in reach[k] if owner.get(c, s) != s]) + weight[k]
                for s in range(len(load))]
        s = ends.index(min(ends))
        finish[k] = load[s] = ends[s]
        owner[k] = s
    out = [[item for k in order if owner[k] == s for item in items if (item[0].module, item[0].name) == k]
           for s in range(len(load))]
    return [share for share in out if share]


def waits(dealt: Sequence[Sequence], calls: Mapping) -> list[list[list[tuple]]]:
    """Return, for each entry of each share, the callees other shares compile, which its share
    waits for before compiling it.

    Parameters
    ----------
    dealt : sequence of sequence of (PlanEntry, object)
        Shares as :func:`shares` returned them.
    calls : mapping
        The call graph by ``(module, name)`` (:func:`call_graph`).

    Returns
    -------
    list of list of list of ((str, str), int)
        ``waits[s][i]``: ``(callee, share)`` for every kernel the ``i``-th entry of share ``s``
        reaches (:func:`reached`) that another share compiles, sorted by callee.
    """
    owner = {(e.module, e.name): s for s, share in enumerate(dealt) for e, _ in share}
    return [[[(c, owner[c]) for c in sorted(reached((e.module, e.name), calls)) if owner.get(c, s) != s]
             for e, _ in share] for s, share in enumerate(dealt)]


#: Longest wait of a share for a callee another share compiles [s]; then it compiles the callee
#: itself (a share killed before it wrote its end mark).
WAIT_S = 300.0
#: A share that has not started this long after another began to wait for it [s] is not
#: running alongside (a ``run`` that calls its tasks one after the other): not waited for.
START_S = 30.0


def _wait_for(folder: str, waits: Sequence[tuple[str, int]]) -> None:
    """Wait until each ``(mark, share)`` has its mark file in ``folder``, or that share ended
    (its ``s<share>.ended`` mark), did not start within :data:`START_S`, or :data:`WAIT_S` passed."""
    import time

    t0 = time.monotonic()
    for mark, share in waits:
        while not os.path.exists(os.path.join(folder, mark)):
            waited = time.monotonic() - t0
            if (os.path.exists(os.path.join(folder, f"s{share}.ended")) or waited > WAIT_S
                    or (waited > START_S and not os.path.exists(os.path.join(folder, f"s{share}.started")))):
                break
            time.sleep(0.02)


def _mark(folder: str, name: str) -> None:
    """Create the empty mark file ``name`` in ``folder``."""
    with open(os.path.join(folder, name), "w", encoding="utf-8"):
        pass


def _compile_share(share: list, index: int, folder: str, leader: int) -> Callable[[], None]:
    """A task that compiles a share's overloads here (the cache written by numba), each kernel's
    failure left for the run to raise. ``share`` holds ``(entry, kernel, waits, mark)``: before
    the entry it waits for the marks ``waits`` of the callees other shares compile (only in a
    process other than ``leader``'s, i.e. alongside the other shares), and after it writes
    ``mark`` (its kernel's last overload of the share) into ``folder``."""

    def task() -> None:
        from rfsim.core._jit import compiling_elsewhere

        _mark(folder, f"s{index}.started")
        try:
            with compiling_elsewhere(None):  # compile in this (child) process itself
                for entry, d, waits, mark in share:
                    if os.getpid() != leader:
                        _wait_for(folder, waits)
                    try:
                        d.compile(tuple(type_of_text(t) for t in entry.signature))
                    except Exception:  # the run compiles it again when called, and raises there
                        pass
                    if mark:
                        _mark(folder, mark)
        finally:
            _mark(folder, f"s{index}.ended")

    return task


def precompile(entries: Sequence[PlanEntry], *, processes: int | None = None,
               run: Callable | None = None) -> int:
    """Compile a plan's uncached kernels in child processes at once, before a run.

    The kernels are dealt by :func:`shares` over the call graph (:func:`call_graph`): each
    child compiles its kernels callees first, and before a kernel whose callee another child
    compiles, waits until that child has written the callee to the cache (a mark file in a
    temporary folder after each kernel), so every kernel is compiled once.

    Parameters
    ----------
    entries : sequence of PlanEntry
        The plan.
    processes : int, optional
        Child processes (default :func:`usable_cpus`, at most :data:`MAX_PROCESSES`); with one,
        nothing is done (the run compiles each kernel when called, which takes as long).
    run : callable, optional
        ``run(task, while_waiting=...)``: calls ``task()`` in a child process, calling
        ``while_waiting()`` here meanwhile (default :func:`rfsim.core.procs.run_in_child`).

    Returns
    -------
    int
        The overloads given to the children (0: nothing to do).
    """
    import shutil
    import tempfile

    n = min(MAX_PROCESSES, usable_cpus() if processes is None else int(processes))
    todo = uncached(entries)
    if n < 2 or len(todo) < 2:
        return 0
    if run is None:
        from rfsim.core.procs import run_in_child as run
    calls = call_graph()
    dealt = shares(todo, n, calls)
    keys = list(dict.fromkeys((e.module, e.name) for e, _ in todo))
    folder = tempfile.mkdtemp(prefix="rfsim-plan-")
    tasks = []
    for s, (share, share_waits) in enumerate(zip(dealt, waits(dealt, calls))):
        rows = []
        for i, ((e, d), wait) in enumerate(zip(share, share_waits)):
            key = (e.module, e.name)
            last = i + 1 == len(share) or (share[i + 1][0].module, share[i + 1][0].name) != key
            rows.append((e, d, [(f"k{keys.index(c)}.done", t) for c, t in wait],
                         f"k{keys.index(key)}.done" if last else None))
        tasks.append(_compile_share(rows, s, folder, os.getpid()))

    def start(k: int) -> None:  # child k, and the later ones while it works
        if k < len(tasks):
            run(tasks[k], while_waiting=(lambda: start(k + 1)) if k + 1 < len(tasks) else None)

    try:
        start(0)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return len(todo)


def precompile_scenario(name: str) -> int:
    """:func:`precompile` the plan of a scenario, if the plans file holds one.

    Parameters
    ----------
    name : str
        The scenario's name.

    Returns
    -------
    int
        The overloads given to child processes (0: no plan, a warm cache or one CPU).
    """
    try:
        plan = read_plans().get(name)
    except (OSError, ValueError):  # a damaged plans file: the run compiles lazily as before
        return 0
    return precompile(plan) if plan else 0


def record(names: Sequence[str]) -> dict[str, list[PlanEntry]]:
    """Run each scenario's default config (seed 1) in this process and return its plan.

    Each scenario's plan is the overloads its kernels hold after its run that were not held
    before it (so run each scenario in a new process for a complete plan: the kernels an
    earlier scenario left compiled are not recorded again).

    Parameters
    ----------
    names : sequence of str
        Built-in scenario names.

    Returns
    -------
    dict of str to list of PlanEntry
        The plans.
    """
    from rfsim.core._jit import compiled_signatures
    from rfsim.runs.registry import builtin_modules

    modules = builtin_modules()
    plans = {}
    for name in names:
        before = set((m, n, s) for m, n, s in compiled_signatures())
        module = modules[name]
        module.run(module.Config(), seed=1)
        plans[name] = entries_of([k for k in compiled_signatures() if k not in before])
    return plans


def compile_times(entries: Sequence[PlanEntry]) -> list[PlanEntry]:
    """Compile a plan's entries in its order here and return them with the CPU time each took.

    Run it in a new process with an empty kernel cache (``NUMBA_CACHE_DIR`` a new folder):
    an entry's time then includes its callees that no earlier entry compiled (and the first
    entry the compiler's own start).

    Parameters
    ----------
    entries : sequence of PlanEntry
        The plan.

    Returns
    -------
    list of PlanEntry
        The entries with ``compile_s`` set (entries of kernels no longer declared left out).
    """
    import time

    out = []
    for entry in entries:
        d = _kernel(entry)
        if d is None:
            continue
        t0 = time.process_time()
        d.compile(tuple(type_of_text(t) for t in entry.signature))
        out.append(dataclasses.replace(entry, compile_s=time.process_time() - t0))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rfsim.runs.kernel_plan SCENARIO ...``: record the plans of the scenarios
    (each in a process of its own) and write them into the plans file, keeping the others.

    Run it with ``NUMBA_CACHE_DIR`` set to a new, empty folder for each scenario: the kernels
    are then compiled in the recording process, and the kernels they call are listed as entries
    of their own, before their callers (a cache loads a caller with its callees inside, which
    then go unlisted). The children then compile the callees side by side before their callers,
    and :func:`shares` can balance them.

    Parameters
    ----------
    argv : sequence of str, optional
        Scenario names (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status (0).
    """
    import subprocess
    import tempfile

    names = list(sys.argv[1:] if argv is None else argv)
    plans = read_plans()
    for name in names:
        code = ("import json, sys; from rfsim.runs.kernel_plan import record; "
                "print(json.dumps([e.text() for e in record([sys.argv[1]])[sys.argv[1]]]))")
        out = subprocess.run([sys.executable, "-c", code, name], check=True, capture_output=True, text=True)
        lines = json.loads(out.stdout.strip().splitlines()[-1])
        timing = ("import json, sys; from rfsim.runs.kernel_plan import PlanEntry, compile_times; "
                  "print(json.dumps([e.compile_s for e in compile_times([PlanEntry.parse(x) for x in "
                  "json.loads(sys.argv[1])])]))")
        with tempfile.TemporaryDirectory() as empty:  # an empty cache: every entry compiles
            out = subprocess.run([sys.executable, "-c", timing, json.dumps(lines)], check=True, capture_output=True,
                                 text=True, env=dict(os.environ, NUMBA_CACHE_DIR=empty))
        seconds = json.loads(out.stdout.strip().splitlines()[-1])
        plans[name] = [dataclasses.replace(PlanEntry.parse(x), compile_s=t) for x, t in zip(lines, seconds)]
        print(f"{name}: {len(plans[name])} kernel overloads, {sum(seconds):.1f} s of compilation")
    write_plans(plans)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())


__all__ = ["PLANS_FILE", "PLANS_FORMAT", "MAX_PROCESSES", "SCALARS", "PlanEntry", "text_of_type", "type_of_text",
           "entries_of", "read_plans", "write_plans", "usable_cpus", "uncached", "kernel_key", "call_graph",
           "reached", "shares", "waits", "WAIT_S", "START_S", "precompile",
           "precompile_scenario", "record", "compile_times", "main"]

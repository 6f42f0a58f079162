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
weights by which :func:`shares` deals the entries to the children, longest first. A signature is written as text, one argument type
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
from collections.abc import Callable, Sequence
from pathlib import Path

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


def shares(items: Sequence, n: int) -> list[list]:
    """Deal items to ``n`` shares, longest compilation first onto the share with the least
    compile time so far (the LPT rule; an entry without a recorded time weighs one second).

    Parameters
    ----------
    items : sequence of (PlanEntry, object)
        What :func:`uncached` returned.
    n : int
        Shares (≥ 1).

    Returns
    -------
    list of list
        At most ``n`` non-empty shares, each in the plan's order.
    """
    weight = [(e.compile_s if e.compile_s > 0 else 1.0) for e, _ in items]
    out: list[list[int]] = [[] for _ in range(max(1, int(n)))]
    load = [0.0] * len(out)
    for i in sorted(range(len(items)), key=lambda i: -weight[i]):
        k = min(range(len(out)), key=lambda k: load[k])
        out[k].append(i)
        load[k] += weight[i]
    return [[items[i] for i in sorted(share)] for share in out if share]


def _compile_share(share: list) -> Callable[[], None]:
    """A task that compiles a share's overloads here (the cache written by numba), each kernel's
    failure left for the run to raise."""

    def task() -> None:
        from rfsim.core._jit import compiling_elsewhere

        with compiling_elsewhere(None):  # compile in this (child) process itself
            for entry, d in share:
                try:
                    d.compile(tuple(type_of_text(t) for t in entry.signature))
                except Exception:  # the run compiles it again when called, and raises there
                    pass

    return task


def precompile(entries: Sequence[PlanEntry], *, processes: int | None = None,
               run: Callable | None = None) -> int:
    """Compile a plan's uncached kernels in child processes at once, before a run.

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
    n = min(MAX_PROCESSES, usable_cpus() if processes is None else int(processes))
    todo = uncached(entries)
    if n < 2 or len(todo) < 2:
        return 0
    if run is None:
        from rfsim.core.procs import run_in_child as run
    tasks = [_compile_share(s) for s in shares(todo, n)]

    def start(k: int) -> None:  # child k, and the later ones while it works
        if k < len(tasks):
            run(tasks[k], while_waiting=(lambda: start(k + 1)) if k + 1 < len(tasks) else None)

    start(0)
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
           "entries_of", "read_plans", "write_plans", "usable_cpus", "uncached", "shares", "precompile",
           "precompile_scenario", "record", "compile_times", "main"]

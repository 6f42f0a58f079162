"""The size of a run before any work: work units and an upper bound on peak memory.

A scenario may define ``resource_estimate(config) -> Estimate`` (the built-in scenarios' size
models are in :mod:`rfsim.runs.sizes`, whose ``estimate_of`` finds a run's estimate).
:func:`check_memory` compares the estimate with a limit (``--max-memory``; default half the
memory the system reports available) and stops with one line naming the config keys that drive
the size, the estimate and the limit (:class:`~rfsim.core.errors.UserError`, exit status 2).
A scenario without ``resource_estimate`` is not checked.

The peak is that of the largest rfsim process of the run, in bytes of resident memory: the
baseline of a process that has imported the libraries and loaded the compiled kernels
(:data:`BASELINE_BYTES`, measured) plus the bytes per work unit times the units held at once.
A run with worker processes counts one such process per worker besides the leader.

The first run after an install or an edit of a kernel source compiles the scenario's numba
kernels (a cold cache): a compiling process holds more (LLVM, the typed IR) and keeps much of it
until it ends, so the run compiles each missing kernel in a short-lived child process
(:func:`rfsim.core._jit.compiling_elsewhere`) and only loads the result. The largest process of
such a run is then the run's own (``peak_bytes``) or a compiling child: a process that has
imported the libraries (:data:`IMPORT_BYTES`) plus what compiling adds (``compile_bytes``).
:attr:`Estimate.first_run_bytes`, the larger of the two, is what :func:`check_memory` compares
with the limit, since a run cannot tell beforehand which kernels it will compile.
"""

from __future__ import annotations

import dataclasses
import os
import re
from pathlib import Path

from rfsim.core.errors import UserError

#: Resident memory of a run's process before its arrays [B]: interpreter, numpy, scipy, numba,
#: h5py and the compiled kernels of a scenario (measured 180-260 MB by the peak resident set
#: of the smallest run of every built-in scenario, rounded up).
BASELINE_BYTES = 300 * 2**20
#: Resident memory of an rfsim process that has imported its libraries, before any kernel is
#: compiled or any array made [B] (the command-line process: 94 MiB measured, rounded up); the
#: base of a compiling child (:attr:`Estimate.first_run_bytes`).
IMPORT_BYTES = 100 * 2**20

_UNITS = {"": 1, "b": 1, "k": 10**3, "kb": 10**3, "m": 10**6, "mb": 10**6, "g": 10**9, "gb": 10**9,
          "t": 10**12, "tb": 10**12, "kib": 2**10, "mib": 2**20, "gib": 2**30, "tib": 2**40}
_SIZE = re.compile(r"\s*([0-9]*\.?[0-9]+(?:[eE][0-9]+)?)\s*([a-zA-Z]*)\s*")


@dataclasses.dataclass(frozen=True)
class Estimate:
    """The size of a run.

    Parameters
    ----------
    work_units : int
        Trials, draws, positions... (the scenario's unit).
    peak_bytes : int
        Upper bound on the peak resident memory of the run's largest process [B].
    drivers : tuple of str
        The config keys that set the size, named in the error when it is too large.
    compile_bytes : int, default 0
        What compiling the scenario's kernels on a cold cache adds to the peak of a process
        [B] (measured: peak of the smallest run on an empty cache minus that on a full one,
        rounded up); 0 for a scenario without kernels.
    """

    work_units: int
    peak_bytes: int
    drivers: tuple[str, ...]
    compile_bytes: int = 0

    @property
    def first_run_bytes(self) -> int:
        """Upper bound on the peak of a run that compiles the kernels (a cold cache) [B]:
        ``max(peak_bytes, IMPORT_BYTES + compile_bytes)`` — the run's own process, or a
        short-lived child compiling a kernel (module docstring); ``peak_bytes`` without
        kernels to compile."""
        if not self.compile_bytes:
            return self.peak_bytes
        return max(self.peak_bytes, IMPORT_BYTES + self.compile_bytes)


def process_peak(bytes_per_unit: float, units_at_once: float, *, processes: int = 1,
                 baseline_bytes: int = BASELINE_BYTES) -> int:
    """Peak memory of processes that each hold some work units above a baseline.

    .. math:: P = N_{proc} (B_0 + b u)

    (the project's own size model, module docstring).

    Parameters
    ----------
    bytes_per_unit : float
        Bytes held per work unit, :math:`b` [B].
    units_at_once : float
        Work units held at once by one process, :math:`u`.
    processes : int, default 1
        Processes of the run, :math:`N_{proc}`.
    baseline_bytes : int, default BASELINE_BYTES
        Resident memory of a process before its arrays, :math:`B_0` [B].

    Returns
    -------
    int
        The peak :math:`P` [B].
    """
    return int(processes * (baseline_bytes + bytes_per_unit * units_at_once))


def pool_processes(workers: int, tasks: int) -> int:
    """Processes of a run on a pool: the leader plus the workers that start.

    Parameters
    ----------
    workers : int
        Pool workers asked for (0 = all cores, 1 = in process).
    tasks : int
        Tasks of the run.

    Returns
    -------
    int
        1 in process, else 1 + min(workers, tasks).
    """
    w = workers or (os.cpu_count() or 1)
    return 1 if w <= 1 or tasks <= 1 else 1 + min(w, tasks)


def parse_size(text: str) -> int:
    """Bytes of a size such as ``2GiB``, ``500M``, ``1e9``.

    Parameters
    ----------
    text : str
        A number with an optional unit: k/M/G/T (decimal), KiB/MiB/GiB/TiB (binary), B;
        case-insensitive.

    Returns
    -------
    int
        The size [B], at least 1.

    Raises
    ------
    UserError
        ``text`` is not a size (one line naming ``--max-memory``).
    """
    m = _SIZE.fullmatch(text)
    unit = m.group(2).lower() if m else ""
    if not m or unit not in _UNITS or float(m.group(1)) * _UNITS[unit] < 1:
        raise UserError(f"--max-memory {text!r}: expected a size such as 2GiB, 500MB or 1e9 (bytes)")
    return int(float(m.group(1)) * _UNITS[unit])


def available_bytes(meminfo: Path = Path("/proc/meminfo")) -> int | None:
    """``MemAvailable`` of the system.

    Parameters
    ----------
    meminfo : Path, default /proc/meminfo
        The file that reports it.

    Returns
    -------
    int or None
        The available memory [B]; None where it is not reported.
    """
    try:
        for line in meminfo.read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def default_limit_bytes() -> int | None:
    """The default limit of ``--max-memory``: half of the available memory.

    Returns
    -------
    int or None
        Half of :func:`available_bytes` [B]; None where it is unknown (no check).
    """
    avail = available_bytes()
    return avail // 2 if avail else None


def format_bytes(n: float) -> str:
    """A size in MiB or GiB, e.g. ``'1.5 GiB'``.

    Parameters
    ----------
    n : float
        The size [B].

    Returns
    -------
    str
        GiB with one decimal from 1 GiB on, else whole MiB.
    """
    return f"{n / 2**30:.1f} GiB" if n >= 2**30 else f"{n / 2**20:.0f} MiB"


def check_memory(estimate: Estimate | None, limit_bytes: int | None, *, what: str,
                 processes: int = 1) -> None:
    """Stop when ``processes`` × the estimated peak of a first run exceeds the limit.

    The peak compared is :attr:`Estimate.first_run_bytes` (kernel compilation included).

    Parameters
    ----------
    estimate : Estimate or None
        The run's estimate (None: not checked).
    limit_bytes : int or None
        The limit [B] (None: not checked).
    what : str
        The run, as the message names it.
    processes : int, default 1
        Runs of this size at once (sweep workers).

    Raises
    ------
    UserError
        One line naming the drivers, the estimate and the limit (exit status 2).
    """
    if estimate is None or limit_bytes is None:
        return
    peak = estimate.first_run_bytes * processes
    if peak > limit_bytes:
        times = f" × {processes} at once" if processes > 1 else ""
        raise UserError(f"{what} is too large: {', '.join(estimate.drivers)} give an estimated peak "
                        f"memory of {format_bytes(peak)}{times} ({estimate.work_units} work units) "
                        f"over the limit of {format_bytes(limit_bytes)}; make them smaller or raise "
                        f"--max-memory")


__all__ = ["BASELINE_BYTES", "Estimate", "available_bytes", "check_memory", "default_limit_bytes",
           "format_bytes", "parse_size", "pool_processes", "process_peak"]

"""rfsim — time-domain, sample-level UHF RFID link-level simulator.

Core package: units and constants (:mod:`rfsim.core.units`), reproducible randomness
(:mod:`rfsim.core.rng`), typed configs (:mod:`rfsim.core.config`), HDF5 datasets
(:mod:`rfsim.core.dataset`), the EPC Gen2 PHY/MAC primitives (:mod:`rfsim.gen2`) and the
command line (:mod:`rfsim.cli`). Propagation lives in the sibling package
``channels``, device models in ``devices`` and runnable scenarios in ``scenarios``.

The Python API (:mod:`rfsim.runs.api`; every name below is imported on first use, so
``import rfsim`` stays light):

* :func:`rfsim.run` runs a scenario (a name from ``rfsim list`` or a scenario file's path)
  and returns a :class:`rfsim.Result`: ``.table(name)`` (pandas), ``.to_xarray()``,
  ``.figures()``, ``.save(path)``;
* :func:`rfsim.run_sweep` runs a sweep spec and returns its merged dataset as a Result;
* :class:`rfsim.Simulation` (:mod:`rfsim.protocols.simulation`) runs a scene of devices
  and a channel built in a script, round by round;
* :class:`rfsim.Scene` is the propagation environment of a channel
  (:class:`rfsim.channels.Scene`: surfaces, walls, large- and small-scale models); devices
  are placed by their antennas, not in the Scene.
"""

from __future__ import annotations

import os as _os

# rfsim parallelises by processes (one per core, rfsim.core.procs) and its kernels are
# single-threaded; a multi-threaded BLAS inside each process only oversubscribes the cores
# (on a loaded 2-core machine a 17,600-sample dot product took 7.8 ms with OpenBLAS threads
# and 5 µs with one). One BLAS thread unless the user chose otherwise; effective when rfsim
# is imported before numpy (the ``rfsim`` command).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")


def _version() -> str:
    # importlib.metadata costs ≈ 0.1 s of start-up: read on first use of rfsim.__version__
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rfsim")
    except PackageNotFoundError:  # running from a source tree that is not installed
        return "0+unknown"


def __getattr__(name: str):
    if name == "__version__":
        value = _version()
        globals()["__version__"] = value
        return value
    if name == "Simulation":
        from rfsim.protocols.simulation import Simulation

        return Simulation
    if name in _API:
        from rfsim.runs import api

        return getattr(api, name)
    raise AttributeError(f"module 'rfsim' has no attribute {name!r}")


#: Names exported from :mod:`rfsim.runs.api` on first use.
_API = ("run", "run_sweep", "Result", "Scene")

__all__ = ["__version__", "run", "run_sweep", "Result", "Simulation", "Scene"]


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

"""rfsim — time-domain, sample-level UHF RFID link-level simulator.

Core package: units and constants (:mod:`rfsim.core.units`), reproducible randomness
(:mod:`rfsim.core.rng`), typed configs (:mod:`rfsim.core.config`), HDF5 datasets
(:mod:`rfsim.core.dataset`), the EPC Gen2 PHY/MAC primitives (:mod:`rfsim.gen2`) and the
command line (:mod:`rfsim.cli`). Propagation lives in the sibling package
``channels``, device models in ``devices`` and runnable scenarios in ``scenarios``.

Scripts build a scene from ``devices`` and ``channels`` and run it with
:class:`rfsim.Simulation` (:mod:`rfsim.protocols.simulation`; imported on first use, so
``import rfsim`` stays light).
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
    raise AttributeError(f"module 'rfsim' has no attribute {name!r}")


__all__ = ["__version__", "Simulation"]

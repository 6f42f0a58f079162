"""Run one scenario: config → ``run()`` → atomic HDF5 dataset with provenance → figures.

The dataset path and the figure folder are checked before the simulation starts
(:mod:`rfsim.core.outputs`). The simulation and the dataset file are made in a child process
(:func:`rfsim.core.procs.run_in_child`), which returns the run's memory (kernels, libraries,
arrays) to the system when it exits; the figures are then drawn here from the file. A kernel
missing from numba's on-disk cache (a first run) is compiled in a short-lived child of that
child (:func:`rfsim.core._jit.compiling_elsewhere`), so the compiler's memory is never added to
the run's.
Each stage is announced on the active progress reporter (:mod:`rfsim.core.progress`; nothing
is printed without one), and the first run after install says that numba compiles its
kernels. Figures are named after the dataset's stem (``x.h5`` → ``x-*.png``).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from types import ModuleType
from typing import Any

from rfsim.core.config import to_toml
from rfsim.core.dataset import make_provenance, utc_now, write_dataset
from rfsim.core.errors import ResourceError, UserError, check_seed
from rfsim.core.locks import output_lock
from rfsim.core.outputs import check_output_file, check_output_folder, remove_stale_partials
from rfsim.core.procs import few_collections, run_in_child
from rfsim.core.progress import current, stage
from rfsim.runs.resources import check_memory, default_limit_bytes
from rfsim.runs.sizes import estimate_of


@dataclasses.dataclass(frozen=True)
class RunOutput:
    """What a run wrote: the dataset file, the figures and the wall time.

    Attributes
    ----------
    dataset_path : pathlib.Path
        The HDF5 dataset file.
    figure_paths : tuple of pathlib.Path
        The figure files (empty without figures).
    wall_time_s : float
        Wall time of the whole run, figures included [s].
    """

    dataset_path: Path
    figure_paths: tuple[Path, ...]
    wall_time_s: float


def run_scenario(module: ModuleType, config: Any, *, seed: int, out_dir: Path,
                 output: Path | None = None, make_plots: bool = True,
                 max_memory_bytes: int | None | str = "default") -> RunOutput:
    """Run ``module`` with ``config`` and ``seed``; write ``<out_dir>/<name>.h5`` + figures.

    The dataset path and the figure folder are checked (and missing folders created)
    before the simulation starts, so a path that cannot be written is an error then, not
    a lost result afterwards. The simulation and the dataset file are made in a child
    process; the figures are drawn here from the file.

    Parameters
    ----------
    module : module
        The scenario module (``NAME``, ``run``, ``plot``).
    config : object
        The scenario's resolved ``Config``.
    seed : int
        Root seed in [0, 2**64).
    out_dir : pathlib.Path
        Folder of the figures, and of the dataset when ``output`` is None.
    output : pathlib.Path, optional
        The dataset file (``.h5`` or ``.hdf5``); None writes ``<out_dir>/<NAME>.h5``.
    make_plots : bool, optional
        Draw the scenario's figures, default True.
    max_memory_bytes : int, None or "default", optional
        Refuse a run whose estimated peak memory (:func:`rfsim.runs.sizes.estimate_of`)
        exceeds it [bytes]; ``"default"`` (the default): half the available memory; None:
        no check.

    Returns
    -------
    RunOutput
        The dataset path, the figure paths and the wall time.

    Raises
    ------
    rfsim.core.errors.UserError
        A bad seed, an estimated memory over ``max_memory_bytes``, an output path or
        folder that cannot be written, or a figure that could not be saved (the dataset is
        then written); one line.
    rfsim.core.errors.ResourceError
        The system stopped the run (e.g. the disk filled up).
    """
    start_utc, t0 = utc_now(), time.perf_counter()
    check_seed(seed)
    limit = default_limit_bytes() if max_memory_bytes == "default" else max_memory_bytes
    check_memory(estimate_of(module, config), limit, what=f"the {module.NAME} run")
    path = output if output is not None else out_dir / f"{module.NAME}.h5"
    if make_plots or output is None:
        check_output_folder(out_dir, "--out-dir")
    check_output_file(path, "--output" if output is not None else "dataset", suffixes=(".h5", ".hdf5"))

    def simulate_and_write() -> None:
        from rfsim.core._jit import compiling_elsewhere  # numba: in the child only
        from rfsim.runs.kernel_plan import precompile_scenario

        _announce_compilation()
        # a cold cache: the kernels the scenario's default run calls are compiled side by side,
        # one child process per usable CPU, before the run (rfsim.runs.kernel_plan)
        precompile_scenario(module.NAME)
        # each kernel the cache lacks is compiled in a process of its own, which ends after it:
        # the compiler's memory is not added to the run's (a warm run finds every kernel cached)
        with compiling_elsewhere(run_in_child), few_collections():
            stage(f"running {module.NAME} (seed {seed})")
            dataset = module.run(config, seed=seed)
        dataset.scenario = module.NAME
        provenance = make_provenance(config_toml=to_toml(config), seed=seed, scenario=module.NAME,
                                     start_time_utc=start_utc)
        stage(f"writing {path}")
        write_dataset(path, dataset, provenance)

    # The figures read the file: the run's kernels, libraries and arrays need not stay in
    # memory beside them; a child process returns all of them to the system when it exits.
    # No other rfsim process writes the dataset meanwhile (its lock), and what killed
    # writers of it left behind is removed.
    with output_lock(path, what="--output" if output is not None else "dataset", kind="run"):
        remove_stale_partials(path)
        run_in_child(simulate_and_write,
                     while_waiting=(lambda: _import_figure_libraries(module)) if make_plots else None)
    figures: tuple[Path, ...] = ()
    if make_plots:
        _release_free_memory()
        stage("drawing figures")
        try:
            figures = tuple(module.plot(path, out_dir))
        except ResourceError as err:  # disk full while drawing: the dataset is safe
            raise ResourceError(f"dataset {str(path)!r} written, but {err}") from None
        except OSError as err:  # e.g. a folder where a figure file should go; the dataset is safe
            raise UserError(f"dataset {str(path)!r} written, but a figure could not be saved in "
                            f"{str(out_dir)!r}: {err.strerror or err}; redraw after fixing it") from None
    return RunOutput(path, figures, time.perf_counter() - t0)


def _import_figure_libraries(module: ModuleType) -> None:
    """matplotlib (Agg), h5py and the modules a scenario names in its optional
    ``FIGURE_IMPORTS``, which its figures need here: imported while the child runs (≈ 0.4 s
    CPU on one core, beside the run's workers) rather than after it."""
    import importlib

    import h5py  # noqa: F401

    from rfsim.core.plots import pyplot

    pyplot()
    for name in getattr(module, "FIGURE_IMPORTS", ()):
        importlib.import_module(name)


def _release_free_memory() -> None:
    """Hand the memory the run freed back to the system before the figures allocate their
    own (glibc keeps freed blocks in per-thread arenas, which the main thread's figures do
    not reuse, so the peak would be the run's leftovers plus the figures). A no-op where
    the C library has no ``malloc_trim``."""
    import ctypes
    import ctypes.util
    import gc

    gc.collect()
    try:
        ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


#: Top-level packages of the project (their lazily declared modules are loaded before a run).
_PROJECT = ("rfsim",)


def _announce_compilation() -> None:
    """Say so up front when no kernel is cached yet (the pool workers compile silently)."""
    import importlib

    from rfsim.core._jit import first_compilation
    from rfsim.core.lazy import DECLARED

    # the kernel modules declare their kernels when loaded. The project's modules declared
    # lazily (a scenario's physics, so that 'rfsim config' stays light) are loaded first, until
    # they declare no more; the libraries declared beside them (scipy.signal, h5py, ...:
    # ~70 MB resident) load only if the run uses them
    loaded: set[str] = set()
    while todo := [n for n in dict.fromkeys(DECLARED) if n not in loaded and n.split(".")[0] in _PROJECT]:
        for name in todo:
            importlib.import_module(name)
            loaded.add(name)
    rep = current()
    if rep is not None and first_compilation():
        rep.compile_started()


__all__ = ["RunOutput", "run_scenario"]

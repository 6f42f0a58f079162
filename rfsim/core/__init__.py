"""Plumbing of rfsim: units and constants, errors, the RNG tree, typed configs, HDF5 datasets,
per-read records, columns and row tables (``columns``, ``rows``), output checks, progress, the
figure helpers (``plots``), the jit policy (``_jit``), lazy imports, worker processes and the
Monte-Carlo cell runner (``procs``, ``monte_carlo``), references and trajectories. Imports nothing
of rfsim outside ``rfsim.core``.
"""

"""Plumbing of rfsim: units and constants, errors, the RNG tree, typed configs, HDF5 datasets and
per-read records, output checks, progress, the figure helpers, the jit policy, lazy imports,
worker processes, references, trajectories. Imports nothing of rfsim outside ``rfsim.core``.
"""

"""Running scenarios: discovery of built-in and user scenarios (:mod:`~rfsim.runs.registry`) and
one run from config to HDF5 dataset and figures (:mod:`~rfsim.runs.runner`). An edge of the core:
it may import ``rfsim.scenarios`` at run time; the rest of the core never does.
"""

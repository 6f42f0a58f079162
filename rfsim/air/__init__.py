"""The air interface: segments, the one propagation step (:mod:`~rfsim.air.step`), receiver
noise (:mod:`~rfsim.air.noise`), carrier plans (:mod:`~rfsim.air.carriers`) and the passband
cross-check (:mod:`~rfsim.air.passband`). Imports only ``rfsim.core``; meets devices through protocols.
"""

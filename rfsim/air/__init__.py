"""The air interface: segments (:mod:`~rfsim.air.segment`), the one propagation step
(:mod:`~rfsim.air.step`) with the devices' protocols (:mod:`~rfsim.air.roles`), its links
(:mod:`~rfsim.air.links`), reflector groups (:mod:`~rfsim.air.groups`) and fused backscatter
fast path (:mod:`~rfsim.air.fused`), receiver noise (:mod:`~rfsim.air.noise`), carrier plans (:mod:`~rfsim.air.carriers`) and the passband
cross-check (:mod:`~rfsim.air.passband`). Imports only ``rfsim.core``; meets devices through protocols.
"""

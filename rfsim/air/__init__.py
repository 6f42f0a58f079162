"""The air interface: segments (:mod:`~rfsim.air.segment`), the roles devices play and their
protocols (:mod:`~rfsim.air.roles`), links (:mod:`~rfsim.air.links`), reflector groups
(:mod:`~rfsim.air.groups`), the one propagation step in stages (:mod:`~rfsim.air.step`) and its batch
(:mod:`~rfsim.air.batch`) with its
fused backscatter strategy (:mod:`~rfsim.air.fused`), receiver noise (:mod:`~rfsim.air.noise`),
carrier plans (:mod:`~rfsim.air.carriers`) and the passband cross-check (:mod:`~rfsim.air.passband`).
Imports only ``rfsim.core``; meets devices through the protocols of :mod:`~rfsim.air.roles`.
"""

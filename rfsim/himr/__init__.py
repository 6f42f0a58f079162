"""The HIMR inertial-tag link family: the BOC line code (:mod:`~rfsim.himr.boc`), packets and
CRC-8 (:mod:`~rfsim.himr.packet`), per-packet link formulas (:mod:`~rfsim.himr.link`) and the
pylon's per-packet DSP (:mod:`~rfsim.himr.dsp`). Imports only ``rfsim.core``.
"""

"""What runs on the air: the Gen2 engine and trial batches (:mod:`~rfsim.protocols.engine`,
:mod:`~rfsim.protocols.batch`), inventory control, bistatic listening, beacons, FSA analytics and the
script entry point :class:`~rfsim.protocols.simulation.Simulation`. Imports ``rfsim.core``, ``rfsim.gen2``, ``rfsim.air``.
"""

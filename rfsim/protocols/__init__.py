"""What runs on the air: the Gen2 engine and trial batches (:mod:`~rfsim.protocols.engine`,
:mod:`~rfsim.protocols.batch`), inventory control (:mod:`~rfsim.protocols.inventory`), bistatic
listening, the beacon MAC, FSA analytics, the reference tags' slotted-Aloha schedule
(:mod:`~rfsim.protocols.tag_to_tag`), the device interfaces they rely on
(:mod:`~rfsim.protocols.interfaces`) and the script entry point
:class:`~rfsim.protocols.simulation.Simulation`. Imports ``rfsim.core``, ``rfsim.gen2``, ``rfsim.air``.
"""

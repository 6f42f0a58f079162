"""Device models: reader, passive tag, sense-a-tag, HIMR inertial tag, exciter.

Reader (:mod:`rfsim.devices.reader`): PIE transmitter (DSB/SSB/PR-ASK), frequency plans and
hopping, antennas in turn, IQ receiver with leakage removal, FM0/Miller decoding and
per-read RSSI/phase/Doppler/SNR.

Sense-a-tag (:mod:`rfsim.devices.sense_a_tag`): one or two antennas, envelope detector, band-pass
and comparator (:mod:`rfsim.devices.st_receiver`), the closed forms of phase cancellation
(:mod:`rfsim.devices.st_analytic`), dual-antenna techniques and the locator protocol.

Passive tag: Gen2 protocol logic (:mod:`rfsim.devices.gen2_tag_state`), front-end physics —
power-up, reflection-coefficient states, clock (:mod:`rfsim.devices.tag_frontend`), a chip whose
impedance follows its absorbed power (:mod:`rfsim.devices.tag_chip`) — and the
sample-level device that listens to a reader segment and answers with Γ(t)
(:mod:`rfsim.devices.tag`); many tags join the air step as one population
(:mod:`rfsim.devices.tag_population`).

Active RFID (Özkaya's 868 MHz beacons): the beacon tag (:mod:`rfsim.devices.active_tag`), its frame
and MSK modulation (:mod:`rfsim.devices.msk_beacon`), the sample-level reader with its RSSI
(:mod:`rfsim.devices.active_reader`) and the RSSI report stage (:mod:`rfsim.devices.rss_reader`).

Module map of the rest: the reader's transmitter (:mod:`rfsim.devices.reader_tx`), BLF search
(:mod:`rfsim.gen2.blf_search`) and measurements (:mod:`rfsim.devices.reader_measure`); the
tag's response record (:mod:`rfsim.devices.tag_response`), Gen2 values and the array state
machine (:mod:`rfsim.devices.gen2_tag_values`, :mod:`rfsim.devices.gen2_tag_arrays`), the PASS
replication tag (:mod:`rfsim.devices.pass_tag`); the sense-a-tag's settled levels
(:mod:`rfsim.devices.st_levels`), detector choice (:mod:`rfsim.devices.st_detector`), dual-antenna
pair coupling and techniques (:mod:`rfsim.devices.st_pair`), batched technique decoding
(:mod:`rfsim.devices.sense_a_tag_rows`), the frame-level receive chain of an ST listening to a
scheduled sender (:mod:`rfsim.devices.st_rows`) and a device's own transmit schedule
(:mod:`rfsim.devices.own_schedule`).
"""

from rfsim.core.lazy import lazy_exports

#: Module of the package → the public names it provides, each imported on first use (so
#: that importing one module, e.g. for a config dataclass, does not import the others).
_SOURCES = {
    "active_reader": ("ActiveReader", "ActiveReaderConfig", "BeaconRead"),
    "active_tag": ("ActiveTag", "ActiveTagConfig"),
    "gen2_tag_state": ("FlagPersistence", "Reply", "TagState", "pc_word"),
    "reader": ("Reader", "ReaderConfig", "ReadResult", "TxSegment", "frequency_plan"),
    "sense_a_tag": ("Observation", "SenseATag", "SenseATagConfig"),
    "tag": ("PassiveTag", "TagResponse"),
    "tag_config": ("TagConfig",),
    "tag_chip": ("ChipOperatingPoint", "PowerDependentChip"),
    "tag_frontend": ("PowerUp", "ReflectionStates", "TagClock", "differential_rcs_m2", "modulation_factor",
                     "power_transmission_coefficient", "reflection_coefficient"),
    "tag_population": ("TagPopulation",),
}
__getattr__, __dir__ = lazy_exports(globals(), _SOURCES)

__all__ = [
    "ActiveTag", "ActiveTagConfig", "ActiveReader", "ActiveReaderConfig", "BeaconRead",
    "SenseATag", "SenseATagConfig", "Observation",
    "Reader", "ReaderConfig", "ReadResult", "TxSegment", "frequency_plan",
    "PassiveTag", "TagConfig", "TagResponse", "TagPopulation", "PowerDependentChip", "ChipOperatingPoint",
    "TagState", "Reply", "FlagPersistence", "pc_word",
    "PowerUp", "ReflectionStates", "TagClock", "power_transmission_coefficient",
    "reflection_coefficient", "modulation_factor", "differential_rcs_m2",
]

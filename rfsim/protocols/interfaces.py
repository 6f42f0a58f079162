"""What the protocol layers rely on from devices and the channel, declared.

The Gen2 engine (:mod:`rfsim.protocols.engine`), trial batches (:mod:`rfsim.protocols.batch`),
inventory control (:mod:`rfsim.protocols.inventory`), bistatic listening
(:mod:`rfsim.protocols.bistatic`) and the beacon MAC (:mod:`rfsim.protocols.beacons`) meet the
devices of :mod:`rfsim.devices` and the channel of :mod:`rfsim.channels` only through the
members listed here (the air step's own protocols — emitters, reflectors, receivers, links —
are in :mod:`rfsim.air.step`). They import neither package; ``tests/test_interfaces.py`` checks
that every attribute these modules read from a reader, a tag or a channel is declared here and
that the device classes provide each declared member with the keywords the callers pass.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np


class Gen2ReaderSettings(Protocol):
    """The part of a reader's config the protocol layers read."""

    #: ``"off"`` or ``"preamble"``: whether the receiver estimates the tag's BLF from the RN16
    #: preamble (and keeps it for the ACK): a reader with a search keeps state between rounds,
    #: so a batch of trials needs one reader per trial.
    blf_search: str


@runtime_checkable
class Gen2Reader(Protocol):
    """An EPC Gen2 reader as the engine drives it (:class:`rfsim.devices.Reader`).

    ``link`` is its :class:`rfsim.gen2.link.LinkProfile`; ``antennas`` its antenna ports (in
    round-robin order); ``antenna_index(round_index)`` the port of a round; ``transmit`` a
    command and CW as a segment in √W at the port; ``receive`` the samples of the reply window →
    a read (detection, decoding, RSSI [dBm], phase [rad], Doppler [Hz], SNR [dB]);
    ``leakage_gain()`` the TX→RX coupling (complex amplitude gain); ``noise_power_w()`` the
    receiver's noise power [W per complex sample]."""

    link: Any
    antennas: Any
    config: Gen2ReaderSettings

    def antenna_index(self, round_index: int) -> int: ...

    def transmit(self, cmd, *, t0_s: float, cw_after_s: float, cw_before_s: float | None = None,
                 round_index: int = 0) -> Any: ...

    def receive(self, rx: np.ndarray, *, t0_s: float, n_bits: int, expect_crc: bool,
                cmd_end_s: float | None = None, blf_hz: float | None = None,
                carrier: complex | None = None) -> Any: ...

    def leakage_gain(self) -> complex: ...

    def noise_power_w(self) -> float: ...


@runtime_checkable
class Gen2Tag(Protocol):
    """A passive Gen2 tag as the engine drives it (:class:`rfsim.devices.PassiveTag`):
    ``listen`` to the incident field (√W, on the segment's time base) → its response (power-up,
    PIE decoding, state machine, and Γ(t) when it replies); ``state`` its Gen2 state (flags,
    slot counter) that inventory control reads."""

    state: Any

    def listen(self, incident: np.ndarray, *, t0_s: float, fs_hz: float) -> Any: ...


@runtime_checkable
class Gen2Channel(Protocol):
    """The channel as the protocol layers ask it (:class:`rfsim.channels.Channel`): the paths of
    one antenna pair (``link``) and the forward/backward path sets of a backscatter link
    (``backscatter_links``), each a :class:`rfsim.channels.PathSet`."""

    def link(self, tx, rx, *, fc_hz: float, rng: np.random.Generator | None = None, **kw) -> Any: ...

    def backscatter_links(self, emitter, tag, receiver=None, **kw) -> Any: ...


@runtime_checkable
class BeaconTag(Protocol):
    """An active beacon tag as the beacon MAC drives it (:class:`rfsim.devices.ActiveTag`)."""

    config: Any
    rng: Any
    burst_s: float

    def due_times(self, *args, **kw) -> Any: ...

    def next_seq(self) -> int: ...

    def send(self, *args, **kw) -> Any: ...

    def clear(self, *args, **kw) -> Any: ...


__all__ = ["Gen2ReaderSettings", "Gen2Reader", "Gen2Tag", "Gen2Channel", "BeaconTag"]

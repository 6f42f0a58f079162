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
    """The part of a reader's config the protocol layers read.

    Attributes
    ----------
    blf_search : str
        ``"off"`` or ``"preamble"``: whether the receiver estimates the tag's BLF from the RN16
        preamble (and keeps it for the ACK): a reader with a search keeps state between rounds,
        so a batch of trials needs one reader per trial.
    """

    #: ``"off"`` or ``"preamble"``: whether the receiver estimates the tag's BLF from the RN16
    #: preamble (and keeps it for the ACK): a reader with a search keeps state between rounds,
    #: so a batch of trials needs one reader per trial.
    blf_search: str


@runtime_checkable
class Gen2Reader(Protocol):
    """An EPC Gen2 reader as the engine drives it (:class:`rfsim.devices.Reader`).

    Attributes
    ----------
    link : rfsim.gen2.link.LinkProfile
        The reader's link profile.
    antennas : sequence
        Its antenna ports, in round-robin order.
    config : Gen2ReaderSettings
        The part of its config the protocol layers read.
    """

    link: Any
    antennas: Any
    config: Gen2ReaderSettings

    def antenna_index(self, round_index: int) -> int:
        """Return the antenna port used in an inventory round.

        Parameters
        ----------
        round_index : int
            0-based inventory round.

        Returns
        -------
        int
            0-based index into ``antennas`` (round robin).
        """
        ...

    def transmit(self, cmd, *, t0_s: float, cw_after_s: float, cw_before_s: float | None = None,
                 round_index: int = 0) -> Any:
        """Modulate a command with CW before and after it, as a segment at the antenna port.

        Parameters
        ----------
        cmd : object
            A command of :mod:`rfsim.gen2.commands`.
        t0_s : float
            Absolute time of the first sample [s].
        cw_after_s : float
            CW after the command [s].
        cw_before_s : float or None, default None
            CW before the delimiter [s]; None: the reader's default (one Tari).
        round_index : int, default 0
            Inventory round; selects the antenna.

        Returns
        -------
        object
            The transmitted segment (``t0_s``, ``fs_hz``, ``fc_hz``, ``samples`` in √W, the command's
            start and end times).
        """
        ...

    def receive(self, rx: np.ndarray, *, t0_s: float, n_bits: int, expect_crc: bool,
                cmd_end_s: float | None = None, blf_hz: float | None = None,
                carrier: complex | None = None) -> Any:
        """Detect, decode and measure one tag reply in the samples of the reply window.

        Parameters
        ----------
        rx : ndarray, shape (n,), complex
            Everything at the RX port [√W] (leakage, backscatter, noise).
        t0_s : float
            Absolute time of ``rx[0]`` [s].
        n_bits : int
            Data bits of the reply (16 for an RN16, PC+EPC+CRC for an EPC reply).
        expect_crc : bool
            Check the last 16 bits as CRC-16 over the reply.
        cmd_end_s : float or None, default None
            End of the command [s] (the reply start is searched after it); None: anywhere.
        blf_hz : float or None, default None
            The tag's actual BLF [Hz]; None: the profile's nominal BLF (or the reader's estimate).
        carrier : complex or None, default None
            The reader's own transmitted baseband during the reply window [√W] (phase reference).

        Returns
        -------
        object
            A read: detection, decoding, RSSI [dBm], phase [rad], Doppler [Hz], SNR [dB].
        """
        ...

    def leakage_gain(self) -> complex:
        """Return the TX→RX coupling of the reader.

        Returns
        -------
        complex
            Complex amplitude gain of the leakage from transmitter to receiver.
        """
        ...

    def noise_power_w(self) -> float:
        """Return the receiver's noise power.

        Returns
        -------
        float
            Noise power [W per complex sample].
        """
        ...


@runtime_checkable
class Gen2Tag(Protocol):
    """A passive Gen2 tag as the engine drives it (:class:`rfsim.devices.PassiveTag`).

    Attributes
    ----------
    state : object
        Its Gen2 state (flags, slot counter) that inventory control reads.
    """

    state: Any

    def listen(self, incident: np.ndarray, *, t0_s: float, fs_hz: float) -> Any:
        """React to the incident field: power-up, PIE decoding, state machine, Γ(t) when it replies.

        Parameters
        ----------
        incident : ndarray, shape (n,), complex
            Field at the tag's antenna port [√W], on the segment's time base.
        t0_s : float
            Absolute time of sample 0 [s].
        fs_hz : float
            Sample rate [Hz].

        Returns
        -------
        object
            The tag's response.
        """
        ...


@runtime_checkable
class Gen2Channel(Protocol):
    """The channel as the protocol layers ask it (:class:`rfsim.channels.Channel`).

    The paths of one antenna pair (``link``) and the forward/backward path sets of a backscatter
    link (``backscatter_links``), each a :class:`rfsim.channels.PathSet`.
    """

    def link(self, tx, rx, *, fc_hz: float, rng: np.random.Generator | None = None, **kw) -> Any:
        """Return the paths of the link ``tx → rx``.

        Parameters
        ----------
        tx, rx : object
            Transmitting and receiving antennas.
        fc_hz : float
            Carrier frequency [Hz].
        rng : numpy.random.Generator or None, default None
            Draws the random part of the link anew; None reuses the held draw.
        **kw
            Further keywords of the channel (``t_s``, ``tx_motion``, ``rx_motion``).

        Returns
        -------
        PathSet
            The link's paths.
        """
        ...

    def backscatter_links(self, emitter, tag, receiver=None, **kw) -> Any:
        """Return the forward and backward paths of a backscatter link emitter → tag → receiver.

        Parameters
        ----------
        emitter, tag : object
            Antennas of the emitter and of the tag.
        receiver : object, optional
            Antenna of the receiver (None: the emitter, monostatic).
        **kw
            Further keywords of the channel (``fc_hz``, ``rng``, ``t_s``, motions).

        Returns
        -------
        tuple of PathSet
            (forward, backward) paths.
        """
        ...


@runtime_checkable
class BeaconTag(Protocol):
    """An active beacon tag as the beacon MAC drives it (:class:`rfsim.devices.ActiveTag`).

    Attributes
    ----------
    config : object
        Its config (beacon period, jitter, chip rate, ...).
    rng : numpy.random.Generator
        Its generator (jitter, burst phase).
    burst_s : float
        Duration of one beacon burst [s].
    """

    config: Any
    rng: Any
    burst_s: float

    def due_times(self, *args, **kw) -> Any:
        """Return the due times of the tag's beacons in a time window, each jittered.

        Parameters
        ----------
        *args, **kw
            The window ``(t0_s, t1_s, offset_s)`` [s] (:meth:`rfsim.devices.ActiveTag.due_times`).

        Returns
        -------
        ndarray
            Due times [s].
        """
        ...

    def next_seq(self) -> int:
        """Return the sequence number of the next beacon (advances the counter).

        Returns
        -------
        int
            The sequence number.
        """
        ...

    def send(self, *args, **kw) -> Any:
        """Decide a beacon (after listen-before-talk).

        Parameters
        ----------
        *args, **kw
            ``(t_s, seq)``: time [s] and sequence number of the beacon
            (:meth:`rfsim.devices.ActiveTag.send`).

        Returns
        -------
        object
            Nothing the MAC reads.
        """
        ...

    def clear(self, *args, **kw) -> Any:
        """Forget the decided bursts.

        Parameters
        ----------
        *args, **kw
            None are passed by the MAC (:meth:`rfsim.devices.ActiveTag.clear`).

        Returns
        -------
        object
            Nothing the MAC reads.
        """
        ...


__all__ = ["Gen2ReaderSettings", "Gen2Reader", "Gen2Tag", "Gen2Channel", "BeaconTag"]

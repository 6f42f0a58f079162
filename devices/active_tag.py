"""Active RFID beacon tag: a one-way transmitter (an emitter of the air interface).

Özkaya's tags (rssi-localization.md §2.1, §7 P0.3; seeds/002 L957, L1768–L1775): the ID every
1 s, 5 dBm at 868 MHz, Manchester-coded MSK at 250 kbaud (frame and modulation in
:mod:`rfsim.devices.msk_beacon`), listen-before-talk; 3.3 V coin cell, quarter-wave monopole
(isotropic in azimuth when vertical: the channel applies whatever antenna it is given).

Schedule. Beacon n of a tag is due at ``t_n = offset + n·period + U(−jitter, +jitter)``
(the tags are not synchronised; the jitter keeps two tags from meeting at every period,
as the randomised intervals of real beacons do — the thesis gives none, the default
±10 ms is this model's choice). Listen-before-talk (ETSI EN 300 220 style energy detection)
is decided by the beacon MAC (:func:`rfsim.protocols.beacons.run_beacons`): the tag listens for
``lbt_listen_s`` before a due beacon; when the mean power it receives exceeds
``lbt_threshold_dbm`` it backs off ``U(0, backoff_max_s)`` and tries again, at most
``max_attempts`` times, then drops the beacon. Decided beacons are kept as bursts
(start time, sequence number, oscillator phase θ ~ U[0, 2π)) and emitted on any time base
(:meth:`ActiveTag.emit`): the segment is the MSK waveform ``√P·e^{j(φ(t)+θ)}`` of every burst
overlapping it, at the exact (sub-sample) start time, on the tag's own carrier, P the
conducted transmit power.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.air.step import Segment
from rfsim.air.carriers import SUPPORTED_CARRIER_RANGE_HZ
from rfsim.core.config import check_fields, param
from rfsim.core.units import dbm_to_w

from .msk_beacon import FRAME_CHIPS, beacon_bits, manchester_encode, msk_phase


@dataclass(frozen=True)
class ActiveTagConfig:
    """Active beacon tag settings (validated; errors name ``active_tag.<key>``)."""

    tag_id: int = param(1, lo=0, hi=2 ** 32 - 1, doc="32-bit tag ID sent in every beacon")
    fc_hz: float = param(868e6, lo=SUPPORTED_CARRIER_RANGE_HZ[0], hi=SUPPORTED_CARRIER_RANGE_HZ[1], unit="Hz",
                         doc="carrier (868 MHz, L957)")
    tx_power_dbm: float = param(5.0, lo=-40.0, hi=30.0, unit="dBm", doc="conducted transmit power (5 dBm, L957)")
    chip_rate_hz: float = param(250e3, lo=1e3, hi=10e6, unit="Hz", doc="MSK chip rate (250 kbaud, L1770)")
    period_s: float = param(1.0, lo=1e-3, hi=3600.0, unit="s", doc="beacon period (1 s, L1773)")
    jitter_s: float = param(0.01, lo=0.0, hi=10.0, unit="s", doc="uniform ± jitter of each beacon time")
    lbt_listen_s: float = param(0.2e-3, lo=0.0, hi=0.1, unit="s",
                                doc="listen-before-talk window before a beacon (0 = no LBT)")
    lbt_threshold_dbm: float = param(-90.0, lo=-150.0, hi=0.0, unit="dBm",
                                     doc="channel busy when the mean received power exceeds this")
    backoff_max_s: float = param(5e-3, lo=0.0, hi=1.0, unit="s", doc="random back-off U(0, max) when busy")
    max_attempts: int = param(5, lo=1, hi=1000, doc="LBT attempts before a beacon is dropped")

    def __post_init__(self):
        check_fields(self, "active_tag")

    @property
    def burst_s(self) -> float:
        """Duration of one beacon [s] (208 chips / R_c = 0.832 ms at 250 kbaud)."""
        return FRAME_CHIPS / self.chip_rate_hz


class ActiveTag:
    """An active beacon tag (module docstring).

    Parameters
    ----------
    config : ActiveTagConfig
        Tag settings (ID, carrier, power, chip rate, schedule, listen-before-talk).
    antenna : rfsim.channels.Antenna
        The antenna it radiates from.
    rng : numpy.random.Generator
        Keyword-only: generator of the schedule jitter and the oscillator phases.

    Attributes
    ----------
    fc_hz : float
        Transmit carrier [Hz].
    amplitude : float
        :math:`\\sqrt{P}` of the conducted transmit power P [√W].
    bursts : list of tuple
        Decided bursts ``(start time [s], sequence number, oscillator phase [rad])``.
    seq : int
        Sequence number of the next beacon (modulo 256; a scenario may set it).

    Raises
    ------
    TypeError
        When ``config`` is not an :class:`ActiveTagConfig`.
    """

    def __init__(self, config: ActiveTagConfig, antenna, *, rng: np.random.Generator):
        if not isinstance(config, ActiveTagConfig):
            raise TypeError(f"config must be an ActiveTagConfig, got {type(config).__name__}")
        self.config, self.antenna, self.rng = config, antenna, rng
        self.fc_hz = float(config.fc_hz)
        self.amplitude = math.sqrt(float(dbm_to_w(config.tx_power_dbm)))
        #: decided bursts: (start time [s], sequence number, oscillator phase [rad])
        self.bursts: list[tuple[float, int, float]] = []
        self._chips: dict[int, np.ndarray] = {}
        #: sequence number of the next beacon (modulo 256; a scenario may set it)
        self.seq = 0

    @property
    def burst_s(self) -> float:
        return self.config.burst_s

    def chips(self, seq: int) -> np.ndarray:
        """Return the Manchester chips of beacon ``seq`` (remembered per sequence number).

        Parameters
        ----------
        seq : int
            Sequence number (taken modulo 256).

        Returns
        -------
        ndarray of int, shape (n_chips,)
            The ±1 chips of the beacon's payload, as :func:`rfsim.devices.msk_beacon.manchester_encode`
            gives them for :func:`~rfsim.devices.msk_beacon.beacon_bits`.
        """
        seq %= 256
        c = self._chips.get(seq)
        if c is None:
            c = self._chips[seq] = manchester_encode(beacon_bits(self.config.tag_id, seq))
        return c

    def due_times(self, t0_s: float, t1_s: float, offset_s: float = 0.0) -> np.ndarray:
        """Draw the due times of the beacons in a time window.

        Beacon n is due at :math:`t_n = \\mathrm{offset} + n T + U(-J, J)` for every n with
        :math:`t_0 \\le \\mathrm{offset} + n T < t_1` (T the period, J the jitter; the jitter is
        drawn from the tag's ``rng``, none when J = 0).

        Parameters
        ----------
        t0_s, t1_s : float
            Window [t0, t1) of the nominal (without jitter) times [s].
        offset_s : float, optional
            Schedule offset [s], default 0.0.

        Returns
        -------
        ndarray of float, shape (n_beacons,)
            The jittered due times [s].
        """
        p = self.config.period_s
        n = np.arange(math.ceil((t0_s - offset_s) / p - 1e-12), math.ceil((t1_s - offset_s) / p - 1e-12))
        j = self.config.jitter_s
        return offset_s + n * p + (self.rng.uniform(-j, j, n.size) if j > 0 else 0.0)

    def next_seq(self) -> int:
        """Take the sequence number of the next beacon and advance the counter.

        Returns
        -------
        int
            The sequence number, 0 ≤ seq < 256.
        """
        s = self.seq % 256
        self.seq = (s + 1) % 256
        return s

    def send(self, t_s: float, seq: int) -> None:
        """Decide a beacon at ``t_s`` (after listen-before-talk).

        Appends a burst with a fresh oscillator phase θ ~ U[0, 2π) to :attr:`bursts`.

        Parameters
        ----------
        t_s : float
            Start time of the beacon [s].
        seq : int
            Its sequence number.
        """
        self.bursts.append((float(t_s), int(seq), float(self.rng.uniform(0.0, 2.0 * math.pi))))

    def clear(self) -> None:
        """Forget the decided bursts."""
        self.bursts.clear()

    def emit(self, *, t0_s: float, fs_hz: float, n_samples: int) -> Segment | None:
        """Emit the tag's segment on a time base.

        The samples are :math:`\\sqrt{P} e^{j(\\varphi(t) + \\theta)}` of every decided burst
        overlapping the window, at its exact (sub-sample) start time, zero elsewhere.

        Parameters
        ----------
        t0_s : float
            Start time of the segment [s] (keyword-only, like the others).
        fs_hz : float
            Sample rate [Hz].
        n_samples : int
            Number of samples.

        Returns
        -------
        rfsim.air.segment.Segment or None
            The segment on the tag's carrier (samples shape (n_samples,) [√W]); None when no
            burst overlaps the window.
        """

        n = int(n_samples)
        t1 = t0_s + n / fs_hz
        x = None
        sps = fs_hz / self.config.chip_rate_hz
        for t_b, seq, theta in self.bursts:
            if t_b >= t1 or t_b + self.burst_s <= t0_s:
                continue
            phase, on = msk_phase(self.chips(seq), sps, (t0_s - t_b) * self.config.chip_rate_hz, n)
            burst = np.where(on, self.amplitude * np.exp(1j * (phase + theta)), 0.0)
            x = burst if x is None else x + burst
        return None if x is None else Segment(t0_s, fs_hz, self.fc_hz, x)


__all__ = ["ActiveTagConfig", "ActiveTag"]

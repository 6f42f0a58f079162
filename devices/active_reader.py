"""Active-RFID reader: receives the beacons of active tags at sample level and reports RSSI.

Özkaya's readers (rssi-localization.md §2.1; seeds/002 L957, L1784–L1787): 868 MHz, −90 dBm
sensitivity, a digital RSSI in 1 dB steps. Receive chain of one air-step segment y (complex
baseband √W at the antenna port, noise included by the air step: k·T0·fs·F per sample)::

    1. channel filter   y_f = h * y, h a linear-phase FIR low-pass (``FILTER_TAPS`` taps,
                        Hamming window, cut-off B/2 for the two-sided bandwidth B = 540 kHz,
                        L1770; zero delay: odd length, centred)
    2. discriminator    d[n] = arg(y_f[n]·conj(y_f[n−1]))  (rfsim.devices.msk_beacon)
    3. synchronisation  normalised correlation of d with the preamble + sync-word template
                        ρ(τ) = Σ d[τ+n]·t[n] / (‖t‖·‖d[τ:τ+L]‖); a frame starts at each
                        maximum ρ ≥ ``sync_threshold`` (the next searched outside that frame)
    4. chips            sign of Σ d over each chip (the chip's sample boundaries excluded)
    5. decoding         Manchester → ID, sequence, CRC-16 (rfsim.devices.msk_beacon)
    6. RSSI             P = mean |y_f|² over the frame [dBm], what a transceiver's RSSI
                        register measures: the power in the channel bandwidth, in-band noise
                        included (at −90 dBm with NF = 10 dB the noise adds 0.09 dB)
    7. report           rfsim.devices.rss_reader.RssReport: 1 dB steps, nothing below −90 dBm;
                        only frames with a valid CRC are reported

MSK keeps 99.5 % of its power inside ±270 kHz at 250 kchip/s, so the filtered RSSI of a clean
beacon is 0.02 dB below the received power (the tests bound it). Two beacons overlapping in
time collide: the discriminator follows the stronger one (FM capture), so the stronger may
still decode when it is well above the weaker one; otherwise the CRC fails and nothing is
reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.air.carriers import SUPPORTED_CARRIER_RANGE_HZ
from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.air.noise import thermal_noise_power_w
from rfsim.core.memo import PureCache
from rfsim.core.units import w_to_dbm

from .msk_beacon import (FRAME_CHIPS, HEADER_CHIPS, discriminate, header_chips, manchester_decode,
                         msk_phase, parse_payload)
from .rss_reader import RssReport
from rfsim.core.lazy import lazy_import

_signal = lazy_import("scipy.signal")

#: Taps of the channel filter (odd: a centred, zero-delay linear-phase FIR).
FILTER_TAPS = 63
#: Most frames searched in one segment.
MAX_FRAMES = 16


@dataclass(frozen=True)
class ActiveReaderConfig:
    """Active-RFID reader settings (validated; errors name ``active_reader.<key>``)."""

    fc_hz: float = param(868e6, lo=SUPPORTED_CARRIER_RANGE_HZ[0], hi=SUPPORTED_CARRIER_RANGE_HZ[1], unit="Hz",
                         doc="receive carrier")
    fs_hz: float = param(2e6, lo=1e5, hi=1e8, unit="Hz", doc="sample rate (an integer multiple ≥ 4 of the chip rate)")
    chip_rate_hz: float = param(250e3, lo=1e3, hi=10e6, unit="Hz", doc="MSK chip rate of the beacons")
    bandwidth_hz: float = param(540e3, lo=1e3, hi=1e8, unit="Hz", doc="two-sided channel-filter bandwidth (L1770)")
    noise_figure_db: float = param(10.0, lo=0.0, hi=40.0, unit="dB", doc="receiver noise figure")
    sync_threshold: float = param(0.7, lo=0.05, hi=1.0, doc="normalised preamble correlation for a frame")
    report: RssReport = param(RssReport(), doc="RSSI report: 1 dB steps, −90 dBm floor (L1785–L1787)")

    def __post_init__(self):
        check_fields(self, "active_reader")
        sps = self.fs_hz / self.chip_rate_hz
        if abs(sps - round(sps)) > 1e-9 or round(sps) < 4:
            raise ConfigError("active_reader.fs_hz", self.fs_hz,
                              f"an integer multiple ≥ 4 of the chip rate {self.chip_rate_hz:g} Hz")
        if not self.bandwidth_hz < self.fs_hz:
            raise ConfigError("active_reader.bandwidth_hz", self.bandwidth_hz, f"a bandwidth below fs = {self.fs_hz:g} Hz")

    @property
    def sps(self) -> int:
        """Samples per chip."""
        return int(round(self.fs_hz / self.chip_rate_hz))


@dataclass(frozen=True)
class BeaconRead:
    """One frame the reader found in a segment.

    Attributes
    ----------
    t_s : float
        Time of the frame's first sample [s].
    tag_id, seq : int
        Decoded tag ID and sequence number.
    crc_ok : bool
        The CRC-16 holds.
    rssi_dbm : float
        Measured power over the frame [dBm].
    rssi_reported_dbm : float
        What the reader reports [dBm] (quantized; NaN when the CRC fails or below the floor).
    correlation : float
        Normalised correlation ρ of the synchronisation [1].
    violations : int
        Manchester code violations in the payload.
    """


    t_s: float
    tag_id: int
    seq: int
    crc_ok: bool
    rssi_dbm: float
    rssi_reported_dbm: float
    correlation: float
    violations: int


def _filter_taps(fs_hz: float, bandwidth_hz: float) -> np.ndarray:
    """The receiver's FIR channel filter of ``FILTER_TAPS`` taps for a rate and bandwidth [Hz]."""
    return _signal.firwin(FILTER_TAPS, 0.5 * bandwidth_hz, fs=fs_hz)


def _template(sps: int) -> np.ndarray:
    """Discriminator output of a clean header: t[0] = 0, t[n] = φ[n] − φ[n−1]."""
    phase, _ = msk_phase(header_chips(), sps, 0.0, HEADER_CHIPS * sps)
    t = np.diff(phase, prepend=0.0)
    t[0] = 0.0
    return t


#: The channel filter by (rate, bandwidth) and the header template by samples per chip: pure
#: functions of constants and config values, not run state (:class:`rfsim.core.memo.PureCache`).
FILTER_TAPS_CACHE = PureCache(_filter_taps, 8)
HEADER_TEMPLATE_CACHE = PureCache(_template, 8)


class ActiveReader:
    """An active-RFID reader (module docstring): a receiver of the air interface.

    Parameters
    ----------
    config : ActiveReaderConfig
        Receiver settings (carrier, sample rate, channel filter, noise figure, RSSI report).
    antenna : rfsim.channels.Antenna
        The reader's antenna.

    Attributes
    ----------
    fc_hz : float
        Receive carrier [Hz].
    noise_power_w : float
        Noise power per complex sample at ``fs_hz`` [W]: :math:`k T_0 f_s F`.

    Raises
    ------
    TypeError
        When ``config`` is not an :class:`ActiveReaderConfig`.
    """

    def __init__(self, config: ActiveReaderConfig, antenna):
        if not isinstance(config, ActiveReaderConfig):
            raise TypeError(f"config must be an ActiveReaderConfig, got {type(config).__name__}")
        self.config, self.antenna = config, antenna
        self.fc_hz = float(config.fc_hz)
        #: noise power per complex sample at fs [W] (k·T0·fs·F)
        self.noise_power_w = float(thermal_noise_power_w(config.fs_hz, config.noise_figure_db))

    def channel_filter(self, y: np.ndarray) -> np.ndarray:
        """Apply step 1, the zero-delay FIR channel filter, to ``y``.

        The filter is a linear-phase low-pass of ``FILTER_TAPS`` taps (Hamming window, cut-off
        B/2 for the two-sided bandwidth B), convolved in ``"same"`` mode so that its odd, centred
        impulse response adds no delay.

        Parameters
        ----------
        y : ndarray of complex, shape (n_samples,)
            Complex baseband samples at ``fs_hz`` [√W].

        Returns
        -------
        ndarray of complex, shape (n_samples,)
            The filtered samples [√W].
        """
        return np.convolve(y, FILTER_TAPS_CACHE(self.config.fs_hz, self.config.bandwidth_hz), mode="same")

    def receive(self, input) -> list[BeaconRead]:
        """Find and decode every beacon frame in one air-step segment.

        Runs the receive chain of the module docstring: channel filter, FM discriminator,
        normalised preamble correlation, chip decisions, Manchester/CRC decoding and RSSI.

        Parameters
        ----------
        input : rfsim.air.segment.Segment
            The segment at the antenna port (``samples`` shape (n_samples,) [√W], noise
            included; ``fs_hz`` must equal the configured sample rate; ``t0_s`` its start [s]).

        Returns
        -------
        list of BeaconRead
            The frames found (at most ``MAX_FRAMES``), sorted by start time; empty when the
            segment is shorter than one frame or no correlation peak reaches
            ``sync_threshold``.

        Raises
        ------
        ConfigError
            When the segment's sample rate differs from ``fs_hz`` or it has batch dimensions.
        """

        cfg = self.config
        if input.fs_hz != cfg.fs_hz:
            raise ConfigError("active_reader.fs_hz", cfg.fs_hz, f"the air step's sample rate {input.fs_hz:g} Hz")
        y = np.asarray(input.samples)
        if y.ndim != 1:
            raise ConfigError("active_reader.input", y.shape, "one segment (n,) without batch dimensions")
        sps = cfg.sps
        frame_n = FRAME_CHIPS * sps
        tpl = HEADER_TEMPLATE_CACHE(sps)
        if y.size < frame_n + 1:
            return []
        yf = self.channel_filter(y)
        d = discriminate(yf)
        corr = np.correlate(d, tpl, mode="valid")                       # (n − L + 1,)
        e = np.concatenate([[0.0], np.cumsum(d * d)])
        energy = e[tpl.size:] - e[:-tpl.size]
        with np.errstate(invalid="ignore", divide="ignore"):
            rho = np.where(energy > 0, corr / (np.linalg.norm(tpl) * np.sqrt(energy)), 0.0)
        rho[y.size - frame_n:] = -np.inf        # a frame must fit in the segment
        reads = []
        for _ in range(MAX_FRAMES):
            tau = int(np.argmax(rho))
            if not rho[tau] >= cfg.sync_threshold:
                break
            reads.append(self._decode(yf, d, tau, float(rho[tau]), input.t0_s))
            rho[max(0, tau - tpl.size):tau + frame_n] = -np.inf
        reads.sort(key=lambda r: r.t_s)
        return reads

    def _decode(self, yf, d, tau, rho, t0_s) -> BeaconRead:
        sps = self.config.sps
        sums = d[tau:tau + FRAME_CHIPS * sps].reshape(FRAME_CHIPS, sps)[:, 1:].sum(axis=1)
        chips = np.where(sums >= 0, 1, -1)
        bits, violations = manchester_decode(chips[HEADER_CHIPS:])
        tag_id, seq, ok = parse_payload(bits)
        p = float(np.mean(np.abs(yf[tau:tau + FRAME_CHIPS * sps]) ** 2))
        rssi = float(w_to_dbm(p)) if p > 0 else -np.inf
        rep = float(self.config.report.report(rssi)) if ok else float("nan")
        return BeaconRead(t0_s + tau / self.config.fs_hz, tag_id, seq, ok, rssi, rep, rho, violations)


__all__ = ["ActiveReaderConfig", "ActiveReader", "BeaconRead", "FILTER_TAPS"]

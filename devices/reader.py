"""Gen2 interrogator (reader): PIE transmitter, frequency plan, antennas, IQ receiver.

Transmitter (gen2-and-validation-anchors.md §4.1; pass-paris-simulator.md §2.1
``reader_modulation``). With ``e(t)`` the PIE envelope of :func:`rfsim.gen2.pie.pie_envelope`
(1 during CW, ``1 − depth`` in the low pulses, raised-cosine edges) and ``P`` the conducted
power [W] at the antenna port, the complex baseband [√W] is

* DSB-ASK: ``x = √P·e(t)``;
* PR-ASK:  ``x = √P·s(t)·e(t)`` with ``s(t) = ±1`` changing sign at the middle of every low
  pulse (delimiter included), i.e. every PIE symbol has the opposite polarity of the previous
  one; ``|x|`` equals the DSB magnitude sample by sample. At ``depth < 1`` the sign change is
  a jump of ``2(1 − depth)·√P`` (an ideal PR-ASK has depth 1 and passes through zero);
* SSB-ASK: ``x = √P·(e(t) + j·(h_H * (e − 1))(t))`` with ``h_H`` a Blackman-windowed FIR
  Hilbert transformer (``h[k] = 2/(πk)`` for odd k, 0 for even k, |k| ≤ 4·Tari·fs) applied
  to the modulation part ``e − 1`` (zero during CW). Normalisation: the carrier term is not
  transformed, so wherever the envelope has been CW for more than 4 Tari the baseband is
  exactly ``√P`` (CW power = P); the modulation sideband sits at positive frequencies only.
  (An ideal, infinitely long Hilbert transform such as ``scipy.signal.hilbert`` would spread
  the pulse train's non-zero mean as a 1/t tail across the whole reply window; the finite
  FIR leaves the band below ≈ 1/(8·Tari) double-sided instead.)

A segment holds ``cw_before_s`` of CW (default one Tari), the command and ``cw_after_s`` of
CW: ``ceil((cw_before + T_cmd + cw_after)·fs)`` samples, ``T_cmd =
LinkProfile.command_duration_s(cmd)``.

Frequency plan (anchors §4.7 "Regulatory", §4.9; :mod:`rfsim.carriers`): FCC 50 channels
``902.75 + 0.5·k`` MHz, ETSI EN 302 208 four channels 865.7/866.3/866.9/867.5 MHz, or any
explicit list (``region = "custom"``, ``channels_hz``: one 890 MHz carrier, 5.79/5.80/5.81 GHz;
each inside the supported carrier range); a custom plan hops cyclically like ETSI. FCC hopping visits the channels
in a random permutation drawn once from the reader's rng (a randomized hop table, as real
readers do), ETSI cycles through its four channels in order; each channel is held for
``dwell_s`` (FCC ≤ 0.4 s). Channel indices are 1-based into :func:`frequency_plan`, as
LLRP's ChannelIndex. Antennas are used in turn: round r uses antenna ``r mod n`` (0-based
index into ``Reader.antennas``).

Receiver (see :meth:`Reader.receive`): carrier leakage ``L·x_tx`` with
``L = 10^(−isolation/20)·e^{jφ_L}`` (:meth:`Reader.leakage_gain`, added by the engine), a
constant complex offset during the reply window, is removed; the reply is detected by
preamble correlation inside the T1 window and decoded by
:func:`rfsim.gen2.linecode.decode_reply`; EPC replies are checked with CRC-16; RSSI, phase,
Doppler and SNR are measured with the decoded reply as known reference (anchors §4.8, §4.9).

Report (``ReaderConfig.report``, :class:`rfsim.records.ReportConfig`): what the reader hands
over of a read — RSSI rounded to its step, a sensitivity floor, the phase with the port's
phase offset as a 12-bit code, µs time stamps — is applied to the read log by
:func:`rfsim.records.report_columns`; the measurements of :class:`ReadResult` stay unquantized.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.signal import fftconvolve

from rfsim.carriers import ETSI_CHANNELS_HZ, FCC_CHANNELS_HZ, channel_index as _channel_index
from rfsim.carriers import frequency_plan as _plan
from rfsim.config import param, validate
from rfsim.errors import ConfigError
from rfsim.gen2.capture import fit_gain_offset, preamble_threshold
from rfsim.gen2.commands import COMMAND_TYPES, command_preamble, encode
from rfsim.gen2.crc import crc16_ok
from rfsim.gen2.link import LinkProfile, profile, t1
from rfsim.gen2.linecode import decode_reply, preamble_levels, reply_duration_s, reply_waveform
from rfsim.gen2.pie import pie_timeline, pr_ask_baseband, timeline_envelope
from rfsim.noise import thermal_noise_power_w
from rfsim.records import ReportConfig
from rfsim.units import dbm_to_w, w_to_dbm, wrap_phase_rad
from devices import _reader_kernels as _rk

#: FCC maximum dwell time per channel [s].
FCC_MAX_DWELL_S = 0.4
#: Phase of the TX→RX leakage path [rad]. An arbitrary fixed constant (a circulator's
#: through path has some fixed phase); the receiver does not depend on it because the
#: leakage of the CW is removed as an unknown complex constant.
LEAKAGE_PHASE_RAD = math.pi / 3
#: Half-length of the SSB Hilbert FIR in Tari.
SSB_HILBERT_HALF_TARI = 4.0
#: Number of blocks of the reply used for the Doppler fit.
DOPPLER_BLOCKS = 8

FAILURES = ("", "preamble not found", "crc error")
#: Number of modulated command segments a Reader keeps for reuse.
TX_CACHE_SIZE = 16


def frequency_plan(region: str, channels_hz=()) -> np.ndarray:
    """Channel centre frequencies [Hz] of a plan, ``(n,) float64``: ``"FCC"``: 50 channels
    902.75 + 0.5·k MHz (k = 0…49); ``"ETSI"``: 865.7, 866.3, 866.9, 867.5 MHz
    (gen2-and-validation-anchors.md §4.7); ``"custom"``: the explicit list ``channels_hz``
    (:func:`rfsim.carriers.frequency_plan`, validated against the supported carrier range)."""
    return _plan(region, channels_hz, key="reader")


@dataclass(frozen=True)
class ReaderConfig:
    """Reader settings (validated by :class:`Reader`, see :func:`rfsim.config.validate`)."""

    link_profile: str = param("miller4-320k", doc="link profile name (rfsim.gen2.link.PROFILES)")
    ptx_dbm: float = param(30.0, lo=-20.0, hi=36.0, unit="dBm", doc="conducted TX power at the antenna port")
    region: Literal["FCC", "ETSI", "custom"] = param("FCC", doc="frequency plan ('custom': channels_hz)")
    channels_hz: tuple[float, ...] = param((), unit="Hz", doc="explicit carrier list of region 'custom' "
                                                              "(e.g. [890e6] or [5.79e9, 5.80e9, 5.81e9])")
    hopping: bool = param(True, doc="frequency hopping (FCC random hop table, ETSI cyclic)")
    dwell_s: float = param(0.4, lo=0.0, hi=4.0, lo_open=True, unit="s",
                           doc="time on one channel (FCC: at most 0.4 s)")
    fixed_channel: int = param(1, lo=1, hi=1000, doc="1-based channel index used without hopping")
    isolation_db: float = param(30.0, lo=0.0, hi=120.0, unit="dB", doc="TX→RX leakage attenuation")
    noise_figure_db: float = param(10.0, lo=0.0, hi=40.0, unit="dB", doc="receiver noise figure")
    fs_hz: float = param(4e6, lo=2e5, hi=2e8, unit="Hz", doc="baseband sample rate of TX and RX")
    decoder: Literal["viterbi", "bitwise"] = param("viterbi", doc="reply decoder")
    pie_rise_fall_tari: float = param(0.1, lo=0.0, hi=0.33, unit="Tari", doc="10-90 % PIE edge time")
    false_alarm_probability: float = param(1e-3, lo=0.0, hi=1.0, lo_open=True, hi_open=True,
                                           doc="preamble detection false-alarm probability per reply window")
    report: ReportConfig = param(ReportConfig(), doc="what the reader reports of a read: RSSI step, sensitivity "
                                                     "floor, phase code, per-port phase offsets (rfsim.records)")

    def __post_init__(self):
        try:  # checked when the config is loaded, so the message names this key
            profile(self.link_profile)
        except ConfigError as err:
            raise ConfigError("link_profile", err.value, err.allowed) from None
        # The carrier plan is checked when the config is made, so a bad carrier stops a run
        # before anything is simulated (one-line ConfigError on reader.region / reader.channels_hz).
        frequency_plan(self.region, self.channels_hz)


@dataclass(frozen=True)
class TxSegment:
    """One transmitted segment: PIE command + CW.

    Attributes
    ----------
    t0_s : absolute time of sample 0 [s]
    fs_hz : sample rate [Hz]
    samples : (n,) complex128, baseband at the antenna port [√W]
    fc_hz : carrier frequency [Hz]
    channel_index : 1-based index into :func:`frequency_plan`
    antenna_index : 0-based index into ``Reader.antennas``
    cmd_start_s : absolute time of the delimiter's falling edge (50 % point) [s]
    cmd_end_s : absolute time of the last rising edge of the command [s]
    """

    t0_s: float
    fs_hz: float
    samples: np.ndarray
    fc_hz: float
    channel_index: int
    antenna_index: int
    cmd_start_s: float
    cmd_end_s: float

    @property
    def end_s(self) -> float:
        """Time just after the last sample [s]."""
        return self.t0_s + self.samples.size / self.fs_hz


@dataclass(frozen=True)
class ReadResult:
    """Outcome and measurements of one reply window.

    Attributes
    ----------
    success : reply detected, decoded and (if expected) CRC-16 correct
    bits : (n_bits,) uint8 decoded bits (also on a CRC error), None if no reply was found
    failure_reason : "", "preamble not found" or "crc error"
    rssi_dbm : power of the modulated component at the antenna port, 10·log10(|h|²)+30, with
        h the complex amplitude of the ±1 reply waveform (NaN without a reply)
    phase_rad : (−arg h) mod 2π, h at the centre of the reply; for a tag re-radiating
        r = A_s − Γ (devices.tag) h ∝ (r_B − r_A)/2 = (Γ_A − Γ_B)/2, A_s cancels
    doppler_hz : (1/2π)·d(arg h)/dt across the reply (positive for an approaching tag)
    snr_db : |h|²/σ², σ² the residual power per sample at ``fs_hz`` (noise bandwidth fs)
    ebn0_db : snr_db + 10·log10(fs/bit rate), independent of fs
    start_s : absolute time of the detected reply start [s]
    corr : normalised preamble correlation (0…1) at the detected start
    """

    success: bool
    bits: np.ndarray | None
    failure_reason: str
    rssi_dbm: float = math.nan
    phase_rad: float = math.nan
    doppler_hz: float = math.nan
    snr_db: float = math.nan
    ebn0_db: float = math.nan
    start_s: float = math.nan
    corr: float = math.nan


def hilbert_fir(half_length: int) -> np.ndarray:
    """Blackman-windowed FIR Hilbert transformer, ``(2K+1,) float64``.

    ``h[k] = 2/(πk)·w[k]`` for odd k, 0 for even k (k = −K…K); its response is ≈ −j·sign(f)
    above ≈ 2·fs/K.
    """
    k = np.arange(-half_length, half_length + 1)
    h = np.zeros(k.size)
    odd = k % 2 != 0
    h[odd] = 2.0 / (np.pi * k[odd])
    return h * np.blackman(k.size + 2)[1:-1]


class Reader:
    """A Gen2 reader with one or more antennas (used in turn), see the module docstring.

    Parameters
    ----------
    config : ReaderConfig
    antennas : non-empty sequence of channels.antennas.Antenna
    rng : numpy Generator (keyword-only); draws the FCC hop table
    link : optional LinkProfile overriding ``config.link_profile`` (custom profiles)
    """

    def __init__(self, config: ReaderConfig, antennas: Sequence, *, rng: np.random.Generator,
                 link: LinkProfile | None = None):
        self.config = validate(config)
        self.link = profile(self.config.link_profile) if link is None else link
        if not isinstance(self.link, LinkProfile):
            raise ValueError(f"link must be a LinkProfile, got {link!r}")
        self.antennas = tuple(antennas)
        if not self.antennas:
            raise ValueError("a reader needs at least one antenna")
        offsets = self.config.report.port_phase_offsets_rad
        if offsets and len(offsets) != len(self.antennas):
            raise ConfigError("reader.report.port_phase_offsets_rad", list(offsets),
                              f"one offset per antenna port ({len(self.antennas)} port"
                              f"{'s' if len(self.antennas) > 1 else ''}) or []")
        self.fs_hz = float(self.config.fs_hz)
        self.plan_hz = frequency_plan(self.config.region, self.config.channels_hz)
        n = self.plan_hz.size
        if self.config.region == "FCC" and self.config.dwell_s > FCC_MAX_DWELL_S:
            raise ConfigError("reader.dwell_s", self.config.dwell_s, f"(0, {FCC_MAX_DWELL_S}] s for FCC")
        if self.config.fixed_channel > n:
            raise ConfigError("reader.fixed_channel", self.config.fixed_channel,
                              f"1…{n} for {self.config.region}")
        if 2.0 * self.link.blf_hz * (1 + self.link.frt) > self.fs_hz:
            raise ConfigError("reader.fs_hz", self.config.fs_hz,
                              f"≥ 2·BLF_max = {2 * self.link.blf_hz * (1 + self.link.frt):.4g} Hz")
        #: 0-based hop table (channel k of the plan is visited at dwell period i if hop[i % n] = k)
        self.hop_sequence = rng.permutation(n) if self.config.region == "FCC" else np.arange(n)
        #: recently transmitted baseband segments (read-only), keyed by bits and CW lengths
        self._tx_cache: dict = {}
        #: recently sent commands → (bits (read-only), preamble, T_cmd [s]); pure functions of
        #: the (frozen) command and the link, dropped when ``link`` is replaced
        self._cmd_cache: dict = {}
        self._cmd_cache_link = self.link
        #: (config, fs, noise power, leakage gain): derived from the frozen config
        self._derived: tuple = (None, None, 0.0, 0j)

    # ------------------------------------------------------------------ plan, antennas

    def channel_index(self, t_s: float) -> int:
        """1-based channel index at time ``t_s`` [s] (LLRP ChannelIndex)."""
        if not self.config.hopping:
            return int(self.config.fixed_channel)
        period = int(math.floor(float(t_s) / self.config.dwell_s))
        return int(self.hop_sequence[period % self.hop_sequence.size]) + 1

    def fc_hz(self, t_s: float) -> float:
        """Carrier frequency [Hz] at time ``t_s`` [s]."""
        return float(self.plan_hz[self.channel_index(t_s) - 1])

    def channel_of(self, fc_hz: float) -> int:
        """1-based channel index of the carrier ``fc_hz`` [Hz] in the reader's plan (a one-line
        ``ConfigError`` on ``reader.channels_hz`` when the plan has no such carrier)."""
        return _channel_index(self.plan_hz, fc_hz, key="reader.channels_hz")

    def antenna_index(self, round_index: int) -> int:
        """0-based antenna used in inventory round ``round_index`` (round robin)."""
        return int(round_index) % len(self.antennas)

    @property
    def ptx_w(self) -> float:
        """Conducted CW power at the antenna port [W]."""
        return float(dbm_to_w(self.config.ptx_dbm))

    def _fixed(self) -> tuple:
        """``(config, fs, noise power, leakage gain)``, recomputed only when the (frozen)
        config or the sample rate is replaced."""
        d = self._derived
        if d[0] is not self.config or d[1] != self.fs_hz:
            noise = float(thermal_noise_power_w(self.fs_hz, self.config.noise_figure_db))
            leak = complex(10.0 ** (-self.config.isolation_db / 20.0) * np.exp(1j * LEAKAGE_PHASE_RAD))
            d = self._derived = (self.config, self.fs_hz, noise, leak)
        return d

    def noise_power_w(self) -> float:
        """Receiver noise power per complex sample [W]: k·T0·fs·F (kTB·NF over B = fs)."""
        return self._fixed()[2]

    def leakage_gain(self) -> complex:
        """TX→RX leakage as a complex amplitude: 10^(−isolation/20)·e^{j·LEAKAGE_PHASE_RAD}."""
        return self._fixed()[3]

    def _command(self, cmd) -> tuple:
        """``(bits, preamble, T_cmd [s])`` of a command (the last :data:`TX_CACHE_SIZE`
        commands are kept: a reader repeats its Query/QueryRep/ACK many times)."""
        if self._cmd_cache_link is not self.link:
            self._cmd_cache.clear()
            self._cmd_cache_link = self.link
        try:
            hit = self._cmd_cache.get(cmd)
        except TypeError:  # an unhashable command: no caching
            hit, cmd_key = None, None
        else:
            cmd_key = cmd
        if hit is not None:
            return hit
        bits = encode(cmd)
        bits.setflags(write=False)
        preamble = command_preamble(cmd)
        hit = (bits, preamble, self.link.command_duration_s(bits, preamble))
        if cmd_key is not None:
            if len(self._cmd_cache) >= TX_CACHE_SIZE:
                self._cmd_cache.pop(next(iter(self._cmd_cache)))
            self._cmd_cache[cmd_key] = hit
        return hit

    # ------------------------------------------------------------------ transmitter

    def modulate(self, bits, *, preamble: str, cw_after_s: float, cw_before_s: float = 0.0) -> np.ndarray:
        """Baseband of a PIE command [√W], ``(n,) complex128`` (module docstring equations).

        Parameters
        ----------
        bits : (n,) 0/1 command bits (CRC included)
        preamble : "query" or "frame-sync"
        cw_after_s : CW after the last rising edge [s]
        cw_before_s : CW before the falling edge of the delimiter [s]
        """
        lk = self.link
        timing = dict(tari_s=lk.tari_s, data1_tari=lk.data1_tari, trcal_s=lk.trcal_s, pw_s=lk.pw_s,
                      delimiter_s=lk.delimiter_s, preamble=preamble, cw_after_s=float(cw_after_s),
                      cw_before_s=float(cw_before_s))
        tl = pie_timeline(bits, **timing)
        e = timeline_envelope(tl, depth=lk.depth, fs_hz=self.fs_hz,
                              rise_fall_s=self.config.pie_rise_fall_tari * lk.tari_s)
        amp = math.sqrt(self.ptx_w)
        if lk.modulation == "DSB-ASK":
            return (amp * e).astype(np.complex128)
        if lk.modulation == "PR-ASK":
            return pr_ask_baseband(tl, e, amplitude=amp, fs_hz=self.fs_hz)
        # SSB-ASK
        half = int(round(SSB_HILBERT_HALF_TARI * lk.tari_s * self.fs_hz))
        quad = fftconvolve(e - 1.0, hilbert_fir(half), mode="same")
        return amp * (e + 1j * quad)

    def transmit(self, cmd, *, t0_s: float, cw_after_s: float, cw_before_s: float | None = None,
                 round_index: int = 0) -> TxSegment:
        """CW for ``cw_before_s``, PIE command ``cmd`` (Query: full preamble, others:
        frame-sync), then CW for ``cw_after_s``.

        Parameters
        ----------
        cmd : a command of :mod:`rfsim.gen2.commands`
        t0_s : absolute time of the first sample [s]
        cw_after_s : CW after the command [s] (T1max + reply + T2 for a reply window)
        cw_before_s : CW before the delimiter [s]; default one Tari, so that a receiver's
            envelope detector sees the delimiter's falling edge (the segment otherwise starts
            in the middle of that edge). ``cmd_start_s = t0_s + cw_before_s``.
        round_index : inventory round, selects the antenna (round robin)

        The segment has ``ceil((cw_before + T_cmd + cw_after)·fs)`` samples,
        ``T_cmd = LinkProfile.command_duration_s(cmd)``; ``cmd_end_s = cmd_start_s + T_cmd``.
        ``samples`` is read-only: the last :data:`TX_CACHE_SIZE` distinct segments are kept
        and returned again for a repeated command.
        """
        if not isinstance(cmd, COMMAND_TYPES):
            raise TypeError(f"not a Gen2 command: {cmd!r}")
        if not cw_after_s >= 0:
            raise ValueError(f"cw_after_s must be >= 0, got {cw_after_s}")
        cw_before_s = self.link.tari_s if cw_before_s is None else float(cw_before_s)
        if not cw_before_s >= 0:
            raise ValueError(f"cw_before_s must be >= 0, got {cw_before_s}")
        bits, preamble, cmd_duration_s = self._command(cmd)
        key = (bits.tobytes(), preamble, float(cw_after_s), cw_before_s)
        x = self._tx_cache.get(key)
        if x is None:
            # A reader sends the same commands (Query, QueryRep, …) again and again: keep the
            # last few modulated segments (read-only) instead of modulating them anew.
            x = self.modulate(bits, preamble=key[1], cw_after_s=cw_after_s, cw_before_s=cw_before_s)
            x.setflags(write=False)
            if len(self._tx_cache) >= TX_CACHE_SIZE:
                self._tx_cache.pop(next(iter(self._tx_cache)))
            self._tx_cache[key] = x
        t0_s = float(t0_s)
        start = t0_s + cw_before_s
        return TxSegment(t0_s=t0_s, fs_hz=self.fs_hz, samples=x, fc_hz=self.fc_hz(t0_s),
                         channel_index=self.channel_index(t0_s),
                         antenna_index=self.antenna_index(round_index),
                         cmd_start_s=start, cmd_end_s=start + cmd_duration_s)

    # ------------------------------------------------------------------ receiver

    def preamble_samples(self, blf_hz: float | None = None) -> int:
        """Samples fully inside the reply preamble (incl. pilot), as correlated by the detector
        (at ``blf_hz``, default the profile's nominal BLF)."""
        blf = self.link.blf_hz if blf_hz is None else float(blf_hz)
        pre, _, _ = preamble_levels(m=self.link.m, trext=self.link.trext)
        return int(math.floor(pre.size * self.link.m * self.fs_hz / (2.0 * blf)))

    def detection_threshold(self, n_lags: int, blf_hz: float | None = None) -> float:
        """Normalised-correlation threshold γ for a search over ``n_lags`` lags.

        On complex white noise the zero-mean, normalised preamble correlation of
        :func:`~rfsim.gen2.linecode.decode_reply` at one lag obeys corr² ~ Beta(1, n − 2)
        (n = :meth:`preamble_samples`), so P(corr > γ) = (1 − γ²)^(n−2). decode_reply also
        refines the peak over sub-sample shifts, which acts like about twice as many
        independent tests (measured: with the plain union bound the false-alarm rate came
        out 1.0× the target for Miller-4 at 320 kHz and 1.9× for FM0 at 640 kHz, 4 MS/s).
        Hence γ = √(1 − (P_FA/(2·n_lags))^(1/(n−2))), P_FA = ``config.false_alarm_probability``.
        The default P_FA = 1e−3 gives γ ≈ 0.15 for ``miller4-320k`` at 4 MS/s (n = 500, 44 lags).
        """
        return preamble_threshold(self.preamble_samples(blf_hz), n_lags,
                                  self.config.false_alarm_probability)

    def reply_search_window_s(self) -> tuple[float, float]:
        """Reply start relative to the command end [s]: (T1min, T1max) of the link."""
        return _t1_window(self.link)

    def receive(self, rx, *, t0_s: float, n_bits: int, expect_crc: bool,
                cmd_end_s: float | None = None, blf_hz: float | None = None,
                carrier: complex | None = None) -> ReadResult:
        """Detect, decode and measure one tag reply.

        Parameters
        ----------
        rx : (n,) complex, everything at the RX port [√W] (leakage, backscatter, noise)
        t0_s : absolute time of ``rx[0]`` [s]
        n_bits : data bits of the reply (16 for RN16, PC+EPC+CRC for an EPC reply)
        expect_crc : check the last 16 bits as CRC-16 over the reply
        cmd_end_s : end of the command [s]; the reply start is searched in
            [cmd_end + T1min, cmd_end + T1max] (±1 sample). ``None``: anywhere in ``rx``.
        blf_hz : the tag's actual BLF [Hz]; default the profile's nominal BLF. The receiver
            does not estimate the BLF: decoding needs the BLF to about 1/(4·elements of the
            reply) (≈ 0.02 % for a Miller-4 EPC reply), far finer than the tag tolerance FrT,
            so a tag with a clock error must be read with its BLF given here.
        carrier : the reader's own transmitted baseband during the reply window (the CW after
            the command, :attr:`TxSegment.samples` ``[-1]``); the phase is referred to it,
            phase = (−arg(h·|carrier|/carrier)) mod 2π. A PR-ASK command ends with either
            polarity (the parity of its PIE symbols), which would otherwise add π to the
            phase of some commands' replies. None: the unmodulated carrier (phase 0).

        Processing
        ----------
        1. DC/leakage: during the reply window the leakage of the CW is a constant complex
           offset c. If ``rx`` holds at least 8 samples before the earliest reply start, their
           mean is subtracted first (conditioning only). Detection is exactly invariant to a
           constant offset (decode_reply correlates with a zero-mean template).
        2. Detection: maximum normalised preamble correlation over the search window; below
           :meth:`detection_threshold` → "preamble not found".
        3. Offset and gain: (h, c) by least squares over every sample whose waveform is known
           without decisions — the preamble, and the samples before and after the reply,
           where the tag rests in its absorbing state, the reply's −1 level (so the
           backscatter's DC steps by h at the reply's start and end: ``r = c + h·s``, s = −1
           outside the reply); this is the DC removal the decisions rely on (decode_reply's own
           preamble-only estimate of c is noisier; decisions are not used because one FM0/
           Miller bit error inverts all later remodulated levels).
        4. Decoding of r − c with h given (``config.decoder``) and, for ``expect_crc``,
           :func:`crc16_ok` → "crc error" (bits are still returned).
        5. Measurements with the decoded reply ``s(t)`` (±1, dummy-1 included) as reference:
           the reply is cut into :data:`DOPPLER_BLOCKS` blocks, each gives g_k = Σ(r − c)s/Σs²;
           a weighted least-squares line through the unwrapped arg g_k versus block time gives
           the Doppler f_D = slope/2π and the phase at the reply centre; |h| from the whole
           reply after removing the rotation. RSSI = |h|² in dBm, phase = (−arg h) mod 2π,
           SNR = |h|²/σ² with σ² the mean power of the residual r − c − h(t)s(t) over the reply.
           All of these use only samples whose two neighbours carry the same reference level
           (the start is estimated to 1/16 sample; a sample at an element boundary could
           otherwise be assigned the wrong level and bias |h| low and σ² high).
           Doppler resolution: std(f_D) ≈ √12/(2π·T·√(2·E/N0)) for a reply of duration T and
           energy-to-noise ratio E/N0 (≈ 0.1 Hz for T = 1.7 ms needs E/N0 ≈ 67 dB); the
           estimate is unambiguous for |f_D| < K/(2T). Decoding itself assumes a constant h
           over the reply (phase drift |f_D|·T ≲ 1/8 cycle).
        """
        rx = np.ascontiguousarray(rx, dtype=np.complex128)
        if rx.ndim != 1:
            raise ValueError(f"rx must be 1-D, got shape {rx.shape}")
        n_bits = int(n_bits)
        lk, fs = self.link, self.fs_hz
        blf = lk.blf_hz if blf_hz is None else float(blf_hz)
        if not blf > 0:
            raise ValueError(f"blf_hz must be > 0, got {blf_hz}")
        pre_n = self.preamble_samples(blf)
        # reply length in samples (preamble + n_bits + dummy)
        n_reply = int(math.ceil(reply_duration_s(n_bits, m=lk.m, trext=lk.trext, blf_hz=blf) * fs))
        if cmd_end_s is None:
            lo, hi = 0, rx.size - n_reply
        else:
            t1min, t1max = self.reply_search_window_s()
            lo = max(0, int(math.floor((float(cmd_end_s) + t1min - float(t0_s)) * fs)) - 1)
            hi = min(rx.size - n_reply, int(math.ceil((float(cmd_end_s) + t1max - float(t0_s)) * fs)) + 1)
        if hi < lo or pre_n < 3:
            return ReadResult(False, None, "preamble not found")
        r = rx - (rx[:lo].mean() if lo >= 8 else 0.0)
        det = decode_reply(r[lo:], n_bits=n_bits, m=lk.m, trext=lk.trext, blf_hz=blf, fs_hz=fs,
                           method=self.config.decoder, search_samples=hi - lo)
        start = lo + det.start_sample
        start_s = float(t0_s) + start / fs
        if det.corr < self.detection_threshold(hi - lo + 1, blf):
            return ReadResult(False, None, "preamble not found", start_s=start_s, corr=det.corr)
        # step 3: (h, c) from the CW-only samples and the preamble, then decode r − c
        full = self._reference(det.bits, start, r.size, blf)
        pre_n_el = preamble_levels(m=lk.m, trext=lk.trext)[0].size * lk.m  # preamble elements
        # Outside its reply a tag rests in its absorbing state, which is the reply's −1
        # level: the backscatter DC steps by h at the reply's start and end. Only samples
        # whose two neighbours carry the same level (as in the measurements: the start is
        # known to a fraction of a sample, a sample at an element boundary could carry the
        # other level and bias c, which no later step removes).
        h, c = fit_gain_offset(*_known_levels(r, full, start / fs * fs, 2.0 * blf / fs, pre_n_el))
        det2 = decode_reply(r[lo:] - c, n_bits=n_bits, m=lk.m, trext=lk.trext, blf_hz=blf, fs_hz=fs,
                            method=self.config.decoder, start_sample=det.start_sample, gain=h)
        bits = det2.bits.astype(np.uint8)
        ref = full if np.array_equal(bits, det.bits) else self._reference(bits, start, r.size, blf)
        meas = self._measure(r - c, ref, blf)
        if carrier is not None and complex(carrier) != 0:
            meas["phase_rad"] = float(wrap_phase_rad(meas["phase_rad"] + np.angle(complex(carrier))))
        ok = (not expect_crc) or crc16_ok(bits)
        return ReadResult(success=ok, bits=bits, failure_reason="" if ok else "crc error",
                          start_s=start_s, corr=det.corr, **meas)

    def _reference(self, bits: np.ndarray, start: float, n: int, blf_hz: float,
                   dummy: bool = True) -> np.ndarray:
        """The ±1 reply waveform of ``bits`` starting at sample ``start`` (0 elsewhere), (n,)."""
        lk = self.link
        return reply_waveform(bits, m=lk.m, trext=lk.trext, blf_hz=blf_hz, fs_hz=self.fs_hz,
                              t0_s=start / self.fs_hz, n_samples=n, dummy=dummy)

    def _measure(self, z: np.ndarray, s: np.ndarray, blf_hz: float) -> dict:
        """RSSI, phase, Doppler and SNR of ``z = h(t)·s(t) + noise`` (offset removed), see
        :meth:`receive` (numba kernel; :func:`measure_reference` is its NumPy twin)."""
        lk, fs = self.link, self.fs_hz
        h, slope, sigma2 = _measure(z, s, fs)
        p = abs(h) ** 2
        snr = 10.0 * math.log10(p / sigma2) if sigma2 > 0 and p > 0 else math.inf
        return dict(rssi_dbm=float(w_to_dbm(p)) if p > 0 else -math.inf,
                    phase_rad=float(wrap_phase_rad(-np.angle(h))),
                    doppler_hz=slope / (2.0 * math.pi),
                    snr_db=snr, ebn0_db=snr + 10.0 * math.log10(fs * lk.m / blf_hz))


def _measure(z: np.ndarray, s: np.ndarray, fs_hz: float) -> tuple[complex, float, float]:
    """``(h, slope [rad/s], σ²)`` of ``z = h·e^{j·slope·t}·s(t) + noise`` (numba kernel; the
    procedure is :meth:`Reader.receive` step 5, :func:`measure_reference` its NumPy twin)."""
    z = np.ascontiguousarray(z, dtype=np.complex128)
    s = np.ascontiguousarray(s, dtype=np.float64)
    n = s.size
    h, slope, sigma2 = _rk.measure_kernel(z, s, float(fs_hz), DOPPLER_BLOCKS, np.empty(n, np.complex128),
                                          np.empty(n), np.empty(n), np.empty(n, np.int64), np.empty(n), np.empty(n),
                                          np.empty(DOPPLER_BLOCKS, np.complex128), np.empty(DOPPLER_BLOCKS),
                                          np.empty(DOPPLER_BLOCKS))
    return complex(h), float(slope), float(sigma2)


def measure_reference(z: np.ndarray, s: np.ndarray, fs_hz: float) -> tuple[complex, float, float]:
    """Plain-NumPy twin of the measurement kernel: ``(h, slope [rad/s], σ²)``."""
    fs = float(fs_hz)
    idx = np.flatnonzero(s)
    i0, i1 = int(idx[0]), int(idx[-1]) + 1
    t = (np.arange(i0, i1) - 0.5 * (i0 + i1 - 1)) / fs  # time from the reply centre [s]
    # only samples whose neighbours have the same reference level: the start is known to
    # 1/16 sample, so a sample next to an element boundary may carry the other level
    ref = s[i0:i1]
    steady = _steady(ref)
    z, ref, t = z[i0:i1][steady], ref[steady], t[steady]
    starts = np.linspace(0, ref.size, DOPPLER_BLOCKS + 1).astype(int)[:-1]
    counts = np.diff(np.append(starts, ref.size)).astype(float)
    g = np.add.reduceat(z * ref, starts) / np.add.reduceat(ref * ref, starts)
    tc = np.add.reduceat(t, starts) / counts
    w2 = np.abs(g) ** 2  # weights |g_k| on the residuals (numpy.polyfit's w), squared
    if np.all(w2 > 0):
        y = np.unwrap(np.angle(g))
        xm, ym = np.dot(w2, tc) / w2.sum(), np.dot(w2, y) / w2.sum()
        slope = float(np.dot(w2, (tc - xm) * (y - ym)) / np.dot(w2, (tc - xm) ** 2))
    else:
        slope = 0.0
    rot = np.exp(-1j * slope * t)
    h = np.dot(z * rot, ref) / np.dot(ref, ref)
    sigma2 = float(np.mean(np.abs(z - h * ref / rot) ** 2))
    return complex(h), slope, sigma2


@functools.lru_cache(maxsize=64)
def _t1_window(link: LinkProfile) -> tuple[float, float]:
    """(T1min, T1max) of a (frozen, hashable) link profile [s]; a cached pure function."""
    r = t1(link)
    return r.min_s, r.max_s


def _known_levels(r: np.ndarray, full: np.ndarray, t0_samples: float, elements_per_sample: float,
                  n_pre_elements: int) -> tuple[np.ndarray, np.ndarray]:
    """``(r, level)`` at the samples whose level is known without decisions (numba kernel;
    :func:`known_levels_reference` is its NumPy twin). ``full`` is the sampled reply starting
    at ``t0_samples`` (``reply_waveform``'s t0_s·fs), its first ``n_pre_elements`` elements
    the preamble."""
    r_out = np.empty(r.size, dtype=np.complex128)
    level_out = np.empty(r.size)
    m = _rk.known_levels_kernel(np.ascontiguousarray(r, dtype=np.complex128),
                                np.ascontiguousarray(full, dtype=np.float64), float(t0_samples),
                                float(elements_per_sample), int(n_pre_elements), r_out, level_out)
    return r_out[:m], level_out[:m]


def known_levels_reference(r: np.ndarray, pre: np.ndarray, full: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plain-NumPy twin of the known-level selection of :meth:`Reader.receive` step 3: level
    −1 outside the reply (``full == 0``), the preamble ``pre`` inside it; samples with both
    neighbours at the same level."""
    level = np.where(full == 0, -1.0, np.where(pre != 0, pre, full))
    known = ((pre != 0) | (full == 0)) & _steady(level)
    return r[known], level[known]


def _steady(level: np.ndarray) -> np.ndarray:
    """(n,) bool: samples whose two neighbours have the same level (the ends are False)."""
    out = np.zeros(level.size, dtype=bool)
    out[1:-1] = (level[1:-1] == level[:-2]) & (level[1:-1] == level[2:])
    return out


__all__ = [
    "ReaderConfig",
    "Reader",
    "TxSegment",
    "ReadResult",
    "frequency_plan",
    "hilbert_fir",
    "FCC_CHANNELS_HZ",
    "ETSI_CHANNELS_HZ",
    "LEAKAGE_PHASE_RAD",
    "FAILURES",
]

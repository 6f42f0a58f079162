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

Frequency plan (anchors §4.7 "Regulatory", §4.9; :mod:`rfsim.air.carriers`): FCC 50 channels
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

Report (``ReaderConfig.report``, :class:`rfsim.core.records.ReportConfig`): what the reader hands
over of a read — RSSI rounded to its step, a sensitivity floor, the phase with the port's
phase offset as a 12-bit code, µs time stamps — is applied to the read log by
:func:`rfsim.core.records.report_columns`; the measurements of :class:`ReadResult` stay unquantized.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rfsim.air.carriers import ETSI_CHANNELS_HZ, FCC_CHANNELS_HZ, channel_index as _channel_index
from rfsim.core.config import validate
from rfsim.core.errors import ConfigError
from rfsim.gen2.capture import fit_gain_offset, preamble_threshold
from rfsim.gen2.commands import COMMAND_TYPES, command_preamble, encode
from rfsim.gen2.crc import crc16_ok
from rfsim.gen2.link import REPLY_WINDOW_TAIL_TPRI, LinkProfile, profile, reply_window_s, t1
from rfsim.gen2.linecode import decode_bits, decode_reply, preamble_levels, reply_duration_s, reply_waveform
from rfsim.gen2.pie import pie_timeline, pr_ask_baseband, timeline_envelope
from rfsim.air.noise import thermal_noise_power_w
from rfsim.core.units import dbm_to_w, w_to_dbm, wrap_phase_rad
from rfsim.devices.reader_config import ReaderConfig, frequency_plan
from rfsim.core.lazy import lazy_import

_signal = lazy_import("scipy.signal")
_bk = lazy_import("rfsim.devices._blf_search_kernels")
_rk = lazy_import("rfsim.devices._reader_kernels")

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

FAILURES = ("", "preamble not found", "crc error", "rn16 rejected")
#: Number of modulated command segments a Reader keeps for reuse.
TX_CACHE_SIZE = 64


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
        r = A_s − Γ (rfsim.devices.tag) h ∝ (r_B − r_A)/2 = (Γ_A − Γ_B)/2, A_s cancels
    doppler_hz : (1/2π)·d(arg h)/dt across the reply (positive for an approaching tag)
    snr_db : |h|²/σ², σ² the residual power per sample at ``fs_hz`` (noise bandwidth fs)
    ebn0_db : snr_db + 10·log10(fs/bit rate), independent of fs
    start_s : absolute time of the detected reply start [s]
    corr : normalised preamble correlation (0…1) at the detected start
    blf_hz : the BLF the reply was decoded at [Hz] (NaN: the nominal BLF, ``blf_search`` off)
    decision_ebn0_db : the acceptance statistic, Eb/(N0 + I) of the decoded reply against its
        residual (:func:`search_decode`; NaN with ``blf_search`` off)
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
    blf_hz: float = math.nan
    decision_ebn0_db: float = math.nan


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


#: recently transmitted baseband segments (read-only) of every reader: ``(id(config), id(link),
#: fs, bits, preamble, CW lengths) → (config, link, samples)`` (:meth:`Reader.transmit`)
_TX_SEGMENTS: dict = {}

#: ReaderConfig objects already validated, by identity: ``id → (config, validated config)``
_VALIDATED: dict = {}
_VALIDATED_SIZE = 16


def _validated(config: ReaderConfig) -> ReaderConfig:
    """:func:`rfsim.core.config.validate` of a (frozen) config, remembered for the last few config
    objects: a Monte Carlo builds one reader per sample from the same config."""
    hit = _VALIDATED.get(id(config))
    if hit is not None and hit[0] is config:
        return hit[1]
    out = validate(config)
    if len(_VALIDATED) >= _VALIDATED_SIZE:
        _VALIDATED.pop(next(iter(_VALIDATED)))
    _VALIDATED[id(config)] = (config, out)  # config kept alive: its id stays its own
    return out


class Reader:
    """A Gen2 reader with one or more antennas (used in turn), see the module docstring.

    Parameters
    ----------
    config : ReaderConfig
    antennas : non-empty sequence of rfsim.channels.antennas.Antenna
    rng : numpy Generator (keyword-only); draws the FCC hop table
    link : optional LinkProfile overriding ``config.link_profile`` (custom profiles)
    """

    def __init__(self, config: ReaderConfig, antennas: Sequence, *, rng: np.random.Generator,
                 link: LinkProfile | None = None):
        self.config = _validated(config)
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
        #: recently sent commands → (bits (read-only), preamble, T_cmd [s]); pure functions of
        #: the (frozen) command and the link, dropped when ``link`` is replaced
        self._cmd_cache: dict = {}
        self._cmd_cache_link = self.link
        #: (config, fs, noise power, leakage gain): derived from the frozen config
        self._derived: tuple = (None, None, 0.0, 0j)
        #: with ``blf_search``: the BLF measured on the last accepted RN16 (the ACKed tag's),
        #: used for the EPC reply that follows; cleared by the next reply decoded
        self._rn16_blf_hz: float | None = None

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

    def _cw_amplitude(self) -> float:
        """CW amplitude A = √P_tx [√W] of the (frozen) config, recomputed when it is replaced."""
        hit = getattr(self, "_amp", None)
        if hit is None or hit[0] is not self.config:
            hit = self._amp = (self.config, math.sqrt(self.ptx_w))
        return hit[1]

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
        rise_fall_s = self.config.pie_rise_fall_tari * lk.tari_s
        amp = self._cw_amplitude()
        if lk.modulation in ("DSB-ASK", "PR-ASK"):
            # Beyond the last rising edge's ramp (≤ 0.28 Tari wide) e = 1 and the PR-ASK sign no
            # longer changes: the samples up to 2 Tari after that edge are modulated, the CW
            # after them is the constant A·s_end (s_end = −1 after an odd number of low pulses).
            head = dataclasses.replace(tl, duration_s=float(tl.rise_s[-1] + min(float(cw_after_s), 2.0 * lk.tari_s)))
            e = timeline_envelope(head, depth=lk.depth, fs_hz=self.fs_hz, rise_fall_s=rise_fall_s)
            x = np.empty(int(math.ceil(tl.duration_s * self.fs_hz)), dtype=np.complex128)
            if lk.modulation == "DSB-ASK":
                x[:e.size] = amp * e
                x[e.size:] = amp
            else:
                x[:e.size] = pr_ask_baseband(head, e, amplitude=amp, fs_hz=self.fs_hz)
                x[e.size:] = amp * (1.0 - 2.0 * (tl.rise_s.size % 2))
            return x
        e = timeline_envelope(tl, depth=lk.depth, fs_hz=self.fs_hz, rise_fall_s=rise_fall_s)
        # SSB-ASK
        half = int(round(SSB_HILBERT_HALF_TARI * lk.tari_s * self.fs_hz))
        quad = _signal.fftconvolve(e - 1.0, hilbert_fir(half), mode="same")
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
        # A reader sends the same commands (Query, QueryRep, …) again and again, and a Monte
        # Carlo builds many readers of one config: keep the last modulated segments (read-only),
        # shared by the readers of the same (frozen) config, link profile and sample rate.
        key = (id(self.config), id(self.link), self.fs_hz, bits.tobytes(), preamble, float(cw_after_s), cw_before_s)
        hit = _TX_SEGMENTS.get(key)
        if hit is not None and hit[0] is self.config and hit[1] is self.link:
            x = hit[2]
        else:
            x = self.modulate(bits, preamble=preamble, cw_after_s=cw_after_s, cw_before_s=cw_before_s)
            x.setflags(write=False)
            if len(_TX_SEGMENTS) >= TX_CACHE_SIZE:
                _TX_SEGMENTS.pop(next(iter(_TX_SEGMENTS)))
            _TX_SEGMENTS[key] = (self.config, self.link, x)  # config and link kept alive: their ids stay theirs
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
        return int(math.floor(self._preamble_elements() * self.fs_hz / (2.0 * blf)))

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
        memo = getattr(self, "_thresholds", None)  # kept while config, link and fs are the same
        if memo is None or memo[0] is not self.config or memo[1] is not self.link or memo[2] != self.fs_hz:
            memo = self._thresholds = (self.config, self.link, self.fs_hz, {})
        key = (int(n_lags), blf_hz)
        hit = memo[3].get(key)
        if hit is None:
            if len(memo[3]) >= TX_CACHE_SIZE:
                memo[3].clear()
            hit = memo[3][key] = preamble_threshold(self.preamble_samples(blf_hz), n_lags,
                                                    self.config.false_alarm_probability)
        return hit

    def listen_window_s(self, reply_bits: int) -> float:
        """CW the reader keeps after a command to hear a reply of ``reply_bits`` bits [s]:
        :func:`rfsim.gen2.link.reply_window_s` (T1max + reply + 3 Tpri at the nominal BLF);
        with ``blf_search`` the reply at the slowest BLF of the tolerance, BLF·(1 − FrT)."""
        return _listen_window_s(self.link, int(reply_bits), self.config.blf_search != "off")

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
        blf_hz : the tag's actual BLF [Hz]; default the profile's nominal BLF. With
            ``blf_search = "off"`` the receiver does not estimate the BLF: decoding needs the
            BLF to about 1/(4·elements of the reply) (≈ 0.02 % for a Miller-4 EPC reply), far
            finer than the tag tolerance FrT, so a tag with a BLF error must be read with its
            BLF given here. With ``blf_search = "preamble"`` and no ``blf_hz`` the receiver
            estimates it within the FrT of the link (:meth:`_receive_searched`,
            :func:`search_decode`), as a real reader must for tags with their own BLF.
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
        memo = self._reply_memo()
        blf = memo[3] if blf_hz is None else float(blf_hz)
        if not blf > 0:
            raise ValueError(f"blf_hz must be > 0, got {blf_hz}")
        hit = memo[4].get((n_bits, blf))
        if hit is None:
            if len(memo[4]) >= TX_CACHE_SIZE:
                memo[4].clear()
            # reply length in samples (preamble + n_bits + dummy)
            hit = memo[4][(n_bits, blf)] = (self.preamble_samples(blf), int(math.ceil(
                reply_duration_s(n_bits, m=lk.m, trext=lk.trext, blf_hz=blf) * fs)))
        pre_n, n_reply = hit
        if cmd_end_s is None:
            lo, hi = 0, rx.size - n_reply
        else:
            t1min, t1max = self.reply_search_window_s()
            lo = max(0, int(math.floor((float(cmd_end_s) + t1min - float(t0_s)) * fs)) - 1)
            hi = min(rx.size - n_reply, int(math.ceil((float(cmd_end_s) + t1max - float(t0_s)) * fs)) + 1)
        if self.config.blf_search == "preamble" and blf_hz is None:
            n_slow = int(math.ceil(reply_duration_s(n_bits, m=lk.m, trext=lk.trext, blf_hz=lk.blf_range_hz[0]) * fs))
            hi = min(hi, rx.size - n_slow)
            if hi < lo or pre_n < 3:
                return ReadResult(False, None, "preamble not found")
            return self._receive_searched(rx - (rx[:lo].mean() if lo >= 8 else 0.0), lo, hi, float(t0_s), n_bits,
                                          expect_crc, carrier)
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
        # Outside its reply a tag rests in its absorbing state, which is the reply's −1
        # level: the backscatter DC steps by h at the reply's start and end. Only samples
        # whose two neighbours carry the same level (as in the measurements: the start is
        # known to a fraction of a sample, a sample at an element boundary could carry the
        # other level and bias c, which no later step removes).
        h, c = fit_gain_offset(*_known_levels(r, full, start / fs * fs, 2.0 * blf / fs, self._preamble_elements()))
        # the reply's samples only (r − c elsewhere is not used): from the sample before its start
        i0 = lo + int(math.floor(det.start_sample))
        span = r[i0: i0 + n_reply + 4] - c
        bits = decode_bits(span, n_bits=n_bits, m=lk.m, trext=lk.trext, blf_hz=blf, fs_hz=fs,
                           method=self.config.decoder, start_sample=det.start_sample - (i0 - lo), gain=h).astype(np.uint8)
        ref = full if bits.tobytes() == det.bits.tobytes() else self._reference(bits, start, r.size, blf)
        meas = self._measure(span, ref[i0: i0 + span.size], blf)
        if carrier is not None and complex(carrier) != 0:
            meas["phase_rad"] = float(wrap_phase_rad(meas["phase_rad"] + np.angle(complex(carrier))))
        ok = (not expect_crc) or crc16_ok(bits)
        return ReadResult(success=ok, bits=bits, failure_reason="" if ok else "crc error",
                          start_s=start_s, corr=det.corr, **meas)

    def _receive_searched(self, r: np.ndarray, lo: int, hi: int, t0_s: float, n_bits: int, expect_crc: bool,
                          carrier) -> ReadResult:
        """:meth:`receive` with ``blf_search = "preamble"``: BLF, start and bits from
        :func:`search_decode` (detection: its coarse correlation against
        :meth:`detection_threshold` over every BLF hypothesis and lag), then (h, c) from the
        known levels and the measurements as in steps 3 and 5 at the decoded BLF; an RN16 is
        accepted only when its decision-domain Eb/(N0 + I) reaches
        :func:`rn16_threshold_db` of ``rn16_false_accept`` (else "rn16 rejected", bits kept).
        The BLF of an accepted RN16 is remembered: the reply with a CRC that follows (the EPC
        of the ACKed tag) is searched at that BLF, within 1/(RN16 elements), over all its bits
        (the PC of an EPC reply is mostly 0s, a square wave at any BLF over its first bits)."""
        lk, fs = self.link, self.fs_hz
        hint, self._rn16_blf_hz = self._rn16_blf_hz, None
        if expect_crc and hint is not None:  # the reply of the tag whose RN16 was ACKed: its BLF is known
            grid = np.array([hint])
            n_el16 = preamble_levels(m=lk.m, trext=lk.trext)[0].size * lk.m + 2 * lk.m * 17
            out = search_decode(r, m=lk.m, trext=lk.trext, n_bits=n_bits, blfs_hz=grid, fs_hz=fs, lo=lo, hi=hi,
                                known_within=1.0 / n_el16)
        else:
            grid = self._blf_grid()
            out = search_decode(r, m=lk.m, trext=lk.trext, n_bits=n_bits, blfs_hz=grid, fs_hz=fs, lo=lo, hi=hi)
        start, blf, corr = float(out.start[0]), float(out.blf_hz[0]), float(out.corr[0])
        start_s = t0_s + start / fs
        if corr < preamble_threshold(self.preamble_samples(), (hi - lo + 1) * grid.size,
                                     self.config.false_alarm_probability):
            return ReadResult(False, None, "preamble not found", start_s=start_s, corr=corr)
        bits = out.bits[0].astype(np.uint8)
        full = self._reference(bits, start, r.size, blf)
        h, c = fit_gain_offset(*_known_levels(r, full, start, 2.0 * blf / fs, self._preamble_elements()))
        meas = self._measure(r - c, full, blf)
        if carrier is not None and complex(carrier) != 0:
            meas["phase_rad"] = float(wrap_phase_rad(meas["phase_rad"] + np.angle(complex(carrier))))
        stat = float(out.decision_ebn0_db[0])
        if expect_crc:
            ok = crc16_ok(bits)
            reason = "" if ok else "crc error"
        else:
            p = self.config.rn16_false_accept
            ok = p == 0 or stat >= rn16_threshold_db(p)
            reason = "" if ok else "rn16 rejected"
            if ok:  # an ACK follows: the reply it elicits comes from the tag measured here
                self._rn16_blf_hz = blf
        return ReadResult(success=ok, bits=bits, failure_reason=reason, start_s=start_s, corr=corr, blf_hz=blf,
                          decision_ebn0_db=stat, **meas)

    def _reply_memo(self) -> tuple:
        """``(config, link, fs, nominal BLF [Hz], {(n_bits, BLF): (preamble samples, reply
        samples)})`` of :meth:`receive`, kept while config, link and fs are the same objects
        (pure functions of them)."""
        memo = getattr(self, "_rx_memo", None)
        if memo is None or memo[0] is not self.config or memo[1] is not self.link or memo[2] != self.fs_hz:
            memo = self._rx_memo = (self.config, self.link, self.fs_hz, self.link.blf_hz, {})
        return memo

    def _preamble_elements(self) -> int:
        """Elements of the reply preamble (pilot included) of the current link (kept while the
        link is the same object)."""
        hit = getattr(self, "_pre_el", None)
        if hit is None or hit[0] is not self.link:
            lk = self.link
            hit = self._pre_el = (lk, preamble_levels(m=lk.m, trext=lk.trext)[0].size * lk.m)
        return hit[1]

    def _blf_grid(self) -> np.ndarray:
        """:func:`blf_grid_hz` of the current link (kept while the link is the same object)."""
        hit = getattr(self, "_grid", None)
        if hit is None or hit[0] is not self.link:
            hit = self._grid = (self.link, blf_grid_hz(self.link))
        return hit[1]

    def _reference(self, bits: np.ndarray, start: float, n: int, blf_hz: float,
                   dummy: bool = True) -> np.ndarray:
        """The ±1 reply waveform of ``bits`` starting at sample ``start`` (0 elsewhere), (n,)."""
        lk = self.link
        return reply_waveform(bits, m=lk.m, trext=lk.trext, blf_hz=blf_hz, fs_hz=self.fs_hz,
                              t0_s=start / self.fs_hz, n_samples=n, dummy=dummy)

    def _measure(self, z: np.ndarray, s: np.ndarray, blf_hz: float) -> dict:
        """RSSI, phase, Doppler and SNR of ``z = h(t)·s(t) + noise`` (offset removed), see
        :meth:`receive` (numba kernel)."""
        lk, fs = self.link, self.fs_hz
        h, slope, sigma2 = _measure(z, s, fs)
        p = abs(h) ** 2
        snr = 10.0 * math.log10(p / sigma2) if sigma2 > 0 and p > 0 else math.inf
        return dict(rssi_dbm=float(w_to_dbm(p)) if p > 0 else -math.inf,
                    phase_rad=float(wrap_phase_rad(-np.angle(h))),
                    doppler_hz=slope / (2.0 * math.pi),
                    snr_db=snr, ebn0_db=snr + 10.0 * math.log10(fs * lk.m / blf_hz))


# ----------------------------------------------------------------------------- BLF search


#: Fine BLF search: half-width in coarse steps and BLFs per side of each pass; bits of its
#: first phase (a longer reply is searched again over all its bits).
FINE_SPAN_STEPS = 2
FINE_PER_SIDE = 4
FINE_FIRST_BITS = 16


@dataclass(frozen=True)
class SearchDecode:
    """Result of :func:`search_decode` for B windows (all arrays of length B).

    bits : (B, n_bits) uint8; blf_hz : BLF decoded at [Hz]; start : reply start [samples into
    the window]; corr : the coarse normalised preamble correlation; gain : h (complex);
    sigma2 : residual power per sample over the reply's steady samples; ebn0_db :
    10·log10(|h|²·(2M/ρ)/σ²), ρ = 2·BLF/fs (samples per bit 2M/ρ); sigma2_bit : σ_eff², the
    disturbance that reaches the decisions: per data half-bit j the matched-filter output
    of the projection y = Re((r − c)·h*)/|h| on the decided levels minus |h|·N_j (N_j steady
    samples), σ_eff² = 2·Σδ_j²/ΣN_j (σ² for white noise; a second tag's in-band reply is not
    reduced by the matched filter's gain); decision_ebn0_db : the acceptance statistic,
    Eb/(N0 + I) in the decision domain = 10·log10(|h|²·(2M/ρ)/σ_eff²).
    """

    bits: np.ndarray
    blf_hz: np.ndarray
    start: np.ndarray
    corr: np.ndarray
    gain: np.ndarray
    sigma2: np.ndarray
    ebn0_db: np.ndarray
    sigma2_bit: np.ndarray
    decision_ebn0_db: np.ndarray


def blf_grid_hz(link: LinkProfile, lo_hz: float | None = None, hi_hz: float | None = None) -> np.ndarray:
    """Coarse BLF hypotheses [Hz]: a geometric grid over BLF·(1 ± FrT) of ``link`` (or
    [lo, hi]) with relative step 1/(2·preamble elements), the correlation peak's half-width
    (as the capture decoder, :mod:`rfsim.gen2.replies` step 2)."""
    lo, hi = link.blf_range_hz if lo_hz is None else (float(lo_hz), float(hi_hz))
    n_pre_el = preamble_levels(m=link.m, trext=link.trext)[0].size * link.m
    step = 1.0 / (2.0 * n_pre_el)
    n = int(math.ceil(math.log(hi / lo) / math.log1p(step))) + 1
    return np.geomspace(lo, hi, max(n, 2))


def _search_setup(m: int, trext: bool, n_bits: int, blfs_hz, fs_hz: float):
    """Preamble elements and levels, coarse templates and fine-search parameters."""
    pre_levels, cur, prev = preamble_levels(m=m, trext=trext)
    pre_el = np.repeat(pre_levels, m).astype(np.float64)
    if m > 1:
        pre_el[1::2] *= -1.0
    ratios = 2.0 * np.asarray(blfs_hz, dtype=np.float64) / fs_hz
    lens = np.floor(pre_el.size / ratios).astype(np.int64)
    tpl0 = np.zeros((ratios.size, int(lens.max())))
    for k, (ratio, n) in enumerate(zip(ratios, lens)):
        t = reply_waveform(np.zeros(0, np.uint8), m=m, trext=trext, blf_hz=0.5 * ratio * fs_hz, fs_hz=fs_hz,
                           dummy=False, n_samples=int(n))
        tpl0[k, :n] = t - t.mean()
    step_c = 1.0 / (2.0 * pre_el.size)
    n_el = pre_el.size + 2 * m * (int(n_bits) + 1)
    n_el1 = pre_el.size + 2 * m * (min(int(n_bits), FINE_FIRST_BITS) + 1)
    return (pre_levels.astype(np.int8), int(cur), int(prev), pre_el, ratios, tpl0, lens,
            FINE_SPAN_STEPS * step_c, 1.0 / (4.0 * n_el1), 1.0 / (4.0 * n_el))


def search_decode(rs, *, m: int, trext: bool, n_bits: int, blfs_hz, fs_hz: float, lo: int, hi: int,
                  threads: int = 1, known_within: float | None = None) -> SearchDecode:
    """Estimate the BLF of, and decode, one reply in each window of ``rs`` (numba kernel).

    Parameters
    ----------
    rs : (B, n) complex, windows ``h·s(t) + c + noise`` [√W] (any constant offset c)
    m, trext, n_bits : line code and data bits of the reply (without the dummy 1)
    blfs_hz : coarse BLF hypotheses (:func:`blf_grid_hz`)
    fs_hz : sample rate [Hz]; lo, hi : the reply start lags searched [samples]
    threads : the windows are split into this many blocks decoded on as many threads (the
        kernel releases the GIL and draws nothing at random: the result does not depend on it)
    known_within : the BLF is known to this relative precision (``blfs_hz`` = the one known
        BLF, e.g. measured on the RN16 of the tag an ACK addresses): the fine search starts
        across ± that

    Method (the reader with ``blf_search = "preamble"``; the capture decoder
    :mod:`rfsim.gen2.replies` steps 2–3 do the same on recordings):

    1. Coarse: the largest zero-mean normalised preamble correlation
       |Σ r[l+i]·t_k[i]| / (‖t_k‖·‖r[l:l+L] − mean‖) over the BLF grid b_k and the lags l,
       refined between lags by a parabola.
    2. Fine: with the preamble's centre held, decode (preamble gain and offset, half-bit
       matched filter, Viterbi) at 2·FINE_PER_SIDE + 1 BLFs across ±FINE_SPAN_STEPS coarse
       steps; the one whose remodulated reply (rest level −1 around it) leaves the least
       least-squares residual over the whole window wins; the span narrows to one step until the step is
       ≤ 1/(4·reply elements) (decoding needs the BLF to about that) — first over the first
       FINE_FIRST_BITS bits, then, for a longer reply, over twice as many bits at a time (all
       at last) across ±4 final steps of the previous phase (a long reply misaligned by a
       coarse step has a residual with many local minima).
    3. Statistic: h and the residual σ² (noise plus whatever the fit does not explain, e.g. a
       second tag) over the reply's steady samples; Eb/(N0 + I) = |h|²·(2M/ρ)/σ².
    """
    r = np.ascontiguousarray(rs, dtype=np.complex128)
    if r.ndim == 1:
        r = r[None, :]
    pre_levels, cur, prev, pre_el, ratios, tpl0, lens, span, target1, target = _search_setup(m, trext, n_bits,
                                                                                             blfs_hz, fs_hz)
    first_bits = FINE_FIRST_BITS
    if known_within is not None:
        span = float(known_within)
    b = r.shape[0]
    bits = np.zeros((b, int(n_bits)), np.uint8)
    ratio, start, corr, sigma2, sigma2_bit = (np.empty(b) for _ in range(5))
    gain = np.empty(b, np.complex128)

    def block(i0: int, i1: int) -> None:
        _bk.search_decode_kernel(r[i0:i1], ratios, tpl0, lens, int(lo), int(hi), pre_el, pre_levels, np.int8(cur),
                                 np.uint8(prev), int(m), int(n_bits), first_bits, span, FINE_PER_SIDE,
                                 target1, target, bits[i0:i1],
                                 ratio[i0:i1], start[i0:i1], corr[i0:i1], gain[i0:i1], sigma2[i0:i1],
                                 sigma2_bit[i0:i1])

    edges = np.linspace(0, b, max(1, min(int(threads), b)) + 1).astype(int)
    if edges.size <= 2:
        block(0, b)
    else:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(edges.size - 1) as pool:
            list(pool.map(block, edges[:-1], edges[1:]))
    return _search_result(bits, ratio, start, corr, gain, sigma2, sigma2_bit, m, fs_hz)


def _search_result(bits, ratio, start, corr, gain, sigma2, sigma2_bit, m, fs_hz) -> SearchDecode:
    with np.errstate(divide="ignore", invalid="ignore"):
        e_bit = np.abs(gain) ** 2 * (2.0 * m / ratio)
        ebn0 = 10.0 * np.log10(e_bit / sigma2)
        ebn0_min = 10.0 * np.log10(e_bit / sigma2_bit)
    return SearchDecode(bits, 0.5 * ratio * fs_hz, start, corr, gain, sigma2, ebn0, sigma2_bit, ebn0_min)


def rn16_threshold_db(false_accept: float, *, n_bits: int = 16) -> float:
    """Eb/(N0 + I) threshold [dB] of the RN16 acceptance for a stated false-accept probability p.

    With Gaussian noise plus interference of density N0 + I, coherent antipodal decisions give
    a bit error probability Q(√(2·Eb/(N0 + I))) (FM0 and Miller-M decoded by the matched
    filter, anchors §4.8), and an n-bit word is wrong with probability
    1 − (1 − P_b)^n ≈ n·P_b. Accepting only when the measured Eb/(N0 + I) ≥ γ with
    n·Q(√(2γ)) = p bounds the probability that an accepted word is wrong by p (within this
    model): γ = (Q⁻¹(p/n))²/2. p = 1e−2 → 7.2 dB for 16 bits. An approximation: the
    interference of a second tag is not Gaussian, so the measured false-ACK rate against γ
    is what sets the default (``inventory`` scenario, ``acceptance`` table).
    """
    from scipy.special import ndtri

    if not 0.0 < false_accept < 0.5:
        raise ValueError(f"false_accept must be in (0, 0.5), got {false_accept}")
    q = -float(ndtri(false_accept / n_bits))  # Q⁻¹(p/n)
    return 10.0 * math.log10(0.5 * q * q)


def _measure(z: np.ndarray, s: np.ndarray, fs_hz: float) -> tuple[complex, float, float]:
    """``(h, slope [rad/s], σ²)`` of ``z = h·e^{j·slope·t}·s(t) + noise`` (numba kernel; the
    procedure is :meth:`Reader.receive` step 5)."""
    z = np.ascontiguousarray(z, dtype=np.complex128)
    s = np.ascontiguousarray(s, dtype=np.float64)
    h, slope, sigma2 = _rk.measure_kernel(z, s, float(fs_hz), DOPPLER_BLOCKS)
    return complex(h), float(slope), float(sigma2)


@functools.lru_cache(maxsize=256)
def _listen_window_s(link: LinkProfile, reply_bits: int, blf_search: bool) -> float:
    """:meth:`Reader.listen_window_s` of a (frozen) link profile: a pure function, cached."""
    if not blf_search:
        return reply_window_s(link, reply_bits)
    return t1(link).max_s + link.reply_duration_s(reply_bits) / (1.0 - link.frt) + REPLY_WINDOW_TAIL_TPRI * link.tpri_s


@functools.lru_cache(maxsize=64)
def _t1_window(link: LinkProfile) -> tuple[float, float]:
    """(T1min, T1max) of a (frozen, hashable) link profile [s]; a cached pure function."""
    r = t1(link)
    return r.min_s, r.max_s


def _known_levels(r: np.ndarray, full: np.ndarray, t0_samples: float, elements_per_sample: float,
                  n_pre_elements: int) -> tuple[np.ndarray, np.ndarray]:
    """``(r, level)`` at the samples whose level is known without decisions (numba kernel;
    the tests hold it to a NumPy twin). ``full`` is the sampled reply starting
    at ``t0_samples`` (``reply_waveform``'s t0_s·fs), its first ``n_pre_elements`` elements
    the preamble."""
    r_out = np.empty(r.size, dtype=np.complex128)
    level_out = np.empty(r.size)
    m = _rk.known_levels_kernel(np.ascontiguousarray(r, dtype=np.complex128),
                                np.ascontiguousarray(full, dtype=np.float64), float(t0_samples),
                                float(elements_per_sample), int(n_pre_elements), r_out, level_out)
    return r_out[:m], level_out[:m]


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
    "SearchDecode",
    "search_decode",
    "blf_grid_hz",
    "rn16_threshold_db",
]

"""Gen2 interrogator (reader): PIE transmitter, frequency plan, antennas, IQ receiver.

Transmitter: :mod:`rfsim.devices.reader_tx` (PIE commands as DSB-, PR- or SSB-ASK complex
baseband [√W] at the antenna port, :class:`~rfsim.devices.reader_tx.PieTransmitter`). BLF search:
:mod:`rfsim.gen2.blf_search`. Per-read measurements: :mod:`rfsim.devices.reader_measure`.

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
preamble correlation inside the T1 window and decoded by the one reply decoder
(:func:`rfsim.gen2.reply_decoder.decode`, the "known" plan at one BLF or the "blf" plan of
the BLF search, kept per link in the run's ``air_cache``); EPC replies are checked with CRC-16
and gain, phase slope and residual power are measured with the decoded reply as known
reference, both steps of the decoder; the reader turns them into RSSI, phase, Doppler and SNR
(anchors §4.8, §4.9).

Report (``ReaderConfig.report``, :class:`rfsim.core.records.ReportConfig`): what the reader hands
over of a read — RSSI rounded to its step, a sensitivity floor, the phase with the port's
phase offset as a 12-bit code, µs time stamps — is applied to the read log by
:func:`rfsim.core.records.report_columns`; the measurements of :class:`ReadResult` stay unquantized.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import operator
from collections.abc import Sequence
from itertools import repeat
from typing import NamedTuple

import numpy as np

from rfsim.air.cache import AirCache, Waveform
from rfsim.air.carriers import ETSI_CHANNELS_HZ, FCC_CHANNELS_HZ, channel_index as _channel_index
from rfsim.core.config import validate
from rfsim.core.errors import ConfigError
from rfsim.gen2.link import REPLY_WINDOW_TAIL_TPRI, LinkProfile, profile, reply_window_s, t1, t5
from rfsim.gen2.linecode import reply_duration_s, reply_waveform
from rfsim.air.noise import thermal_noise_power_w
from rfsim.core.units import dbm_to_w, w_to_dbm, wrap_phase_rad
from rfsim.devices.reader_config import ReaderConfig, frequency_plan
from rfsim.devices.reader_measure import (DOPPLER_BLOCKS, FAILURES, ReadResult, known_levels as _known_levels,
                                          measure as _measure, measurements as _measurements_of,
                                          refer_phase as _refer_phase, steady as _steady)
from rfsim.gen2.blf_search import (FINE_FIRST_BITS, FINE_PER_SIDE, SearchDecode, blf_grid_hz,
                                   rn16_threshold_db, search_decode, search_result as _search_result,
                                   search_setup as _search_setup)
from rfsim.devices.reader_tx import TX_CACHE_SIZE, PieTransmitter, TxSegment, hilbert_fir
from rfsim.devices import reader_statistic as _statistic
from rfsim.gen2.reply_decoder import (DecodePlan as _DecodePlan, DecodedReply as _DecodedReply, LinkPlans as _LinkPlans,
                                     Windows as _Windows, decode as _decode)

#: FCC maximum dwell time per channel [s].
FCC_MAX_DWELL_S = 0.4
#: Phase of the TX→RX leakage path [rad]. An arbitrary fixed constant (a circulator's
#: through path has some fixed phase); the receiver does not depend on it because the
#: leakage of the CW is removed as an unknown complex constant.
LEAKAGE_PHASE_RAD = math.pi / 3


class _Kept(NamedTuple):
    """A value derived by a pure function from one immutable object (a frozen config or link
    profile), kept with it on the reader: recomputed when the object is replaced."""

    source: object
    value: object


class _Fixed(NamedTuple):
    """What the receiver derives from the (frozen) config and the sample rate
    (:meth:`Reader._fixed`)."""

    config: ReaderConfig
    fs_hz: float
    noise_w: float  # k·T0·fs·F [W]
    leakage: complex  # TX→RX leakage gain


class _ReplySize(NamedTuple):
    """Samples of a reply's preamble and of the whole reply (preamble, bits, dummy bit)."""

    preamble_samples: int
    reply_samples: int


class _ReceiveMemo(NamedTuple):
    """What :meth:`Reader.receive` and :meth:`Reader.detection_threshold` derive from the
    reader's config, link, sample rate and run cache, kept while they are the same objects."""

    config: ReaderConfig
    link: LinkProfile
    fs_hz: float
    air_cache: AirCache
    blf_hz: float  # the link's nominal BLF [Hz]
    sizes: dict  # (n_bits, BLF [Hz]) -> _ReplySize
    window: tuple  # the reply start's window after the command end [s] (reply_search_window_s)
    known: _DecodePlan  # the "known" decode plan (_decode_plan)


class Reader(PieTransmitter):
    """A Gen2 reader with one or more antennas (used in turn), see the module docstring.

    Parameters
    ----------
    config : ReaderConfig
        The reader's settings (validated once per run through ``air_cache``).
    antennas : sequence of rfsim.channels.antennas.Antenna
        Its antennas, at least one, used in turn.
    rng : numpy.random.Generator
        Keyword-only: draws the FCC hop table (and spawns the receiver's noise stream with
        ``rx_model = "statistic"``).
    link : LinkProfile or None, optional
        Keyword-only: overrides ``config.link_profile`` (custom profiles); default None.
    air_cache : rfsim.air.cache.AirCache or None, optional
        Keyword-only: the run's cache (its air-step strategy, the modulated command segments
        and what tags derive from them); default None, a new one. A scene that makes a reader
        per trial gives them one, so that a command is modulated and decoded once per run.

    Attributes
    ----------
    fs_hz : float
        Sample rate [Hz].
    plan_hz : ndarray of float
        Carrier of each channel of the frequency plan [Hz].
    hop_sequence : ndarray of int
        0-based hop table: channel ``hop_sequence[i % n]`` in dwell period i.

    Raises
    ------
    ValueError
        When ``link`` is not a LinkProfile or there is no antenna.
    ConfigError
        For port phase offsets not one per antenna, an FCC dwell above 0.4 s, a fixed channel
        outside the plan, or a sample rate below 2·BLF_max.
    """

    def __init__(self, config: ReaderConfig, antennas: Sequence, *, rng: np.random.Generator,
                 link: LinkProfile | None = None, air_cache: AirCache | None = None):
        air_cache = AirCache() if air_cache is None else air_cache
        self.config = air_cache.derived(config, validate)  # a frozen config: validated once per run
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
        #: recently sent commands → their bits (read-only), preamble and T_cmd [s]
        #: (:class:`rfsim.devices.reader_tx._Command`); pure functions of
        #: the (frozen) command and the link, dropped when ``link`` is replaced
        self._cmd_cache: dict = {}
        self._cmd_cache_link = self.link
        #: the run's air-step strategy and caches (:class:`rfsim.air.cache.AirCache`): the
        #: exchanges this reader runs (:mod:`rfsim.protocols.engine`), its modulated segments
        self.air_cache = air_cache
        #: noise power and leakage gain, derived from the frozen config and fs (:class:`_Fixed`)
        self._derived = _Fixed(None, None, 0.0, 0j)
        #: with ``blf_search``: the BLF measured on the last accepted RN16 (the ACKed tag's),
        #: used for the EPC reply that follows; cleared by the next reply decoded
        self._rn16_blf_hz: float | None = None
        #: ``rx_model = "statistic"``: the receiver's own noise stream (rfsim.devices.reader_statistic)
        self._rx_rng = rng.spawn(1)[0] if self.config.rx_model == "statistic" else None

    # ------------------------------------------------------------------ plan, antennas

    def channel_index(self, t_s: float) -> int:
        """Return the 1-based channel index at a time (LLRP ChannelIndex).

        Without hopping the fixed channel; else the hop table's entry of dwell period
        ⌊t/dwell⌋.

        Parameters
        ----------
        t_s : float
            Time [s].

        Returns
        -------
        int
            Channel index, 1 … number of channels in the plan.
        """
        if not self.config.hopping:
            return int(self.config.fixed_channel)
        period = int(math.floor(float(t_s) / self.config.dwell_s))
        return int(self.hop_sequence[period % self.hop_sequence.size]) + 1

    def fc_hz(self, t_s: float) -> float:
        """Return the carrier frequency at a time.

        Parameters
        ----------
        t_s : float
            Time [s].

        Returns
        -------
        float
            Carrier [Hz] of :meth:`channel_index` at ``t_s``.
        """
        return float(self.plan_hz[self.channel_index(t_s) - 1])

    def channel_of(self, fc_hz: float) -> int:
        """Return the 1-based channel index of a carrier in the reader's plan.

        Parameters
        ----------
        fc_hz : float
            Carrier [Hz].

        Returns
        -------
        int
            Channel index, 1 … number of channels in the plan.

        Raises
        ------
        ConfigError
            ``reader.channels_hz`` when the plan has no such carrier.
        """
        return _channel_index(self.plan_hz, fc_hz, key="reader.channels_hz")

    def antenna_index(self, round_index: int) -> int:
        """Return the antenna used in an inventory round (round robin).

        Parameters
        ----------
        round_index : int
            Inventory round r.

        Returns
        -------
        int
            0-based index into ``antennas``: r mod (number of antennas).
        """
        return int(round_index) % len(self.antennas)

    @property
    def ptx_w(self) -> float:
        """Conducted CW power at the antenna port [W]."""
        return float(dbm_to_w(self.config.ptx_dbm))

    def _cw_amplitude(self) -> float:
        """CW amplitude A = √P_tx [√W] of the (frozen) config, recomputed when it is replaced."""
        hit = getattr(self, "_amp", None)
        if hit is None or hit.source is not self.config:
            hit = self._amp = _Kept(self.config, math.sqrt(self.ptx_w))
        return hit.value

    def _fixed(self) -> _Fixed:
        """The noise power and leakage gain (:class:`_Fixed`), recomputed only when the
        (frozen) config or the sample rate is replaced."""
        d = self._derived
        if d.config is not self.config or d.fs_hz != self.fs_hz:
            noise = float(thermal_noise_power_w(self.fs_hz, self.config.noise_figure_db))
            leak = complex(10.0 ** (-self.config.isolation_db / 20.0) * np.exp(1j * LEAKAGE_PHASE_RAD))
            d = self._derived = _Fixed(self.config, self.fs_hz, noise, leak)
        return d

    def noise_power_w(self) -> float:
        """Return the receiver noise power per complex sample: :math:`k T_0 f_s F`.

        kTB·NF over B = fs.

        Returns
        -------
        float
            Noise power [W]; 0 with ``rx_model = "statistic"`` (the air adds none: the
            receiver draws its own).
        """
        return 0.0 if self._rx_rng is not None else self._fixed().noise_w

    def leakage_gain(self) -> complex:
        """Return the TX→RX leakage as a complex amplitude gain.

        :math:`L = 10^{-I/20} e^{j \\phi_L}`, I = ``isolation_db``, φ_L = :data:`LEAKAGE_PHASE_RAD`.

        Returns
        -------
        complex
            L [1] (the engine adds L·x_tx at the RX port).
        """
        return self._fixed().leakage

    # ------------------------------------------------------------------ receiver

    def preamble_samples(self, blf_hz: float | None = None) -> int:
        """Count the samples fully inside the reply preamble (pilot included).

        As correlated by the detector: ⌊elements · fs / (2·BLF)⌋.

        Parameters
        ----------
        blf_hz : float or None, optional
            BLF [Hz]; default None, the profile's nominal BLF.

        Returns
        -------
        int
            Number of samples.
        """
        blf = self.link.blf_hz if blf_hz is None else float(blf_hz)
        return self._receive_memo().known.preamble_samples(blf)

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
        (:func:`rfsim.gen2.capture.preamble_threshold`.)

        Parameters
        ----------
        n_lags : int
            Number of lags searched.
        blf_hz : float or None, optional
            BLF [Hz] of the preamble length n; default None, the profile's nominal BLF.

        Returns
        -------
        float
            γ, a normalised correlation in (0, 1).
        """
        blf = self.link.blf_hz if blf_hz is None else float(blf_hz)
        return self._receive_memo().known.detection(int(n_lags), blf).threshold

    def listen_window_s(self, reply_bits: int) -> float:
        """Return how long the reader keeps its CW after a command to hear a reply.

        :func:`rfsim.gen2.link.reply_window_s` (T1max + reply + 3 Tpri at the nominal BLF);
        with ``blf_search`` the reply at the slowest BLF of the tolerance, BLF·(1 − FrT).

        Parameters
        ----------
        reply_bits : int
            Data bits of the expected reply.

        Returns
        -------
        float
            Listen window [s].
        """
        return self.air_cache.link_timing(_listen_window_s, self.link, int(reply_bits), self.config.blf_search != "off")

    def reply_search_window_s(self) -> tuple[float, float]:
        """Return the window of the reply start relative to the command end.

        Returns
        -------
        t1_min_s, t1_max_s : float
            T1min and T1max of the link [s] (:func:`rfsim.gen2.link.t1`); while a delayed
            reply is read (``receive(..., delayed=True)``) T1min and T5max
            (:func:`rfsim.gen2.link.t5`).
        """
        window = self.__dict__.get("_search_window")
        return self.air_cache.link_timing(_t1_window, self.link) if window is None else window

    def reply_start_lags(self, n_samples: int, n_reply: int, *, t0_s: float,
                         cmd_end_s: float | None) -> tuple[int, int]:
        """First and last sample index where a reply of ``n_reply`` samples may start.

        Parameters
        ----------
        n_samples : int
            Samples at the receiver input, the first at absolute time ``t0_s`` [s].
        n_reply : int
            Samples of the whole reply (preamble, bits, dummy 1).
        t0_s : float
            Absolute time of sample 0 [s].
        cmd_end_s : float or None
            End of the command the reply answers [s]; None searches every start.

        Returns
        -------
        lo, hi : int
            The window ``[cmd_end + T1min, cmd_end + T1max]`` (:meth:`reply_search_window_s`)
            in samples at the configured rate, one sample wider each side, clipped to
            ``[0, n_samples - n_reply]`` (``hi < lo``: no room for a reply).
        """
        lo, hi = self._start_lags((n_samples,), n_reply, (None if t0_s is None else float(t0_s),),
                                  (None if cmd_end_s is None else float(cmd_end_s),))
        return lo[0], hi[0]

    def _start_lags(self, n_samples, n_reply: int, t0_s, cmd_end_s) -> tuple[list, list]:
        """:meth:`reply_start_lags` of B windows at once (the rule; one window is a batch of one):
        ``n_samples``, ``t0_s`` and ``cmd_end_s`` sequences of B values (an end None or NaN: every
        start); returns the lists ``lo``, ``hi`` of B ints."""
        top = [int(n) - int(n_reply) for n in n_samples]
        fs = self.fs_hz
        t1min, t1max = self._receive_memo().window
        floor, ceil = math.floor, math.ceil
        lo = [0 if e is None or e != e else max(0, floor((e + t1min - t) * fs) - 1) for t, e in zip(t0_s, cmd_end_s)]
        hi = [k if e is None or e != e else min(k, ceil((e + t1max - t) * fs) + 1)
              for k, t, e in zip(top, t0_s, cmd_end_s)]
        return lo, hi

    def receive(self, rx, *, t0_s: float, n_bits: int, expect_crc: bool,
                cmd_end_s: float | None = None, blf_hz: float | None = None,
                carrier: complex | None = None, delayed: bool = False) -> ReadResult:
        """Detect, decode and measure one tag reply.

        Parameters
        ----------
        rx : ndarray of complex, shape (n,)
            Everything at the RX port [√W] (leakage, backscatter, noise).
        t0_s : float
            Keyword-only (like the others): absolute time of ``rx[0]`` [s].
        n_bits : int
            Data bits of the reply (16 for RN16, PC+EPC+CRC for an EPC reply).
        expect_crc : bool
            Check the last 16 bits as CRC-16 over the reply.
        cmd_end_s : float or None, optional
            End of the command [s]; the reply start is searched in
            [cmd_end + T1min, cmd_end + T1max] (±1 sample). Default None: anywhere in ``rx``.
        blf_hz : float or None, optional
            The tag's actual BLF [Hz]; default None, the profile's nominal BLF. With
            ``blf_search = "off"`` the receiver does not estimate the BLF: decoding needs the
            BLF to about 1/(4·elements of the reply) (≈ 0.02 % for a Miller-4 EPC reply), far
            finer than the tag tolerance FrT, so a tag with a BLF error must be read with its
            BLF given here. With ``blf_search = "preamble"`` and no ``blf_hz`` the receiver
            estimates it within the FrT of the link (``_receive_searched``,
            :func:`search_decode`), as a real reader must for tags with their own BLF.
        carrier : complex or None, optional
            The reader's own transmitted baseband during the reply window (the CW after the
            command, :attr:`TxSegment.samples` ``[-1]``); the phase is referred to it,
            phase = (−arg(h·|carrier|/carrier)) mod 2π. A PR-ASK command ends with either
            polarity (the parity of its PIE symbols), which would otherwise add π to the
            phase of some commands' replies. Default None: the unmodulated carrier (phase 0).
        delayed : bool, optional
            A delayed ("in-process") reply to Write, BlockWrite, BlockErase, Lock or Kill
            (EPC Gen2 v2 §6.3.2.12.3): sent with the extended preamble (as if TRext = 1) and
            searched in [cmd_end + T1min, cmd_end + T5max] (T5max = 20 ms,
            :func:`rfsim.gen2.link.t5`). Default False.

        Returns
        -------
        ReadResult
            Success, the decoded bits (kept on a CRC error), the failure reason (one of
            :data:`FAILURES`), the reply's start time [s], correlation and the measurements
            (RSSI [dBm], phase [rad],
            Doppler [Hz], SNR and Eb/N0 [dB]; with the BLF search also the BLF [Hz]).

        Raises
        ------
        ValueError
            When ``rx`` is not 1-D or ``blf_hz`` is not positive.

        Notes
        -----
        With ``rx_model = "statistic"`` ``rx`` is noise-free and
        :func:`rfsim.devices.reader_statistic.receive` does the work. Otherwise the processing
        is (anchors §4.8, §4.9; steps 1–5 are the steps of the one reply decoder,
        :func:`rfsim.gen2.reply_decoder.decode`; at the nominal or given BLF they run as one numba
        call, ``rfsim.gen2._receive_kernels.receive_kernel``, which calls the kernels of
        :func:`~rfsim.gen2.linecode.decode_reply`, :func:`~rfsim.gen2.capture.fit_gain_offset`,
        the known levels and the measurements; the reader builds the :class:`ReadResult`):

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
           :func:`~rfsim.gen2.crc.crc16_ok` → "crc error" (bits are still returned).
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

        With ``config.track_timing`` the reply found (its start, and BLF with the BLF search)
        is decoded again on the tag's clock by the decoder's "track" timing step, the one the
        capture decoder runs (:func:`rfsim.gen2.reply_decoding._decode_window`: fine BLF, blocks
        of ≈ 24 elements, a quadratic clock fitted over growing spans, resampling), then h and
        σ² are measured on the resampled reply (no Doppler: NaN). A tag whose BLF drifts within
        the Gen2 tolerance over a long reply (a fixed timing is off by drift/2 of its elements at
        the end) is then decoded; the cost is several times the fixed-timing receive.
        """
        if delayed:
            return self._receive_delayed(rx, t0_s=t0_s, n_bits=n_bits, expect_crc=expect_crc, cmd_end_s=cmd_end_s,
                                         blf_hz=blf_hz, carrier=carrier)
        if self._rx_rng is not None:  # rx is noise-free: rfsim.devices.reader_statistic
            return _statistic.receive(self, rx, t0_s=t0_s, n_bits=n_bits, expect_crc=expect_crc, cmd_end_s=cmd_end_s,
                                      blf_hz=blf_hz, carrier=carrier, rng=self._rx_rng)
        rx = np.ascontiguousarray(rx, dtype=np.complex128)
        if rx.ndim != 1:
            raise ValueError(f"rx must be 1-D, got shape {rx.shape}")
        n_bits = int(n_bits)
        lk, fs = self.link, self.fs_hz
        memo, blf, pre_n, n_reply, lo, hi = self._reply_lags(rx.size, n_bits, blf_hz, t0_s, cmd_end_s)
        if self.config.blf_search == "preamble" and blf_hz is None:
            n_slow = int(math.ceil(reply_duration_s(n_bits, m=lk.m, trext=lk.trext, blf_hz=lk.blf_range_hz[0]) * fs))
            hi = min(hi, rx.size - n_slow)
            if hi < lo or pre_n < 3:
                return ReadResult(False, None, "preamble not found")
            return self._receive_searched(rx, lo, hi, float(t0_s), n_bits, expect_crc, carrier)
        if hi < lo or pre_n < 3:
            return ReadResult(False, None, "preamble not found")
        out = _decode(rx, memo.known, lo=lo, hi=hi, n_bits=n_bits, n_reply=n_reply, blf_hz=blf, crc=expect_crc)
        return self._read_result(out, float(t0_s), blf, expect_crc, carrier)

    def receive_batch(self, rx, *, t0_s, n_bits: int, expect_crc: bool, cmd_end_s=None, carrier=None) -> list:
        """:meth:`receive` of B windows, in one call where it can.

        Parameters
        ----------
        rx : ndarray of complex, shape (B, n), sequence of B 1-D arrays, or rfsim.gen2.reply_decoder.Windows
            B windows at the RX port [√W], each as :meth:`receive` takes it (their lengths may
            differ); :class:`~rfsim.gen2.reply_decoder.Windows` are read where they lie (no copy).
        t0_s : float or sequence of float
            Absolute time of each window's first sample [s]: one value for all or window b's.
        n_bits, expect_crc
            As :meth:`receive`, the same for every window.
        cmd_end_s, carrier
            As :meth:`receive`: one value for all or window b's (its command's end [s], the
            reader's own baseband during its reply).

        Returns
        -------
        list of ReadResult
            Window b's :meth:`receive` with its own ``t0_s``, ``cmd_end_s`` and ``carrier`` (at
            the nominal BLF), record for record.

        Raises
        ------
        ValueError
            ``rx`` neither 2-D nor a sequence of 1-D windows; a per-window value of another
            length than ``rx``.

        Notes
        -----
        With ``rx_model = "sample"``, ``blf_search = "off"`` and no timing tracking the reads of
        the windows with room for a reply are one call of the decoder on the batch (its "known"
        plan: the receive kernel on each window with the reply's start searched over that
        window's own lags, ``receive_batch_kernel``), and the :class:`ReadResult` of the windows
        are built from the arrays of the results in one pass (:meth:`_read_results`, the rule of a
        single read too); with ``rx_model = "statistic"`` and windows on one
        time base (one ``t0_s`` and ``cmd_end_s``, equal lengths) they are one
        :func:`rfsim.devices.reader_statistic.receive_many` (the windows in order on the
        receiver's generator: the draws of :meth:`receive` window by window); otherwise
        :meth:`receive` runs window by window.
        """
        if isinstance(rx, np.ndarray) and rx.ndim != 2:
            raise ValueError(f"rx must be 2-D (B, n) or a sequence of 1-D windows, got shape {rx.shape}")
        laid = isinstance(rx, _Windows)
        if laid and (self._rx_rng is not None or self.config.blf_search == "preamble" or self.config.track_timing):
            rx, laid = list(rx), False  # read window by window (or drawn in order): the windows as views
        n_win = len(rx)
        t0s, ends, carriers = (_per_window(v, n_win, name) for v, name in ((t0_s, "t0_s"), (cmd_end_s, "cmd_end_s"),
                                                                           (carrier, "carrier")))
        cfg = self.config
        if (self._rx_rng is not None and n_win > 1 and len(set(t0s)) == 1 and len(set(ends)) == 1
                and len({len(row) for row in rx}) == 1):  # the statistic model's batch entry: the same draws in order
            return _statistic.receive_many(self, np.ascontiguousarray(rx, dtype=np.complex128), t0_s=t0s[0],
                                           n_bits=n_bits, expect_crc=expect_crc, cmd_end_s=ends[0],
                                           carriers=tuple(carriers), rng=self._rx_rng)
        if self._rx_rng is not None or cfg.blf_search == "preamble" or cfg.track_timing or n_win < 2:
            return [self.receive(row, t0_s=t, n_bits=n_bits, expect_crc=expect_crc, cmd_end_s=e, carrier=c)
                    for row, t, e, c in zip(rx, t0s, ends, carriers)]
        n_bits = int(n_bits)
        memo, blf, pre_n, n_reply = self._reply_size(n_bits, None)
        t0s, ends, carriers = (v.tolist() if isinstance(v, np.ndarray) else list(v) for v in (t0s, ends, carriers))
        lo, hi = self._start_lags(rx.lengths().tolist() if laid else list(map(len, rx)), n_reply, t0s, ends)
        # the windows with room for a reply (as receive: none when the preamble is under 3 samples)
        read = [b for b, (a, z) in enumerate(zip(lo, hi)) if z >= a] if pre_n >= 3 else []
        if len(read) == n_win:
            out = _decode(rx, memo.known, lo=np.array(lo), hi=np.array(hi), n_bits=n_bits, n_reply=n_reply, blf_hz=blf,
                          crc=expect_crc)
            return self._read_results(out, t0s, blf, expect_crc, carriers)
        reads = [ReadResult(False, None, FAILURES[1]) for _ in range(n_win)]  # no reply searched
        if read:
            windows = rx.subset(np.array(read)) if laid else [rx[b] for b in read]
            out = _decode(windows, memo.known, lo=np.array([lo[b] for b in read]), hi=np.array([hi[b] for b in read]),
                          n_bits=n_bits, n_reply=n_reply, blf_hz=blf, crc=expect_crc)
            for b, r in zip(read, self._read_results(out, [t0s[b] for b in read], blf, expect_crc,
                                                     [carriers[b] for b in read])):
                reads[b] = r
        return reads

    def _reply_size(self, n_bits: int, blf_hz):
        """The receive memo, the BLF decoded at and the preamble and reply lengths [samples] at it
        (:meth:`receive`)."""
        lk, fs = self.link, self.fs_hz
        memo = self._receive_memo()
        blf = memo.blf_hz if blf_hz is None else float(blf_hz)
        if not blf > 0:
            raise ValueError(f"blf_hz must be > 0, got {blf_hz}")
        hit = memo.sizes.get((n_bits, blf))
        if hit is None:
            if len(memo.sizes) >= TX_CACHE_SIZE:
                memo.sizes.clear()
            # reply length in samples (preamble + n_bits + dummy)
            hit = memo.sizes[(n_bits, blf)] = _ReplySize(self.preamble_samples(blf), int(math.ceil(
                reply_duration_s(n_bits, m=lk.m, trext=lk.trext, blf_hz=blf) * fs)))
        return (memo, blf, *hit)

    def _reply_lags(self, n: int, n_bits: int, blf_hz, t0_s: float, cmd_end_s):
        """:meth:`_reply_size` and the first and last reply start searched
        (:meth:`reply_start_lags`) of a window of ``n`` samples (:meth:`receive`)."""
        memo, blf, pre_n, n_reply = self._reply_size(n_bits, blf_hz)
        lo, hi = self.reply_start_lags(n, n_reply, t0_s=t0_s, cmd_end_s=cmd_end_s)
        return memo, blf, pre_n, n_reply, lo, hi

    def _receive_delayed(self, rx, **kwargs) -> ReadResult:
        """:meth:`receive` of a delayed reply: the same receiver on a view of this reader whose
        link has TRext = 1 and whose reply start is searched in [T1min, T5max]
        (:meth:`delayed_view`)."""
        return self.delayed_view().receive(rx, **kwargs)

    def delayed_view(self) -> "Reader":
        """This reader as it reads a delayed ("in-process") reply.

        A shallow copy (the same config, antennas and generators) whose link is this link with
        TRext = 1 and whose reply search window is [T1min, T5max] (EPC Gen2 v2 §6.3.2.12.3;
        :func:`rfsim.gen2.link.t5`). Kept with the link and config it was made from, made again
        when either is replaced.

        Returns
        -------
        Reader
            The view (its own receive memos).
        """
        kept = self.__dict__.get("_delayed")
        if kept is None or kept.source[0] is not self.link or kept.source[1] is not self.config:
            lk = self.link
            view = copy.copy(self)
            view.__dict__.pop("_delayed", None)
            view.link = dataclasses.replace(lk, trext=True)
            view._search_window = (t1(lk).min_s, t5(lk).max_s)
            kept = self._delayed = _Kept((lk, self.config), view)
        return kept.value

    def _receive_searched(self, rx: np.ndarray, lo: int, hi: int, t0_s: float, n_bits: int, expect_crc: bool,
                          carrier) -> ReadResult:
        """:meth:`receive` with ``blf_search = "preamble"``: BLF, start and bits from
        :func:`search_decode` (detection: its coarse correlation against
        :meth:`detection_threshold` over every BLF hypothesis and lag), then (h, c) from the
        known levels and the measurements as in steps 3 and 5 at the decoded BLF (the decoder's
        measurement step, the plan's ``refit``); an RN16 is
        accepted only when its decision-domain Eb/(N0 + I) reaches
        :func:`rn16_threshold_db` of ``rn16_false_accept`` (else "rn16 rejected", bits kept).
        The BLF of an accepted RN16 is remembered: the reply with a CRC that follows (the EPC
        of the ACKed tag) is searched at that BLF, within 1/(RN16 elements), over all its bits
        (the PC of an EPC reply is mostly 0s, a square wave at any BLF over its first bits)."""
        hint, self._rn16_blf_hz = self._rn16_blf_hz, None
        # with a hint: the reply of the tag whose RN16 was ACKed, its BLF is known
        out = _decode(rx, self._decode_plan("blf"), lo=lo, hi=hi, n_bits=n_bits,
                      blf_hint_hz=hint if expect_crc else None, crc=expect_crc, reference=self._reference)
        return self._read_result(out, t0_s, out.blf_hz, expect_crc, carrier, searched=True)

    def _read_result(self, out, t0_s: float, blf: float, expect_crc: bool, carrier, searched: bool = False
                     ) -> ReadResult:
        """The :class:`ReadResult` of the decoder's reply ``out`` of one window: :meth:`_read_results`
        of a batch of one."""
        truncated = out.extra is not None and out.extra.get("truncated", False)
        one = _DecodedReply([bool(out.found) and not truncated], [out.start], [out.corr], [out.bits], out.blf_hz,
                            [out.gain], [out.sigma2], [out.slope], [out.decision_ebn0_db], None, None, [out.crc_ok])
        return self._read_results(one, [t0_s], blf, expect_crc, [carrier], searched)[0]

    def _read_results(self, out, t0_s: list, blf: float, expect_crc: bool, carrier: list, searched: bool = False
                      ) -> list:
        """The :class:`ReadResult` of each of B windows the decoder read, built in one pass from
        its result ``out`` (``found``, ``start``, ``corr``, ``gain``, ``sigma2``, ``slope``,
        ``decision_ebn0_db``: B values each, arrays or lists; ``bits`` B rows; ``crc_ok`` B values)
        and each window's ``t0_s`` and ``carrier`` (lists): the failure reason, the measurements at
        ``blf`` (:func:`rfsim.devices.reader_measure.measurements`, phase referred to the window's
        carrier where it is given and non-zero); with the BLF search also the BLF, the
        decision-domain Eb/(N0 + I) and, for an RN16, its acceptance. With timing tracking
        (``config.track_timing``) a reply the window cuts (on the tag's clock, the decoder's
        ``truncated``) is not found (:meth:`_read_result`), and the Doppler is not measured (NaN)."""
        found = out.found.tolist() if isinstance(out.found, np.ndarray) else out.found
        start = out.start.tolist() if isinstance(out.start, np.ndarray) else out.start
        corr = out.corr.tolist() if isinstance(out.corr, np.ndarray) else out.corr
        fs = self.fs_hz
        start_s = list(map(operator.add, t0_s, map(operator.truediv, start, repeat(fs))))  # t0 + start/fs
        gain, slope, sigma2, bits, crc_ok = out.gain, out.slope, out.sigma2, out.bits, out.crc_ok
        crc_ok = [None] * len(found) if crc_ok is None else crc_ok
        if not all(found):  # the windows without a reply: no measurements
            reads = [None if f else ReadResult(False, None, FAILURES[1], start_s=t, corr=c)
                     for f, t, c in zip(found, start_s, corr)]
            hit = [b for b, f in enumerate(found) if f]
            if not hit:
                return reads
            gain, slope, sigma2, bits, crc_ok, carrier, start_s, corr = (
                [v[b] for b in hit] for v in (gain, slope, sigma2, bits, crc_ok, carrier, start_s, corr))
        meas = _measurements_of(gain, slope, sigma2, blf_hz=blf, fs_hz=fs, m=self.link.m)
        refer = [b for b, c in enumerate(carrier) if c is not None and complex(c) != 0]
        phase = meas["phase_rad"]
        if len(refer) == 1:  # the phase referred to the reader's carrier during the reply
            phase[refer[0]] = _refer_phase(phase[refer[0]], carrier[refer[0]])
        elif refer:
            referred = _refer_phase(np.array([phase[b] for b in refer]),
                                    np.array([carrier[b] for b in refer], dtype=np.complex128)).tolist()
            for b, v in zip(refer, referred):
                phase[b] = v
        n = len(start_s)
        nan = [math.nan] * n
        blfs = decision = nan
        if expect_crc:
            ok = list(map(bool, crc_ok))
            reason = list(map((FAILURES[2], FAILURES[0]).__getitem__, ok))
        elif searched:
            p = self.config.rn16_false_accept
            ok = [p == 0 or x >= rn16_threshold_db(p) for x in out.decision_ebn0_db]
            reason = [FAILURES[0] if c else FAILURES[3] for c in ok]
            if ok[-1]:  # an ACK follows: the reply it elicits comes from the tag measured here
                self._rn16_blf_hz = blf
        else:
            ok, reason = [True] * n, [FAILURES[0]] * n
        if searched:  # (one window: the search is not batched)
            blfs, decision = [blf] * n, list(out.decision_ebn0_db)
        made = map(ReadResult, ok, bits, reason, meas["rssi_dbm"], meas["phase_rad"], meas["doppler_hz"],
                   meas["snr_db"], meas["ebn0_db"], start_s, corr, blfs, decision)
        if len(found) == n:
            return list(made)
        for b, r in zip(hit, made):
            reads[b] = r
        return reads

    def _decode_plan(self, search: str) -> _DecodePlan:
        """The :class:`rfsim.gen2.reply_decoder.DecodePlan` of ``search`` ("known" or "blf") for
        this reader's link, sample rate, decisions and false-alarm probability, kept in the
        run's ``air_cache`` with the (frozen) link."""
        cfg = self.config
        return self.air_cache.derived(self.link, _LinkPlans).plan(search, self.fs_hz, cfg.decoder,
                                                                  cfg.false_alarm_probability,
                                                                  refit=search == "blf" and not cfg.track_timing,
                                                                  track_timing=cfg.track_timing)

    def _receive_memo(self) -> _ReceiveMemo:
        """The :class:`_ReceiveMemo` of :meth:`receive` and :meth:`detection_threshold`, kept
        while config, link, fs and the run cache are the same objects (pure functions of them)."""
        memo = self.__dict__.get("_rx_memo")
        if (memo is None or memo.config is not self.config or memo.link is not self.link or memo.fs_hz != self.fs_hz
                or memo.air_cache is not self.air_cache):
            memo = self._rx_memo = _ReceiveMemo(self.config, self.link, self.fs_hz, self.air_cache, self.link.blf_hz,
                                                {}, self.reply_search_window_s(), self._decode_plan("known"))
        return memo

    def _reference(self, bits: np.ndarray, start: float, n: int, blf_hz: float,
                   dummy: bool = True) -> np.ndarray:
        """The ±1 reply waveform of ``bits`` starting at sample ``start`` (0 elsewhere), (n,).

        With the run's strategy ``exchange="compiled"`` (:class:`rfsim.air.cache.Strategy`) it is
        kept by its content (bits, start, n, BLF, fs, dummy; made with this link) in the run's
        ``air_cache`` and returned read-only: the EPC reply of a static exchange repeats."""
        lk = self.link
        cache = self.air_cache
        if cache.strategy.exchange != "compiled":
            return reply_waveform(bits, m=lk.m, trext=lk.trext, blf_hz=blf_hz, fs_hz=self.fs_hz,
                                  t0_s=start / self.fs_hz, n_samples=n, dummy=dummy)
        key = ("reader reference", bits.dtype.str, bits.tobytes(), float(start), int(n), float(blf_hz), self.fs_hz,
               bool(dummy))
        hit = cache.waveform(key, (lk,))
        if hit is None:
            ref = reply_waveform(bits, m=lk.m, trext=lk.trext, blf_hz=blf_hz, fs_hz=self.fs_hz,
                                 t0_s=start / self.fs_hz, n_samples=n, dummy=dummy)
            ref.flags.writeable = False
            hit = Waveform(samples=ref, makers=(lk,))
            cache.remember(cache.waveforms, key, hit)
        return hit.samples

    def _measure(self, z: np.ndarray, s: np.ndarray, blf_hz: float) -> dict:
        """RSSI, phase, Doppler and SNR of ``z = h(t)·s(t) + noise`` (offset removed), see
        :meth:`receive` (numba kernel)."""
        return self._measurements(*_measure(z, s, self.fs_hz), blf_hz)

    def _measurements(self, h: complex, slope: float, sigma2: float, blf_hz: float) -> dict:
        """RSSI, phase, Doppler and SNR (the :class:`ReadResult` fields) from the measured gain
        h [√W], phase slope [rad/s] and residual power σ² [W] (:meth:`receive` step 5): the
        measurement rule :func:`rfsim.devices.reader_measure.measurements` on a batch of one."""
        meas = _measurements_of([complex(h)], [float(slope)], [float(sigma2)], blf_hz=blf_hz, fs_hz=self.fs_hz,
                                m=self.link.m)
        return {k: v[0] for k, v in meas.items()}


def _per_window(value, n: int, name: str):
    """``value`` for each of ``n`` windows (:meth:`Reader.receive_batch`): a scalar (or None) for
    every window, else a sequence of ``n`` values, window b's the b-th."""
    if np.ndim(value) == 0:
        return (value,) * n
    if len(value) != n:
        raise ValueError(f"{name}: {len(value)} values for {n} windows")
    return value


def _listen_window_s(link: LinkProfile, reply_bits: int, blf_search: bool) -> float:
    """:meth:`Reader.listen_window_s` of a (frozen) link profile: a pure function (kept per run in
    the reader's ``air_cache``, :meth:`rfsim.air.cache.AirCache.link_timing`)."""
    if not blf_search:
        return reply_window_s(link, reply_bits)
    return t1(link).max_s + link.reply_duration_s(reply_bits) / (1.0 - link.frt) + REPLY_WINDOW_TAIL_TPRI * link.tpri_s


def _t1_window(link: LinkProfile) -> tuple[float, float]:
    """(T1min, T1max) of a (frozen, hashable) link profile [s]; a pure function (kept per run in the
    reader's ``air_cache``)."""
    r = t1(link)
    return r.min_s, r.max_s




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

"""Sense-a-tag (ST): a semi-passive listener with one or two antennas, its own Gen2 identity
and the locator protocol (auris-sense-a-tag.md §1.1 "ST locator protocol", §1.5, §1.6, §5,
§6 "ST model"; seed L1228-1267, L3131-3196, L5874-6023).

Antennas. SA2 carries the full ST path P2 (backscatter modulator, envelope detector,
band-pass, comparator, decoder); a dual-antenna ST adds SA1, the receive-only path P1
(source convention, :mod:`rfsim.devices.st_analytic`). The ST is handed its antennas (SA1, SA2) or
(SA2,): the source models vertical half-wave dipoles (omnidirectional in azimuth, L2878-2880,
:func:`rfsim.channels.antennas.vertical_dipole`) at the positions of :func:`st_antenna_positions`,
``center ± s/2·û`` with ``û = (cos φ, sin φ, 0)``, ``s = spacing_m`` (default λ/4 = 0.082 m at
915 MHz, L3420-3422) and ``φ = orientation_deg``; a single-antenna ST is SA2 alone at the
centre.

Own schedule. Besides answering a reader, an ST can backscatter a frame on its own schedule
(:meth:`SenseATag.send_frame`: FM0/Miller bits from a start time, on whatever carrier is
incident — an exciter's CW for ST-to-ST links, auris-sense-a-tag.md ch. 5): during the frame
it re-radiates A_s − Γ(t) with Γ(t) its modulator's two states.

Receive chain: :class:`rfsim.devices.st_receiver.STReceiver` (linear diode detector at
:data:`rfsim.devices.st_receiver.REFERENCE_IMPEDANCE_OHM` = 50 Ω, output ``gain·sqrt(2R)·|x|``
[V], RC, Butterworth band-pass, hysteresis comparator at ``threshold_v`` = 5 mV). The
source's detector output is ≈ 6× the antenna-level difference in its own voltage unit
(R3-1/R3-4; peak sqrt(2P) across 1 Ω, i.e. ≈ 0.85× the 50 Ω difference,
:func:`rfsim.devices.st_receiver.to_source_volts`); ``detector_gain`` sets the factor per 50 Ω
volt (default 1: the output equals the closed forms).

Own identity. The ST answers the reader like a tag through a :class:`rfsim.devices.tag.PassiveTag`
on SA2 (PIE decoding with its clock, Gen2 state machine, Γ(t) of its modulator). It is
semi-passive (battery): ``sensitivity_dbm`` is the command-detection floor of its PIE path,
not a harvesting threshold.

Locator protocol (format chosen here; the source only says "QT/QS by manipulating Select"
and "conveys the stored IDs inside its EPC payload"):

* **QS** (enter the responding round) = a Select on the EPC bank (membank 1) at pointer
  32 (first EPC word) whose 16-bit mask equals the ST's ``st_id``. The ST rebuilds its EPC
  as the report (below) and passes the Select to its tag state, so a following
  ``Query(sel="SL")`` inventories the ST like any tag.
* **QT** (listening round) = any other Select, or a Query while not responding. While
  listening the ST never replies; after each reader command it decodes the backscatter
  of other tags (RN16 after Query/QueryRep/QueryAdjust, PC+EPC+CRC-16 after ACK, with the
  link parameters M, TRext and BLF = DR/TRcal measured from the last Query) with its
  technique, and records every CRC-valid EPC with the query rounds in which it was heard.
* **Report** = the ST's EPC in the responding round: word 0 ``st_id``, word 1 the number of
  tags heard, then one word per tag (at most 29): the tag's CRC-16 over PC+EPC (its
  StoredCRC, the "hash" of its ID), in order of first detection.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.memo import PureCache
from rfsim.devices import st_receiver as sr
from rfsim.devices.st_bandpass import sos_steady_state
from rfsim.devices.sense_a_tag_config import DEFAULT_SPACING_M, SenseATagConfig
from rfsim.devices.gen2_tag_state import Reply
from rfsim.devices.tag import PassiveTag, TagConfig, TagResponse, envelope, incident_power_w
from rfsim.core.errors import ConfigError
from rfsim.gen2.bits import bits_to_int, int_to_bits
from rfsim.gen2.commands import ACK, CommandParseError, Query, QueryAdjust, QueryRep, Select, parse
from rfsim.gen2.linecode import decode_reply_rows, reply_duration_s, reply_waveform
from rfsim.gen2.pie import pie_decode
from rfsim.core.units import dbm_to_w, w_to_dbm
from rfsim.core.lazy import lazy_import

_kernels = lazy_import("rfsim.devices._sense_a_tag_kernels")
_k = lazy_import("rfsim.devices._st_receiver_kernels")

TECHNIQUES = ("single", "combination", "selection", "stamp")
#: Maximum number of hashes in the report (EPC ≤ 496 bits = 31 words, 2 header words).
MAX_REPORTED = 29


def st_antenna_positions(center_m, *, n_antennas: int = 2, spacing_m: float = DEFAULT_SPACING_M,
                         orientation_rad=0.0) -> np.ndarray:
    """Return the positions of SA1 and SA2 (or SA2 alone).

    :math:`c \\mp \\frac{s}{2} \\hat u`, :math:`\\hat u = (\\cos\\varphi, \\sin\\varphi, 0)`
    (module docstring; auris-sense-a-tag.md, L3420-3422).

    Parameters
    ----------
    center_m : array_like of float, shape (..., 3)
        ST centre(s) [m].
    n_antennas : {1, 2}, optional
        Keyword-only: 2 (default) for SA1 and SA2, 1 for SA2 alone at the centre.
    spacing_m : float, optional
        Keyword-only: antenna spacing s [m], default ``DEFAULT_SPACING_M`` (λ/4 at 915 MHz).
    orientation_rad : float or array_like of float, shape (...), optional
        Keyword-only: azimuth φ of the SA1→SA2 axis [rad], default 0.0.

    Returns
    -------
    ndarray of float64, shape (..., n_antennas, 3)
        ``center − s/2·û`` (SA1), ``center + s/2·û`` (SA2) [m].
    """
    c = np.asarray(center_m, dtype=float)
    if n_antennas == 1:
        return c[..., None, :].copy()
    phi = np.asarray(orientation_rad, dtype=float)
    u = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=-1) * (0.5 * spacing_m)
    return np.stack([c - u, c + u], axis=-2)


# ----------------------------------------------------------------------------- device


@dataclass(frozen=True)
class Observation:
    """What the ST made of other tags' backscatter in one reader segment.

    Attributes
    ----------
    command : object or None
        The decoded reader command (or None).
    kind : {"RN16", "EPC", ""}
        What was expected ("" nothing).
    detected : bool
        A reply was decoded (EPC: CRC valid).
    bits : ndarray of uint8 or None
        Decoded bits.
    path : int or None
        1 or 2 for selection and stamp (which path decoded), else None.
    reception : object or None
        The underlying :mod:`rfsim.devices.st_receiver` result.
    """

    command: object | None
    kind: str
    detected: bool
    bits: np.ndarray | None
    path: int | None
    reception: object | None


class SenseATag:
    """A sense-a-tag device (module docstring).

    Parameters
    ----------
    config : SenseATagConfig
        The ST's settings (identity, technique, detector, threshold, antennas).
    antennas : sequence of rfsim.channels.Antenna
        (SA1, SA2) or (SA2,), ``config.n_antennas`` of them.
    rng : numpy.random.Generator
        Keyword-only: the ST's own stream (its RN16s and slot counter).
    fs_hz : float
        Keyword-only: sample rate of the segments it will hear [Hz].

    Attributes
    ----------
    mode : {"listening", "responding"}
        The locator protocol's round.
    heard : dict of int to list of int
        CRC-16 hash of each EPC heard → the query rounds in which it was heard.
    query_round : int
        Index of the last Query heard (−1 before the first).
    tag : rfsim.devices.tag.PassiveTag
        The ST's own Gen2 identity on SA2.

    Raises
    ------
    TypeError
        When ``config`` is not a SenseATagConfig.
    ConfigError
        ``st.antennas`` when the number of antennas differs from ``config.n_antennas``.
    """

    def __init__(self, config: SenseATagConfig, antennas, *, rng: np.random.Generator, fs_hz: float):
        if not isinstance(config, SenseATagConfig):
            raise TypeError(f"config must be a SenseATagConfig, got {type(config).__name__}")
        self.config = config
        self.rng = rng
        self.fs_hz = float(fs_hz)
        self.antennas = tuple(antennas)
        if len(self.antennas) != config.n_antennas:
            raise ConfigError("st.antennas", len(self.antennas), f"{config.n_antennas} antenna(s) (st.n_antennas)")
        self._frames: list[tuple] = []  # scheduled own frames (bits, start_s, blf_hz, m, trext)
        self.mode = "listening"
        self.heard: dict[int, list[int]] = {}  # CRC-16 hash -> query rounds in which it was heard
        self.query_round = -1
        self._query: Query | None = None
        self._blf_hz: float | None = None
        self._expect: str = ""
        self.tag = self._make_tag(config.identity_epc_hex)

    @property
    def antenna(self):
        """SA2, the antenna of the full ST path and of the modulator (reflector protocol)."""
        return self.antennas[-1]

    def _make_tag(self, epc_hex: str) -> PassiveTag:
        tc = TagConfig(epc_hex=epc_hex, sensitivity_dbm=self.config.sensitivity_dbm,
                       modulation=self.config.modulation)
        return PassiveTag(tc, self.antenna, rng=self.rng)

    # -------------------------------------------------------------- protocol

    def report_epc_hex(self) -> str:
        """Return the responding-round EPC: st_id, count, CRC-16 hashes (module docstring).

        Returns
        -------
        str
            The EPC in hex: word 0 ``st_id``, word 1 the number of tags heard, then their
            hashes in order of first detection (at most :data:`MAX_REPORTED`).
        """
        hashes = list(self.heard)[:MAX_REPORTED]
        return "".join(f"{w:04X}" for w in [self.config.st_id, len(hashes), *hashes])

    @staticmethod
    def parse_report(epc_bits) -> tuple[int, list[int]]:
        """Parse a report EPC, the inverse of :meth:`report_epc_hex`.

        Parameters
        ----------
        epc_bits : array_like of {0, 1}, shape (n_bits,)
            The report's EPC bits.

        Returns
        -------
        st_id : int
            Word 0.
        hashes : list of int
            The CRC-16 hashes of the tags heard.
        """
        b = np.asarray(epc_bits, dtype=np.uint8)
        words = [bits_to_int(b[i:i + 16]) for i in range(0, b.size - 15, 16)]
        n = words[1]
        return words[0], words[2:2 + n]

    def _is_qs(self, cmd) -> bool:
        want = "".join(str(v) for v in int_to_bits(self.config.st_id, 16))
        return isinstance(cmd, Select) and cmd.membank == 1 and cmd.pointer == 32 and cmd.mask == want

    def decode_command(self, x, *, fs_hz: float):
        """PIE-decode the reader command in ``x`` with the tag's PIE path.

        Envelope detection (:func:`rfsim.devices.tag.envelope`), :func:`rfsim.gen2.pie.pie_decode`
        and :func:`rfsim.gen2.commands.parse` of the first frame.

        Parameters
        ----------
        x : array_like of complex, shape (n,)
            SA2 input [√W].
        fs_hz : float
            Keyword-only: sample rate [Hz].

        Returns
        -------
        cmd : rfsim.gen2.commands command or None
            The command; None below ``sensitivity_dbm``, without a frame or on garbage.
        frame : object or None
            The PIE frame it was decoded from (its ``bits``, ``trcal``), or None.
        """
        x = np.asarray(x)
        if incident_power_w(x) < dbm_to_w(self.config.sensitivity_dbm):
            return None, None
        frames = pie_decode(envelope(x, fs_hz=fs_hz, rc_s=self.tag.config.envelope_rc_s))
        if not frames:
            return None, None
        try:
            return parse(frames[0].bits), frames[0]
        except CommandParseError:
            return None, None

    def send_frame(self, bits, *, start_s: float, blf_hz: float, m: int = 1, trext: bool = False) -> float:
        """Schedule a frame of its own, backscattered by :meth:`reflect`.

        Parameters
        ----------
        bits : array_like of {0, 1}, shape (n_bits,)
            The frame's bits.
        start_s : float
            Keyword-only: start time [s].
        blf_hz : float
            Keyword-only: link frequency [Hz].
        m : {1, 2, 4, 8}, optional
            Keyword-only: line code, 1 = FM0 (default), else Miller-M.
        trext : bool, optional
            Keyword-only: pilot tone before the preamble, default False.

        Returns
        -------
        float
            The frame's end [s].

        Raises
        ------
        ConfigError
            ``st.frame.m`` or ``st.frame.blf_hz`` for an invalid line code or BLF.
        """
        b = np.asarray(bits, dtype=np.uint8)
        if m not in (1, 2, 4, 8):
            raise ConfigError("st.frame.m", m, "1 (FM0), 2, 4 or 8")
        if not blf_hz > 0:
            raise ConfigError("st.frame.blf_hz", blf_hz, "a link frequency > 0 Hz")
        self._frames.append((b, float(start_s), float(blf_hz), int(m), bool(trext)))
        return float(start_s) + reply_duration_s(b.size, m=m, trext=trext, blf_hz=blf_hz)

    def reflect(self, incident) -> TagResponse:
        """Respond to an incident segment (reflector protocol of :mod:`rfsim.air.step`).

        A scheduled frame overlapping the segment is backscattered (Γ(t) of the ST's
        modulator: Γ_B on +1 levels, Γ_A on −1 and at rest); otherwise :meth:`listen`.

        Parameters
        ----------
        incident : rfsim.air.segment.Segment
            The incident field at SA2 (``samples`` [√W], ``t0_s``, ``fs_hz``,
            ``n_samples``).

        Returns
        -------
        rfsim.devices.tag_response.TagResponse
            The response (powered: the ST is semi-passive).
        """
        t0, fs, n = incident.t0_s, incident.fs_hz, incident.n_samples
        t_end = t0 + n / fs
        for bits, start, blf, m, trext in self._frames:
            end = start + reply_duration_s(bits.size, m=m, trext=trext, blf_hz=blf)
            if start < t_end and end > t0:
                states = self.tag.reflection_states
                lev = reply_waveform(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=start - t0, n_samples=n)
                gamma = np.where(lev > 0, states.gamma_b, states.gamma_a).astype(np.complex128)
                p_w = incident_power_w(np.asarray(incident.samples))
                return TagResponse(powered=True, command=None, reply=Reply("RN16" if bits.size == 16 else "EPC", bits),
                                   gamma=gamma, reply_start_s=start, blf_hz=blf, reason="",
                                   incident_power_dbm=float(w_to_dbm(p_w)) if p_w > 0 else -math.inf,
                                   reply_end_s=end, m=m, trext=trext, gamma_rest=states.gamma_a,
                                   structural_mode=complex(self.tag.config.structural_mode))
        return self.listen(incident.samples, t0_s=t0, fs_hz=fs)

    def listen(self, incident, *, t0_s: float, fs_hz: float) -> TagResponse:
        """Reflector protocol of the engine: the ST's reaction to a reader segment at SA2.

        Listening: decodes the command (link parameters, what reply to expect from other
        tags) and does not reply (Γ_A throughout: it re-radiates A_s − Γ_A). Responding: acts
        as its tag. A QS Select switches to responding (with the report as EPC), any other
        Select to listening.

        Parameters
        ----------
        incident : array_like of complex, shape (n,)
            The segment at SA2 [√W].
        t0_s : float
            Keyword-only: time of the first sample [s].
        fs_hz : float
            Keyword-only: sample rate [Hz].

        Returns
        -------
        rfsim.devices.tag_response.TagResponse
            The response: no reply while listening, its tag's response while responding.
        """
        cmd, frame = self.decode_command(incident, fs_hz=fs_hz)
        if isinstance(cmd, Select):
            if self._is_qs(cmd) and self.mode != "responding":
                self.mode = "responding"
                self.tag = self._make_tag(self.report_epc_hex())
            elif not self._is_qs(cmd):
                self.mode = "listening"
        self._expect = ""
        if isinstance(cmd, Query):
            self._query = cmd
            self.query_round += 1
            self._blf_hz = _dr(cmd.dr) * fs_hz / frame.trcal  # BLF = DR/TRcal, TRcal measured
        if cmd is not None and self._query is not None:
            if isinstance(cmd, (Query, QueryRep, QueryAdjust)):
                self._expect = "RN16"
            elif isinstance(cmd, ACK):
                self._expect = "EPC"
        if self.mode == "responding":
            return self.tag.listen(incident, t0_s=t0_s, fs_hz=fs_hz)
        p_w = incident_power_w(np.asarray(incident))
        p_dbm = float(w_to_dbm(p_w)) if p_w > 0 else -math.inf
        return TagResponse(powered=True, command=cmd, reply=None, gamma=None, reply_start_s=None, blf_hz=None,
                           reason="no reply", incident_power_dbm=p_dbm,
                           gamma_rest=self.tag.reflection_states.gamma_a,
                           structural_mode=complex(self.tag.config.structural_mode))

    def receiver(self) -> sr.STReceiver:
        """Build the receive chain for the link parameters of the last Query (:func:`make_receiver`).

        Returns
        -------
        rfsim.devices.st_receiver.STReceiver
            The chain at the measured BLF = DR/TRcal and the Query's M and TRext.

        Raises
        ------
        ValueError
            When no Query has been heard yet.
        """
        q = self._query
        if q is None or self._blf_hz is None:
            raise ValueError("no Query heard yet: link parameters unknown")
        return make_receiver(self.config, fs_hz=self.fs_hz, blf_hz=self._blf_hz, m=q.m, trext=q.trext)

    def observe(self, inputs, *, start_sample: int = 0, stamp: sr.StampFrame | None = None) -> Observation:
        """Decode other tags' backscatter in one segment with the configured technique.

        Records the CRC-16 hash of every EPC detected while listening in :attr:`heard`.

        Parameters
        ----------
        inputs : ndarray of complex128, shape (n_antennas, n)
            Input at SA1 (, SA2) [√W] (e.g.
            :attr:`rfsim.protocols.bistatic.BistaticExchange.inputs`); call :meth:`listen` on
            the SA2 input of the same segment first (it sets what to expect).
        start_sample : int, optional
            Keyword-only: decode from this sample on (after the reader's command), default 0.
        stamp : rfsim.devices.st_receiver.StampFrame or None, optional
            Keyword-only: the stamped frame (technique "stamp": the transmitter's ASK-PSK
            stamp); default None.

        Returns
        -------
        Observation
            What was expected and decoded (nothing when responding or nothing expected).

        Raises
        ------
        ValueError
            When ``inputs`` has not one row per antenna, no Query was heard, or technique
            "stamp" is used without ``stamp``.
        """
        x = np.asarray(inputs)
        if x.shape[0] != len(self.antennas):
            raise ValueError(f"inputs must have {len(self.antennas)} rows, got {x.shape}")
        kind = self._expect if self.mode == "listening" else ""
        if not kind:
            return Observation(None, "", False, None, None, None)
        rx = self.receiver()
        n_bits, crc = (16, False) if kind == "RN16" else (128, True)
        kw = dict(n_bits=n_bits, crc=crc, start_sample=start_sample)
        path = None
        tech = self.config.technique
        if tech == "single":
            rec = rx.receive(x[-1], **kw)
        elif tech == "combination":
            rec = sr.receive_combined(rx, x[0], x[1], **kw)
        elif tech == "selection":
            sel = sr.receive_selection(rx, x[0], x[1], **kw)
            rec, path = sel.selected, sel.path
        else:
            if stamp is None:
                raise ValueError("technique 'stamp' needs the stamped frame")
            kw.pop("start_sample")
            st = sr.receive_stamp(rx, x[0], x[1], stamp, **kw)
            rec, path = st.selected, (1 if st.use_p1 else 2)
        if rec.detected and kind == "EPC":
            h = bits_to_int(rec.bits[-16:])
            rounds = self.heard.setdefault(h, [])
            if self.query_round not in rounds:
                rounds.append(self.query_round)
        return Observation(None, kind, bool(rec.detected), rec.bits, path, rec)


def listen_start_sample(cmd_end_s: float, t0_s: float, fs_hz: float) -> int:
    """Return the first sample the ST's chains decode from.

    The sample after the reader command's last rising edge: ⌈(cmd_end − t0)·fs⌉ + 1.

    Parameters
    ----------
    cmd_end_s : float
        The command's last rising edge [s].
    t0_s : float
        Start of the segment [s].
    fs_hz : float
        Sample rate [Hz].

    Returns
    -------
    int
        Sample index.
    """
    return int(math.ceil((cmd_end_s - t0_s) * fs_hz)) + 1


def _dr(dr: str) -> float:
    return 64.0 / 3.0 if dr == "64/3" else 8.0


def make_receiver(config: SenseATagConfig, *, fs_hz: float, blf_hz: float, m: int, trext: bool) -> sr.STReceiver:
    """Build the ST receive chain (linear detector with ``config.detector_gain`` at 50 Ω).

    The detector's RC time constant is :math:`\\tau = 1/(2\\pi \\cdot 4\\,\\mathrm{BLF})`.

    Parameters
    ----------
    config : SenseATagConfig
        Detector gain and comparator threshold.
    fs_hz : float
        Keyword-only (like the others): sample rate [Hz].
    blf_hz : float
        Link frequency [Hz].
    m : int
        Line code (1 = FM0, else Miller-M).
    trext : bool
        Pilot tone before the preamble.

    Returns
    -------
    rfsim.devices.st_receiver.STReceiver
        The chain.
    """
    det = sr.EnvelopeDetector(tau_s=1.0 / (2.0 * math.pi * 4.0 * blf_hz), gain=config.detector_gain)
    return sr.STReceiver(fs_hz=fs_hz, blf_hz=blf_hz, m=m, trext=trext, threshold_v=config.threshold_v,
                         detector=det)


# ----------------------------------------------------------------------------- many positions at once


def chain_rows(rx: sr.STReceiver, x) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`STReceiver.chain` for many inputs at once (rows), in one numba pass per row.

    Parameters
    ----------
    rx : rfsim.devices.st_receiver.STReceiver
        The receive chain.
    x : array_like of complex, shape (r, n) or (n,)
        Baseband inputs [√W], one row per input.

    Returns
    -------
    envelope_v, bandpassed_v : ndarray of float64, shape (r, n)
        Detector output after the RC and band-passed [V].
    comparator : ndarray of float64, shape (r, n)
        Comparator output (±1).
    toggles : ndarray of int64, shape (r,)
        Comparator toggles per row.

    Raises
    ------
    ValueError
        When the rows hold no sample.

    Notes
    -----
    ``rx.chain(x[i])`` row by row (same RC start state, band-pass started in the steady state
    of the first sample, comparator from −1; equal to rounding: the RC here is SciPy's
    ``lfilter`` order ``y = (1 − a)·y + a·u``, the single chain's ``y += a·(u − y)``). With the
    diode law the detector, RC, band-pass and comparator run in one numba kernel per row
    (:func:`rfsim.devices._sense_a_tag_kernels.diode_chain_rows_kernel`: the operations of
    SciPy's ``lfilter``, ``sosfilt`` and the comparator in the same order); the other laws compute
    the detector in NumPy and the rest in :func:`rfsim.devices._st_receiver_kernels.chain_rows_kernel`.
    """
    x = np.atleast_2d(np.asarray(x))
    det = rx.envelope_detector
    if x.shape[1] < 1:
        raise ValueError(f"x must hold at least one sample per row, got shape {x.shape}")
    if det.law != "diode":
        return _chain_rows_of_law(rx, x)
    x_abs = np.abs(x)  # the RF peak sqrt(2R)·|x| of EnvelopeDetector.rf_peak_v is taken in the kernel
    r, n = x_abs.shape
    env, bp, cmp = np.empty((r, n)), np.empty((r, n)), np.empty((r, n))
    tog = np.empty(r, dtype=np.int64)
    sos, zi = BAND_PASS_CACHE(rx.bpf_order, rx.bpf_low_factor, rx.bpf_high_factor, rx.blf_hz, rx.fs_hz)
    _kernels.diode_chain_rows_kernel(x_abs, det.volts_per_sqrt_w, det.matching_gain, det.thermal_voltage_v,
                                     -math.expm1(-1.0 / (rx.fs_hz * det.tau_s)), sos, zi, 0.5 * rx.threshold_v,
                                     -0.5 * rx.threshold_v, env, bp, cmp, tog)
    return env, bp, cmp, tog


def _band_pass(order: int, low_factor: float, high_factor: float, blf_hz: float,
               fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """:attr:`STReceiver.sos` of a receiver with these band-pass settings and its
    ``sosfilt_zi`` (kept in :data:`BAND_PASS_CACHE`: a receiver's chains all use the same filter;
    the kernel only reads them, and they stay writeable so that it is compiled for one array type)."""
    rx = sr.STReceiver(fs_hz=fs_hz, blf_hz=blf_hz, bpf_order=order, bpf_low_factor=low_factor,
                       bpf_high_factor=high_factor)
    sos = np.ascontiguousarray(rx.sos, dtype=np.float64)
    return sos, np.ascontiguousarray(sos_steady_state(sos))


#: :func:`_band_pass` by the receiver's band-pass settings: a pure function of config values,
#: not run state (:class:`rfsim.core.memo.PureCache`).
BAND_PASS_CACHE = PureCache(_band_pass, 16)


def _chain_rows_of_law(rx: sr.STReceiver, x) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`chain_rows` of the laws other than the diode's: the detector law in NumPy, then the
    RC, band-pass and comparator in one numba pass per row
    (:func:`rfsim.devices._st_receiver_kernels.chain_rows_kernel`)."""
    u, a, sos, sos_zi = _chain_inputs(rx, x)
    env, bp, cmp = np.empty_like(u), np.empty_like(u), np.empty_like(u)
    tog = np.empty(u.shape[0], dtype=np.int64)
    _k.chain_rows_kernel(u, a, -(1.0 - a), np.ascontiguousarray(sos), np.ascontiguousarray(sos_zi),
                         0.5 * rx.threshold_v, -0.5 * rx.threshold_v, env, bp, cmp, tog)
    return env, bp, cmp, tog


def _chain_inputs(rx: sr.STReceiver, x) -> tuple:
    """``(detector output before the RC (r, n) [V], RC coefficient a, band-pass sections,
    their steady state per unit input)`` of the rows ``x``."""
    x = np.atleast_2d(np.asarray(x))
    det = rx.envelope_detector
    u = np.ascontiguousarray(det.instantaneous_v(x), dtype=np.float64)
    a = -math.expm1(-1.0 / (rx.fs_hz * det.tau_s))
    sos = rx.sos
    return u, a, sos, sos_steady_state(sos)


def level_differences(envelope_v, levels, rx: sr.STReceiver) -> np.ndarray:
    """Return the signed envelope difference A(+1) − A(−1) of every row.

    :func:`rfsim.devices.st_receiver.state_envelope_difference` vectorised: the mean envelope
    over the settled samples of each level.

    Parameters
    ----------
    envelope_v : ndarray of float, shape (r, n)
        Detector envelopes [V].
    levels : ndarray of int, shape (n,)
        The true line-code levels (±1, 0 outside the reply), common to all rows.
    rx : rfsim.devices.st_receiver.STReceiver
        The chain (its settle and guard samples).

    Returns
    -------
    ndarray of float, shape (r,)
        A(+1) − A(−1) [V].
    """
    ok = sr.settled_mask(levels, rx.settle_samples, rx.guard_samples)
    hi, lo = ok & (levels == 1), ok & (levels == -1)
    return envelope_v[:, hi].mean(axis=1) - envelope_v[:, lo].mean(axis=1)


def decode_rows(rx: sr.STReceiver, env, bp, cmp, tog, *, rows, expected_bits, start_sample: int,
                search_samples: int | None, memo: dict | None = None) -> np.ndarray:
    """Decode the reply in the chosen rows and compare it with the expected bits.

    The outcome of :meth:`STReceiver.decode_chain` without a CRC: a preamble correlation of
    at least ``rx.min_corr`` and the expected bits. Rows whose comparator does not toggle
    ``rx.min_toggles`` times after ``start_sample`` are not decoded (False); the toggles of
    all rows are counted at once, and only the comparator is decoded (the envelope
    measurements of ``decode_chain`` are not needed for the outcome).

    The decoder is a deterministic function of its input row and settings, so rows with the
    same comparator output (from ``start_sample`` on) are decoded once: the rows are keyed by
    their ±1 samples packed to bits (with the settings), and ``memo`` keeps the decodings
    across calls (phase-cancellation full run: about half of a position batch's rows repeat
    one already decoded in its five chains).

    Parameters
    ----------
    rx : rfsim.devices.st_receiver.STReceiver
        The chain (line code, BLF, decoder, thresholds).
    env : ndarray of float, shape (r, n)
        Envelopes (:func:`chain_rows`); only their row count is read.
    bp : ndarray of float, shape (r, n)
        Band-passed outputs (not read).
    cmp : ndarray of float, shape (r, n)
        Comparator outputs (±1), the input of the decoder.
    tog : ndarray of int, shape (r,)
        Toggles of the whole rows, from the comparator's start at −1 (read when
        ``start_sample`` is 0; else the toggles after ``start_sample`` are counted).
    rows : array_like of bool, shape (r,)
        Keyword-only (like the others): the rows to decode.
    expected_bits : array_like of {0, 1}, shape (n_bits,)
        The bits sent.
    start_sample : int
        Decode from this sample on.
    search_samples : int or None
        The reply start is searched among lags 0…search_samples (None: every lag that fits).
    memo : dict or None
        Decodings by row content and settings, read and extended here (share one between
        calls on the same rows' chains); None: a fresh one.

    Returns
    -------
    ndarray of bool, shape (r,)
        True where the decoded bits equal ``expected_bits``.
    """

    out = np.zeros(env.shape[0], dtype=bool)
    exp = np.asarray(expected_bits, dtype=np.uint8)
    part = cmp[:, start_sample:]
    if start_sample == 0:  # the toggles between samples: all but a first one from −1 to +1
        toggles = np.asarray(tog) - (cmp[:, 0] > 0)
    else:
        toggles = np.count_nonzero(part[:, 1:] != part[:, :-1], axis=1)
    idx = np.flatnonzero(np.asarray(rows, bool) & (toggles >= rx.min_toggles))
    memo = {} if memo is None else memo
    keys = _row_keys(part[idx], (exp.size, rx.m, rx.trext, rx.blf_hz, rx.fs_hz, rx.method, search_samples))
    todo = {}  # each key not decoded yet → its first row
    for i, key in zip(idx.tolist(), keys):
        if key not in memo:
            todo.setdefault(key, i)
    # rx.decode_comparator row by row, its setup done once (rfsim.gen2.linecode.decode_reply_rows)
    dets = decode_reply_rows(part, np.fromiter(todo.values(), np.int64, len(todo)), n_bits=exp.size, m=rx.m,
                             trext=rx.trext, blf_hz=rx.blf_hz, fs_hz=rx.fs_hz, method=rx.method,
                             search_samples=search_samples)
    memo.update(zip(todo, dets))
    want = exp.tobytes()  # the decoded bits are uint8 of the same length: equal bytes = equal bits
    for i, key in zip(idx.tolist(), keys):
        det = memo[key]
        out[i] = det is not None and det.corr >= rx.min_corr and det.bits.tobytes() == want
    return out


def _row_keys(x, settings: tuple) -> list:
    """A hashable key per row of ``x`` (r, n) that is equal exactly for equal rows: with every
    sample ±1 (a comparator's output) the signs packed to bits, else the rows' bytes; each
    with ``settings`` and the row length."""
    a = np.abs(x)
    if a.size and a.min() == 1.0 == a.max():
        rows = np.packbits(x > 0, axis=1)
        kind = "sign"
    else:
        rows, kind = np.ascontiguousarray(x), "bytes"
    return [(settings, kind, x.shape[1], r.tobytes()) for r in rows]


__all__ = ["TECHNIQUES", "MAX_REPORTED", "DEFAULT_SPACING_M", "SenseATagConfig", "st_antenna_positions",
           "Observation", "SenseATag", "make_receiver", "listen_start_sample", "chain_rows",
           "level_differences", "decode_rows"]

"""Synthetic captures of a Gen2 exchange: "make a capture of this command/reply list".

A monostatic reader capture is the reader's carrier, amplitude-modulated by its PIE commands,
with the tag's backscatter riding on it:

    x(t) = A·e(t)·(1 + μ·e^{jφ}·(s(t) + 1)/2) + n(t)

e(t) the PIE envelope of the commands (1 during CW, 1 − depth in the low pulses;
:func:`rfsim.gen2.pie.timeline_envelope`), s(t) the tag's FM0/Miller element sequence, ±1 during
a reply and −1 (its absorbing state) elsewhere (:func:`rfsim.gen2.linecode.reply_waveform`),
μ the tag's modulation depth relative to the carrier (real backscatter: a few per cent), φ the
phase of the backscatter relative to the carrier and n(t) complex white Gaussian noise. The
magnitude |x| is what an envelope detector or a magnitude-only recording holds.

Link timing (gen2-and-validation-anchors.md §4.1–4.3): Tari, data-1, PW, delimiter and TRcal
of :class:`SyntheticLink`; the tags' BLF is DR/TRcal of the last Query (or the link's
``blf_hz``), their M and TRext those of the last Query (or the link's, before any Query). An
immediate reply starts T1 = max(RTcal, 10/BLF) (nominal, §4.3) after the command's last
rising edge; a delayed (in-process) reply — Write, BlockWrite, BlockErase, Lock, the final
Kill — starts ``delay_s`` later (T5 = T1 … 20 ms, :data:`rfsim.gen2.access.MAX_DELAYED_REPLY_S`)
and is sent with the extended preamble (the pilot tone, as if TRext = 1). The next command
follows T2 = :data:`T2_TPRI` Tpri after the reply's end, unless the exchange cuts the reply
(``cut_bits``: the next command's delimiter starts after that many data bits of the reply).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rfsim.gen2.access import MAX_DELAYED_REPLY_S
from rfsim.gen2.commands import DR_VALUES, Query, command_preamble, encode
from rfsim.gen2.linecode import reply_duration_s, reply_waveform
from rfsim.gen2.pie import pie_timeline, timeline_envelope

#: Reply end → next command (T2), in Tpri = 1/BLF (the Gen2 range is 3–20 Tpri, §4.3).
T2_TPRI = 10.0
#: Gap after a command without a reply, before the next command [s].
NO_REPLY_GAP_S = 100e-6


@dataclass(frozen=True)
class SyntheticLink:
    """Reader PIE timing and the tags' link of a synthetic capture.

    Attributes
    ----------
    tari_s : float
        Data-0 duration Tari [s].
    data1_tari : float
        Data-1 duration [Tari] (RTcal = (1 + data1_tari)·Tari).
    pw_tari : float
        Low-pulse width PW [Tari].
    delimiter_s : float
        Delimiter [s].
    trcal_s : float
        TRcal of the Query preambles [s].
    depth : float
        Reader ASK modulation depth (A − B)/A.
    blf_hz : float or None
        The tags' actual BLF [Hz]; None: DR/TRcal of the last Query (required when the
        exchanges start without a Query).
    m : int
        Line code before any Query (1 = FM0, 2/4/8 = Miller); a Query sets its own.
    trext : bool
        Pilot tone before any Query; a Query sets its own.
    """

    tari_s: float = 12.5e-6
    data1_tari: float = 2.0
    pw_tari: float = 0.5
    delimiter_s: float = 12.5e-6
    trcal_s: float = 64.0 / 3.0 / 256e3
    depth: float = 0.9
    blf_hz: float | None = None
    m: int = 1
    trext: bool = False

    @property
    def rtcal_s(self) -> float:
        """RTcal = Tari + data-1 [s]."""
        return self.tari_s * (1.0 + self.data1_tari)


@dataclass(frozen=True)
class Exchange:
    """One reader command and the tag's reply to it.

    Attributes
    ----------
    command : rfsim.gen2.commands.Command
        The reader command.
    reply : numpy.ndarray or None
        ``(n,) uint8`` data bits of the reply as the tag sends them (CRC included; the dummy 1
        is added by the line code), or None for no reply.
    delayed : bool
        A delayed (in-process) reply: extended preamble, at T1 + ``delay_s``.
    delay_s : float
        Wait beyond T1 of a delayed reply [s] (T1 + delay ≤ 20 ms).
    cut_bits : int or None
        The next command starts after this many data bits of the reply (a reply cut short);
        None: the reply is complete.
    """

    command: object
    reply: np.ndarray | None = None
    delayed: bool = False
    delay_s: float = 0.0
    cut_bits: int | None = None


@dataclass(frozen=True)
class ReplyTruth:
    """Where and how a reply of a synthetic capture was sent.

    Attributes
    ----------
    index : int
        Index of the exchange (and of its command) in the list.
    start_s, end_s : float
        Start of the reply (pilot or preamble) and end of its dummy 1 [s].
    cut_s : float
        Start of the next command's delimiter when it cuts the reply, else NaN [s].
    bits : numpy.ndarray
        ``(n,) uint8`` data bits sent.
    m : int
        Line code.
    trext : bool
        Pilot tone sent.
    blf_hz : float
        BLF [Hz].
    delayed : bool
        A delayed reply.
    """

    index: int
    start_s: float
    end_s: float
    cut_s: float
    bits: np.ndarray
    m: int
    trext: bool
    blf_hz: float
    delayed: bool


@dataclass(frozen=True)
class SyntheticCapture:
    """A synthetic capture and what it holds.

    Attributes
    ----------
    iq : numpy.ndarray
        ``(n,) complex128`` complex baseband, sample k at k/fs, unit of the carrier amplitude.
    fs_hz : float
        Sample rate [Hz].
    command_starts_s, command_ends_s : numpy.ndarray
        ``(n_cmd,) float64`` falling edge of each command's delimiter and its last rising
        edge [s].
    replies : list of ReplyTruth
        The replies sent, in time order.
    """

    iq: np.ndarray
    fs_hz: float
    command_starts_s: np.ndarray
    command_ends_s: np.ndarray
    replies: list = field(default_factory=list)

    @property
    def magnitude(self) -> np.ndarray:
        """``(n,) float64`` |iq|: the magnitude-only capture."""
        return np.abs(self.iq)


def _timeline(cmd, link: SyntheticLink):
    """PIE edge times of ``cmd`` from its delimiter's falling edge at 0 [s]."""
    preamble = command_preamble(cmd)
    return pie_timeline(encode(cmd), tari_s=link.tari_s, data1_tari=link.data1_tari,
                        trcal_s=link.trcal_s if preamble == "query" else None, pw_s=link.pw_tari * link.tari_s,
                        delimiter_s=link.delimiter_s, preamble=preamble)


def _check(exchanges, link: SyntheticLink, fs_hz: float, tag_depth: float, noise_rms: float) -> None:
    if not (math.isfinite(fs_hz) and fs_hz > 0):
        raise ValueError(f"fs_hz must be > 0, got {fs_hz}")
    if not 0.0 < tag_depth <= 1.0:
        raise ValueError(f"tag_depth must be in (0, 1], got {tag_depth}")
    if not noise_rms >= 0.0:
        raise ValueError(f"noise_rms must be >= 0, got {noise_rms}")
    queried = link.blf_hz is not None
    for k, ex in enumerate(exchanges):
        queried = queried or isinstance(ex.command, Query)
        if ex.reply is not None and not queried:
            raise ValueError(f"exchange {k}: a reply before any Query needs the link's blf_hz")
        if ex.delayed and not 0.0 <= ex.delay_s <= MAX_DELAYED_REPLY_S:
            raise ValueError(f"exchange {k}: delay_s must be in [0, {MAX_DELAYED_REPLY_S}] s, got {ex.delay_s}")
        if ex.cut_bits is not None and (ex.reply is None or not 0 <= ex.cut_bits < len(ex.reply)):
            raise ValueError(f"exchange {k}: cut_bits needs a reply longer than it, got {ex.cut_bits}")


def synthetic_capture(exchanges, *, fs_hz: float, link: SyntheticLink = SyntheticLink(),
                      carrier: complex = 1.0, tag_depth: float = 0.03, tag_phase_rad: float = 0.0,
                      noise_rms: float = 0.0, rng: np.random.Generator | None = None,
                      lead_s: float = 200e-6) -> SyntheticCapture:
    """Build the capture of an exchange list (module docstring).

    Parameters
    ----------
    exchanges : sequence of Exchange
        Commands and replies in time order, after ``lead_s`` of carrier.
    fs_hz : float
        Sample rate [Hz].
    link : SyntheticLink
        Reader timing and the tags' link.
    carrier : complex
        Carrier amplitude A at the receiver (unit of the capture).
    tag_depth : float
        Tag modulation depth μ relative to the carrier, in (0, 1].
    tag_phase_rad : float
        Phase φ of the backscatter relative to the carrier [rad] (0: the reflecting state
        adds to the carrier's magnitude).
    noise_rms : float
        RMS of the complex white noise per sample (unit of the capture; 0: none).
    rng : numpy.random.Generator or None
        Draws the noise (required when ``noise_rms`` > 0).
    lead_s : float
        Carrier before the first command and after the last exchange [s].

    Returns
    -------
    SyntheticCapture
        The complex baseband, its commands' times and the replies sent.

    Raises
    ------
    ValueError
        For a non-positive ``fs_hz``, a depth outside (0, 1], a negative noise, noise without
        ``rng``, no BLF for replies before any Query, a delay outside 0–20 ms or a cut
        outside the reply.
    """
    fs = float(fs_hz)
    exchanges = list(exchanges)
    _check(exchanges, link, fs, tag_depth, noise_rms)
    if noise_rms > 0 and rng is None:
        raise ValueError("noise_rms > 0 needs rng")
    m, trext, blf = link.m, link.trext, link.blf_hz
    t_s, timelines, starts, truths = float(lead_s), [], [], []
    for k, ex in enumerate(exchanges):
        if isinstance(ex.command, Query):
            m, trext = ex.command.m, ex.command.trext
            blf = link.blf_hz if link.blf_hz is not None else float(DR_VALUES[ex.command.dr]) / link.trcal_s
        tl = _timeline(ex.command, link)
        a = int(math.ceil(t_s * fs))  # each command starts on a sample
        timelines.append(tl)
        starts.append(a)
        end_s = a / fs + float(tl.rise_s[-1])
        if ex.reply is None:
            t_s = end_s + NO_REPLY_GAP_S
            continue
        bits = np.asarray(ex.reply, dtype=np.uint8)
        pilot = bool(trext or ex.delayed)
        start_s = end_s + max(link.rtcal_s, 10.0 / blf) + (ex.delay_s if ex.delayed else 0.0)
        reply_end_s = start_s + reply_duration_s(bits.size, m=m, trext=pilot, blf_hz=blf)
        if ex.cut_bits is None:
            cut_s, t_s = math.nan, reply_end_s + T2_TPRI / blf
        else:
            cut_s = t_s = start_s + reply_duration_s(ex.cut_bits, m=m, trext=pilot, blf_hz=blf, dummy=False)
        truths.append(ReplyTruth(k, start_s, reply_end_s, cut_s, bits, m, pilot, blf, ex.delayed))
    n = int(math.ceil((t_s + lead_s) * fs))
    env = np.ones(n)
    for a, tl in zip(starts, timelines):
        part = timeline_envelope(tl, depth=link.depth, fs_hz=fs)[: n - a]
        env[a: a + part.size] = part
    s = np.full(n, -1.0)
    for rep in truths:
        a = int(math.floor(rep.start_s * fs))
        w = reply_waveform(rep.bits, m=rep.m, trext=rep.trext, blf_hz=rep.blf_hz, fs_hz=fs,
                           t0_s=rep.start_s - a / fs)[: n - a]
        on = w != 0
        s[a: a + w.size][on] = w[on]
    x = complex(carrier) * env * (1.0 + tag_depth * np.exp(1j * tag_phase_rad) * 0.5 * (s + 1.0))
    if noise_rms > 0:
        x = x + noise_rms / math.sqrt(2.0) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    starts_s = np.array(starts, dtype=np.float64) / fs
    return SyntheticCapture(iq=x, fs_hz=fs, command_starts_s=starts_s,
                            command_ends_s=starts_s + np.array([tl.rise_s[-1] for tl in timelines]), replies=truths)


__all__ = ["T2_TPRI", "NO_REPLY_GAP_S", "SyntheticLink", "Exchange", "ReplyTruth", "SyntheticCapture",
           "synthetic_capture"]

"""The time-domain engine: event-driven between exchanges, sample-level inside them.

One *exchange* is a reader command followed by the CW during which tags may reply
(DESIGN.md "Simulation flow"):

Every exchange is one step of the air interface (:func:`rfsim.air.step.propagate`); this module is
the Gen2 wrapper around it:

1. the reader emits a segment: the PIE command and CW up to the end of the reply window
   (``reader.transmit``, window :func:`rfsim.gen2.link.reply_window_s`), in √W at its antenna port;
2. for every tag the channel gives the forward and backward links (PathSets); the incident
   field is the segment through the forward link (exact carrier phase);
3. each tag listens (``tag.listen``): power-up, envelope/PIE decoding with its own clock,
   Gen2 state machine, and — if it replies — a reflection coefficient Γ(t) on the same
   time base;
4. each tag re-radiates r(t)·incident(t), r = A_s − Γ(t) (``TagResponse.reradiation``: the
   antenna's structural mode A_s and the chip's Γ; rfsim.devices.tag, Nikitin, Rao & Lam 2006),
   through its backward link; at the reader the backscatter of all tags superposes with
   the TX→RX leakage (the reader port's ``coupling``) and thermal noise;
5. the reader decodes the reply window from :func:`rfsim.gen2.link.reader_listen_start_s`
   (``reader.receive``) and measures RSSI, phase, Doppler and SNR.

Propagation (``propagation="auto"``, the default): each link decides between narrowband and
exact fractional delays on the reply bandwidth B = 2·BLF (the main lobe of the FM0/Miller
reply) — the one rule :func:`rfsim.channels.paths.propagation_method`. On narrowband, static links
a tag that does not reply adds one constant to the reader's input (the air step's
a·x + Σ b_i·r_i·x rule), not a full-length pass; a tag population (a reflector group)
decides its quiet tags at once and adds them as one constant (rfsim.air.step "Groups").

Between exchanges nothing is sampled: time advances by the link timing (T2 before the next
command, T4 between commands without a reply), so silent air time costs nothing; within an
exchange in which no tag replies the reader's input is not formed either (the reader reads
only replies; the noise draws are still made, ``propagate(skip_unmodulated=True)``). Each
:class:`Exchange` records the number of samples it simulated (``n_samples``, the length of
the reader's segment: one Tari of CW, the command, T1max + reply + 3 Tpri).

Failure reasons (:data:`FAILURE_REASONS`, checked in this order). The engine knows the ground
truth — who replied, with which bits, when — and uses it to say *why* a read failed; the
reader itself only sees its samples:

* ``"not powered"`` — no tag had enough incident power;
* ``"decode error"`` — no tag replied and a powered tag could not decode the command (PIE);
* ``"no reply"`` — tags were powered but none replied (not addressed: target flag, session,
  wrong RN16 in an ACK, slot counter ≠ 0);
* ``""`` — the reader decoded (CRC ok where there is one) exactly the bits one replying tag
  sent (with several repliers this is *capture*: ``Exchange.decoded_tag`` names the winner);
* ``"timing violation"`` — every replying tag started its reply outside the Gen2 T1 window
  [T1min, T1max] after the command's last rising edge (the reader searches only there; its
  own verdict is then "preamble not found" or a wrong decode);
* ``"collision"`` — several tags replied and the reader decoded none of them;
* the reader's own verdict otherwise: ``"preamble not found"``, ``"crc error"``;
* ``"bit error"`` — the reader accepted the reply (no CRC: an RN16) but its bits differ from
  what the tag sent (the ACK that follows then gets no reply).

Delayed replies (``delayed_reply=True``): a Write, BlockWrite, BlockErase, Lock or final Kill is
answered once the tag has programmed its memory (EPC Gen2 v2 §6.3.2.12.3, :mod:`rfsim.gen2.access`),
T5 after the command, T5 in [T1min, 20 ms] (anchors §4.3, :func:`rfsim.gen2.link.t5`), with the
extended preamble (TRext = 1 whatever the Query said). The reader then keeps its CW for
:func:`rfsim.gen2.link.delayed_reply_window_s` (T5max + the reply at the slowest BLF + 3 Tpri:
the whole window is simulated sample by sample, noise included — skipping the silent air before
the reply would not be exact, since the reader's preamble search can trigger on noise there),
searches the reply start in [T1min, T5max] with the extended preamble (``reader.receive(...,
delayed=True)``) and the timing check uses the T5 window. A reply with a header bit (Read and
every delayed reply; ``header_bit=True``, implied by ``delayed_reply``) may be an error reply
``1 | code(8) | handle | CRC-16`` of :data:`rfsim.gen2.access.ERROR_REPLY_BITS` bits instead of
the expected ``reply_bits``: when the decode at ``reply_bits`` fails its CRC and its first bit
(the header) is 1, the reader decodes the reply again at that length, as a reader that reads
the header first would. Without these keywords every exchange is exactly as before.

The engine only sees devices and the channel through these methods (and the PathSet members
of the air interface's link protocol); it imports neither ``channels`` nor ``devices``.
"""

from __future__ import annotations

import dataclasses
import math
import operator
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from rfsim.air.step import PROPAGATION_METHODS, AirResult, FixedEmitter, as_reflector, members_of, propagate
from rfsim.gen2.access import ERROR_REPLY_BITS
from rfsim.gen2.bits import bits_to_int
from rfsim.gen2.commands import ACK
from rfsim.gen2.reply_decoder import Windows
from rfsim.gen2.link import delayed_reply_window_s, reader_listen_start_s, reply_window_s, t1, t5

#: Failure reasons of a read, in the order the engine checks them.
FAILURE_REASONS = ("", "not powered", "decode error", "no reply", "timing violation", "collision",
                   "preamble not found", "crc error", "bit error")


@dataclasses.dataclass(frozen=True)
class Exchange:
    """Record of one reader command and what came back.

    Attributes
    ----------
    time_s : float
        Start of the reader's segment [s] (CW lead-in, then the command).
    command : str
        Command name (``"Query"``, ``"ACK"``, …).
    antenna : int
        Reader antenna index (0-based).
    channel_index : int
        1-based index into the reader's frequency plan (as LLRP reports it).
    fc_hz : float
        Carrier frequency [Hz].
    replied : tuple of int
        Indices of the tags that replied.
    powered : tuple of int
        Indices of the tags that were powered.
    incident_power_dbm : tuple of float
        (n_tags,) incident power at each tag's antenna port [dBm].
    read : object or None
        The reader's ``ReadResult``-like measurement, or None when nobody replied.
    failure_reason : str
        One of :data:`FAILURE_REASONS` (``""`` = decoded; module docstring).
    end_s : float
        End of the reply window [s].
    decoded_tag : int or None
        Index of the replying tag whose bits the reader decoded exactly (None if none); with
        several repliers a non-None value means capture.
    reply_start_s : tuple of float
        (n_replied,) true reply start of each replying tag [s].
    timing_ok : tuple of bool
        (n_replied,) whether each reply started inside the T1 window (the T5 window when the
        exchange listened for a delayed reply).
    n_samples : int
        Samples simulated for this exchange (the reader's segment).
    cmd_end_s : float
        End of the command (last rising edge) [s].
    """

    time_s: float
    command: str
    antenna: int
    channel_index: int
    fc_hz: float
    replied: tuple[int, ...]
    powered: tuple[int, ...]
    incident_power_dbm: tuple[float, ...]
    read: Any
    failure_reason: str
    end_s: float
    decoded_tag: int | None = None
    reply_start_s: tuple[float, ...] = ()
    timing_ok: tuple[bool, ...] = ()
    n_samples: int = 0
    cmd_end_s: float = math.nan

    @property
    def success(self) -> bool:
        """The reader decoded one replying tag's bits exactly (failure_reason ``""``)."""
        return self.failure_reason == ""

    @property
    def bits(self):
        """Bits the reader decoded ((n,) uint8), or None."""
        return None if self.read is None else self.read.bits


def _failure(read, replied: Sequence[int], powered: Sequence[int], decode_error: bool,
             decoded_tag: int | None, timing_ok: Sequence[bool]) -> str:
    """Failure reason from the ground truth and the reader's verdict (module docstring);
    ``decode_error``: a powered tag could not decode the command."""
    if not powered:
        return "not powered"
    if not replied:
        return "decode error" if decode_error else "no reply"
    if decoded_tag is not None and read.success:
        return ""
    if not any(timing_ok):
        return "timing violation"
    if len(replied) > 1:
        return "collision"
    if read is None:
        return "preamble not found"
    return read.failure_reason if not read.success else "bit error"


def run_exchange(reader, tags: Sequence, channel, cmd, *, t_s: float, rng: np.random.Generator,
                 reply_bits: int, expect_crc: bool, motions: Sequence | None = None,
                 round_index: int = 0, draw_channel: bool = True,
                 propagation: str = "auto", link_cache: dict | None = None, delayed_reply: bool = False,
                 header_bit: bool = False) -> Exchange:
    """Simulate one command and its reply window at sample level.

    One exchange is the batch of one of :func:`run_exchanges` (the same code); the steps are
    those of the module docstring.

    Parameters
    ----------
    reader : object
        Reader device (``transmit``, ``receive``, ``leakage_gain``, ``noise_power_w``,
        ``antennas``, ``antenna_index``, ``link``; its ``air_cache``, when it has one, is the
        run's :class:`rfsim.air.cache.AirCache`: the reader lives for the run).
    tags : sequence
        Reflectors of the air step (``reflect``, ``antenna``; a device with only
        ``listen(samples, *, t0_s, fs_hz)`` is accepted too) returning TagResponse-like records,
        or reflector groups of them (:class:`rfsim.air.step.ReflectorGroup`: a tag population,
        whose members count as tags in the order given).
    channel : object
        Link model with a ``backscatter_links`` method ``(emitter, tag, *, fc_hz, rng, t_s,
        tag_motion)`` → (forward, backward) PathSets.
    cmd : object
        The Gen2 command object to send.
    t_s : float
        Start time of the command [s].
    rng : numpy.random.Generator
        Generator for the channel draw and the receiver noise.
    reply_bits : int
        Number of bits of the expected reply (16 for RN16, PC+EPC+CRC otherwise).
    expect_crc : bool
        Whether the reply carries a CRC-16 (EPC replies).
    motions : sequence, optional
        Per-tag motion (velocity (3,) m/s or callable t → position).
    round_index : int, default 0
        Inventory round (selects the antenna when several are used in turn).
    draw_channel : bool, default True
        Draw the channel's random part anew from ``rng`` (otherwise reuse the draw the channel
        holds: a quasi-static channel within a round).
    propagation : {"auto", "exact", "narrowband"}, default "auto"
        Propagation policy (module docstring).
    link_cache : dict, optional
        Holds the forward and backward links of static tags for one channel draw, keyed by
        (tag index, reader antenna, carrier). Filled on every call; read only with
        ``draw_channel=False`` for a tag without motion — the links are then exactly what the
        channel would return again (held draw, same geometry and carrier).
    delayed_reply : bool, default False
        Listen for a delayed ("in-process") reply: the window, search and preamble of the
        module docstring ("Delayed replies"); implies ``header_bit``.
    header_bit : bool, default False
        The reply starts with a header bit: an error reply (header 1,
        :data:`rfsim.gen2.access.ERROR_REPLY_BITS` bits) is decoded at its own length (module
        docstring).

    Returns
    -------
    Exchange
        The record of the command and what came back.

    Raises
    ------
    ValueError
        An unknown ``propagation``.
    """
    return run_exchanges(reader, [tags], channel, cmd, t_s=t_s, rngs=[rng], reply_bits=reply_bits,
                         expect_crc=expect_crc, motions=motions, round_index=round_index, draw_channel=draw_channel,
                         propagation=propagation, link_caches=[link_cache], delayed_reply=delayed_reply,
                         header_bit=header_bit)[0]


def _per_trial(value, n: int, name: str) -> list:
    """``value`` for each of ``n`` trials: a list/tuple of n values, or one value for all."""
    return _per_trials(n, **{name: value})[0]


def _per_trials(n: int, **values) -> list[list]:
    """:func:`_per_trial` of every keyword (its name is the one an error gives), in order."""
    out = []
    for name, value in values.items():
        if isinstance(value, (list, tuple)):
            if len(value) != n:
                raise ValueError(f"{name}: {len(value)} values for {n} trials (give one value or one per trial)")
            out.append(list(value))
        else:
            out.append([value] * n)
    return out


#: Trials run together, stage by stage: their air steps (with noise), then their reads
#: (bounds the memory of a large batch: a reader input per trial of the block).
BLOCK = 64


def run_exchanges(reader, tags: Sequence[Sequence], channel, cmd, *, t_s, rngs: Sequence[np.random.Generator],
                  reply_bits: int, expect_crc: bool, motions: Sequence | None = None, round_index=0,
                  draw_channel: bool = True, propagation: str = "auto",
                  link_caches: Sequence[dict | None] | None = None, delayed_reply: bool = False,
                  header_bit: bool = False) -> list[Exchange]:
    """Simulate B independent exchanges as one batch (:mod:`rfsim.protocols.batch`).

    The one implementation of the exchange: :func:`run_exchange` is its batch of one.

    Parameters
    ----------
    reader : object or list
        As for :func:`run_exchange`; one value for every trial or a list of B values.
    tags : sequence of sequence
        B sequences of reflectors, trial b's tags (their own state and RN16 stream).
    channel : object or list
        As for :func:`run_exchange`; one value or a list of B values.
    cmd : object or list
        As for :func:`run_exchange`; one value or a list of B values.
    t_s : float or list of float
        Start time of the command [s]; one value or a list of B values.
    rngs : sequence of numpy.random.Generator
        B generators: trial b's channel draw and receiver noise.
    reply_bits : int
        As for :func:`run_exchange` (the same for every trial).
    expect_crc : bool
        As for :func:`run_exchange` (the same for every trial).
    motions : sequence, optional
        As for :func:`run_exchange` (the same for every trial).
    round_index : int or list of int, default 0
        As for :func:`run_exchange`; one value or a list of B values.
    draw_channel : bool, default True
        As for :func:`run_exchange` (the same for every trial).
    propagation : {"auto", "exact", "narrowband"}, default "auto"
        As for :func:`run_exchange` (the same for every trial).
    link_caches : sequence of dict or None, optional
        B dicts (or None), trial b's ``link_cache``.
    delayed_reply : bool, default False
        As for :func:`run_exchange` (the same for every trial).
    header_bit : bool, default False
        As for :func:`run_exchange` (the same for every trial).

    Returns
    -------
    list of Exchange
        One record per trial, in trial order.

    Raises
    ------
    ValueError
        A per-trial list of the wrong length, or an unknown ``propagation``.

    Notes
    -----
    Per block of :data:`BLOCK` trials: 1. per trial the reader's segment (made once per
    distinct reader, command, time and round), its port and the tags' links (drawn from the
    trial's own ``rngs[b]``); 2. per trial the air step with its receiver noise
    (:func:`rfsim.air.step.propagate` with the trial's generator and ``skip_unmodulated``: a
    trial in which no tag replies forms no reader input, its noise draws are still made), of
    which only the ground truth and the reader's input are kept (a block's inputs of one reader
    formed in one array, :meth:`ReaderPort.input_array`); 3. the reader's reads of the trials with
    a reply (those of consecutive trials read by one reader, each on its own port, in one
    :meth:`ReaderPort.receive_batch`, the windows read where stage 2 formed them); 4. the records.
    Each stage runs over the block's trials in a row (the same code and tables hot: trial by trial
    took 5–10 % more CPU), and a step's other objects do not outlive it (fewer collections of
    Python's cyclic garbage collector).
    """
    n = len(rngs)
    if len(tags) != n:
        raise ValueError(f"tags: {len(tags)} tag lists for {n} trials (one per generator in rngs)")
    readers, channels, cmds, times, rounds, caches = _per_trials(
        n, reader=reader, channel=channel, cmd=cmd, t_s=t_s, round_index=round_index,
        link_caches=None if link_caches is None else list(link_caches))
    if propagation not in PROPAGATION_METHODS:
        raise ValueError(f"propagation must be one of {PROPAGATION_METHODS}, got {propagation!r}")
    # the reader's segment with its emitter and port, once per distinct reader, command, time and round
    segments: dict = {}
    listens: dict = {}  # id(reader) -> its _Listen for this call (the readers are held by ``readers``)
    out: list = []
    for k0 in range(0, n, BLOCK):
        preps = []
        for b in range(k0, min(n, k0 + BLOCK)):
            key = (id(readers[b]), id(cmds[b]), float(times[b]), rounds[b])
            sent = segments.get(key)
            if sent is None:
                if len(segments) >= BLOCK:
                    segments.clear()
                listen = listens.get(key[0])
                if listen is None:
                    listen = listens[key[0]] = _listen(readers[b], reply_bits, delayed_reply)
                sent = segments[key] = _sent(readers[b], cmds[b], t_s=times[b], reply_bits=reply_bits,
                                             expect_crc=expect_crc, round_index=rounds[b],
                                             delayed_reply=delayed_reply, header_bit=header_bit, listen=listen)
            preps.append(_prepare(readers[b], tags[b], channels[b], cmds[b], t_s=times[b], rng=rngs[b],
                                  motions=motions, draw_channel=draw_channel, propagation=propagation,
                                  link_cache=caches[b], sent=sent))
        if len(preps) > 1:  # the block's reader inputs in one array per reader (read where they lie)
            n_block = sum([prep.sent.tx.samples.size for prep in preps])
            for listen in listens.values():
                listen.inputs.reset(n_block)
        heard = [_heard(_air(prep, rngs[k0 + k]), prep.members) for k, prep in enumerate(preps)]
        for prep, (truth, _), read in zip(preps, heard, _reads(preps, heard)):
            out.append(_record(prep, truth, read))
    return out


def _reads(preps: list, heard: list) -> list:
    """Stage 3 of :func:`run_exchanges`: the reader's read of each trial with a reply (None
    for the others), in trial order; the reads of consecutive trials whose ports read alike
    (the same reader and reply; each trial's own command, listen start and carrier,
    :meth:`ReaderPort.receive_batch`) in one call."""
    reads: list = [None] * len(preps)
    runs: list = []  # ([port, …], [trial, …]) of consecutive trials with a reply, read in one call
    for k, (prep, (truth, _)) in enumerate(zip(preps, heard)):
        if truth[0]:
            port = prep.sent.port
            if runs and runs[-1][0][-1].batch_key == port.batch_key:
                runs[-1][0].append(port)
                runs[-1][1].append(k)
            else:
                runs.append(([port], [k]))
    for ports, trials in runs:
        for k, read in zip(trials, ports[0].receive_batch([heard[k][1] for k in trials], ports)):
            reads[k] = read
    return reads


class _Sent(NamedTuple):
    """The reader's side of one command, shared by the trials that send it (same reader, command,
    time and round): its antenna, its segment, the air step's emitters (the segment as one
    emitter) and receivers (the port that reads the reply), that port, the links' bandwidth B = 2·BLF [Hz] of the reply (the main
    lobe of FM0/Miller, module docstring), the run's air cache and the window a reply must
    start in (T1, or T5 for a delayed reply)."""

    antenna_index: int
    tx: Any
    emitters: tuple
    receivers: tuple
    port: "ReaderPort"
    bandwidth_hz: float
    air_cache: Any
    reply_range: Any


class _Prepared(NamedTuple):
    """One exchange set up for the air step: the reader's side (:class:`_Sent`), the reflectors
    and their links (:func:`_prepare`)."""

    t_s: float
    cmd: Any
    sent: _Sent
    reflectors: list
    members: list
    links: "_EngineLinks"
    propagation: str


class _Listen(NamedTuple):
    """What a reader's commands of one :func:`run_exchanges` call share (:func:`_listen`): the
    CW after a command [s], the links' bandwidth B = 2·BLF [Hz], the run's air cache, the
    window a reply must start in (T1, or T5 for a delayed reply), and the reader's receiver
    noise power [W] and TX→RX leakage gain (read once for the call's ports)."""

    window_s: float
    bandwidth_hz: float
    air_cache: Any
    reply_range: Any
    noise_w: float
    leakage: complex
    inputs: "_InputBlock | None" = None


class _InputBlock:
    """The reader inputs of a block of trials in one array (stage 2 of :func:`run_exchanges`): the
    air step forms each trial's input in a part of it (:meth:`ReaderPort.input_array`), the
    reads of stage 3 read them there (:class:`rfsim.gen2.reply_decoder.Windows`, no copy). The
    array is used again by the next block (the inputs of a block are read before the next block's
    air steps)."""

    __slots__ = ("buffer", "used", "starts", "views")

    def __init__(self):
        self.buffer, self.used = None, 0
        self.starts: dict = {}  # id(view) -> its first sample in buffer (the views held in ``views``)
        self.views: list = []

    def reset(self, n_samples: int) -> None:
        """A new block of at most ``n_samples`` samples of inputs."""
        if self.buffer is None or self.buffer.size < n_samples:
            self.buffer = np.empty(n_samples, dtype=np.complex128)
        self.used = 0
        self.starts.clear()
        self.views.clear()

    def take(self, n_samples: int) -> np.ndarray | None:
        """The next ``n_samples`` of the array for one input (None: no room)."""
        i = self.used
        if self.buffer is None or i + n_samples > self.buffer.size:
            return None
        view = self.buffer[i:i + n_samples]
        self.used = i + n_samples
        self.starts[id(view)] = i
        self.views.append(view)
        return view

    def windows(self, inputs, i0: list) -> Windows | None:
        """The windows ``input.samples[i0[b]:]`` of inputs formed here as
        :class:`rfsim.gen2.reply_decoder.Windows` of the array, or None when one was not."""
        rows = [x.samples for x in inputs]
        starts = [self.starts.get(id(row)) for row in rows]
        if None in starts:
            return None
        first = np.array(starts, dtype=np.int64)
        ends = first + np.array([row.shape[-1] for row in rows], dtype=np.int64)
        return Windows(self.buffer, np.minimum(first + np.array(i0, dtype=np.int64), ends), ends)


def _listen(reader, reply_bits: int, delayed_reply: bool) -> _Listen:
    """The reader's :class:`_Listen` for replies of ``reply_bits`` bits (a delayed reply with
    ``delayed_reply``): the CW to the end of the reply window (a reader that searches the BLF
    listens longer), 2·BLF, its air cache and the reply's start window."""
    listen = getattr(reader, "listen_window_s", None)
    if delayed_reply:
        window_s = _link_time(reader, _delayed_window_s, int(reply_bits))
    elif listen is not None:
        window_s = listen(int(reply_bits))
    else:
        window_s = _link_time(reader, reply_window_s, int(reply_bits))
    return _Listen(window_s=window_s, bandwidth_hz=2.0 * reader.link.blf_hz,
                   air_cache=getattr(reader, "air_cache", None),
                   reply_range=_link_time(reader, t5 if delayed_reply else t1),
                   noise_w=reader.noise_power_w(), leakage=reader.leakage_gain(), inputs=_InputBlock())


def _sent(reader, cmd, *, t_s, reply_bits, expect_crc, round_index, delayed_reply=False, header_bit=False,
          listen: _Listen | None = None) -> _Sent:
    """Step 1 of the module docstring: the reader's segment for ``cmd`` at ``t_s`` in round
    ``round_index``, its emitter and its port (``listen``: the reader's :func:`_listen`, made
    here when None)."""
    if listen is None:
        listen = _listen(reader, reply_bits, delayed_reply)
    antenna_index = reader.antenna_index(round_index)
    antenna = reader.antennas[antenna_index]
    tx = reader.transmit(cmd, t0_s=t_s, cw_after_s=listen.window_s, round_index=round_index)
    port = ReaderPort(reader, antenna, tx, reply_bits=reply_bits, expect_crc=expect_crc, delayed_reply=delayed_reply,
                      header_bit=header_bit, noise_w=listen.noise_w, leakage=listen.leakage, inputs=listen.inputs)
    return _Sent(antenna_index=antenna_index, tx=tx, emitters=(FixedEmitter(antenna, tx, device=reader),),
                 receivers=(port,), port=port, bandwidth_hz=listen.bandwidth_hz, air_cache=listen.air_cache,
                 reply_range=listen.reply_range)


def _prepare(reader, tags, channel, cmd, *, t_s, rng, motions, draw_channel, propagation, link_cache,
             sent: _Sent) -> _Prepared:
    """Step 2 of the module docstring up to the air step: the tags as reflectors and their
    links, for the reader's side ``sent``."""
    reflectors = [as_reflector(t) for t in tags]
    members = members_of(reflectors)
    links = _EngineLinks(channel, sent.port.antenna, reflectors, members, motions, rng if draw_channel else None, t_s,
                         link_cache, draw_channel)
    return _Prepared(t_s=t_s, cmd=cmd, sent=sent, reflectors=reflectors, members=members, links=links,
                     propagation=propagation)


def _air(prep: _Prepared, rng) -> AirResult:
    """The air step of a prepared exchange (:func:`rfsim.air.step.propagate`, ``skip_unmodulated``:
    a step in which no tag replies forms no reader input, its noise draws are still made), with
    the trial's generator ``rng``."""
    sent = prep.sent
    tx = sent.tx
    return propagate(sent.emitters, prep.reflectors, sent.receivers, prep.links, t0_s=prep.t_s, fs_hz=tx.fs_hz,
                     n_samples=tx.samples.size, rng=rng, bandwidth_hz=sent.bandwidth_hz,
                     propagation=prep.propagation, decide=False, skip_unmodulated=True, cache=sent.air_cache)


def _heard(air: AirResult, members) -> tuple:
    """``(truth, input)`` of an air step: its ground truth (:func:`_truth`) and the reader's input
    segment when a tag replied (else None); the rest of the step is dropped with ``air`` (its objects do
    not outlive the step: fewer collections of Python's cyclic garbage collector)."""
    truth = _truth(air, members)
    return truth, (air.inputs[0] if truth[0] else None)


def _truth(air, members) -> tuple:
    """Ground truth of the step: ``(replied, powered, incident_dbm, sent bits, reply starts,
    decode_error)`` over the members (tag populations that answered at once included; one that
    holds every member gives its ``record_values``, tuples shared between exchanges while
    equal, else its arrays are converted here)."""
    replied, powered, incident_dbm, sent, starts = [], [], [], [], []
    decode_error = False
    shortcut = dict(air.groups)
    j, n_members = 0, len(members)
    while j < n_members:
        group = shortcut.get(j)
        if group is not None:  # a tag population that answered at once: its arrays, its reacting tags
            values = getattr(group, "record_values", None)
            if values is not None and j == 0 and len(group) == n_members:
                record = values()
                incident_dbm, powered = record.incident_power_dbm, record.powered
            else:
                incident_dbm.extend(group.incident_power_dbm.tolist())
                powered.extend((np.flatnonzero(group.powered) + j).tolist())
            for jl, response in group.reactions.items():
                decode_error |= response.reason == "decode error"
                if response.gamma is not None:
                    replied.append(j + jl)
                    sent.append(np.asarray(response.reply.bits))
                    starts.append(float(response.reply_start_s))
            j += len(group)
            continue
        response = air.reflections[j]
        incident_dbm.append(float(response.incident_power_dbm))
        decode_error |= response.reason == "decode error"
        if response.powered:
            powered.append(j)
        if response.gamma is not None:
            replied.append(j)
            sent.append(np.asarray(response.reply.bits))
            starts.append(float(response.reply_start_s))
        j += 1
    return replied, powered, incident_dbm, sent, starts, decode_error


def _record(prep: _Prepared, truth: tuple, read) -> Exchange:
    """The :class:`Exchange` of a prepared exchange from its ground truth and the reader's read."""
    replied, powered, incident_dbm, sent, starts, decode_error = truth
    side = prep.sent
    tx = side.tx
    decoded_tag = None
    if read is not None and read.bits is not None:
        for i, bits in zip(replied, sent):
            if bits.size == read.bits.size and (np.array_equal(bits, read.bits) if bits.dtype != read.bits.dtype
                                                else bits.tobytes() == read.bits.tobytes()):
                decoded_tag = i
                break
    t1_range = side.reply_range
    lo, hi, cmd_end_s = t1_range.min_s, t1_range.max_s, tx.cmd_end_s
    timing_ok = tuple([bool(lo <= st - cmd_end_s <= hi) for st in starts])
    n = int(tx.samples.size)
    # every field of the frozen record given, as its constructor would set them (one dict update
    # instead of a frozen dataclass's set per field; tests/test_engine.py::test_record_is_the_constructors_record)
    ex = _new_record(Exchange)
    ex.__dict__.update(time_s=prep.t_s, command=type(prep.cmd).__name__, antenna=side.antenna_index,
                       channel_index=tx.channel_index, fc_hz=tx.fc_hz, replied=tuple(replied),
                       powered=tuple(powered), incident_power_dbm=tuple(incident_dbm), read=read,
                       failure_reason=_failure(read, replied, powered, decode_error, decoded_tag, timing_ok),
                       end_s=prep.t_s + n / tx.fs_hz, decoded_tag=decoded_tag,
                       reply_start_s=tuple(starts), timing_ok=timing_ok, n_samples=n,
                       cmd_end_s=float(tx.cmd_end_s))
    return ex


_new_record = object.__new__


class _AckDelays(NamedTuple):
    """From an RN16 reply's start to the ACK [s] (:func:`_ack_delays`), added in this order."""

    reply_s: float  # the reply: 16 bits at the nominal BLF
    t2_s: float  # T2 = 10 Tpri, inside the Gen2 3–20 Tpri window


# Timing of a (frozen, hashable) LinkProfile: pure functions, kept per run in the reader's
# AirCache (:func:`_link_time`).
def _link_time(reader, rule, *args):
    """``rule(reader.link, *args)``, kept in the run's cache (:meth:`rfsim.air.cache.AirCache.link_timing`)
    when the reader has one."""
    cache = getattr(reader, "air_cache", None)
    return rule(reader.link, *args) if cache is None else cache.link_timing(rule, reader.link, *args)


def _ack_delays(link) -> _AckDelays:
    """From an RN16 reply's start to the ACK [s]: the reply (16 bits at the nominal BLF) and
    T2 = 10 Tpri, inside the Gen2 3–20 Tpri window."""
    return _AckDelays(reply_s=link.reply_duration_s(16), t2_s=10.0 * link.tpri_s)


def _delayed_window_s(link, reply_bits: int) -> float:
    """CW after a command awaiting a delayed reply [s]: :func:`rfsim.gen2.link.delayed_reply_window_s`
    of the longer of the expected reply and an error reply."""
    return delayed_reply_window_s(link, max(reply_bits, ERROR_REPLY_BITS))


class ReaderPort:
    """The reader's IQ input as a receiver of the air step (:class:`rfsim.air.step.Receiver`).

    Its noise is ``reader.noise_power_w()``; its own TX→RX leakage ``reader.leakage_gain()`` is
    the coupling from its own transmitter (a :class:`rfsim.air.step.FixedEmitter` with
    ``device=reader`` on ``antenna``), instead of a channel link. :meth:`receive` is the reader's
    read of one reply: it listens from :func:`rfsim.gen2.link.reader_listen_start_s` after the
    command of ``tx`` (the edge and the channel's delay spread have settled), searches the reply
    in the T1 window with no knowledge of the tags (BLF: the profile's nominal value) and takes
    its phase reference from its own carrier during the reply window (``tx.samples[-1]``: PR-ASK
    ends a command with either polarity, depending on the parity of its PIE symbols).

    Parameters
    ----------
    reader : object
        Reader device (``receive``, ``leakage_gain``, ``noise_power_w``, ``link``).
    antenna : object
        The reader antenna of the exchange.
    tx : object
        The reader's segment (``t0_s``, ``fs_hz``, ``samples``, ``cmd_end_s`` [s]).
    reply_bits : int
        Bits of the expected reply.
    expect_crc : bool
        Whether it carries a CRC-16.
    delayed_reply : bool, default False
        Listen for a delayed reply (:func:`run_exchange`): ``reader.receive(..., delayed=True)``.
    header_bit : bool, default False
        The reply has a header bit: an error reply is decoded at its own length
        (:func:`run_exchange`); implied by ``delayed_reply``.
    noise_w : float or None, default None
        ``reader.noise_power_w()`` [W] when the caller read it already (one read for the ports of a
        batch's commands); None: read here.
    leakage : complex or None, default None
        ``reader.leakage_gain()`` when the caller read it already; None: read here.
    inputs : _InputBlock or None, default None
        Where the air step forms this port's inputs (:meth:`input_array`; the engine's block of
        inputs); None: the air step makes each.
    """

    fc_hz = None

    def __init__(self, reader, antenna, tx, *, reply_bits: int, expect_crc: bool, delayed_reply: bool = False,
                 header_bit: bool = False, noise_w: float | None = None, leakage: complex | None = None,
                 inputs: _InputBlock | None = None):
        self.reader, self.antenna, self.tx = reader, antenna, tx
        self._inputs = inputs
        self.reply_bits, self.expect_crc = int(reply_bits), bool(expect_crc)
        self.delayed_reply = bool(delayed_reply)
        self.header_bit = self.delayed_reply or bool(header_bit)
        # its reads draw their own noise in call order (an error reply's read must follow its read)
        self._reads_draw = getattr(getattr(reader, "config", None), "rx_model", "sample") == "statistic"
        # its noise and coupling: read once per command, or given (read once for a batch's commands)
        self.noise_power_w = reader.noise_power_w() if noise_w is None else noise_w
        self._leakage = reader.leakage_gain() if leakage is None else leakage
        self._listen_s = reader_listen_start_s(reader.link, tx.cmd_end_s)  # the reader's listen start [s]
        # ports that read alike (receive_batch): the same reader and reply; with a header bit (an
        # error reply is read again after the batch) the same port
        self.batch_key = (id(reader), self.reply_bits, self.expect_crc, self.delayed_reply,
                          id(self) if self.header_bit else None)

    def coupling(self, emitter):
        """Return the direct coupling from an emitter, replacing the channel's link.

        Parameters
        ----------
        emitter : object
            An emitter of the step.

        Returns
        -------
        complex or None
            ``reader.leakage_gain()`` (complex amplitude gain, read when the port is made) for the
            reader's own transmitter on this port's antenna; None for any other emitter (the
            channel's link applies).
        """
        if getattr(emitter, "device", None) is self.reader and emitter.antenna is self.antenna:
            return self._leakage
        return None

    def first_read_sample(self, t0_s: float, fs_hz: float, n_samples: int) -> int:
        """Return the first sample of an input that :meth:`receive` reads.

        That is the reader's listen start after the command of ``tx``
        (:func:`rfsim.gen2.link.reader_listen_start_s`).

        Parameters
        ----------
        t0_s : float
            Time of the input's first sample [s].
        fs_hz : float
            Sample rate [Hz].
        n_samples : int
            Samples of the input.

        Returns
        -------
        int
            ceil((listen start − t0)·fs), at most ``n_samples``.
        """
        return min(int(_first_sample(self._listen_s, t0_s, fs_hz)), int(n_samples))

    def input_array(self, n_samples: int) -> np.ndarray | None:
        """Return where the air step forms an input of this port.

        Parameters
        ----------
        n_samples : int
            Samples of the input.

        Returns
        -------
        ndarray of complex128, shape (n_samples,), or None
            A part of the engine's block of inputs (the reads find it there), or None (no block,
            or no room left: the air step makes its own array).
        """
        return None if self._inputs is None else self._inputs.take(n_samples)

    def receive(self, input):
        """Read the reply in the reader's input.

        Parameters
        ----------
        input : rfsim.air.step.Segment
            The reader's input on the time base of ``tx`` [√W].

        Returns
        -------
        object
            The reader's ``ReadResult``-like measurement of the reply (samples from the listen
            start on, searched after ``tx.cmd_end_s``, phase referred to ``tx.samples[-1]``; with
            ``header_bit`` an error reply at its own length, :func:`run_exchange`).
        """
        i0, kwargs = self._read_arguments(input)
        return self._error_reply(self.reader.receive(input.samples[i0:], n_bits=self.reply_bits, **kwargs),
                                 input.samples[i0:], kwargs)

    def receive_batch(self, inputs, ports=None):
        """Read the reply in each of several inputs (trials of one reader and reply).

        Parameters
        ----------
        inputs : list of rfsim.air.step.Segment
            The reader's inputs [√W], input b on the time base of its port's ``tx``.
        ports : sequence of ReaderPort, optional
            The port of each input (each trial's own command, listen start and carrier); default
            this port for every input. Ports of another :attr:`batch_key` than this one's are
            read one by one.

        Returns
        -------
        list
            Input b's port's :meth:`receive` of it, in order. The inputs are read in one
            ``reader.receive_batch`` call (each its own first sample time, length, command end
            and carrier) when the reader has it, every port has this port's :attr:`batch_key`
            and the reply is not a delayed one; otherwise one by one.

        Raises
        ------
        ValueError
            ``ports`` of another length than ``inputs``.
        """
        ports = (self,) * len(inputs) if ports is None else ports
        if len(ports) != len(inputs):
            raise ValueError(f"ports: {len(ports)} ports for {len(inputs)} inputs")
        batch = getattr(self.reader, "receive_batch", None)
        key = self.batch_key
        if (batch is None or self.delayed_reply or len(inputs) < 2 or (self.header_bit and self._reads_draw)
                or any([p.batch_key != key for p in ports])):
            return [p.receive(x) for p, x in zip(ports, inputs)]
        i0, t0, ends, carriers = _read_arguments(ports, inputs)
        laid = None if self._inputs is None else self._inputs.windows(inputs, i0)
        rows = [x.samples[i:] for x, i in zip(inputs, i0)] if laid is None or self.header_bit else None
        reads = batch(rows if laid is None else laid, n_bits=self.reply_bits, expect_crc=self.expect_crc, t0_s=t0,
                      cmd_end_s=ends, carrier=carriers)
        if not self.header_bit:
            return reads
        return [p._error_reply(read, row, dict(t0_s=t, expect_crc=self.expect_crc, cmd_end_s=e, carrier=c))
                for p, read, row, t, e, c in zip(ports, reads, rows, t0, ends, carriers)]

    def _read_arguments(self, input) -> tuple:
        """The first sample read of ``input`` (the listen start) and the keywords of
        ``reader.receive`` for it (:func:`_read_arguments` of one input)."""
        i0, t0, ends, carriers = _read_arguments((self,), (input,))
        kwargs = dict(t0_s=t0[0], expect_crc=self.expect_crc, cmd_end_s=ends[0], carrier=carriers[0])
        if self.delayed_reply:
            kwargs["delayed"] = True
        return i0[0], kwargs

    def _error_reply(self, read, rx, kwargs):
        """``read``, or with ``header_bit`` the read of ``rx`` at the error reply's length when the
        header of a failed read says the reply is one (:func:`run_exchange`)."""
        if (self.header_bit and self.reply_bits != ERROR_REPLY_BITS and not read.success and read.bits is not None
                and read.bits[0] == 1):  # the header says: an error reply
            read = self.reader.receive(rx, n_bits=ERROR_REPLY_BITS, **kwargs)
        return read


def _first_sample(listen_s: float, t0_s: float, fs_hz: float) -> int:
    """The first sample a read takes of an input whose first sample is at ``t0_s`` [s]:
    ceil((listen start − t0)·fs), the listen start ``listen_s`` [s] and rate ``fs_hz`` [Hz]."""
    return math.ceil((listen_s - t0_s) * fs_hz)


def _read_arguments(ports, inputs) -> tuple:
    """What the reads of B inputs take, each read by its own port (:meth:`ReaderPort.receive`,
    :meth:`ReaderPort.receive_batch`; one input is a batch of one), lists of B values: ``i0``, the
    first sample read (ceil((listen start − t0)·fs)); ``t0_s``, the time of that sample [s];
    ``cmd_end_s``, the command's end [s]; ``carrier``, the reader's own baseband during the reply
    (``tx.samples[-1]``)."""
    i0 = [_first_sample(p._listen_s, x.t0_s, x.fs_hz) for p, x in zip(ports, inputs)]
    return (i0, [x.t0_s + i / x.fs_hz for x, i in zip(inputs, i0)], [p.tx.cmd_end_s for p in ports],
            [p.tx.samples[-1] for p in ports])


class _TagIndex(NamedTuple):
    """A tag population's antennas (held: their identities are the keys) and the index of
    each in the population."""

    antennas: tuple
    index: dict


class _LinkPair(NamedTuple):
    """A tag's forward (reader → tag) and backward (tag → reader) links of one draw, with the
    reader antenna they were drawn for (kept alive: its identity is part of the key)."""

    reader_antenna: Any
    forward: Any
    backward: Any


class _HeldConstants(NamedTuple):
    """The narrowband constants of held links between ``reader_antenna`` and ``antennas`` (a tuple,
    held: a hit compares them by identity), one per antenna in that order."""

    reader_antenna: Any
    antennas: tuple
    constants: Sequence


class _EngineLinks:
    """The engine's links for the air step: forward and backward link of each tag from
    ``channel.backscatter_links`` (monostatic), held in ``link_cache`` as described in
    :func:`run_exchange`: ``(tag index, id(reader antenna), carrier)`` → :class:`_LinkPair`,
    ``("index",)`` → a population's :class:`_TagIndex`, ``("held", …)`` → :class:`_HeldConstants`
    (the link cache keeps the antennas it keys by identity alive)."""

    __slots__ = ("channel", "antenna", "rng", "t_s", "cache", "draw", "motions", "index", "backward", "drawn")

    def __init__(self, channel, antenna, reflectors, members, motions, rng, t_s, cache, draw):
        self.channel, self.antenna, self.rng, self.t_s = channel, antenna, rng, t_s
        self.cache, self.draw, self.motions = cache, draw, motions
        if len(reflectors) == 1 and hasattr(reflectors[0], "antennas"):  # a tag population: index kept
            ants = reflectors[0].antennas
            hit = cache.get(("index",)) if cache is not None else None
            if hit is None or hit.antennas is not ants:
                hit = _TagIndex(antennas=ants, index={id(a): i for i, a in enumerate(ants)})
                if cache is not None:
                    cache[("index",)] = hit
            self.index = hit.index
        else:
            self.index = ({id(members[0].antenna): 0} if len(members) == 1
                          else {id(t.antenna): i for i, t in enumerate(members)})
        self.backward: dict = {}
        self.drawn: dict = {}  # id(tag antenna) -> _LinkPair of this step's draw (drawn once per step)
        if draw and cache:  # a new draw: the held constants of the previous one are void
            for key in [k for k in cache if k[0] == "held"]:
                del cache[key]

    def paths(self, tx, rx, *, fc_hz, t_s):
        if tx is self.antenna:
            i = self.index.get(id(rx))
            if i is None:
                return None
            links = self.drawn.get(id(rx))
            if links is None:
                links = self._draw(i, rx, fc_hz, t_s)
            return links.forward
        if rx is self.antenna:
            hit = self.backward.get(id(tx))
            if hit is None and self.cache is not None and not self.draw:  # after held_constants
                i = self.index.get(id(tx))
                links = self._held_pair((i, id(self.antenna), fc_hz)) if i is not None else None
                if links is None and i is not None:  # held as constants only (a bulk hop): the link now
                    self.paths(self.antenna, tx, fc_hz=fc_hz, t_s=t_s)
                    links = self._held_pair((i, id(self.antenna), fc_hz))
                hit = links.backward if links is not None else None
            return hit
        return None

    def held_constants(self, antenna, others, *, fc_hz, bandwidth_hz, propagation, inbound):
        """The narrowband constants of the held links between the reader ``antenna`` and the
        tag antennas ``others`` (forward, or backward with ``inbound``), in that order; None
        unless every one of them is narrowband and static, no tag moves, and the links are
        held in the link cache or drawn now (a new draw: each tag's links drawn here in the
        order of ``others``, the members' order in which the air step would ask them, and held
        for the step). Remembered in the link cache for the round's draw: the Query's
        constants serve its ACK (the channel holds one draw per round). Where every tag's backward
        link is its forward link (a reciprocal channel's monostatic pair), the constants of both
        directions are the same numbers and are remembered for both at once."""
        if self.motions is not None or antenna is not self.antenna or (self.cache is None and not self.draw):
            return None
        inbound = bool(inbound)
        key = ("held", id(antenna), fc_hz, bandwidth_hz, propagation, inbound, len(others))
        cache = self.cache
        hit = cache.get(key) if cache is not None else None
        if hit is not None and hit.reader_antenna is antenna and (
                hit.antennas is others or all(map(operator.is_, hit.antennas, others))):
            return hit.constants  # (the key holds the count: the antennas compared one by one)
        out = []
        reciprocal = True  # every pair's backward link is its forward link
        index, draw = self.index, self.draw
        for ant in others:
            i = index.get(id(ant))
            links = self._pair(i, ant, fc_hz) if i is not None else None
            if links is None and draw:  # a tag the engine does not know: the step asks it (an error)
                return None
            if links is None:  # not held at this carrier: every constant at once, if the channel can
                out = self._bulk_constants(others, fc_hz, bandwidth_hz, propagation, inbound)
                if out is None:
                    return None
                reciprocal = False
                break
            link = links.backward if inbound else links.forward
            reciprocal = reciprocal and links.backward is links.forward
            f = getattr(link, "narrowband_constant", None)
            c = f(fc_hz, bandwidth_hz, propagation) if f is not None else None
            if c is None:
                return None
            out.append(c)
        if cache is not None:
            entry = cache[key] = _HeldConstants(reader_antenna=antenna, antennas=tuple(others), constants=out)
            if reciprocal:  # the other direction: the same links, the same constants
                cache[key[:5] + (not inbound, key[6])] = entry
        return out

    def _draw(self, i: int, rx, fc_hz, t_s) -> _LinkPair:
        """Tag i's (antenna ``rx``) links: held in the link cache (no new draw, no motion), else
        drawn from the channel (``backscatter_links``, with the step's generator on a new draw)
        and held for the step (and in the link cache when the tag does not move)."""
        motion = self.motions[i] if self.motions is not None else None
        links = None
        if self.cache is not None:
            key = (i, id(self.antenna), fc_hz)
            if motion is None and not self.draw:
                links = self._held_pair(key)
        if links is None:
            forward, backward = self.channel.backscatter_links(self.antenna, rx, fc_hz=fc_hz, rng=self.rng,
                                                               t_s=t_s, tag_motion=motion)
            links = _LinkPair(reader_antenna=self.antenna, forward=forward, backward=backward)
            if self.cache is not None and motion is None:
                self.cache[key] = links
        self.drawn[id(rx)] = links
        self.backward[id(rx)] = links.backward
        return links

    def _pair(self, i: int, ant, fc_hz) -> _LinkPair | None:
        """Tag i's (antenna ``ant``) links for :meth:`held_constants`: on a new draw drawn now (each
        tag once per step, in the order asked: the members' order, as the air step asks its
        links), else the held ones (None when not held at this carrier)."""
        if self.draw:
            hit = self.drawn.get(id(ant))
            return hit if hit is not None else self._draw(i, ant, fc_hz, self.t_s)
        return self._held_pair((i, id(self.antenna), fc_hz))

    def _bulk_constants(self, others, fc_hz, bandwidth_hz, propagation, inbound) -> list | None:
        """The constants of the static links between the reader antenna and every tag antenna of
        ``others`` from the channel at once (``static_constants``, rfsim.channels.scene.Channel:
        the numbers of the links' own ``narrowband_constant``, bit for bit), or None. Only for a
        channel without random part (whose links are the same with or without a draw) and tags
        that are all the engine's; the links themselves are formed when a tag asks for them
        (:meth:`paths`)."""
        bulk = getattr(self.channel, "static_constants", None)
        if bulk is None or getattr(self.channel, "has_random_part", True) is not False:
            return None
        if any(self.index.get(id(a)) is None for a in others):
            return None
        return bulk(self.antenna, others, fc_hz=fc_hz, bandwidth_hz=bandwidth_hz, propagation=propagation,
                    inbound=inbound)

    def _held_pair(self, key) -> _LinkPair | None:
        """The held links of ``key`` = (tag index, id(reader antenna), carrier), None unless
        held for this reader antenna (the entry keeps it: an id is only its own while alive)."""
        hit = self.cache.get(key)
        return hit if hit is not None and hit.reader_antenna is self.antenna else None


def singulate(reader, tags: Sequence, channel, *, t_s: float, rng: np.random.Generator,
              query, round_index: int = 0, motions: Sequence | None = None,
              epc_bits: int = 128, draw_channel: bool = True) -> list[Exchange]:
    """Run one inventory round of a Q = 0 Query: Query → RN16 → ACK → PC+EPC+CRC.

    The ACK is sent whenever the *reader* accepted an RN16 (its preamble was found) — as a real
    reader does, it cannot know of a collision or a bit error; the ACK then carries the RN16 it
    decoded, and a wrong one gets no reply. It starts T2 (10 Tpri, inside the 3–20 Tpri window of
    EPC Gen2) after the RN16 reply ends. The channel is drawn (when ``draw_channel``) for the
    Query and held for the ACK. The batch of one of :func:`singulate_batch` (the same code).

    Parameters
    ----------
    reader : object
        Reader device (as for :func:`run_exchange`).
    tags : sequence
        The tags (as for :func:`run_exchange`).
    channel : object
        Link model (as for :func:`run_exchange`).
    t_s : float
        Start time of the Query [s].
    rng : numpy.random.Generator
        Generator for the channel draw and the receiver noise.
    query : object
        The Query command (Q = 0).
    round_index : int, default 0
        Inventory round (selects the antenna).
    motions : sequence, optional
        Per-tag motion (as for :func:`run_exchange`).
    epc_bits : int, default 128
        Bits of the PC+EPC+CRC reply to the ACK.
    draw_channel : bool, default True
        Draw the channel anew for the Query.

    Returns
    -------
    list of Exchange
        The Query's exchange, and the ACK's when the reader accepted an RN16.
    """
    return singulate_batch(reader, [tags], channel, t_s=t_s, rngs=[rng], query=query, round_index=round_index,
                           motions=motions, epc_bits=epc_bits, draw_channel=draw_channel)[0]


def singulate_batch(reader, tags: Sequence[Sequence], channel, *, t_s, rngs: Sequence[np.random.Generator],
                    query, round_index=0, motions: Sequence | None = None, epc_bits: int = 128,
                    draw_channel: bool = True) -> list[list[Exchange]]:
    """Run B independent singulations (:func:`singulate`) as two batches.

    The Queries of all trials, then the ACKs of the trials whose RN16 the reader accepted (each
    with the RN16 it decoded, T2 after that trial's reply).

    Parameters
    ----------
    reader : object or list
        Reader device; one value or one per trial.
    tags : sequence of sequence
        B sequences of tags, trial b's tags.
    channel : object or list
        Link model; one value or one per trial.
    t_s : float or list of float
        Start time of the Query [s]; one value or one per trial.
    rngs : sequence of numpy.random.Generator
        B generators, trial b's channel draw and noise.
    query : object or list
        The Query command; one value or one per trial.
    round_index : int or list of int, default 0
        Inventory round; one value or one per trial.
    motions : sequence, optional
        Per-tag motion (the same for every trial).
    epc_bits : int, default 128
        Bits of the PC+EPC+CRC reply to the ACK.
    draw_channel : bool, default True
        Draw the channel anew for the Queries.

    Returns
    -------
    list of list of Exchange
        Per trial its exchanges (one or two).

    Raises
    ------
    ValueError
        One reader shared by several trials while it searches the BLF (``blf_search``: it keeps
        the RN16's BLF for the ACK).
    """
    n = len(rngs)
    readers = _per_trial(reader, n, "reader")
    distinct = {id(r): r for r in readers}  # (each reader asked once)
    if len(distinct) < n and any([r.config.blf_search != "off" for r in distinct.values()]):
        raise ValueError("reader: a reader with blf_search keeps the RN16's BLF for the ACK; give one reader per "
                         "trial")
    caches = [{} for _ in range(n)]  # each trial's Query draw, held for its ACK
    first = run_exchanges(readers, tags, channel, query, t_s=t_s, rngs=rngs, reply_bits=16, expect_crc=False,
                          motions=motions, round_index=round_index, draw_channel=draw_channel, link_caches=caches)
    go = [b for b, ex in enumerate(first) if ex.read is not None and ex.read.success]
    out = [[ex] for ex in first]
    if not go:
        return out
    channels, rounds = _per_trials(n, channel=channel, round_index=round_index)
    acks, t_acks = [], []
    ack_delays: dict = {}  # id(reader) -> its _AckDelays (the readers are held by ``readers``)
    for b in go:
        acks.append(ACK(bits_to_int(first[b].read.bits)))
        delays = ack_delays.get(id(readers[b]))
        if delays is None:
            delays = ack_delays[id(readers[b])] = _link_time(readers[b], _ack_delays)
        t_acks.append(first[b].read.start_s + delays.reply_s + delays.t2_s)
    second = run_exchanges([readers[b] for b in go], [tags[b] for b in go], [channels[b] for b in go], acks,
                           t_s=t_acks, rngs=[rngs[b] for b in go], reply_bits=epc_bits, expect_crc=True,
                           motions=motions, round_index=[rounds[b] for b in go], draw_channel=False,
                           link_caches=[caches[b] for b in go])
    for b, ex in zip(go, second):
        out[b].append(ex)
    return out


__all__ = ["Exchange", "FAILURE_REASONS", "PROPAGATION_METHODS", "ReaderPort", "run_exchange", "run_exchanges",
           "singulate", "singulate_batch"]

"""Reader inventory control: Gen2 rounds with the Q algorithm over an air interface.

The controller (:func:`run_inventory`) is the reader's MAC (gen2-and-validation-anchors.md
§4.4–4.6). A round starts with a Query of Q = round(Qfp); every tag loads a slot counter
uniformly from [0, 2^Q − 1] and replies with an RN16 when it reaches 0. Per slot the reader

* receives the slot's RN16 window; if it decodes an RN16 it sends ACK(RN16) T2 after the
  reply; the tag whose RN16 it is answers with PC + EPC + CRC-16 (others go to Arbitrate);
* checks the CRC-16: a good EPC is a *read*; a bad one is NAKed (tag back to Arbitrate);
* classifies the slot as the reader sees it: ``empty`` (no RN16 preamble), ``success`` (EPC
  read) or ``collision`` (an RN16 was detected but no EPC was read);
* Q algorithm (anchors §4.5, the standard's example): collision → Qfp = min(15, Qfp + C),
  empty → Qfp = max(0, Qfp − C), success → unchanged; when round(Qfp) ≠ Q it sends
  QueryAdjust (UpDn ±1: every tag in Arbitrate/Reply redraws its counter in 2^Q' slots),
  otherwise a QueryRep. Fixed-Q mode never adjusts.
* A round ends when its frame (2^Q slots after the last Query/QueryAdjust) is used up; the
  next round starts with a new Query. The inventory stops after a round in which the reader
  detected no reply at all ("rounds until no reply"); in dual-target mode it then flips the
  Query target A ↔ B (tags read in the last pass answer again) until ``target_switches``
  flips have been made.

Timing (anchors §4.3, §4.6): the reader starts its next command T2 (``t2_tpri`` Tpri) after
the end of a detected reply, and max(T1max + T3, T4) after the end of its command when it
detected nothing. Each command segment starts with one Tari of CW before the delimiter
(``Reader.transmit``), which lies inside the preceding gap. A slot lasts from its command's
start to the next command's start: an empty slot command + max(T1max + T3, T4), a collided
slot command + T1 + RN16 + T2 (+ the ACK exchange when the reader decoded garbage bits from
the collision and ACKed them), a successful one adds ACK + T1 + EPC + T2.
Durations come from the exchanges themselves (command durations of the link profile, reply
starts as detected by the receiver); silent time is skipped, not sampled.

Air interfaces (anything with ``link`` and ``exchange(...) -> AirExchange``):

* :class:`EngineAir` — sample level, through :func:`rfsim.protocols.engine.run_exchange`: the reader's
  waveform, every tag's front end and state machine, superposition of all replies at the
  reader, the receiver's preamble detection and decoding. Capture, collisions and CRC errors
  emerge from the waveforms.
* :class:`ProtocolAir` — protocol level: the same tag state machines driven with the command
  objects, no waveforms; a slot with exactly one reply is decoded, two or more are a
  collision that is never decoded (no capture) and that the reader does not ACK. Timing
  uses the nominal T1 and BLF. It reproduces the slot statistics of the Gen2 MAC at a
  fraction of the cost; slot durations of collided slots differ from the sample level when
  the sample-level reader ACKs bits decoded from a collision. Given the tags' state in
  arrays (``arrays=``, e.g. ``rfsim.devices.gen2_tag_arrays.StateArrays``) it applies each
  command's silent steps, and a QueryAdjust's new slot counters, to all tags at once and
  drives only the others one by one (the same outcome, tag states and draws).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple

import numpy as np

from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.core.records import READ_MEASUREMENT_FIELDS
from rfsim.core.lazy import lazy_import

_bits = lazy_import("rfsim.gen2.bits")
_commands = lazy_import("rfsim.gen2.commands")
_crc = lazy_import("rfsim.gen2.crc")
_link = lazy_import("rfsim.gen2.link")

#: Reader-side slot classes (what the Q algorithm sees).
READER_VIEWS = ("empty", "success", "collision")
#: Slot types with the ground truth (number of tags that replied with an RN16):
#: empty (0, nothing detected), false_alarm (0, something detected), success (1 reply, EPC
#: read), capture (≥ 2 replies, one EPC read), collision (≥ 2, none read), lost (1, not read).
SLOT_TYPES = ("empty", "false_alarm", "success", "capture", "collision", "lost")


@dataclass(frozen=True)
class InventoryConfig:
    """Reader inventory settings (validated; errors name ``inventory.<key>``)."""

    q_mode: Literal["dynamic", "fixed"] = param("dynamic", doc="Q algorithm or fixed Q")
    q_initial: float = param(4.0, lo=0.0, hi=15.0, doc="initial Qfp (fixed mode: Q = round(q_initial))")
    c: float = param(0.3, lo=0.0, hi=1.0, lo_open=True, hi_open=True, doc="Q-algorithm step C")
    session: int = param(0, lo=0, hi=3, doc="inventory session S0–S3")
    sel: Literal["all", "sl", "~sl"] = param("all", doc="Query Sel field")
    target: Literal["A", "B"] = param("A", doc="initial Query target")
    target_switches: int = param(0, lo=0, hi=1000,
                                 doc="dual target: A↔B flips after a round without replies (0 = single target)")
    select_before_round: bool = param(False, doc="send a Select that sets every tag's session flag to the "
                                                 "target before each Query (repeatable frames)")
    select_mask: str = param("", doc="Select mask ('0'/'1' string) on the EPC bank asserting SL on matching tags "
                                     "at the start (sent when non-empty or sel is not 'all')")
    select_pointer: int = param(32, lo=0, hi=496, doc="bit address of the Select mask in the EPC bank (EPC at 20h)")
    t2_tpri: float = param(10.0, lo=3.0, hi=20.0, unit="Tpri", doc="T2: reply end → next command")
    t3_s: float = param(0.0, lo=0.0, hi=1e-3, unit="s", doc="T3: extra wait after T1 when nothing was detected")
    epc_reply_bits: int = param(128, lo=32, hi=528, doc="PC + EPC + CRC-16 bits of the ACK reply")
    max_rounds: int = param(10000, lo=1, hi=10**7, doc="stop after this many rounds")
    max_slots: int = param(100000, lo=1, hi=10**8, doc="stop after this many slots")

    def __post_init__(self):
        check_fields(self, "inventory")
        if any(ch not in "01" for ch in self.select_mask) or len(self.select_mask) > 255:
            raise ConfigError("inventory.select_mask", self.select_mask, "at most 255 '0'/'1' characters")


class AirExchange(NamedTuple):
    """One reader command and what the reader got back (both air interfaces).

    An immutable record, one per command; its fields are listed once, here (a named tuple:
    made at a third of a frozen dataclass's cost). Compared by identity, not by value (its
    ``bits`` are an array).

    Attributes
    ----------
    command : str
        Command name.
    time_s : float
        Start of the reader's segment [s] (one Tari of CW, then the command).
    cmd_end_s : float
        Last rising edge of the command [s].
    replied : tuple of int
        Indices of the tags that replied (ground truth).
    detected : bool
        The receiver found a reply preamble.
    bits : ndarray, shape (n,), uint8, or None
        Decoded bits.
    success : bool
        Decoded (and CRC-16 correct where expected).
    failure_reason : str
        ``""`` or the reason (see :data:`rfsim.protocols.engine.FAILURE_REASONS`).
    reply_start_s : float
        Detected reply start [s] (NaN when nothing was detected).
    antenna : int
        0-based reader antenna.
    channel_index : int
        1-based channel index of the frequency plan.
    fc_hz : float
        Carrier [Hz].
    read : object or None
        The receiver's ReadResult (sample level) or None.
    incident_power_dbm : tuple of float
        (n_tags,) CW power at each tag [dBm] (NaN at protocol level).
    """

    command: str
    time_s: float
    cmd_end_s: float
    replied: tuple[int, ...]
    detected: bool
    bits: np.ndarray | None
    success: bool
    failure_reason: str
    reply_start_s: float
    antenna: int = 0
    channel_index: int = 0
    fc_hz: float = math.nan
    read: Any = None
    incident_power_dbm: tuple[float, ...] = ()

    # by identity, as a record of one command (a tuple's value comparison would compare arrays)
    __eq__ = object.__eq__
    __ne__ = object.__ne__
    __hash__ = object.__hash__


# ============================================================================ records


SLOT_FIELDS = {
    "time_s": ("s", "start of the slot's first command segment"),
    "duration_s": ("s", "air time of the slot (until the next command starts)"),
    "round": ("1", "inventory round (one Query each)"),
    "slot": ("1", "slot index within the round"),
    "q": ("1", "Q of the slot's frame"),
    "qfp": ("1", "Q algorithm's floating-point Qfp after the slot"),
    "command": ("", "command that opened the slot (Query, QueryRep, QueryAdjust)"),
    "target": ("", "Query target (A/B)"),
    "antenna": ("1", "reader antenna port (1-based)"),
    "slot_type": ("", "empty/false_alarm/success/capture/collision/lost (ground truth + reader)"),
    "reader_view": ("", "empty/success/collision as the reader sees it (drives the Q algorithm)"),
    "n_replies": ("1", "number of tags that replied with an RN16 (ground truth)"),
    "epc_hex": ("", "EPC read in the slot ('' if none)"),
    "tag": ("1", "index of the tag read (-1 if none)"),
}

READ_FIELDS = {
    "time_s": ("s", "start of the ACK segment of the read"),
    "round": ("1", "inventory round (one Query and its QueryReps) of the read, 0-based"),
    "slot": ("1", "slot index within the round"),
    "tag": ("1", "index of the tag that answered the ACK (-1 if not unique)"),
    "epc_hex": ("", "EPC decoded (CRC-16 ok)"),
    **READ_MEASUREMENT_FIELDS,
    "n_replies": ("1", "tags that replied in the RN16 slot (> 1: capture)"),
    "tag_incident_power_dbm": ("dBm", "CW power incident at the read tag (ACK)"),
}


@dataclass(eq=False)
class InventoryLog:
    """Records of one inventory: per-slot and per-read columns (lists) and the time span.

    Attributes
    ----------
    slots : dict of str to list
        One column per entry of :data:`SLOT_FIELDS`, one row per slot.
    reads : dict of str to list
        One column per entry of :data:`READ_FIELDS`, one row per read.
    t0_s : float
        Start time of the inventory [s].
    t_end_s : float
        End of the last slot [s] (NaN until the inventory ends).
    """

    slots: dict[str, list]
    reads: dict[str, list]
    t0_s: float
    t_end_s: float = math.nan

    @property
    def n_slots(self) -> int:
        """Number of slots recorded."""
        return len(self.slots["time_s"])

    @property
    def air_time_s(self) -> float:
        """Total air time [s] from the first command to the end of the last slot."""
        return self.t_end_s - self.t0_s

    def tags_read(self) -> set[int]:
        """Return the indices of the tags read at least once.

        Returns
        -------
        set of int
            Tag indices (ground truth of the reads; reads without a unique tag are left out).
        """
        return {t for t in self.reads["tag"] if t >= 0}

    def completion(self, n_tags: int) -> tuple[int, float] | None:
        """Return the slots and air time until a number of distinct tags was read.

        Parameters
        ----------
        n_tags : int
            Number of distinct tags to be read.

        Returns
        -------
        tuple of (int, float) or None
            (slots, air time [s] from ``t0_s`` to the end of that slot), or None when fewer tags
            were read.
        """
        seen: set[int] = set()
        for k, (tag, t, d) in enumerate(zip(self.slots["tag"], self.slots["time_s"], self.slots["duration_s"])):
            if tag >= 0:
                seen.add(tag)
                if len(seen) >= n_tags:
                    return k + 1, t + d - self.t0_s
        return None

    def counts(self, column: str = "slot_type") -> dict[str, int]:
        """Count the slots per value of a column.

        Parameters
        ----------
        column : {"slot_type", "reader_view"}, default "slot_type"
            The column: the slot types with ground truth (:data:`SLOT_TYPES`) or the reader's view
            (:data:`READER_VIEWS`).

        Returns
        -------
        dict of str to int
            Number of slots per value, every value of the column's set present.
        """
        vals = self.slots[column]
        return {v: vals.count(v) for v in (SLOT_TYPES if column == "slot_type" else READER_VIEWS)}


def _slot_type(n_replies: int, detected: bool, read: bool) -> str:
    if read:
        return "success" if n_replies == 1 else "capture"
    if n_replies == 0:
        return "false_alarm" if detected else "empty"
    return "collision" if n_replies >= 2 else "lost"


def epc_hex_of(bits: np.ndarray) -> str:
    """Return the EPC of a PC + EPC + CRC-16 reply as upper-case hex.

    The 16 PC bits and the 16 CRC bits are removed; the EPC bits are read MSB first, four per
    hex digit (trailing bits short of a digit are left out).

    Parameters
    ----------
    bits : array_like, shape (n,), uint8
        The reply bits, 0/1.

    Returns
    -------
    str
        The EPC in hex; ``''`` for fewer than 48 bits.
    """
    b = np.asarray(bits, dtype=np.uint8)
    if b.size < 48:
        return ""
    epc = _bits.as_bits(b[16:-16])
    nibbles = epc[:epc.size - epc.size % 4].reshape(-1, 4) @ _NIBBLE_WEIGHTS  # MSB first
    return "".join(map("0123456789ABCDEF".__getitem__, nibbles.tolist()))


_NIBBLE_WEIGHTS = np.array([8, 4, 2, 1], dtype=np.int64)


def _epc_hex(bits: np.ndarray, memo: dict) -> str:
    """:func:`epc_hex_of` of ``bits``, kept in ``memo`` by the bits' dtype and bytes (a tag's
    EPC is read again and again)."""
    b = np.asarray(bits)
    key = (b.dtype.str, b.tobytes())
    epc = memo.get(key)
    if epc is None:
        epc = memo[key] = epc_hex_of(b)
    return epc


# ============================================================================ controller


class _Clock:
    """Reader timing rules (module docstring): when the next command starts."""

    def __init__(self, link, config: InventoryConfig):
        self.link = link
        self.t2_s = config.t2_tpri * link.tpri_s
        self.idle_s = max(_link.t1(link).max_s + config.t3_s, 2.0 * link.rtcal_s)  # max(T1max + T3, T4)
        self.lead_s = link.tari_s  # CW before the delimiter (Reader.transmit default)
        self._reply_s: dict = {}  # nominal reply duration per reply length (a pure function of the link)

    def next_command_s(self, ex: AirExchange, reply_bits: int) -> float:
        if ex.detected and math.isfinite(ex.reply_start_s):
            duration = self._reply_s.get(reply_bits)
            if duration is None:
                duration = self._reply_s[reply_bits] = self.link.reply_duration_s(reply_bits)
            blf = getattr(ex.read, "blf_hz", math.nan)  # the BLF the reader measured, if it did
            if blf > 0:
                duration *= self.link.blf_hz / blf
            return ex.reply_start_s + duration + self.t2_s
        return ex.cmd_end_s + self.idle_s


def _round_half_up(x: float) -> int:
    """Q = round(Qfp) with halves rounded up (Python's round() would round 2.5 to 2)."""
    return int(math.floor(x + 0.5))


def run_inventory(air, config: InventoryConfig = InventoryConfig(), *, t0_s: float = 0.0,
                  on_round: Callable[[int, float], None] | None = None) -> InventoryLog:
    """Inventory the tags behind an air interface with the Q algorithm (module docstring).

    Gen2 rounds and the Q algorithm of gen2-and-validation-anchors.md §4.4–4.6, timing of §4.3,
    §4.6.

    Parameters
    ----------
    air : EngineAir, ProtocolAir or object
        Has ``link`` and ``exchange(cmd, *, t_s, reply_bits, expect_crc, round_index,
        new_round)`` → :class:`AirExchange`.
    config : InventoryConfig, default InventoryConfig()
        Inventory settings.
    t0_s : float, default 0.0
        Start time of the first command segment [s].
    on_round : callable, optional
        Called as ``on_round(round_index, t_s)`` before each round (e.g. to interrupt the CW or
        move tags).

    Returns
    -------
    InventoryLog
        One row per slot and one per read.
    """
    link = air.link
    clock = _Clock(link, config)
    log = InventoryLog({k: [] for k in SLOT_FIELDS}, {k: [] for k in READ_FIELDS}, float(t0_s))
    qfp = float(config.q_initial)
    target = config.target
    switches = 0
    t_cmd = float(t0_s) + clock.lead_s  # start of the next command (its delimiter)
    n_slots = 0
    # the commands are immutable: one QueryRep, and one QueryAdjust per UpDn, for the inventory
    rep = _commands.QueryRep(session=config.session)
    adjust: dict[int, Any] = {}
    epcs: dict = {}  # the EPC (hex) of each distinct reply read
    # each slot's values are appended to the columns in the order of SLOT_FIELDS
    slot_columns = [log.slots[k].append for k in SLOT_FIELDS]
    if config.select_mask or config.sel != "all":
        # assert SL on matching tags, deassert it on the others (Select action 0)
        sel = _commands.Select(target=4, action=0, membank=1, pointer=config.select_pointer, mask=config.select_mask)
        ex = air.exchange(sel, t_s=t_cmd - clock.lead_s, reply_bits=16, expect_crc=False, round_index=0,
                          new_round=True)
        t_cmd = clock.next_command_s(ex, 16)
    for rnd in range(config.max_rounds):
        if on_round is not None:
            on_round(rnd, t_cmd - clock.lead_s)
        new_round = True
        if config.select_before_round:
            sel = _commands.Select(target=config.session, action=0 if target == "A" else 4, membank=1, pointer=32, mask="")
            ex = air.exchange(sel, t_s=t_cmd - clock.lead_s, reply_bits=16, expect_crc=False,
                              round_index=rnd, new_round=True)
            t_cmd = clock.next_command_s(ex, 16)
            new_round = False
        q = _round_half_up(qfp) if config.q_mode == "dynamic" else _round_half_up(config.q_initial)
        cmd = _commands.Query(dr=link.dr, m=link.m, trext=link.trext, sel=config.sel, session=config.session,
                              target=target, q=q)
        frame_left = 1 << q
        detected_any = False
        slot = 0
        while True:
            t_slot = t_cmd - clock.lead_s
            view, t_cmd, read_ex, first = _slot(air, cmd, t_slot, rnd, new_round, clock, config)
            new_round = False
            detected_any |= first.detected
            n_rep = len(first.replied)
            stype = _slot_type(n_rep, first.detected, read_ex is not None)
            if config.q_mode == "dynamic":
                if view == "collision":
                    qfp = min(15.0, qfp + config.c)
                elif view == "empty":
                    qfp = max(0.0, qfp - config.c)
            tag = read_ex.replied[0] if read_ex is not None and len(read_ex.replied) == 1 else -1
            epc = _epc_hex(read_ex.bits, epcs) if read_ex is not None else ""
            for add, value in zip(slot_columns, (t_slot, (t_cmd - clock.lead_s) - t_slot, rnd, slot, q, qfp,
                                                 first.command, target, first.antenna + 1, stype, view, n_rep,
                                                 epc, tag)):
                add(value)
            if read_ex is not None:
                _append_read(log.reads, read_ex, rnd, slot, tag, epc, n_rep)
            slot += 1
            n_slots += 1
            frame_left -= 1
            if n_slots >= config.max_slots:
                break
            q_new = _round_half_up(qfp)
            if config.q_mode == "dynamic" and q_new != q:
                updn = 1 if q_new > q else -1
                q += updn
                cmd = adjust.get(updn)
                if cmd is None:
                    cmd = adjust[updn] = _commands.QueryAdjust(session=config.session, updn=updn)
                frame_left = 1 << q
            elif frame_left > 0:
                cmd = rep
            else:
                break
        if n_slots >= config.max_slots:
            break
        if not detected_any:
            if switches >= config.target_switches:
                break
            switches += 1
            target = "B" if target == "A" else "A"
    log.t_end_s = t_cmd - clock.lead_s
    return log


def _slot(air, cmd, t_s: float, rnd: int, new_round: bool, clock: _Clock, config: InventoryConfig):
    """One slot: RN16 window, ACK if an RN16 was decoded, NAK on a bad EPC CRC.

    Returns (reader view, start of the next command [s], the EPC exchange if read, the
    RN16 exchange).
    """
    first = air.exchange(cmd, t_s=t_s, reply_bits=16, expect_crc=False, round_index=rnd, new_round=new_round)
    t_next = clock.next_command_s(first, 16)
    if not first.detected:
        return "empty", t_next, None, first
    if not first.success or first.bits is None:
        return "collision", t_next, None, first
    ack = _commands.ACK(_bits.bits_to_int(first.bits))
    second = air.exchange(ack, t_s=t_next - clock.lead_s, reply_bits=config.epc_reply_bits, expect_crc=True,
                          round_index=rnd, new_round=False)
    t_next = clock.next_command_s(second, config.epc_reply_bits)
    if second.success:
        return "success", t_next, second, first
    if second.detected:  # EPC with a bad CRC-16: NAK returns the tag to Arbitrate
        nak = air.exchange(_commands.NAK(), t_s=t_next - clock.lead_s, reply_bits=16, expect_crc=False,
                           round_index=rnd, new_round=False)
        t_next = clock.next_command_s(nak, 16)
    return "collision", t_next, None, first


def _append(rows: dict[str, list], **values) -> None:
    for k, v in values.items():
        rows[k].append(v)


def _append_read(rows, ex: AirExchange, rnd: int, slot: int, tag: int, epc: str, n_rep: int) -> None:
    r = ex.read
    nan = math.nan
    inc = ex.incident_power_dbm[tag] if (tag >= 0 and ex.incident_power_dbm) else nan
    _append(rows, time_s=ex.time_s, round=rnd, slot=slot, tag=tag, epc_hex=epc, antenna=ex.antenna + 1,
            channel_index=ex.channel_index, frequency_hz=ex.fc_hz,
            rssi_dbm=r.rssi_dbm if r is not None else nan, phase_rad=r.phase_rad if r is not None else nan,
            doppler_hz=r.doppler_hz if r is not None else nan, snr_db=r.snr_db if r is not None else nan,
            n_replies=n_rep, tag_incident_power_dbm=inc)


# ============================================================================ protocol level


class ProtocolAir:
    """Protocol-level air interface: Gen2 tag state machines, no waveforms.

    A slot with exactly one reply is decoded (its bits are the tag's reply bits, the reply
    starts at the nominal T1 = max(RTcal, 10·Tpri) after the command); two or more replies are a
    detected, undecodable collision (no capture).

    Parameters
    ----------
    link : rfsim.gen2.link.LinkProfile
        The link profile (timing).
    tags : sequence
        PassiveTag-like objects (``state``, ``rng``) or (TagState, Generator) pairs; each tag
        keeps its own generator.
    powered : callable, optional
        ``powered(t_s)`` → (n_tags,) bool; None: every tag powered. A tag that becomes unpowered
        loses its round state (``TagState.on_power``).
    arrays : callable, optional
        ``arrays(states, rngs)`` → the tags' Gen2 state in arrays
        (``rfsim.devices.gen2_tag_arrays.StateArrays``, or anything with its methods). With it and
        without ``powered``, each command's silent steps (and a QueryAdjust's new slot counters,
        when every tag has a generator of its own) are applied to all tags at once and only the
        other tags are driven one by one: the same replies, tag states and draws (module
        ``rfsim.devices.gen2_tag_arrays``), at a cost per command that does not grow with the
        tags that stay silent. Between exchanges change the tags only through the air, or call
        :meth:`refresh`.
    """

    def __init__(self, link, tags: Sequence, *, powered: Callable[[float], np.ndarray] | None = None,
                 arrays: Callable | None = None):
        self.link = link
        self._tags = [(t.state, t.rng) if hasattr(t, "state") else (t[0], t[1]) for t in tags]
        self.powered = powered
        self._t1_s = max(link.rtcal_s, 10.0 * link.tpri_s)
        self._make_arrays = arrays
        self._arrays = None
        self.refresh()

    def refresh(self) -> None:
        """Read every tag's state into the arrays again (after changing the tags' states from
        outside the air); nothing to do without ``arrays``."""
        if self._make_arrays is None or not self._tags:
            return
        states, rngs = [s for s, _ in self._tags], [g for _, g in self._tags]
        own = len(set(map(id, rngs))) == len(rngs) and None not in rngs
        self._arrays = self._make_arrays(states, rngs if own else None)
        self._own_rngs = own
        self._nobody = np.zeros(len(states), bool)

    @property
    def states(self) -> list:
        """The tags' Gen2 states (``TagState``), in tag order."""
        return [s for s, _ in self._tags]

    def exchange(self, cmd, *, t_s: float, reply_bits: int, expect_crc: bool, round_index: int = 0,
                 new_round: bool = False) -> AirExchange:
        """Drive every powered tag's state machine with one command and judge the slot.

        Parameters
        ----------
        cmd : object
            The Gen2 command (:mod:`rfsim.gen2.commands`).
        t_s : float
            Start of the reader's segment [s] (one Tari of CW, then the command).
        reply_bits : int
            Bits of the expected reply (16 for an RN16, PC+EPC+CRC after an ACK).
        expect_crc : bool
            Whether the reply carries a CRC-16.
        round_index : int, default 0
            Inventory round (selects the reader antenna).
        new_round : bool, default False
            The command opens a new round (not used at protocol level).

        Returns
        -------
        AirExchange
            No reply: not detected, ``"no reply"``; two or more: detected, ``"collision"``; one:
            decoded, ``success`` when no CRC is expected or the CRC-16 is correct.
        """
        lk = self.link
        cmd_end = float(t_s) + lk.tari_s + lk.command_duration_s(cmd)
        if self._make_arrays is not None and self.powered is None and self._tags:
            if self._arrays is None:  # tags driven one by one since the arrays were read
                self.refresh()
            replies = self._drive_arrays(cmd, float(t_s), cmd_end)
        else:
            self._arrays = None
            mask = np.ones(len(self._tags), bool) if self.powered is None else np.asarray(self.powered(t_s), bool)
            replies = []
            for i, (state, rng) in enumerate(self._tags):
                if not mask[i]:
                    state.on_power(False, t_s)
                    continue
                if not state.powered:
                    state.on_power(True, t_s)
                reply = state.on_command(cmd, t_s=cmd_end, rng=rng)
                if reply is not None:
                    replies.append((i, reply))
        replied = tuple(i for i, _ in replies)
        nan = math.nan
        if not replies:
            return AirExchange(type(cmd).__name__, float(t_s), cmd_end, (), False, None, False, "no reply", nan)
        start = cmd_end + self._t1_s
        if len(replies) > 1:
            return AirExchange(type(cmd).__name__, float(t_s), cmd_end, replied, True, None, False,
                               "collision", start)
        bits = replies[0][1].bits
        ok = (not expect_crc) or _crc.crc16_ok(bits)
        return AirExchange(type(cmd).__name__, float(t_s), cmd_end, replied, True, bits, ok,
                           "" if ok else "crc error", start)

    def _drive_arrays(self, cmd, t_s: float, cmd_end_s: float) -> list:
        """Every tag powered: the silent steps and a QueryAdjust's redraws at once, the other
        tags one by one in tag order (powering up first where unpowered). Returns the
        ``(tag, reply)`` pairs in tag order."""
        arrays = self._arrays
        # the powered tags' silent steps and redraws in one pass; the unpowered ones react
        done = arrays.step_silently(cmd, arrays.powered, self._nobody, cmd_end_s, redraw=self._own_rngs)
        replies = list(done.replies)
        rest = done.react
        tags = self._tags
        for i in rest:
            state, rng = tags[i]
            if not state.powered:
                state.on_power(True, t_s)
            reply = state.on_command(cmd, t_s=cmd_end_s, rng=rng)
            if reply is not None:
                replies.append((i, reply))
        arrays.read(rest)
        if done.replies and len(replies) > 1:
            replies.sort(key=operator.itemgetter(0))
        return replies


# ============================================================================ sample level


class _RoundLinks(NamedTuple):
    """One held entry of :class:`_RoundChannel`: the antennas whose identities key it (kept
    alive) and the channel's ``(forward, backward)`` links."""

    emitter: object
    tag: object
    receiver: object
    links: tuple


class _RoundChannel:
    """The channel held for a round: the PathSets of each (antenna, tag, fc) are computed once
    and reused until :meth:`clear` (static tags; moving tags are evaluated at every call).
    Entries: ``(id(emitter), id(tag), id(receiver), fc_hz)`` → :class:`_RoundLinks`.

    With a quasi-static channel the links are deterministic functions of the geometry and the
    held diffuse draw, so reusing them is exact; it only saves recomputing geometry.
    """

    def __init__(self, channel):
        self.channel = channel
        self._links: dict = {}

    def clear(self) -> None:
        self._links.clear()

    @property
    def has_random_part(self) -> bool:
        return getattr(self.channel, "has_random_part", True)

    def static_constants(self, emitter, tags, **kw):
        """The channel's ``static_constants`` (the narrowband constants of many static links at
        one carrier at once), or None when it has none."""
        f = getattr(self.channel, "static_constants", None)
        return f(emitter, tags, **kw) if f is not None else None

    def backscatter_links(self, emitter, tag, receiver=None, *, fc_hz, rng=None, t_s=0.0, tag_motion=None,
                          **kw):
        if tag_motion is not None or kw:
            return self.channel.backscatter_links(emitter, tag, receiver, fc_hz=fc_hz, rng=rng, t_s=t_s,
                                                  tag_motion=tag_motion, **kw)
        key = (id(emitter), id(tag), id(receiver), float(fc_hz))
        hit = self._links.get(key) if rng is None else None
        if hit is not None and hit.emitter is emitter and hit.tag is tag and hit.receiver is receiver:
            return hit.links
        out = self.channel.backscatter_links(emitter, tag, receiver, fc_hz=fc_hz, rng=rng, t_s=t_s)
        self._links[key] = _RoundLinks(emitter, tag, receiver, out)
        return out


class EngineAir:
    """Sample-level air interface through :func:`rfsim.protocols.engine.run_exchange`.

    Parameters
    ----------
    reader : rfsim.devices.reader.Reader
        The reader.
    tags : sequence of rfsim.devices.tag.PassiveTag
        The tags, each with its own generator.
    channel : object
        Channel with ``backscatter_links`` (e.g. ``rfsim.channels.Channel``); its random part is
        drawn at the first exchange of every round and held for the round. A channel without
        one (``has_random_part`` False: no diffuse taps, no shadowing field) gives static tags
        the same links in every round, so its links are evaluated once and held across rounds
        while no tag's antenna changes (and without ``motions``), from the first exchange on as
        the narrowband constants of all tags at once where the channel offers them
        (``static_constants``, as at a frequency hop); the records are those of a draw per
        round, bit for bit (the draw takes nothing from ``rng``).
    rng : numpy.random.Generator
        Generator for the channel draws and the receiver noise.
    motions : sequence, optional
        Per-tag motions (see :func:`rfsim.protocols.engine.run_exchange`).
    propagation : {"auto", "exact", "narrowband"}, default "auto"
        Propagation policy.
    fast : bool, default True
        Let tags that see scaled copies of one reader segment share its front-end work
        (``PassiveTag.shared_front_end``, rfsim.devices.tag) and join the air step as one
        population (the tags' ``population``, rfsim.devices.tag_population: the quiet tags of an
        exchange decided at once, their re-radiation one held constant); False makes every tag
        listen to its own samples on every exchange (identical records, slower). Sets the
        attribute on every tag that has it.
    keep_exchanges : bool, default False
        Append every :class:`AirExchange` to ``self.exchanges``.
    """

    def __init__(self, reader, tags: Sequence, channel, *, rng: np.random.Generator, motions=None,
                 propagation: str = "auto", fast: bool = True, keep_exchanges: bool = False):
        from rfsim.protocols.engine import run_exchange

        self._run_exchange = run_exchange
        self.exchanges: list[AirExchange] | None = [] if keep_exchanges else None
        self.reader = reader
        self.tags = list(tags)
        self.link = reader.link
        self.rng = rng
        self.motions = motions
        self.propagation = propagation
        self._channel = _RoundChannel(channel)
        self._round_links: dict = {}  # run_exchange's link_cache: the round's (forward, backward) links
        self._held_antennas: tuple | None = None  # the tag antennas of links held across rounds
        for t in self.tags:
            if hasattr(t, "shared_front_end"):
                t.shared_front_end = bool(fast)
        make = getattr(type(self.tags[0]), "population", None) if (fast and self.tags) else None
        same = make is not None and all(getattr(type(t), "population", None) == make for t in self.tags)
        self._reflectors = [make(self.tags)] if same else self.tags

    def cw_off(self, t_s: float) -> None:
        """Interrupt the reader's CW: every tag loses power.

        Gen2: a tag goes back to Ready, its S0 flag to A; S1–S3 and SL are kept within their
        persistence times.

        Parameters
        ----------
        t_s : float
            Time of the interruption [s].
        """
        for tag in self.tags:
            tag.state.on_power(False, t_s)
        if self._reflectors is not self.tags:
            self._reflectors[0].refresh()

    def exchange(self, cmd, *, t_s: float, reply_bits: int, expect_crc: bool, round_index: int = 0,
                 new_round: bool = False) -> AirExchange:
        """Run one command through the sample-level engine.

        Parameters
        ----------
        cmd : object
            The Gen2 command (:mod:`rfsim.gen2.commands`).
        t_s : float
            Start of the reader's segment [s] (one Tari of CW, then the command).
        reply_bits : int
            Bits of the expected reply (16 for an RN16, PC+EPC+CRC after an ACK).
        expect_crc : bool
            Whether the reply carries a CRC-16.
        round_index : int, default 0
            Inventory round (selects the reader antenna).
        new_round : bool, default False
            The command opens a new round: the channel is drawn anew (and the round's held
            links dropped) unless the held links are still the channel's.

        Returns
        -------
        AirExchange
            The exchange as the reader saw it (``detected`` when it decoded bits), with the
            engine's failure reason.
        """
        draw = new_round and not self._links_still_held()
        if draw:
            self._channel.clear()
            self._round_links.clear()
            self._hold_placements(round_index)
            if self.motions is None and getattr(self._channel.channel, "has_random_part", True) is False:
                # nothing to draw (the draw takes nothing from rng): the static links' constants
                # are asked of the channel at once (its static_constants, as at a frequency hop)
                draw = False
        ex = self._run_exchange(self.reader, self._reflectors, self._channel, cmd, t_s=t_s, rng=self.rng,
                                reply_bits=reply_bits, expect_crc=expect_crc, motions=self.motions,
                                round_index=round_index, draw_channel=draw, propagation=self.propagation,
                                link_cache=self._round_links)
        read = ex.read
        detected = read is not None and read.bits is not None
        cmd_end = ex.cmd_end_s  # t_s + Tari (CW lead-in) + T_cmd, from the reader's segment
        out = AirExchange(ex.command, float(t_s), cmd_end, ex.replied, detected,
                          read.bits if detected else None, bool(read is not None and read.success),
                          ex.failure_reason, read.start_s if detected else math.nan, ex.antenna,
                          ex.channel_index, ex.fc_hz, read, ex.incident_power_dbm)
        if self.exchanges is not None:
            self.exchanges.append(out)
        return out

    def _hold_placements(self, round_index: int) -> None:
        """At a new draw: the carrier-independent geometry of the round's reader antenna →
        tag links of static tags evaluated at once by a channel that offers it
        (``hold_placements``, rfsim.channels.scene.Channel: bit-identical to the link-by-link
        evaluation it replaces)."""
        hold = getattr(self._channel.channel, "hold_placements", None)
        if hold is None or self.motions is not None or not self.tags:
            return
        hold(self.reader.antennas[self.reader.antenna_index(round_index)], [t.antenna for t in self.tags])

    def _links_still_held(self) -> bool:
        """At a new round: whether the held links are still the channel's (a channel without
        random part, no motions, the same tag antennas as when they were evaluated); else
        they are to be drawn again (and the antennas are remembered for the next round)."""
        ants = tuple(t.antenna for t in self.tags)
        held = self._held_antennas
        same = held is not None and len(held) == len(ants) and all(map(operator.is_, held, ants))
        keep = (same and self.motions is None and self._round_links
                and getattr(self._channel.channel, "has_random_part", True) is False)
        self._held_antennas = ants
        return bool(keep)


__all__ = ["InventoryConfig", "AirExchange", "InventoryLog", "EngineAir", "ProtocolAir", "run_inventory",
           "epc_hex_of", "READER_VIEWS", "SLOT_TYPES", "SLOT_FIELDS", "READ_FIELDS"]

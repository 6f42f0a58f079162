"""Gen2 tag state machine as pure logic: states, sessions, flags, slot counter, replies.

No waveforms here: a :class:`TagState` consumes parsed reader commands
(:mod:`rfsim.gen2.commands`) and returns the bits the tag backscatters, or ``None``.
Rules follow the EPC Gen2 protocol ("Tag states and slot counter", "Sessions and
inventoried flags", "Selected flag", the Select/Inventory/Access command sections;
gen2-and-validation-anchors.md §4.4–4.5):

* States: ``ready``, ``arbitrate``, ``reply``, ``acknowledged``, ``open``, ``secured``
  (Open/Secured only as far as Req_RN and Read need them; Killed is not modelled).
* Sessions S0–S3 each hold an inventoried flag ``"A"``/``"B"``; SL is a separate flag.
* Slot counter: Query and QueryAdjust load a value drawn uniformly from [0, 2^Q − 1] with
  the tag's own ``rng``; QueryRep decrements it; the tag backscatters a new RN16 when it
  reaches 0. A tag in Reply that receives a QueryRep goes to Arbitrate with its counter
  at 7FFFh (the standard's wrap-around: no second reply in the round).
* ACK with the tag's RN16 in Reply/Acknowledged → PC + EPC + CRC-16 and Acknowledged; a
  wrong RN16 → Arbitrate, no reply. Req_RN with the RN16 in Acknowledged → handle + CRC-16
  and Secured (access password 0) or Open; with a wrong RN16 it is ignored (state kept, as
  recalled from the standard's state-transition tables, unverified). Read with the handle
  in Open/Secured → header 0 + words + handle + CRC-16. NAK → Arbitrate from Reply, Acknowledged, Open, Secured.
* End of a successful inventory: a tag in Acknowledged/Open/Secured that receives a
  QueryRep or QueryAdjust of the round's session inverts that session's inventoried flag
  (A↔B) and goes to Ready; a Query of the round's session inverts the flag first and is
  then evaluated like any Query.
* Select (any powered state) sets the SL or an inventoried flag per the action table and
  returns the tag to Ready. The mask is compared with the chosen bank from bit ``Pointer``
  (EPC bank: StoredCRC at 00h, PC at 10h, EPC from 20h). Truncated replies are not
  modelled: a Select with Truncate = 1 acts like Truncate = 0.

Flag persistence (anchors §4.4, *values recalled from Gen2 v1.2.0, unverified*): S0 is kept
only while powered; S1 reverts from B to A 0.5–5 s after it was set, powered or not; S2, S3
and SL survive a power loss shorter than their persistence time (> 2 s). The times used are
fields of :class:`FlagPersistence`.

Memory model (Gen2 "Tag memory"): EPC bank = StoredCRC (word 0) | PC (word 1) | EPC;
PC = L·2¹¹ where L = EPC length in 16-bit words (the 5 MSBs of PC, bits 10h–14h), UMI, XI,
T and the numbering-system bits 0 (so PC = 3000h for a 96-bit EPC). StoredCRC = CRC-16 of
PC + EPC, which is also the CRC the tag sends after PC + EPC in its ACK reply (§3.2).
Reserved bank = kill password | access password (32 bits each); TID and User banks are bit
arrays given by the caller.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import compress

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.gen2.bits import as_bits, bits_to_int, hex_to_bits, int_to_bits, str_to_bits
from rfsim.gen2.commands import ACK, NAK, Query, QueryAdjust, QueryRep, Read, ReqRN, Select
from rfsim.gen2.crc import append_crc16, crc16_bits

STATES = ("ready", "arbitrate", "reply", "acknowledged", "open", "secured")
REPLY_KINDS = ("RN16", "EPC", "HANDLE", "READ", "ERROR")

#: Slot counter value after a QueryRep in Reply state (standard: 0000h decrements to 7FFFh).
SLOT_AFTER_WRAP = 0x7FFF
#: Gen2 tag error code "memory overrun" (Read beyond the bank).
ERROR_MEMORY_OVERRUN = 0x03
#: Example TID of the form E2h | 12-bit mask-designer ID | 12-bit model number (not a real
#: chip's TID; set ``tid`` for a specific chip).
DEFAULT_TID_HEX = "E2006003"

_ACCESS_STATES = ("acknowledged", "open", "secured")
_FLIP = {"A": "B", "B": "A"}


@dataclass(frozen=True, eq=False)
class Reply:
    """What a tag backscatters in response to one command.

    Attributes
    ----------
    kind : "RN16" | "EPC" | "HANDLE" | "READ" | "ERROR"
    bits : (n,) uint8
        Payload bits MSB first, CRC-16 included where Gen2 has one (all kinds but RN16);
        the line-code preamble and the dummy 1 are not included.
    """

    kind: str
    bits: np.ndarray

    def __post_init__(self):
        if self.kind not in REPLY_KINDS:
            raise ValueError(f"reply kind must be one of {REPLY_KINDS}, got {self.kind!r}")
        arr = as_bits(self.bits).copy()
        arr.flags.writeable = False
        object.__setattr__(self, "bits", arr)

    def __eq__(self, other):
        if not isinstance(other, Reply):
            return NotImplemented
        return self.kind == other.kind and np.array_equal(self.bits, other.bits)

    __hash__ = None

    @classmethod
    def _own(cls, kind: str, bits: np.ndarray) -> "Reply":
        """A Reply holding ``bits`` itself: a read-only (n,) uint8 0/1 array its caller has just
        made (not validated and copied again)."""
        out = object.__new__(cls)
        object.__setattr__(out, "kind", kind)
        object.__setattr__(out, "bits", bits)
        return out


@dataclass(frozen=True)
class FlagPersistence:
    """Persistence times of the inventoried and SL flags [s].

    Defaults (anchors §4.4, *unverified*): S1 lies in 0.5–5 s (default 2 s, whether powered
    or not); S2, S3, SL must exceed 2 s unpowered (default 2 s, the bound itself).
    """

    s1_s: float = 2.0
    s2_s: float = 2.0
    s3_s: float = 2.0
    sl_s: float = 2.0

    def __post_init__(self):
        for name in ("s1_s", "s2_s", "s3_s", "sl_s"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value >= 0:
                raise ConfigError(f"tag.persistence.{name}", value, "a non-negative number of seconds")


def pc_word(epc_bits) -> int:
    """Protocol-control word of an EPC: L·2¹¹, L = len(epc)/16 ∈ [0, 31] words.

    UMI, XI, T and the numbering-system bits are 0. ``pc_word(96 zeros) == 0x3000``.
    """
    n = as_bits(epc_bits).size
    if n % 16 or n // 16 > 31:
        raise ValueError(f"EPC length must be a multiple of 16 bits, at most 496, got {n}")
    return (n // 16) << 11


def _draw16(rng: np.random.Generator) -> int:
    """A 16-bit random number, ``rng.integers(0, 2**16)`` (:func:`slot_draw` with Q = 16)."""
    return slot_draw(rng, 16)


#: The 8 bits of every byte value, MSB first ((256, 8) uint8).
_BYTE_BITS = np.unpackbits(np.arange(256, dtype=np.uint8)[:, None], axis=1)


def _bits16(value: int) -> np.ndarray:
    """``int_to_bits(value, 16)`` for 0 ≤ value < 2¹⁶ (by byte lookup), read-only."""
    bits = _BYTE_BITS[[value >> 8, value & 0xFF]].reshape(16)
    bits.setflags(write=False)
    return bits


def slot_draw(rng: np.random.Generator, q: int) -> int:
    """A slot counter uniform in [0, 2^Q − 1], the number ``rng.integers(0, 2**q)`` returns.

    For a power-of-two range numpy's bounded draw (Lemire's multiply-shift) never rejects:
    it returns the top Q bits of one 32-bit word of the bit generator, ``next_uint32 >> (32
    − Q)``, and Q = 0 draws nothing. The word is read here through the bit generator's
    ctypes interface — the same word, the same generator state afterwards (tested against
    ``integers``), without the method's argument handling (a fifth of its cost; an inventory
    draws a counter per tag on every QueryAdjust), and without the generator's lock (a tag's
    generator is its own, used by one thread). A generator without that interface is asked
    through ``integers``.
    """
    if q <= 0:
        return 0
    ct = getattr(getattr(rng, "bit_generator", None), "ctypes", None)
    if ct is None:
        return int(rng.integers(0, 1 << q))
    return ct.next_uint32(ct.state) >> (32 - q)


def _slot_drawer(rng):
    """``q → slot_draw(rng, q)`` with the bit generator's ctypes interface looked up once."""
    ct = getattr(getattr(rng, "bit_generator", None), "ctypes", None)
    if ct is None:
        return lambda q: slot_draw(rng, q)
    word, state = ct.next_uint32, ct.state
    return lambda q: (word(state) >> (32 - q)) if q > 0 else 0


class SharedClock:
    """A time [s] and a count of slot-counter decrements that many :class:`TagState` objects
    follow at once (:meth:`TagState.follow`, :meth:`TagState.follow_decrements`): the silent
    steps of a population (:class:`StateArrays`) advance every tag that takes one, and count
    down every counter a QueryRep decrements, by setting these two values, not each tag's."""

    __slots__ = ("t_s", "decrements")

    def __init__(self, t_s: float = 0.0):
        self.t_s = float(t_s)
        self.decrements = 0


class TagState:
    """Explicit Gen2 protocol state of one passive tag.

    Parameters
    ----------
    epc : (n,) uint8 bits or hex string
        EPC, a multiple of 16 bits (≤ 496).
    tid : bits or hex string, default :data:`DEFAULT_TID_HEX`
    user : bits or hex string, default empty (no User memory)
    kill_password, access_password : int
        32-bit passwords (Reserved bank). Req_RN moves an acknowledged tag to Secured when
        the access password is 0, else to Open.
    persistence : FlagPersistence
    powered : bool
        Initial power state (at time ``t0_s``).
    t0_s : float
        Time of the initial state [s].

    Attributes
    ----------
    state : str, one of :data:`STATES`
    inventoried : dict {0..3: "A" | "B"}
    sl : bool
    q, slot, rn16, handle : int or None
    session : int or None — session of the current inventory round
    last_query : Query or None — link parameters (DR, M, TRext) of the reply
    t_s : time of the state [s] (its last command or power event)
    """

    def __init__(self, epc, *, tid=DEFAULT_TID_HEX, user="", kill_password: int = 0,
                 access_password: int = 0, persistence: FlagPersistence = FlagPersistence(),
                 powered: bool = True, t0_s: float = 0.0):
        self.epc = _bits_arg(epc)
        self.pc = pc_word(self.epc)
        self.tid = _bits_arg(tid)
        self.user = _bits_arg(user)
        if self.tid.size % 16 or self.user.size % 16:
            raise ValueError("TID and User memory must be whole 16-bit words")
        for name, pwd in (("kill_password", kill_password), ("access_password", access_password)):
            if not 0 <= int(pwd) < 1 << 32:
                raise ValueError(f"{name} must be a 32-bit value, got {pwd}")
        self.kill_password = int(kill_password)
        self.access_password = int(access_password)
        self.persistence = persistence
        self.powered = bool(powered)
        self.state = "ready"
        self.inventoried = {s: "A" for s in range(4)}
        self.sl = False
        self.q = 0
        self._slot_clock: SharedClock | None = None
        self._slot: int | None = None
        self.rn16: int | None = None
        self.handle: int | None = None
        self.session: int | None = None
        self.last_query: Query | None = None
        self._clock: SharedClock | None = None
        self._t_s = float(t0_s)
        self._s1_set_s: float | None = None  # time S1 was last set to B
        self._off_since_s: float | None = None if self.powered else float(t0_s)

    # ------------------------------------------------------------------ memory
    @property
    def stored_crc(self) -> int:
        """StoredCRC: CRC-16 over PC + EPC (EPC bank word 0)."""
        return bits_to_int(crc16_bits(self.pc_epc_bits))

    @property
    def pc_epc_bits(self) -> np.ndarray:
        """PC + EPC, ``(16 + n,) uint8``."""
        return np.concatenate([int_to_bits(self.pc, 16), self.epc])

    def bank_bits(self, membank: int) -> np.ndarray:
        """Bits of a memory bank (0 Reserved, 1 EPC, 2 TID, 3 User), bit address 0 first."""
        if membank == 0:
            return np.concatenate([int_to_bits(self.kill_password, 32), int_to_bits(self.access_password, 32)])
        if membank == 1:
            return np.concatenate([int_to_bits(self.stored_crc, 16), self.pc_epc_bits])
        if membank == 2:
            return self.tid
        if membank == 3:
            return self.user
        raise ValueError(f"memory bank must be 0-3, got {membank}")

    # ------------------------------------------------------------------ time and power
    @property
    def t_s(self) -> float:
        """Time of the state [s]: its own, or the :class:`SharedClock` it follows."""
        clock = self._clock
        return self._t_s if clock is None else clock.t_s

    @t_s.setter
    def t_s(self, value: float) -> None:
        self._clock = None  # the tag's own time from now on
        self._t_s = value

    def follow(self, clock: SharedClock | None) -> None:
        """Let the state's time be ``clock.t_s`` until it is set (None: keep the current
        time as the state's own)."""
        if clock is None:
            self.t_s = self.t_s
        else:
            self._clock = clock

    @property
    def slot(self) -> int | None:
        """Slot counter (None: no round): its own, or counted down by the :class:`SharedClock`
        it follows, (offset − decrements) mod 2^15."""
        clock = self._slot_clock
        return self._slot if clock is None else (self._slot - clock.decrements) & 0x7FFF

    @slot.setter
    def slot(self, value: int | None) -> None:
        self._slot_clock = None  # the tag's own counter from now on
        self._slot = value

    def follow_decrements(self, clock: SharedClock | None) -> None:
        """Let the slot counter count down with ``clock.decrements`` from now on, from its
        current value, until it is set (None: keep the current value as the tag's own)."""
        slot = self.slot
        if clock is None:
            self.slot = slot
        else:
            self._slot_clock, self._slot = clock, slot + clock.decrements

    def _advance(self, t_s: float) -> None:
        t_s = float(t_s)
        if t_s < self.t_s:
            raise ValueError(f"time went backwards: {t_s} s < {self.t_s} s")
        self.t_s = t_s
        if self._s1_set_s is not None and t_s - self._s1_set_s >= self.persistence.s1_s:
            self.inventoried[1] = "A"
            self._s1_set_s = None

    def _set_flag(self, session: int, value: str) -> None:
        self.inventoried[session] = value
        if session == 1:
            self._s1_set_s = self.t_s if value == "B" else None

    def on_power(self, powered: bool, t_s: float) -> None:
        """Power loss or power-up at time ``t_s`` [s].

        Power loss: state → Ready, round state cleared, S0 → A. Power-up after an outage of
        duration d: S2/S3 → A and SL deasserted when d exceeds their persistence time; S1
        decays by its own timer regardless of power.
        """
        self._advance(t_s)
        powered = bool(powered)
        if powered == self.powered:
            return
        if not powered:
            self.powered = False
            self._off_since_s = self.t_s
            self._reset_round()
            self.inventoried[0] = "A"
            self.last_query = None
            return
        off_s = self.t_s - (self._off_since_s if self._off_since_s is not None else self.t_s)
        p = self.persistence
        for session, keep_s in ((2, p.s2_s), (3, p.s3_s)):
            if off_s > keep_s:
                self.inventoried[session] = "A"
        if off_s > p.sl_s:
            self.sl = False
        self.powered = True
        self._off_since_s = None
        self._reset_round()

    def _reset_round(self) -> None:
        self.state = "ready"
        self.slot = self.rn16 = self.handle = self.session = None

    # ------------------------------------------------------------------ commands
    def on_command(self, cmd, *, t_s: float, rng: np.random.Generator) -> Reply | None:
        """Apply one reader command received at time ``t_s`` [s]; return the tag's reply.

        ``rng`` is the tag's own generator (slot counters, RN16s, handles). An unpowered
        tag ignores every command (returns ``None``).
        """
        self._advance(t_s)
        if not self.powered:
            return None
        if isinstance(cmd, Query):
            return self._query(cmd, rng)
        if isinstance(cmd, QueryRep):
            return self._query_rep(cmd, rng)
        if isinstance(cmd, QueryAdjust):
            return self._query_adjust(cmd, rng)
        if isinstance(cmd, ACK):
            return self._ack(cmd)
        if isinstance(cmd, NAK):
            if self.state in ("reply", "acknowledged", "open", "secured"):
                self.state = "arbitrate"
            return None
        if isinstance(cmd, ReqRN):
            return self._req_rn(cmd, rng)
        if isinstance(cmd, Read):
            return self._read(cmd)
        if isinstance(cmd, Select):
            self._select(cmd)
            return None
        raise TypeError(f"not a Gen2 command: {cmd!r}")

    def on_command_if_silent(self, cmd, *, t_s: float) -> bool:
        """Apply ``cmd`` at ``t_s`` [s] when the rules above make it a silent step that needs no
        random draw; return True if applied (the tag is then exactly as :meth:`on_command`
        would leave it, and it does not reply), False if nothing was done (call
        :meth:`on_command`).

        The silent steps of a powered tag: a QueryRep or QueryAdjust of another session than
        the tag's round (or with no round); a QueryRep in Arbitrate whose decremented counter
        is not 0 (the counter decrements, nothing else changes); an ACK or NAK in Ready or
        Arbitrate. These are the same branches as in :meth:`on_command` (``_query_rep``,
        ``_query_adjust``, ``_ack``, NAK), taken without the dispatch — in an inventory almost
        every tag takes one of them on almost every command.
        """
        if not self.powered:
            return False
        kind = type(cmd)
        if kind is QueryAdjust:
            if self.session is None or cmd.session != self.session:
                self._advance(t_s)
                return True
            return False
        if kind is QueryRep:
            if self.session is None or cmd.session != self.session:
                self._advance(t_s)
                return True
            if self.state == "arbitrate":
                nxt = (self.slot - 1) & 0x7FFF
                if nxt != 0:
                    self._advance(t_s)
                    self.slot = nxt
                    return True
            return False
        if (kind is ACK or kind is NAK) and self.state in ("ready", "arbitrate"):
            self._advance(t_s)
            return True
        return False

    def row(self) -> tuple:
        """The state as :class:`StateArrays` keeps it: ``(powered, state code, session or −1,
        slot or −1, t_s, time S1 was set to B or NaN, S1 persistence [s], Q)``."""
        return (self.powered, STATE_CODES[self.state], -1 if self.session is None else self.session,
                -1 if self.slot is None else self.slot, self.t_s,
                float("nan") if self._s1_set_s is None else self._s1_set_s, self.persistence.s1_s, self.q)

    def _matches_query(self, cmd: Query) -> bool:
        if cmd.sel == "sl" and not self.sl:
            return False
        if cmd.sel == "~sl" and self.sl:
            return False
        return self.inventoried[cmd.session] == cmd.target

    def _load_slot(self, rng: np.random.Generator) -> Reply | None:
        self.slot = slot_draw(rng, self.q)
        return self._reply_if_zero(rng)

    def _reply_if_zero(self, rng: np.random.Generator) -> Reply | None:
        if self.slot == 0:
            self.state = "reply"
            self.rn16 = _draw16(rng)
            return Reply._own("RN16", _bits16(self.rn16))
        self.state = "arbitrate"
        return None

    def _query(self, cmd: Query, rng) -> Reply | None:
        if self.state in _ACCESS_STATES and cmd.session == self.session:
            self._set_flag(self.session, _FLIP[self.inventoried[self.session]])
        self.last_query = cmd
        if not self._matches_query(cmd):
            self._reset_round()
            return None
        self.session, self.q, self.handle = cmd.session, cmd.q, None
        return self._load_slot(rng)

    def _close_access(self) -> bool:
        """An acknowledged/open/secured tag ends its round on a QueryRep/QueryAdjust of its
        session: its inventoried flag flips and it returns to Ready. True if that happened."""
        if self.state not in _ACCESS_STATES:
            return False
        self._set_flag(self.session, _FLIP[self.inventoried[self.session]])
        self._reset_round()
        return True

    def _query_rep(self, cmd: QueryRep, rng) -> Reply | None:
        if self.session is None or cmd.session != self.session:
            return None
        if self._close_access():
            return None
        if self.state == "reply":
            self.state, self.slot = "arbitrate", SLOT_AFTER_WRAP
            return None
        if self.state == "arbitrate":
            self.slot = (self.slot - 1) & 0x7FFF
            return self._reply_if_zero(rng)
        return None

    def _query_adjust(self, cmd: QueryAdjust, rng) -> Reply | None:
        if self.session is None or cmd.session != self.session:
            return None
        if self._close_access():
            return None
        if self.state in ("arbitrate", "reply"):
            self.q = min(15, max(0, self.q + cmd.updn))
            return self._load_slot(rng)
        return None

    def _ack(self, cmd: ACK) -> Reply | None:
        if self.state in ("reply", "acknowledged"):
            if cmd.rn16 != self.rn16:
                self.state = "arbitrate"
                return None
            self.state = "acknowledged"
            return self._epc_reply()
        if self.state in ("open", "secured"):
            if cmd.rn16 != self.handle:
                self.state = "arbitrate"
                return None
            return self._epc_reply()
        return None

    def _epc_reply(self) -> Reply:
        """The ACK reply PC + EPC + CRC-16 (an immutable record: made once for this EPC and
        PC and given again while they stay the same)."""
        key = (self.epc.tobytes(), self.pc)
        memo = self.__dict__.get("_epc_reply_memo")
        if memo is None or memo[0] != key:
            memo = self.__dict__["_epc_reply_memo"] = (key, Reply("EPC", append_crc16(self.pc_epc_bits)))
        return memo[1]

    def _req_rn(self, cmd: ReqRN, rng) -> Reply | None:
        if self.state == "acknowledged":
            if cmd.rn16 != self.rn16:  # invalid RN16: ignored, tag stays Acknowledged
                return None
            self.handle = _draw16(rng)
            self.state = "secured" if self.access_password == 0 else "open"
            return Reply("HANDLE", append_crc16(int_to_bits(self.handle, 16)))
        if self.state in ("open", "secured") and cmd.rn16 == self.handle:
            return Reply("RN16", append_crc16(int_to_bits(_draw16(rng), 16)))
        return None

    def _read(self, cmd: Read) -> Reply | None:
        if self.state not in ("open", "secured") or cmd.rn16 != self.handle:
            return None
        bank = self.bank_bits(cmd.membank)
        start = 16 * cmd.word_ptr
        stop = bank.size if cmd.word_count == 0 else start + 16 * cmd.word_count
        handle = int_to_bits(self.handle, 16)
        if start >= bank.size or stop > bank.size:
            body = np.concatenate([[1], int_to_bits(ERROR_MEMORY_OVERRUN, 8), handle]).astype(np.uint8)
            return Reply("ERROR", append_crc16(body))
        body = np.concatenate([np.zeros(1, np.uint8), bank[start:stop], handle])
        return Reply("READ", append_crc16(body))

    def select_matches(self, cmd: Select) -> bool:
        """True when ``cmd.mask`` equals the bank bits at ``cmd.pointer`` (Length 0: all
        tags match; a mask running past the end of the bank does not match)."""
        if cmd.length == 0:
            return True
        bank = self.bank_bits(cmd.membank)
        stop = cmd.pointer + cmd.length
        if stop > bank.size:
            return False
        return bool(np.array_equal(bank[cmd.pointer : stop], str_to_bits(cmd.mask)))

    def _select(self, cmd: Select) -> None:
        """Select action table (Gen2 "Select"): per action, what a matching / non-matching
        tag does. 'set' = assert SL or inventoried→A; 'clear' = deassert SL or →B;
        'flip' = negate SL or A↔B; None = do nothing."""
        if cmd.membank == 0:  # MemBank 00 is RFU for Select in Gen2 v1.2: ignored
            return
        match = self.select_matches(cmd)
        todo = _SELECT_ACTIONS[cmd.action][0 if match else 1]
        if cmd.target == 4:
            if todo == "set":
                self.sl = True
            elif todo == "clear":
                self.sl = False
            elif todo == "flip":
                self.sl = not self.sl
        elif cmd.target <= 3:
            s = cmd.target
            if todo == "set":
                self._set_flag(s, "A")
            elif todo == "clear":
                self._set_flag(s, "B")
            elif todo == "flip":
                self._set_flag(s, _FLIP[self.inventoried[s]])
        self._reset_round()


class StateArrays:
    """The Gen2 state of many tags in arrays, for the silent steps of a population.

    Columns (one row per tag, :meth:`TagState.row`): ``powered`` (bool), ``code`` (index into
    :data:`STATES`), ``session`` (−1: none), ``slot`` (−1: none), ``t_s`` [s], ``s1_set_s``
    (NaN: S1 not set to B), ``s1_keep_s`` and ``q``. :meth:`silent_steps` is
    :meth:`TagState.on_command_if_silent`'s decision for every row at once (the same rules);
    :meth:`take_silent_steps` applies the steps so decided to the rows and to the
    :class:`TagState` objects, exactly as ``on_command_if_silent`` would have left them.
    :meth:`redraw_steps` / :meth:`take_redraw_steps` do the same for the other frequent step
    of an inventory, a QueryAdjust that makes every tag of the round load a new slot counter
    (the branch of ``on_command`` taken without the dispatch, each counter drawn from its
    tag's own generator).

    The tags whose last step was a silent one follow the arrays' :class:`SharedClock`
    (``clock``; ``following`` marks them): the next silent step advances them all by setting
    the clock, and only the tags that join or leave that set are touched one by one. So do
    the slot counters of the tags whose last step was a QueryRep's decrement
    (``counting``: ``clock.decrements``). A tag's own step (``on_command`` …) sets its time
    and counter, which ends its following; :meth:`read` notes it.
    """

    def __init__(self, states):
        self.states = list(states)
        n = len(self.states)
        self.powered = np.zeros(n, bool)
        self.code = np.zeros(n, np.int8)
        self.session = np.full(n, -1, np.int64)
        self.slot = np.full(n, -1, np.int64)
        self.t_s = np.zeros(n)
        self.s1_set_s = np.full(n, np.nan)
        self.s1_keep_s = np.zeros(n)
        self.q = np.zeros(n, np.int64)
        self.clock = SharedClock()
        self.following = np.zeros(n, bool)
        self.counting = np.zeros(n, bool)
        self.read(range(n))

    def read(self, index) -> None:
        """Copy the rows ``index`` (a sequence of ints) from their :class:`TagState` objects."""
        index = list(index)
        if not index:
            return
        states, clock = self.states, self.clock
        if len(index) <= 8:  # the few tags of one exchange that reacted: element by element
            columns = [getattr(self, name) for name in _COLUMNS]
            following, counting = self.following, self.counting
            for i in index:
                st = states[i]
                for col, value in zip(columns, st.row()):
                    col[i] = value
                following[i] = st._clock is clock
                counting[i] = st._slot_clock is clock
            return
        cols = list(zip(*[states[i].row() for i in index]))
        for name, col in zip(_COLUMNS, cols):
            getattr(self, name)[index] = col
        self.following[index] = [states[i]._clock is clock for i in index]
        self.counting[index] = [states[i]._slot_clock is clock for i in index]

    def silent_steps(self, cmd, candidates: np.ndarray, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(silent, decrement): which of the ``candidates`` (bool mask of powered tags) take a
        silent step for ``cmd`` received at ``t_s`` [s], and which of those decrement their
        slot counter (a QueryRep in Arbitrate of the round's session). The rules of
        :meth:`TagState.on_command_if_silent`; a tag whose clock is past ``t_s`` is left to
        ``on_command`` (it raises)."""
        ok = candidates & self.powered & (self.t_s <= t_s)
        kind = type(cmd)
        if kind is QueryRep:
            other = (self.session < 0) | (self.session != cmd.session)
            dec = ~other & (self.code == _ARBITRATE) & (self.slot >= 0) & (((self.slot - 1) & 0x7FFF) != 0)
            return ok & (other | dec), ok & dec
        if kind is QueryAdjust:
            return ok & ((self.session < 0) | (self.session != cmd.session)), np.zeros_like(ok)
        if kind is ACK or kind is NAK:
            return ok & ((self.code == _READY) | (self.code == _ARBITRATE)), np.zeros_like(ok)
        return np.zeros_like(ok), np.zeros_like(ok)

    def redraw_steps(self, cmd, candidates: np.ndarray, t_s: float) -> np.ndarray:
        """Which of the ``candidates`` (bool mask) load a new slot counter on ``cmd``, a
        QueryAdjust received at ``t_s`` [s]: powered tags in Arbitrate or Reply of the
        command's session (``TagState._query_adjust``) whose clock is not past ``t_s`` and
        whose S1 flag is not due to revert (those are left to ``on_command``). All False for
        other commands."""
        if type(cmd) is not QueryAdjust:
            return np.zeros(len(self.states), bool)
        t_s = float(t_s)
        ok = candidates & self.powered & (self.t_s <= t_s) & ~(t_s - self.s1_set_s >= self.s1_keep_s)
        in_round = (self.session == cmd.session) & ((self.code == _ARBITRATE) | (self.code == _REPLY))
        return ok & in_round

    def take_redraw_steps(self, cmd, index: list, rngs: list, t_s: float) -> list:
        """Apply the QueryAdjust ``cmd`` at ``t_s`` [s] to the rows ``index`` (from
        :meth:`redraw_steps`), tag ``index[k]`` drawing from its own generator ``rngs[k]``:
        its clock advances to ``t_s``, Q ← min(15, max(0, Q + UpDn)), and it loads its slot
        counter and replies when it is 0 (``TagState._load_slot``: the same draws in the same
        order as ``on_command``). Returns ``[(row, Reply)]`` of the tags that reply."""
        if not index:
            return []
        t_s = float(t_s)
        idx = np.asarray(index, dtype=np.int64)
        q_new = np.minimum(np.maximum(self.q[idx] + int(cmd.updn), 0), 15)  # min(15, max(0, Q + UpDn))
        states = self.states
        replies, slots = [], []
        for i, q, rng, draw in zip(index, q_new.tolist(), rngs, self._slot_draws(rngs)):
            st = states[i]
            st._clock, st._t_s, st.q = None, t_s, q  # its own time (the t_s setter)
            # TagState._load_slot: the counter (slot_draw), a reply with an RN16 at 0
            slot = draw(q)
            st._slot_clock, st._slot = None, slot  # its own counter (the slot setter)
            if slot == 0:
                replies.append((i, st._reply_if_zero(rng)))
            else:
                st.state = "arbitrate"
            slots.append(slot)
        self.following[idx] = False  # each tag's own time and counter were set
        self.counting[idx] = False
        self.t_s[idx] = t_s
        self.q[idx] = q_new
        slot = np.array(slots, dtype=np.int64)
        self.slot[idx] = slot
        self.code[idx] = np.where(slot == 0, _REPLY, _ARBITRATE)
        return replies

    def _slot_draws(self, rngs: list) -> list:
        """Per generator a function ``q → slot_draw(rng, q)``, kept per generator: the bit
        generator's 32-bit word read through its ctypes interface, found once (not on every
        draw), or ``slot_draw`` itself for a generator without it."""
        memo = self.__dict__.setdefault("_draw_memo", {})
        if len(memo) > 4 * len(self.states) + 16:
            memo.clear()
        out = []
        for rng in rngs:
            hit = memo.get(id(rng))
            if hit is None or hit[0] is not rng:
                hit = memo[id(rng)] = (rng, _slot_drawer(rng))  # the generator kept alive: its id stays its own
            out.append(hit[1])
        return out

    def take_silent_steps(self, cmd, silent: np.ndarray, decrement: np.ndarray, t_s: float) -> None:
        """Apply the silent steps of :meth:`silent_steps` at ``t_s`` [s]: each tag's clock
        advances to ``t_s`` and a decrementing tag's slot counter goes to (slot − 1) mod 2^15.
        A tag whose S1 flag is due to revert takes the step through
        :meth:`TagState.on_command_if_silent` itself (and its row is read back)."""
        t_s = float(t_s)
        due = silent & (t_s - self.s1_set_s >= self.s1_keep_s)  # NaN (S1 not set) compares False
        if np.count_nonzero(due):
            idx = due.nonzero()[0]
            for i in idx.tolist():
                if not self.states[i].on_command_if_silent(cmd, t_s=t_s):
                    raise RuntimeError("a silent step was refused")  # the rules above disagree
            self.read(idx.tolist())
            silent = silent & ~due
            decrement = decrement & ~due
        if np.count_nonzero(decrement):
            self.slot[decrement] = (self.slot[decrement] - 1) & 0x7FFF
        self._count_down(decrement)
        self.t_s[silent] = t_s
        self._follow(silent, t_s)

    def _count_down(self, decrement: np.ndarray) -> None:
        """The counters of the tags ``decrement`` (bool mask) go to (slot − 1) mod 2^15
        through the shared clock: when any does, those that counted with it and do not
        decrement now keep their counter as their own, the clock counts one decrement more,
        and the decrementing ones that did not count with it join it from their decremented
        value (a step without decrements changes no counter: the clock stays)."""
        if not np.count_nonzero(decrement):
            return
        clock, states = self.clock, self.states
        leave = self.counting & ~decrement
        if np.count_nonzero(leave):
            for st in compress(states, leave.tolist()):
                st.follow_decrements(None)
        d = clock.decrements + 1
        for st in compress(states, (decrement & ~self.counting).tolist()):
            # follow_decrements(clock) of the decremented counter, the clock one decrement on
            st._slot_clock, st._slot = clock, ((st.slot - 1) & 0x7FFF) + d
        clock.decrements = d
        self.counting = decrement.copy()

    def _follow(self, silent: np.ndarray, t_s: float) -> None:
        """The tags ``silent`` (bool mask) advance to ``t_s`` [s] through the shared clock:
        those that followed it and are not silent now keep the clock's time as their own,
        the clock moves to ``t_s``, and the silent ones follow it."""
        clock, states = self.clock, self.states
        leave = self.following & ~silent
        if np.count_nonzero(leave):
            for st in compress(states, leave.tolist()):
                st.follow(None)
        clock.t_s = t_s
        join = silent & ~self.following
        if np.count_nonzero(join):
            for st in compress(states, join.tolist()):
                st._clock = clock  # follow(clock)
        self.following = silent.copy()


STATE_CODES = {s: k for k, s in enumerate(STATES)}
_READY, _ARBITRATE, _REPLY = STATE_CODES["ready"], STATE_CODES["arbitrate"], STATE_CODES["reply"]
#: The columns of :class:`StateArrays`, in the order of :meth:`TagState.row`.
_COLUMNS = ("powered", "code", "session", "slot", "t_s", "s1_set_s", "s1_keep_s", "q")


#: Select action → (matching tag, non-matching tag).
_SELECT_ACTIONS = {
    0: ("set", "clear"),
    1: ("set", None),
    2: (None, "clear"),
    3: ("flip", None),
    4: ("clear", "set"),
    5: ("clear", None),
    6: (None, "set"),
    7: (None, "flip"),
}


def _bits_arg(value) -> np.ndarray:
    if isinstance(value, str):
        return hex_to_bits(value) if value else np.zeros(0, np.uint8)
    return as_bits(value).copy()


__all__ = [
    "STATES",
    "REPLY_KINDS",
    "SLOT_AFTER_WRAP",
    "ERROR_MEMORY_OVERRUN",
    "DEFAULT_TID_HEX",
    "Reply",
    "FlagPersistence",
    "SharedClock",
    "TagState",
    "StateArrays",
    "STATE_CODES",
    "slot_draw",
    "pc_word",
]

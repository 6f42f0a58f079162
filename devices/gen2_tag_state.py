"""Gen2 tag state machine as pure logic: states, sessions, flags, slot counter, replies.

No waveforms here: a :class:`TagState` consumes parsed reader commands
(:mod:`rfsim.gen2.commands`) and returns the bits the tag backscatters, or ``None``.
Rules follow the EPC Gen2 protocol ("Tag states and slot counter", "Sessions and
inventoried flags", "Selected flag", the Select/Inventory/Access command sections;
gen2-and-validation-anchors.md §4.4–4.5):

* States: ``ready``, ``arbitrate``, ``reply``, ``acknowledged``, ``open``, ``secured``,
  ``killed``. A killed tag never replies again, powered or not (it ignores every command).
* Sessions S0–S3 each hold an inventoried flag ``"A"``/``"B"``; SL is a separate flag.
* Slot counter: Query and QueryAdjust load a value drawn uniformly from [0, 2^Q − 1] with
  the tag's own ``rng``; QueryRep decrements it; the tag backscatters a new RN16 when it
  reaches 0. A tag in Reply that receives a QueryRep goes to Arbitrate with its counter
  at 7FFFh (the standard's wrap-around: no second reply in the round).
* ACK with the tag's RN16 in Reply/Acknowledged → PC + EPC + CRC-16 and Acknowledged; a
  wrong RN16 → Arbitrate, no reply. Req_RN with the RN16 in Acknowledged → handle + CRC-16
  and Secured (access password 0) or Open; with a wrong RN16 it is ignored (state kept, as
  recalled from the standard's state-transition tables, unverified). In Open/Secured every
  access command (Req_RN, Read, Write, Kill, Lock, Access, BlockWrite, BlockErase) is executed
  by :func:`rfsim.gen2.access.execute` on the tag's :class:`rfsim.gen2.memory.TagMemory` (the
  one definition of those rules: handle check, replies with handle and CRC-16, the delayed
  reply of Write/BlockWrite/BlockErase/Lock/Kill with its header bit and error codes, the
  chip's write time and write power threshold, Access → Secured, Kill → Killed); its state
  ``arbitrate`` (a wrong password half) becomes the tag's. NAK → Arbitrate from Reply,
  Acknowledged, Open, Secured.
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

Memory model (Gen2 "Tag memory"): a :class:`rfsim.gen2.memory.TagMemory`, given or built
from the EPC, TID, User and passwords (:meth:`rfsim.gen2.memory.TagMemory.from_words`, on the
chip model ``chip`` resized to hold exactly them): EPC bank = StoredCRC (word 0) | PC (word 1)
| EPC; PC = L·2¹¹ where L = EPC length in 16-bit words (the 5 MSBs of PC, bits 10h–14h), UMI,
XI, T and the numbering-system bits 0 (so PC = 3000h for a 96-bit EPC). StoredCRC = CRC-16
of PC + EPC, which is also the CRC the tag sends after PC + EPC in its ACK reply (§3.2).
Reserved bank = kill password | access password (32 bits each). The EPC, PC, TID, User and
passwords below are read from the memory (a Write to the EPC changes the ACK reply).

The rules of the inventory (Query's Sel/Target, the transitions of Query, QueryRep,
QueryAdjust, ACK and NAK with the end of an access, the slot counter's decrement and reply,
the S1 persistence, the Select action table) are written once, over arrays, in
:mod:`rfsim.devices.gen2_tag_arrays` (:func:`round_step` …): a :class:`TagState` applies them
to itself as a population of one (its row of the rules evaluated for every state,
:func:`round_step_of_one`), and :class:`StateArrays` to a whole population at once. The reply
record, flag persistence, state codes, slot-counter draws, the Q adjustment and the shared
clock are in :mod:`rfsim.devices.gen2_tag_values`. Both are importable from here.
"""

from __future__ import annotations

import numpy as np

import dataclasses
import math

from rfsim.gen2.access import AccessContext, execute, rn_reply, state_after_req_rn
from rfsim.gen2.bits import as_bits, hex_to_bits, str_to_bits
from rfsim.gen2.commands import ACCESS_COMMANDS, ACK, NAK, Query, QueryAdjust, QueryRep, Read, ReqRN, Select
from rfsim.gen2.crc import crc16_bytes
from rfsim.gen2.memory import CHIP_MODELS, EPC, ChipModel, TagError, TagMemory, pc_epc_length
from rfsim.devices.gen2_tag_arrays import (StateArrays, decremented, query_matches, round_step_of_one, s1_reverts,
                                           select_step, slot_replies)
from rfsim.devices.gen2_tag_values import (REPLY_KINDS, STATE_CODES, STATES, FlagPersistence, Reply, SharedClock,
                                           _bits16, adjusted_q, draw_rn16, pc_word, slot_draw)

#: Slot counter value after a QueryRep in Reply state (standard: 0000h decrements to 7FFFh).
SLOT_AFTER_WRAP = 0x7FFF
#: Gen2 tag error code "memory overrun" (Read beyond the bank).
ERROR_MEMORY_OVERRUN = int(TagError.MEMORY_OVERRUN)
#: Chip model of a tag's memory built from its contents (write time and write power
#: threshold; :data:`rfsim.gen2.memory.CHIP_MODELS`).
DEFAULT_CHIP = "generic"
#: Example TID of the form E2h | 12-bit mask-designer ID | 12-bit model number (not a real
#: chip's TID; set ``tid`` for a specific chip).
DEFAULT_TID_HEX = "E2006003"

_FLIP = {"A": "B", "B": "A"}


class TagState:
    """Explicit Gen2 protocol state of one passive tag.

    Parameters
    ----------
    epc : (n,) uint8 bits or hex string, optional
        EPC, a multiple of 16 bits (≤ 496); required unless ``memory`` is given.
    tid : (n,) uint8 bits or hex string, optional
        TID bank, whole 16-bit words; default :data:`DEFAULT_TID_HEX`.
    user : (n,) uint8 bits or hex string, optional
        User bank, whole 16-bit words; default empty (no User memory).
    kill_password, access_password : int
        32-bit passwords (Reserved bank), default 0. Req_RN moves an acknowledged tag to
        Secured when the access password is 0, else to Open.
    persistence : FlagPersistence
        Flag persistence times, default ``FlagPersistence()``.
    powered : bool
        Initial power state (at time ``t0_s``), default True.
    t0_s : float
        Time of the initial state [s], default 0.0.
    chip : str or rfsim.gen2.memory.ChipModel
        Chip model of the memory built from ``epc``, ``tid``, ``user`` and the passwords (its
        write time, write power threshold, BlockWrite/BlockErase support; its sizes are set to
        hold exactly the given contents), default :data:`DEFAULT_CHIP`.
    memory : rfsim.gen2.memory.TagMemory or None
        The tag's memory itself (then ``epc``, ``tid``, ``user``, the passwords and ``chip`` are
        not given); default None, built as above.

    Attributes
    ----------
    memory : rfsim.gen2.memory.TagMemory
        The tag's memory (changed by Write, BlockWrite, BlockErase, Lock).
    state : str
        One of :data:`STATES`.
    inventoried : dict of int to str
        Inventoried flag ``"A"`` or ``"B"`` of each session 0–3.
    sl : bool
        The SL flag.
    q, slot, rn16, handle : int or None
        Q, slot counter, last RN16 and access handle.
    session : int or None
        Session of the current inventory round.
    last_query : Query or None
        Link parameters (DR, M, TRext) of the reply.
    t_s : float
        Time of the state [s] (its last command or power event).

    Raises
    ------
    ValueError
        When TID or User are not whole 16-bit words, a password is not a 32-bit value, the
        EPC length is invalid (:func:`pc_word`), or neither or both of ``epc`` and ``memory``
        are given.
    """

    def __init__(self, epc=None, *, tid=DEFAULT_TID_HEX, user="", kill_password: int = 0,
                 access_password: int = 0, persistence: FlagPersistence = FlagPersistence(),
                 powered: bool = True, t0_s: float = 0.0, chip: str | ChipModel = DEFAULT_CHIP,
                 memory: TagMemory | None = None):
        if (epc is None) == (memory is None):
            raise ValueError("give the EPC or the memory (not both)")
        if memory is None:
            memory = _memory_of(_bits_arg(epc), _bits_arg(tid), _bits_arg(user), kill_password, access_password,
                                CHIP_MODELS[chip] if isinstance(chip, str) else chip)
        self.memory = memory
        self._access: AccessContext | None = None  # Open/Secured/Killed: access.execute's context
        self.persistence = persistence
        self.powered = bool(powered)
        self.state = "ready"
        self.inventoried = {s: "A" for s in range(4)}
        self.sl = False
        self._slot_clock: SharedClock | None = None  # the clock whose arrays hold slot and Q
        self._slot: int | None = None  # the counter, or its row in the clock's arrays
        self._q = 0
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
    def epc(self) -> np.ndarray:
        """The EPC: the L words after the StoredPC, ``(16·L,) uint8`` bits."""
        return _words_bits(self.memory.epc_words)

    @property
    def pc(self) -> int:
        """The StoredPC (EPC bank word 1)."""
        return self.memory.stored_pc

    @property
    def tid(self) -> np.ndarray:
        """The TID bank, ``(n,) uint8`` bits."""
        return _words_bits(self.memory.banks[2])

    @property
    def user(self) -> np.ndarray:
        """The User bank, ``(n,) uint8`` bits."""
        return _words_bits(self.memory.banks[3])

    @property
    def kill_password(self) -> int:
        """The 32-bit kill password."""
        return self.memory.kill_password

    @property
    def access_password(self) -> int:
        """The 32-bit access password."""
        return self.memory.access_password

    @property
    def stored_crc(self) -> int:
        """StoredCRC: CRC-16 over PC + EPC (EPC bank word 0)."""
        return self.memory.stored_crc

    @property
    def pc_epc_bits(self) -> np.ndarray:
        """PC + EPC, ``(16 + n,) uint8``."""
        return _words_bits(self._pc_epc_words())

    def _pc_epc_words(self) -> list:
        bank = self.memory.banks[EPC]
        return bank[1 : 2 + pc_epc_length(bank[1])]

    def bank_bits(self, membank: int) -> np.ndarray:
        """Return the bits of a memory bank, bit address 0 first.

        Reserved = kill password | access password; EPC = StoredCRC | PC | EPC (and the
        chip's unused EPC words) (EPC Gen2 "Tag memory"): the words of :attr:`memory`.

        Parameters
        ----------
        membank : int
            0 Reserved, 1 EPC, 2 TID, 3 User.

        Returns
        -------
        ndarray of uint8, shape (n_bits,)
            The bank's bits (0/1).

        Raises
        ------
        ValueError
            When ``membank`` is not 0–3.
        """
        if membank not in (0, 1, 2, 3):
            raise ValueError(f"memory bank must be 0-3, got {membank}")
        return _words_bits(self.memory.banks[membank])

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
        """Let the state's time follow a shared clock until it is set.

        Parameters
        ----------
        clock : SharedClock or None
            The clock whose ``t_s`` becomes the state's time; None keeps the current time as
            the state's own.
        """
        if clock is None:
            self.t_s = self.t_s
        else:
            self._clock = clock

    @property
    def slot(self) -> int | None:
        """Slot counter (None: no round): its own, or its row of the arrays of the
        :class:`SharedClock` it counts with (``slots``)."""
        clock = self._slot_clock
        return self._slot if clock is None else int(clock.slots[self._slot])

    @slot.setter
    def slot(self, value: int | None) -> None:
        clock = self._slot_clock
        if clock is not None:  # the tag's own counter and Q from now on
            self._q = int(clock.qs[self._slot])
            self._slot_clock = None
        self._slot = value

    @property
    def q(self) -> int:
        """Q of the round (the slot counter is drawn from [0, 2^Q − 1]): its own, or its row of
        the arrays of the :class:`SharedClock` its counter counts with (``qs``)."""
        clock = self._slot_clock
        return self._q if clock is None else int(clock.qs[self._slot])

    @q.setter
    def q(self, value: int) -> None:
        if self._slot_clock is not None:
            self.slot = self.slot  # the counter (and Q) the tag's own
        self._q = value

    def follow_decrements(self, clock: SharedClock | None, row: int | None = None) -> None:
        """Let the slot counter and Q be held by a shared clock's arrays until either is set.

        Parameters
        ----------
        clock : SharedClock or None
            The clock whose ``slots`` and ``qs`` hold the counter and Q at ``row`` from now on
            (the tag's values are written there); None keeps the current values as the tag's
            own.
        row : int, optional
            The tag's row of the clock's arrays (with a clock).
        """
        if clock is None:
            self.slot = self.slot
        else:
            slot, q = self.slot, self.q
            clock.slots[row], clock.qs[row] = -1 if slot is None else slot, q
            self.count_with(clock, row)

    def count_with(self, clock: SharedClock, row: int) -> None:
        """Let the slot counter and Q be those a shared clock's arrays hold at ``row`` until
        either is set: :meth:`follow_decrements` when the arrays' step has written the tag's
        values there already (a population's decrement or counter draw).

        Parameters
        ----------
        clock : SharedClock
            The clock whose ``slots`` and ``qs`` hold the counter and Q at ``row``.
        row : int
            The tag's row of the clock's arrays.
        """
        self._slot_clock, self._slot = clock, row

    def _advance(self, t_s: float) -> None:
        t_s = float(t_s)
        now = self.t_s
        if t_s < now:
            raise ValueError(f"time went backwards: {t_s} s < {now} s")
        self.t_s = t_s
        if self._s1_set_s is not None and s1_reverts(t_s, self._s1_set_s, self.persistence.s1_s):
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
        decays by its own timer regardless of power (EPC Gen2 "Sessions and inventoried
        flags"). Nothing changes when the power state is the same. A killed tag stays killed.

        Parameters
        ----------
        powered : bool
            The new power state.
        t_s : float
            Time of the event [s].

        Raises
        ------
        ValueError
            When ``t_s`` is before the state's time.
        """
        self._advance(t_s)
        powered = bool(powered)
        if powered == self.powered:
            return
        if self.state == "killed":  # killed for good
            self.powered = powered
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
    def on_command(self, cmd, *, t_s: float, rng: np.random.Generator,
                   power_margin_db: float = math.inf) -> Reply | None:
        """Apply one reader command received at time ``t_s`` [s]; return the tag's reply.

        An unpowered or killed tag ignores every command. The rules are those of the module
        docstring (EPC Gen2 command sections).

        Parameters
        ----------
        cmd : rfsim.gen2.commands command
            Query, QueryRep, QueryAdjust, ACK, NAK, Select or an access command
            (:data:`rfsim.gen2.commands.ACCESS_COMMANDS`).
        t_s : float
            Keyword-only: time the command is received [s].
        rng : numpy.random.Generator
            Keyword-only: the tag's own generator (slot counters, RN16s, handles).
        power_margin_db : float
            Keyword-only: power at the chip above its sensitivity [dB]; a command that writes
            memory below the chip's write threshold gets error 0x0B (insufficient power,
            :func:`rfsim.gen2.access.execute`). Default inf.

        Returns
        -------
        Reply or None
            What the tag backscatters; None when it stays silent.

        Raises
        ------
        TypeError
            When ``cmd`` is not a Gen2 command.
        ValueError
            When ``t_s`` is before the state's time.
        """
        self._advance(t_s)
        if not self.powered or self.state == "killed":
            return None
        if isinstance(cmd, Query):
            return self._query(cmd, rng)
        if isinstance(cmd, (QueryRep, QueryAdjust, ACK, NAK)):
            return self._round_command(cmd, rng)
        if isinstance(cmd, ACCESS_COMMANDS):
            return self._access_command(cmd, rng, power_margin_db)
        if isinstance(cmd, Select):
            self._select(cmd)
            return None
        raise TypeError(f"not a Gen2 command: {cmd!r}")

    def on_command_if_silent(self, cmd, *, t_s: float) -> bool:
        """Apply ``cmd`` when it is a silent step that needs no random draw.

        When applied, the tag is exactly as :meth:`on_command` would leave it, and it does not
        reply; otherwise nothing is done (call :meth:`on_command`).

        The silent steps of a powered tag (``silent`` of
        :func:`rfsim.devices.gen2_tag_arrays.round_step`, the rules :class:`StateArrays` applies
        to a population): a QueryRep or QueryAdjust of another session than the tag's round (or
        with no round); a QueryRep in Arbitrate whose decremented counter is not 0 (the counter
        decrements, nothing else changes); an ACK or NAK in Ready or Arbitrate. These are the
        same steps as in :meth:`on_command`, taken without the dispatch — in an inventory almost
        every tag takes one of them on almost every command.

        Parameters
        ----------
        cmd : rfsim.gen2.commands command
            The received command.
        t_s : float
            Keyword-only: time the command is received [s].

        Returns
        -------
        bool
            True if the step was applied, False if nothing was done (also for an unpowered
            tag).

        Raises
        ------
        ValueError
            When a silent step's ``t_s`` is before the state's time.
        """
        if not self.powered:
            return False
        step = round_step_of_one(cmd, self.state, self.session)
        if not step.silent:
            return False
        if step.decrement:
            slot = decremented(self.slot)
            if slot_replies(slot):
                return False
            self._advance(t_s)
            self.slot = slot
            return True
        self._advance(t_s)
        return True

    def row(self) -> tuple:
        """Return the state as one row of :class:`StateArrays`.

        Returns
        -------
        tuple
            ``(powered, state code, session or −1, slot or −1, t_s [s], time S1 was set to B
            [s] or NaN, S1 persistence [s], Q)``.
        """
        return (self.powered, STATE_CODES[self.state], -1 if self.session is None else self.session,
                -1 if self.slot is None else self.slot, self.t_s,
                float("nan") if self._s1_set_s is None else self._s1_set_s, self.persistence.s1_s, self.q)

    def _load_slot(self, rng: np.random.Generator) -> Reply | None:
        self.slot = slot_draw(rng, self.q)
        return self._reply_if_zero(rng)

    def _reply_if_zero(self, rng: np.random.Generator) -> Reply | None:
        if slot_replies(self.slot):
            self.state = "reply"
            self.rn16 = draw_rn16(rng)
            return Reply._own("RN16", _bits16(self.rn16))
        self.state = "arbitrate"
        return None

    def _query(self, cmd: Query, rng) -> Reply | None:
        if round_step_of_one(cmd, self.state, self.session).close:
            self._set_flag(self.session, _FLIP[self.inventoried[self.session]])
        self.last_query = cmd
        if not query_matches(cmd.sel, cmd.target, self.sl, self.inventoried[cmd.session]):
            self._reset_round()
            return None
        self.session, self.q, self.handle = cmd.session, cmd.q, None
        return self._load_slot(rng)

    def _round_command(self, cmd, rng) -> Reply | None:
        """QueryRep, QueryAdjust, ACK or NAK: the transition
        :func:`rfsim.devices.gen2_tag_arrays.round_step` decides (this tag's row of it)."""
        step = round_step_of_one(cmd, self.state, self.session)
        if step.close:  # the access ends: the round's flag inverts, back to Ready
            self._set_flag(self.session, _FLIP[self.inventoried[self.session]])
            self._reset_round()
        elif step.wrap:
            self.state, self.slot = "arbitrate", SLOT_AFTER_WRAP
        elif step.decrement:
            self.slot = decremented(self.slot)
            return self._reply_if_zero(rng)
        elif step.redraw:
            self.q = int(adjusted_q(self.q, cmd.updn))
            return self._load_slot(rng)
        elif step.acknowledge or step.confirm:
            if cmd.rn16 != (self.rn16 if step.acknowledge else self.handle):
                self.state = "arbitrate"
                return None
            if step.acknowledge:
                self.state = "acknowledged"
            return self._epc_reply()
        elif step.to_arbitrate:
            self.state = "arbitrate"
        return None

    def _epc_reply(self) -> Reply:
        """The ACK reply PC + EPC + CRC-16 (an immutable record: made once for this PC and
        EPC and given again while they stay the same)."""
        words = self._pc_epc_words()
        memo = self.__dict__.get("_epc_reply_memo")
        if memo is None or memo[0] != words:
            # PC + EPC and their CRC-16 (over the words' bytes as sent, MSB first), as bits at once
            bits = _words_bits([*words, crc16_bytes(np.asarray(words, dtype=">u2").tobytes())])
            bits.setflags(write=False)
            memo = self.__dict__["_epc_reply_memo"] = (list(words), Reply._own("EPC", bits))
        return memo[1]

    def _req_rn(self, cmd: ReqRN, rng) -> Reply | None:
        """Req_RN in Acknowledged: the handle, and Open or Secured
        (:func:`rfsim.gen2.access.state_after_req_rn`)."""
        if cmd.rn16 != self.rn16:  # invalid RN16: ignored, tag stays Acknowledged
            return None
        self.handle = draw_rn16(rng)
        self.state = state_after_req_rn(self.memory)
        self._access = AccessContext(self.state, self.handle, cover_rn16=self.handle)
        return Reply("HANDLE", rn_reply(self.handle))

    def _access_command(self, cmd, rng, power_margin_db: float) -> Reply | None:
        """An access command: Req_RN in Acknowledged (:meth:`_req_rn`), any in Open/Secured
        :func:`rfsim.gen2.access.execute` (ignored in any other state)."""
        if isinstance(cmd, ReqRN) and self.state == "acknowledged":
            return self._req_rn(cmd, rng)
        if self.state not in ("open", "secured"):
            return None
        res = execute(self.memory, self._access, cmd, power_margin_db=power_margin_db, rng=rng)
        self._access = res.context
        self.state = res.context.state
        if res.reply is None:
            return None
        if isinstance(cmd, ReqRN):
            kind = "RN16"
        elif res.error is not None:
            kind = "ERROR"
        elif isinstance(cmd, Read):
            kind = "READ"
        else:
            kind = "DELAYED" if res.delayed else "HANDLE"
        return Reply(kind, res.reply, delay_s=res.delay_s, delayed=res.delayed)

    def select_matches(self, cmd: Select) -> bool:
        """Tell whether the tag matches a Select's mask (EPC Gen2 "Select").

        Parameters
        ----------
        cmd : rfsim.gen2.commands.Select
            The Select (``membank``, ``pointer``, ``length``, ``mask``).

        Returns
        -------
        bool
            True when ``cmd.mask`` equals the bank bits from bit ``cmd.pointer`` on; Length 0
            matches every tag, a mask running past the end of the bank matches none.
        """

        if cmd.length == 0:
            return True
        bank = self.bank_bits(cmd.membank)
        stop = cmd.pointer + cmd.length
        if stop > bank.size:
            return False
        return bool(np.array_equal(bank[cmd.pointer : stop], str_to_bits(cmd.mask)))

    def _select(self, cmd: Select) -> None:
        """Select (Gen2 "Select"): the action table
        (:func:`rfsim.devices.gen2_tag_arrays.select_step`) applied to the SL flag (target 4)
        or an inventoried flag (targets 0–3: asserted = A), then back to Ready."""
        if cmd.membank == 0:  # MemBank 00 is RFU for Select in Gen2 v1.2: ignored
            return
        match = self.select_matches(cmd)
        if cmd.target == 4:
            acts, new = select_step(cmd.action, match, self.sl)
            if acts:
                self.sl = bool(new)
        elif cmd.target <= 3:
            s = cmd.target
            acts, new = select_step(cmd.action, match, self.inventoried[s] == "A")
            if acts:
                self._set_flag(s, "A" if new else "B")
        self._reset_round()


def _bits_arg(value) -> np.ndarray:
    if isinstance(value, str):
        return hex_to_bits(value) if value else np.zeros(0, np.uint8)
    return as_bits(value).copy()


def _words_bits(words) -> np.ndarray:
    """16-bit words → their bits MSB first, ``(16·n,) uint8``."""
    return np.unpackbits(np.asarray(words, dtype=">u2").view(np.uint8))


def _memory_of(epc: np.ndarray, tid: np.ndarray, user: np.ndarray, kill_password, access_password,
               chip: ChipModel) -> TagMemory:
    """The memory holding exactly these contents (bits) on ``chip`` resized to them."""
    pc_word(epc)  # the EPC length check
    if tid.size % 16 or user.size % 16:
        raise ValueError("TID and User memory must be whole 16-bit words")
    for name, pwd in (("kill_password", kill_password), ("access_password", access_password)):
        if not 0 <= int(pwd) < 1 << 32:
            raise ValueError(f"{name} must be a 32-bit value, got {pwd}")
    words = [np.packbits(b).view(">u2").tolist() for b in (epc, tid, user)]
    chip = dataclasses.replace(chip, epc_words=len(words[0]), user_words=len(words[2]))
    return TagMemory.from_words(chip, epc=words[0], tid=words[1], user=words[2], kill_password=int(kill_password),
                                access_password=int(access_password))


__all__ = [
    "STATES",
    "REPLY_KINDS",
    "SLOT_AFTER_WRAP",
    "ERROR_MEMORY_OVERRUN",
    "DEFAULT_TID_HEX",
    "DEFAULT_CHIP",
    "Reply",
    "FlagPersistence",
    "SharedClock",
    "TagState",
    "StateArrays",
    "STATE_CODES",
    "slot_draw",
    "pc_word",
]

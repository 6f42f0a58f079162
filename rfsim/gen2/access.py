"""Tag-side execution of Gen2 access commands: replies, state and reply delay.

:func:`execute` takes a tag's memory (:class:`rfsim.gen2.memory.TagMemory`), its access
context (:class:`AccessContext`: Open/Secured/Killed, handle, the last RN16 it backscattered)
and one parsed access command of :mod:`rfsim.gen2.commands`, and returns what the tag
backscatters, its new context and when it answers (EPC Gen2 v2 / ISO 18000-63 §6.3.2.12.3).
It is logic only: no waveform, no inventory state (Ready/Arbitrate/Reply/Acknowledged belong
to the tag state machine, which hands over with :func:`state_after_req_rn`).

Replies (MSB first; CRC-16 as transmitted, over every bit before it):

===============================  =================================================  =======
command                          reply                                              timing
===============================  =================================================  =======
Req_RN                           new RN16 | CRC-16                                  T1
Read                             ``0`` | words | handle | CRC-16                    T1
Access, first Kill               handle | CRC-16                                    T1
Write, BlockWrite, BlockErase,   success ``0`` | handle | CRC-16;                   delayed
Lock, final Kill                 error ``1`` | code(8) | handle | CRC-16
(errors of Read likewise)        ``1`` | code(8) | handle | CRC-16                  T1
===============================  =================================================  =======

A delayed ("in-process") reply comes once the tag has programmed its memory, with the
extended preamble (the tag replies as if TRext = 1), at most 20 ms after the command
(:data:`MAX_DELAYED_REPLY_S`, the standard's limit for a Write's reply). Its delay here is
``n_words · write_time_s`` of the chip (:class:`rfsim.gen2.memory.ChipModel`) on success and
on an insufficient-power error, 0 for errors found before programming (overrun, locked), in
addition to T1. A command that writes memory needs ``power_margin_db`` (power at the chip
above its read sensitivity) of at least the chip's ``write_threshold_db``; below, the tag
answers error 0x0B (insufficient power) and memory is unchanged (the project's model of a
failed programming, with the datasheet's read/write sensitivity gap as threshold).

No reply: a Killed tag; a handle that is not the tag's (§6.3.2.12.3: the command is for
another tag); an incorrect Access or Kill password half (the tag goes to Arbitrate); a Lock
in Open (Lock is valid in Secured only, as recalled from the standard's state tables).

Password sequences (§6.3.2.12.3.4 Kill, §6.3.2.12.3.6 Access): the reader sends the upper
half XOR an RN16 from Req_RN, then the lower half XOR a newer RN16; any command other than
Req_RN in between restarts the sequence. Each half is checked on arrival. Both Access halves
right → Secured. Both Kill halves right and a non-zero kill password → Killed, with a
delayed success reply; a zero kill password → error 0x00 (other error; a tag does not kill
with a zero kill password). Kill with non-zero Recom bits (recommissioning) → error 0x01
(not supported here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from rfsim.gen2.bits import int_to_bits
from rfsim.gen2.commands import (
    ACCESS_COMMANDS,
    Access,
    BlockErase,
    BlockWrite,
    Kill,
    Lock,
    Read,
    ReqRN,
    Write,
)
from rfsim.gen2.crc import append_crc16
from rfsim.gen2.memory import MemoryAccessError, TagError, TagMemory
from rfsim.gen2.tag_draws import draw_rn16

#: Longest time a tag may take to send a delayed reply, s (EPC Gen2 v2, Write command:
#: 20 ms).
MAX_DELAYED_REPLY_S = 20e-3

#: Bits of an error reply: header ``1`` | error code (8) | handle (16) | CRC-16 (16).
ERROR_REPLY_BITS = 41
#: Bits of a delayed success reply: header ``0`` | handle (16) | CRC-16 (16).
SUCCESS_REPLY_BITS = 33
#: Bits of an RN16 or handle reply (Req_RN, Access, the first Kill): RN16 (16) | CRC-16 (16).
RN_REPLY_BITS = 32


def read_reply_bits(word_count: int) -> int:
    """Bits of a Read reply of ``word_count`` words: ``0`` | words | handle | CRC-16.

    Parameters
    ----------
    word_count : int
        Words read.

    Returns
    -------
    int
        ``33 + 16·word_count``.
    """
    return 33 + 16 * int(word_count)

State = Literal["open", "secured", "killed", "arbitrate"]


@dataclass(frozen=True)
class AccessContext:
    """Access state of one tag after singulation.

    Parameters
    ----------
    state : str
        ``"open"``, ``"secured"``, ``"killed"`` or ``"arbitrate"`` (left the access states).
    handle : int
        The tag's handle (16 bits).
    cover_rn16 : int
        The last RN16 the tag backscattered (handle or Req_RN reply): the cover code of the
        next Write, Kill or Access.
    pending : str
        ``"access"`` or ``"kill"`` after a right first password half; ``""`` otherwise.
    """

    state: State
    handle: int
    cover_rn16: int
    pending: str = ""

    def __post_init__(self):
        if self.state not in ("open", "secured", "killed", "arbitrate"):
            raise ValueError(f"access state must be open, secured, killed or arbitrate, got {self.state!r}")
        if self.pending not in ("", "access", "kill"):
            raise ValueError(f"pending must be '', 'access' or 'kill', got {self.pending!r}")

    @property
    def secured(self) -> bool:
        """Whether the tag is in the Secured state."""
        return self.state == "secured"


@dataclass(frozen=True)
class AccessResult:
    """What a tag does with one access command.

    Parameters
    ----------
    reply : numpy.ndarray or None
        ``(n,) uint8`` reply bits (CRC included), None for no reply.
    context : AccessContext
        The tag's access context after the command.
    delay_s : float
        Delay of the reply beyond T1, s (0 for immediate replies).
    delayed : bool
        Whether the reply is a delayed ("in-process") reply (extended preamble).
    error : TagError or None
        Error code of an error reply.
    words : tuple of int
        Words read (Read only).
    """

    reply: np.ndarray | None
    context: AccessContext
    delay_s: float = 0.0
    delayed: bool = False
    error: TagError | None = None
    words: tuple[int, ...] = ()


def state_after_req_rn(memory: TagMemory) -> State:
    """Access state a tag enters from Acknowledged on Req_RN.

    A tag whose access password is zero goes to Secured, otherwise to Open (EPC Gen2 v2,
    §6.3.2.12.3.1 Req_RN / Acknowledged state).

    Parameters
    ----------
    memory : TagMemory
        The tag's memory.

    Returns
    -------
    str
        ``"secured"`` or ``"open"``.
    """
    return "secured" if memory.access_password == 0 else "open"


def _bits(*fields: tuple[int, int]) -> np.ndarray:
    return np.concatenate([int_to_bits(value, n) for value, n in fields]) if fields else np.zeros(0, np.uint8)


def success_reply(handle: int) -> np.ndarray:
    """Bits of a delayed reply of success: ``0`` | handle | CRC-16 (33 bits).

    Parameters
    ----------
    handle : int
        The tag's handle.

    Returns
    -------
    numpy.ndarray
        ``(33,) uint8``.
    """
    return append_crc16(_bits((0, 1), (handle, 16)))


def error_reply(code: int, handle: int) -> np.ndarray:
    """Bits of an error reply: ``1`` | error code (8) | handle | CRC-16 (41 bits).

    Parameters
    ----------
    code : int
        Error code (:class:`rfsim.gen2.memory.TagError`).
    handle : int
        The tag's handle.

    Returns
    -------
    numpy.ndarray
        ``(41,) uint8``.
    """
    return append_crc16(_bits((1, 1), (int(code), 8), (handle, 16)))


def read_reply(words, handle: int) -> np.ndarray:
    """Bits of a Read reply: ``0`` | words | handle | CRC-16.

    Parameters
    ----------
    words : sequence of int
        The 16-bit words read.
    handle : int
        The tag's handle.

    Returns
    -------
    numpy.ndarray
        ``(33 + 16·len(words),) uint8``.
    """
    return append_crc16(_bits((0, 1), *[(w, 16) for w in words], (handle, 16)))


def rn_reply(rn16: int) -> np.ndarray:
    """Bits of an RN16 + CRC-16 reply (Req_RN; Access and first Kill, with the handle).

    Parameters
    ----------
    rn16 : int
        The RN16 or handle.

    Returns
    -------
    numpy.ndarray
        ``(32,) uint8``.
    """
    return append_crc16(_bits((rn16, 16)))


def execute(memory: TagMemory, context: AccessContext, cmd, *, power_margin_db: float = math.inf,
            rng: np.random.Generator | None = None) -> AccessResult:
    """Execute one access command on a tag.

    The memory is changed in place by a successful Write, BlockWrite, BlockErase or Lock.

    Parameters
    ----------
    memory : TagMemory
        The tag's memory.
    context : AccessContext
        The tag's access state before the command.
    cmd : Command
        A parsed access command (Req_RN, Read, Write, Kill, Lock, Access, BlockWrite,
        BlockErase).
    power_margin_db : float
        Power at the chip above its read sensitivity, dB; default inf (plenty).
    rng : numpy.random.Generator or None
        Draws the new RN16 of a Req_RN (required for Req_RN;
        :func:`rfsim.gen2.tag_draws.draw_rn16`).

    Returns
    -------
    AccessResult
        Reply bits (or None), new context, delay and error code.

    Raises
    ------
    TypeError
        If ``cmd`` is not an access command.
    ValueError
        For a Req_RN without ``rng``.
    """
    if not isinstance(cmd, ACCESS_COMMANDS):
        raise TypeError(f"not an access command: {cmd!r}")
    if context.state not in ("open", "secured") or cmd.rn16 != context.handle:
        return AccessResult(None, context)
    handle = context.handle
    if isinstance(cmd, ReqRN):
        if rng is None:
            raise ValueError("Req_RN needs rng to draw the new RN16")
        rn16 = draw_rn16(rng)
        return AccessResult(rn_reply(rn16), replace(context, cover_rn16=rn16))
    if isinstance(cmd, (Access, Kill)):
        return _password_half(memory, context, cmd, power_margin_db)
    ctx = replace(context, pending="")
    if isinstance(cmd, Read):
        try:
            words = memory.read(cmd.membank, cmd.word_ptr, cmd.word_count, secured=ctx.secured)
        except MemoryAccessError as err:
            return AccessResult(error_reply(err.code, handle), ctx, error=err.code)
        return AccessResult(read_reply(words, handle), ctx, words=words)
    if isinstance(cmd, Lock) and not ctx.secured:
        return AccessResult(None, ctx)
    return _delayed(memory, ctx, cmd, power_margin_db)


def _delayed(memory: TagMemory, ctx: AccessContext, cmd, power_margin_db: float) -> AccessResult:
    """Write, BlockWrite, BlockErase, Lock: check, program, answer with a delayed reply."""
    chip, handle, secured = memory.chip, ctx.handle, ctx.secured
    try:
        if isinstance(cmd, Write):
            words = [cmd.data ^ ctx.cover_rn16]
            memory.check_write(cmd.membank, cmd.word_ptr, words, secured=secured)
            n_words, apply = 1, lambda: memory.write(cmd.membank, cmd.word_ptr, words, secured=secured)
        elif isinstance(cmd, BlockWrite):
            if cmd.word_count > chip.max_block_write_words:
                raise MemoryAccessError(TagError.NOT_SUPPORTED, f"BlockWrite of {cmd.word_count} words")
            memory.check_write(cmd.membank, cmd.word_ptr, cmd.data, secured=secured)
            n_words, apply = cmd.word_count, lambda: memory.write(cmd.membank, cmd.word_ptr, cmd.data,
                                                                 secured=secured)
        elif isinstance(cmd, BlockErase):
            if not chip.block_erase:
                raise MemoryAccessError(TagError.NOT_SUPPORTED, "BlockErase")
            memory.check_write(cmd.membank, cmd.word_ptr, [0] * cmd.word_count, secured=secured)
            n_words, apply = cmd.word_count, lambda: memory.erase(cmd.membank, cmd.word_ptr, cmd.word_count,
                                                                 secured=secured)
        else:  # Lock
            memory.locks_after(cmd.mask, cmd.action)
            n_words, apply = 1, lambda: memory.lock(cmd.mask, cmd.action)
    except MemoryAccessError as err:
        return AccessResult(error_reply(err.code, handle), ctx, delayed=True, error=err.code)
    delay_s = n_words * chip.write_time_s
    if power_margin_db < chip.write_threshold_db:
        code = TagError.INSUFFICIENT_POWER
        return AccessResult(error_reply(code, handle), ctx, delay_s=delay_s, delayed=True, error=code)
    apply()
    return AccessResult(success_reply(handle), ctx, delay_s=delay_s, delayed=True)


def _password_half(memory: TagMemory, context: AccessContext, cmd, power_margin_db: float) -> AccessResult:
    """One Access or Kill command: check the half, advance the sequence, answer."""
    kind = "access" if isinstance(cmd, Access) else "kill"
    handle = context.handle
    password = memory.access_password if kind == "access" else memory.kill_password
    second = context.pending == kind
    expected = password & 0xFFFF if second else password >> 16
    if cmd.password ^ context.cover_rn16 != expected:
        return AccessResult(None, replace(context, state="arbitrate", pending=""))
    if not second:
        return AccessResult(rn_reply(handle), replace(context, pending=kind))
    ctx = replace(context, pending="")
    if kind == "access":
        return AccessResult(rn_reply(handle), replace(ctx, state="secured"))
    if cmd.recom:
        code = TagError.NOT_SUPPORTED
        return AccessResult(error_reply(code, handle), ctx, delayed=True, error=code)
    if password == 0:
        code = TagError.OTHER
        return AccessResult(error_reply(code, handle), ctx, delayed=True, error=code)
    delay_s = memory.chip.write_time_s
    if power_margin_db < memory.chip.write_threshold_db:
        code = TagError.INSUFFICIENT_POWER
        return AccessResult(error_reply(code, handle), ctx, delay_s=delay_s, delayed=True, error=code)
    return AccessResult(success_reply(handle), replace(ctx, state="killed"), delay_s=delay_s, delayed=True)


__all__ = [
    "MAX_DELAYED_REPLY_S", "ERROR_REPLY_BITS", "SUCCESS_REPLY_BITS", "RN_REPLY_BITS", "read_reply_bits", "AccessContext", "AccessResult",
    "state_after_req_rn", "execute",
    "success_reply", "error_reply", "read_reply", "rn_reply",
]

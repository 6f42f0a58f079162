"""Gen2 reader commands: typed fields, bit encoding and parsing.

Formats (gen2-and-validation-anchors.md §3.3, §4.4; EPC Gen2 "Commands" section), MSB first:

=============  ==========================================================================  ======
command        fields                                                                      bits
=============  ==========================================================================  ======
QueryRep       ``00`` | Session(2)                                                          4
ACK            ``01`` | RN16(16)                                                            18
Query          ``1000`` | DR(1) | M(2) | TRext(1) | Sel(2) | Session(2) | Target(1) |      22
               Q(4) | CRC-5
QueryAdjust    ``1001`` | Session(2) | UpDn(3)                                              9
Select         ``1010`` | Target(3) | Action(3) | MemBank(2) | Pointer(EBV) | Length(8) |   ≥ 45
               Mask(Length) | Truncate(1) | CRC-16
NAK            ``11000000``                                                                 8
Req_RN         ``11000001`` | RN16(16) | CRC-16                                              40
Read           ``11000010`` | MemBank(2) | WordPtr(EBV) | WordCount(8) | RN16(16) |         ≥ 58
               CRC-16
Write          ``11000011`` | MemBank(2) | WordPtr(EBV) | Data(16, cover-coded) |            ≥ 66
               RN16(16) | CRC-16
Kill           ``11000100`` | Password(16, cover-coded) | RFU/Recom(3) | RN16(16) |        59
               CRC-16
Lock           ``11000101`` | Payload(20: Mask(10) Action(10)) | RN16(16) | CRC-16          60
Access         ``11000110`` | Password(16, cover-coded) | RN16(16) | CRC-16                 56
BlockWrite     ``11000111`` | MemBank(2) | WordPtr(EBV) | WordCount(8) |                    ≥ 74
               Data(16·WordCount) | RN16(16) | CRC-16
BlockErase     ``11001000`` | MemBank(2) | WordPtr(EBV) | WordCount(8) | RN16(16) |        ≥ 58
               CRC-16
=============  ==========================================================================  ======

Access commands (EPC Gen2 v2 / ISO 18000-63 §6.3.2.12.3: Write, Kill, Lock, Access,
BlockWrite, BlockErase) carry the tag's handle in their RN16 field. Write, Kill and Access
send a 16-bit word *cover-coded*: the on-air field is the word XOR a fresh RN16 the reader
obtained with Req_RN (:func:`cover_code`; Kill and Access send a password in two halves, one
command each). The objects here hold the on-air field values (``data``/``password`` as
sent); :meth:`Write.cover_coded`, :meth:`Kill.cover_coded` and :meth:`Access.cover_coded`
build them from the plain word. The Lock payload is Mask(10) | Action(10), each in the order
kill password, access password, EPC, TID, User with two bits per field (:data:`LOCK_FIELDS`;
mask bit 1: apply the action's pair; action pair: pwd-write/read lock, permalock).

Field conventions (Query): DR "8" → 0, "64/3" → 1; M 1/2/4/8 (FM0, Miller-2/4/8) → 00/01/10/11;
Sel "all" → 00, "all01" → 01 (the standard's second code for All), "~sl" → 10, "sl" → 11;
Session 0–3 (S0–S3); Target "A" → 0, "B" → 1; Q 0–15. QueryAdjust UpDn +1 → 110, 0 → 000,
−1 → 011. Invalid field values raise :class:`rfsim.core.errors.ConfigError` (a ``ValueError``)
naming the field, the value and what is allowed.

:func:`parse` identifies a command by its prefix and length and verifies its CRC. It
**raises** :class:`CommandParseError` on an unknown prefix, a wrong length, an invalid field
code or a bad CRC — a tag that cannot parse a command ignores it, so there is no partially
valid result to return.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from fractions import Fraction
from typing import ClassVar, Union

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.gen2.bits import as_bits, bits_to_int, bits_to_str, int_to_bits, str_to_bits
from rfsim.gen2.crc import append_crc5, append_crc16, crc5_ok, crc16_ok

DR_VALUES: dict[str, Fraction] = {"8": Fraction(8), "64/3": Fraction(64, 3)}
"""Divide ratios by their canonical names (BLF = DR / TRcal)."""

M_CODES = {1: 0b00, 2: 0b01, 4: 0b10, 8: 0b11}
SEL_CODES = {"all": 0b00, "all01": 0b01, "~sl": 0b10, "sl": 0b11}
TARGET_CODES = {"A": 0, "B": 1}
UPDN_CODES = {1: 0b110, 0: 0b000, -1: 0b011}
MEMBANKS = {0: "reserved", 1: "epc", 2: "tid", 3: "user"}
#: Fields of a Lock payload, most significant first (two mask and two action bits each).
LOCK_FIELDS = ("kill_pwd", "access_pwd", "epc", "tid", "user")


class CommandParseError(ValueError):
    """A bit string is not a valid Gen2 command (unknown prefix, length, field or CRC)."""


# --------------------------------------------------------------------------- helpers


def normalize_dr(value, key: str = "dr") -> str:
    """Canonical divide-ratio name ``"8"`` or ``"64/3"``.

    Floats are refused (64/3 has no exact float).

    Parameters
    ----------
    value : str, int or fractions.Fraction
        A name, int 8 or ``Fraction(64, 3)``.
    key : str
        Configuration key named in the error.

    Returns
    -------
    str
        ``"8"`` or ``"64/3"``.

    Raises
    ------
    ConfigError
        ``(key, ...)`` for any other value.
    """
    if isinstance(value, str) and value.replace(" ", "") in DR_VALUES:
        return value.replace(" ", "")
    if isinstance(value, (int, Fraction)) and not isinstance(value, bool):
        for name, frac in DR_VALUES.items():
            if value == frac:
                return name
    raise ConfigError(key, value, '"8" or "64/3" (string; or int 8 / Fraction(64, 3))')


def _check_int(key: str, value, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ConfigError(key, value, f"an integer in [{lo}, {hi}]")
    return int(value)


def _check_choice(key: str, value, choices) -> None:
    if isinstance(value, bool) or value not in choices:
        raise ConfigError(key, value, "one of " + ", ".join(repr(c) for c in choices))


def _check_bool(key: str, value) -> bool:
    if isinstance(value, (bool, np.bool_)) or value in (0, 1):
        return bool(value)
    raise ConfigError(key, value, "true/false")


def _set(obj, name: str, value) -> None:
    object.__setattr__(obj, name, value)


def ebv_encode(value: int) -> np.ndarray:
    """Extensible bit vector of ``value``.

    8-bit blocks of (extension bit, 7 value bits), MSB block first; the extension bit is 1
    in every block but the last.

    Parameters
    ----------
    value : int
        Non-negative value.

    Returns
    -------
    numpy.ndarray
        ``(8·n_blocks,) uint8`` bits.

    Raises
    ------
    ValueError
        If ``value`` is negative.

    Examples
    --------
    >>> bits_to_str(ebv_encode(128))
    '1000000100000000'
    """
    value = int(value)
    if value < 0:
        raise ValueError(f"EBV value must be non-negative, got {value}")
    groups = []
    while True:
        groups.append(value & 0x7F)
        value >>= 7
        if not value:
            break
    groups.reverse()
    out = [int_to_bits(((i < len(groups) - 1) << 7) | g, 8) for i, g in enumerate(groups)]
    return np.concatenate(out)


def ebv_decode(bits, start: int = 0) -> tuple[int, int]:
    """Decode an EBV starting at ``bits[start]``.

    Parameters
    ----------
    bits : array_like or str
        Bit array, MSB first.
    start : int
        Index of the EBV's first bit.

    Returns
    -------
    value : int
        The decoded value.
    n_bits_used : int
        Bits the EBV occupies (a multiple of 8).

    Raises
    ------
    ValueError
        When the bits end before a block with extension bit 0.
    """
    arr = as_bits(bits)
    value, pos = 0, int(start)
    while True:
        if pos + 8 > arr.size:
            raise ValueError("EBV runs past the end of the bits")
        block = bits_to_int(arr[pos : pos + 8])
        value = (value << 7) | (block & 0x7F)
        pos += 8
        if not block & 0x80:
            return value, pos - int(start)


# --------------------------------------------------------------------------- commands


@dataclass(frozen=True)
class Query:
    """Query: start an inventory round (sent after the full preamble with TRcal)."""

    dr: str = "8"
    m: int = 1
    trext: bool = False
    sel: str = "all"
    session: int = 0
    target: str = "A"
    q: int = 4

    NAME: ClassVar[str] = "Query"
    PREAMBLE: ClassVar[str] = "query"

    def __post_init__(self):
        _set(self, "dr", normalize_dr(self.dr, "query.dr"))
        _check_choice("query.m", self.m, tuple(M_CODES))
        _set(self, "m", int(self.m))
        _set(self, "trext", _check_bool("query.trext", self.trext))
        _check_choice("query.sel", self.sel, tuple(SEL_CODES))
        _set(self, "session", _check_int("query.session", self.session, 0, 3))
        _check_choice("query.target", self.target, tuple(TARGET_CODES))
        _set(self, "q", _check_int("query.q", self.q, 0, 15))

    def _encode(self) -> np.ndarray:
        # code 1000, DR (1), M (2), TRext (1), Sel (2), Session (2), Target (1), Q (4): the
        # fields as one 17-bit word, MSB first, then its CRC-5
        word = 0b1000
        for value, n_bits in ((self.dr == "64/3", 1), (M_CODES[self.m], 2), (self.trext, 1),
                              (SEL_CODES[self.sel], 2), (self.session, 2), (TARGET_CODES[self.target], 1),
                              (self.q, 4)):
            word = (word << n_bits) | int(value)
        return append_crc5(int_to_bits(word, 17))


@dataclass(frozen=True)
class QueryRep:
    """QueryRep: decrement slot counters of the tags in the round's session."""

    session: int = 0

    NAME: ClassVar[str] = "QueryRep"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _set(self, "session", _check_int("queryrep.session", self.session, 0, 3))

    def _encode(self) -> np.ndarray:
        return np.concatenate([str_to_bits("00"), int_to_bits(self.session, 2)])


@dataclass(frozen=True)
class QueryAdjust:
    """QueryAdjust: change Q by ``updn`` ∈ {+1, 0, −1} and re-draw slot counters."""

    session: int = 0
    updn: int = 0

    NAME: ClassVar[str] = "QueryAdjust"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _set(self, "session", _check_int("queryadjust.session", self.session, 0, 3))
        _check_choice("queryadjust.updn", self.updn, tuple(UPDN_CODES))
        _set(self, "updn", int(self.updn))

    def _encode(self) -> np.ndarray:
        return np.concatenate(
            [str_to_bits("1001"), int_to_bits(self.session, 2), int_to_bits(UPDN_CODES[self.updn], 3)]
        )


@dataclass(frozen=True)
class ACK:
    """ACK: echo the tag's RN16 (no CRC)."""

    rn16: int = 0

    NAME: ClassVar[str] = "ACK"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _set(self, "rn16", _check_int("ack.rn16", self.rn16, 0, 0xFFFF))

    def _encode(self) -> np.ndarray:
        # code 01 then the RN16, MSB first: the low 18 bits of 0b01 << 16 | RN16 as 3 bytes
        return np.unpackbits(np.frombuffer(((1 << 16) | self.rn16).to_bytes(3, "big"), dtype=np.uint8))[6:]


@dataclass(frozen=True)
class NAK:
    """NAK: return tags to Arbitrate."""

    NAME: ClassVar[str] = "NAK"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def _encode(self) -> np.ndarray:
        return str_to_bits("11000000")


@dataclass(frozen=True)
class ReqRN:
    """Req_RN: ask an acknowledged tag for a handle (or a new RN16); RN16 + CRC-16."""

    rn16: int = 0

    NAME: ClassVar[str] = "Req_RN"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _set(self, "rn16", _check_int("req_rn.rn16", self.rn16, 0, 0xFFFF))

    def _encode(self) -> np.ndarray:
        return append_crc16(np.concatenate([str_to_bits("11000001"), int_to_bits(self.rn16, 16)]))


@dataclass(frozen=True)
class Read:
    """Read ``word_count`` 16-bit words (0 = to the end of the bank) from ``membank``
    (0 Reserved, 1 EPC, 2 TID, 3 User) starting at word ``word_ptr``; ``rn16`` = handle."""

    membank: int = 1
    word_ptr: int = 0
    word_count: int = 1
    rn16: int = 0

    NAME: ClassVar[str] = "Read"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _set(self, "membank", _check_int("read.membank", self.membank, 0, 3))
        _set(self, "word_ptr", _check_int("read.word_ptr", self.word_ptr, 0, 2**32 - 1))
        _set(self, "word_count", _check_int("read.word_count", self.word_count, 0, 255))
        _set(self, "rn16", _check_int("read.rn16", self.rn16, 0, 0xFFFF))

    def _encode(self) -> np.ndarray:
        body = [
            str_to_bits("11000010"),
            int_to_bits(self.membank, 2),
            ebv_encode(self.word_ptr),
            int_to_bits(self.word_count, 8),
            int_to_bits(self.rn16, 16),
        ]
        return append_crc16(np.concatenate(body))


@dataclass(frozen=True)
class Select:
    """Select: set SL or inventoried flags of tags whose ``membank`` bits starting at bit
    ``pointer`` match ``mask`` (a '0'/'1' string; Length = ``len(mask)`` ≤ 255).

    ``target`` 0–3 = inventoried flag of S0–S3, 4 = SL; ``action`` 0–7 (standard's table).
    """

    target: int = 4
    action: int = 0
    membank: int = 1
    pointer: int = 32
    mask: str = ""
    truncate: bool = False

    NAME: ClassVar[str] = "Select"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _set(self, "target", _check_int("select.target", self.target, 0, 4))
        _set(self, "action", _check_int("select.action", self.action, 0, 7))
        _set(self, "membank", _check_int("select.membank", self.membank, 0, 3))
        _set(self, "pointer", _check_int("select.pointer", self.pointer, 0, 2**32 - 1))
        mask = self.mask
        if not isinstance(mask, str) or any(c not in "01" for c in mask) or len(mask) > 255:
            raise ConfigError("select.mask", mask, "a string of at most 255 '0'/'1' characters")
        _set(self, "truncate", _check_bool("select.truncate", self.truncate))

    @property
    def length(self) -> int:
        """Mask length in bits (the Length field)."""
        return len(self.mask)

    def _encode(self) -> np.ndarray:
        body = [
            str_to_bits("1010"),
            int_to_bits(self.target, 3),
            int_to_bits(self.action, 3),
            int_to_bits(self.membank, 2),
            ebv_encode(self.pointer),
            int_to_bits(self.length, 8),
            str_to_bits(self.mask),
            int_to_bits(self.truncate, 1),
        ]
        return append_crc16(np.concatenate(body))


def cover_code(word: int, rn16: int) -> int:
    """Cover-code a 16-bit word for the air: ``word`` XOR ``rn16`` (Gen2 §6.3.2.12.3.4).

    The tag recovers the word by the same XOR with the RN16 it backscattered in reply to the
    reader's Req_RN; an eavesdropper on the forward link alone learns nothing of the word.

    Parameters
    ----------
    word : int
        Plain 16-bit word (data or half password), 0–0xFFFF.
    rn16 : int
        The fresh RN16 obtained with Req_RN, 0–0xFFFF.

    Returns
    -------
    int
        The on-air 16-bit field.
    """
    return _check_int("word", word, 0, 0xFFFF) ^ _check_int("rn16", rn16, 0, 0xFFFF)


def _membank_ptr_count(name: str, cmd, with_count: bool, max_count: int = 255) -> None:
    _set(cmd, "membank", _check_int(f"{name}.membank", cmd.membank, 0, 3))
    _set(cmd, "word_ptr", _check_int(f"{name}.word_ptr", cmd.word_ptr, 0, 2**32 - 1))
    if with_count:
        _set(cmd, "word_count", _check_int(f"{name}.word_count", cmd.word_count, 1, max_count))
    _set(cmd, "rn16", _check_int(f"{name}.rn16", cmd.rn16, 0, 0xFFFF))


@dataclass(frozen=True)
class Write:
    """Write: one 16-bit word to ``membank`` at word ``word_ptr``; ``data`` is the on-air,
    cover-coded field (:meth:`cover_coded`), ``rn16`` the handle."""

    membank: int = 3
    word_ptr: int = 0
    data: int = 0
    rn16: int = 0

    NAME: ClassVar[str] = "Write"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _membank_ptr_count("write", self, False)
        _set(self, "data", _check_int("write.data", self.data, 0, 0xFFFF))

    @classmethod
    def cover_coded(cls, membank: int, word_ptr: int, word: int, cover_rn16: int, handle: int) -> "Write":
        """The Write of the plain ``word``, cover-coded with ``cover_rn16``.

        Parameters
        ----------
        membank : int
            Memory bank 0–3 (Reserved, EPC, TID, User).
        word_ptr : int
            Word address.
        word : int
            Plain 16-bit word to write.
        cover_rn16 : int
            RN16 the tag returned to the Req_RN before this Write.
        handle : int
            The tag's handle.

        Returns
        -------
        Write
            The command with ``data = word ^ cover_rn16``.
        """
        return cls(membank=membank, word_ptr=word_ptr, data=cover_code(word, cover_rn16), rn16=handle)

    def _encode(self) -> np.ndarray:
        return append_crc16(np.concatenate([str_to_bits("11000011"), int_to_bits(self.membank, 2),
                                            ebv_encode(self.word_ptr), int_to_bits(self.data, 16),
                                            int_to_bits(self.rn16, 16)]))


@dataclass(frozen=True)
class Kill:
    """Kill: one half of the 32-bit kill password, cover-coded (``password`` as on air), the
    3-bit RFU/Recom field and the handle ``rn16``. A tag kills itself after two Kills in a row
    carrying both halves (first the upper word, then the lower)."""

    password: int = 0
    recom: int = 0
    rn16: int = 0

    NAME: ClassVar[str] = "Kill"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _set(self, "password", _check_int("kill.password", self.password, 0, 0xFFFF))
        _set(self, "recom", _check_int("kill.recom", self.recom, 0, 7))
        _set(self, "rn16", _check_int("kill.rn16", self.rn16, 0, 0xFFFF))

    @classmethod
    def cover_coded(cls, half_password: int, cover_rn16: int, handle: int, recom: int = 0) -> "Kill":
        """The Kill of one plain password half, cover-coded with ``cover_rn16``.

        Parameters
        ----------
        half_password : int
            Upper or lower 16 bits of the kill password.
        cover_rn16 : int
            RN16 the tag returned to the Req_RN before this Kill.
        handle : int
            The tag's handle.
        recom : int
            RFU/Recom bits (0: kill; v2 recommissioning otherwise).

        Returns
        -------
        Kill
            The command with ``password = half_password ^ cover_rn16``.
        """
        return cls(password=cover_code(half_password, cover_rn16), recom=recom, rn16=handle)

    def _encode(self) -> np.ndarray:
        return append_crc16(np.concatenate([str_to_bits("11000100"), int_to_bits(self.password, 16),
                                            int_to_bits(self.recom, 3), int_to_bits(self.rn16, 16)]))


@dataclass(frozen=True)
class Lock:
    """Lock: the 20-bit payload Mask(10) | Action(10) (fields in :data:`LOCK_FIELDS` order,
    two bits each) and the handle ``rn16``; :meth:`of` builds it per field."""

    mask: int = 0
    action: int = 0
    rn16: int = 0

    NAME: ClassVar[str] = "Lock"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _set(self, "mask", _check_int("lock.mask", self.mask, 0, 0x3FF))
        _set(self, "action", _check_int("lock.action", self.action, 0, 0x3FF))
        _set(self, "rn16", _check_int("lock.rn16", self.rn16, 0, 0xFFFF))

    @classmethod
    def of(cls, handle: int, **actions: tuple[bool, bool]) -> "Lock":
        """The Lock that applies ``(pwd_lock, permalock)`` to the named fields only.

        Parameters
        ----------
        handle : int
            The tag's handle.
        **actions : tuple of (bool, bool)
            Field name of :data:`LOCK_FIELDS` → (pwd-write/read lock bit, permalock bit);
            fields not named keep their state (mask bits 00).

        Returns
        -------
        Lock
            The command.
        """
        mask = action = 0
        for name, (lock, perma) in actions.items():
            if name not in LOCK_FIELDS:
                raise ConfigError("lock.field", name, "one of " + ", ".join(LOCK_FIELDS))
            shift = 2 * (len(LOCK_FIELDS) - 1 - LOCK_FIELDS.index(name))
            mask |= 0b11 << shift
            action |= (int(bool(lock)) << 1 | int(bool(perma))) << shift
        return cls(mask=mask, action=action, rn16=handle)

    def _encode(self) -> np.ndarray:
        return append_crc16(np.concatenate([str_to_bits("11000101"), int_to_bits(self.mask, 10),
                                            int_to_bits(self.action, 10), int_to_bits(self.rn16, 16)]))


@dataclass(frozen=True)
class Access:
    """Access: one half of the 32-bit access password, cover-coded (``password`` as on air),
    and the handle ``rn16``; two in a row (upper, then lower half) move a tag to Secured."""

    password: int = 0
    rn16: int = 0

    NAME: ClassVar[str] = "Access"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _set(self, "password", _check_int("access.password", self.password, 0, 0xFFFF))
        _set(self, "rn16", _check_int("access.rn16", self.rn16, 0, 0xFFFF))

    @classmethod
    def cover_coded(cls, half_password: int, cover_rn16: int, handle: int) -> "Access":
        """The Access of one plain password half, cover-coded with ``cover_rn16``.

        Parameters
        ----------
        half_password : int
            Upper or lower 16 bits of the access password.
        cover_rn16 : int
            RN16 the tag returned to the Req_RN before this Access.
        handle : int
            The tag's handle.

        Returns
        -------
        Access
            The command with ``password = half_password ^ cover_rn16``.
        """
        return cls(password=cover_code(half_password, cover_rn16), rn16=handle)

    def _encode(self) -> np.ndarray:
        return append_crc16(np.concatenate([str_to_bits("11000110"), int_to_bits(self.password, 16),
                                            int_to_bits(self.rn16, 16)]))


@dataclass(frozen=True)
class BlockWrite:
    """BlockWrite: ``len(data)`` words (not cover-coded) to ``membank`` from word ``word_ptr``;
    ``rn16`` = handle. WordCount = ``len(data)`` (1–255)."""

    membank: int = 3
    word_ptr: int = 0
    data: tuple[int, ...] = (0,)
    rn16: int = 0

    NAME: ClassVar[str] = "BlockWrite"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        words = tuple(self.data) if isinstance(self.data, (tuple, list)) else None
        if not words or len(words) > 255:
            raise ConfigError("block_write.data", self.data, "a list of 1 to 255 16-bit words")
        _set(self, "data", tuple(_check_int("block_write.data", w, 0, 0xFFFF) for w in words))
        _membank_ptr_count("block_write", self, False)

    @property
    def word_count(self) -> int:
        """Words written (the WordCount field)."""
        return len(self.data)

    def _encode(self) -> np.ndarray:
        return append_crc16(np.concatenate([str_to_bits("11000111"), int_to_bits(self.membank, 2),
                                            ebv_encode(self.word_ptr), int_to_bits(self.word_count, 8),
                                            *[int_to_bits(w, 16) for w in self.data], int_to_bits(self.rn16, 16)]))


@dataclass(frozen=True)
class BlockErase:
    """BlockErase: set ``word_count`` words (1–255) of ``membank`` from word ``word_ptr`` to
    zero; ``rn16`` = handle."""

    membank: int = 3
    word_ptr: int = 0
    word_count: int = 1
    rn16: int = 0

    NAME: ClassVar[str] = "BlockErase"
    PREAMBLE: ClassVar[str] = "frame-sync"

    def __post_init__(self):
        _membank_ptr_count("block_erase", self, True)

    def _encode(self) -> np.ndarray:
        return append_crc16(np.concatenate([str_to_bits("11001000"), int_to_bits(self.membank, 2),
                                            ebv_encode(self.word_ptr), int_to_bits(self.word_count, 8),
                                            int_to_bits(self.rn16, 16)]))


Command = Union[Query, QueryRep, QueryAdjust, ACK, NAK, ReqRN, Read, Select, Write, Kill, Lock, Access, BlockWrite,
                BlockErase]
COMMAND_TYPES: tuple[type, ...] = (Query, QueryRep, QueryAdjust, ACK, NAK, ReqRN, Read, Select, Write, Kill, Lock,
                                   Access, BlockWrite, BlockErase)
#: Access commands (after singulation, addressed by the handle).
ACCESS_COMMANDS: tuple[type, ...] = (ReqRN, Read, Write, Kill, Lock, Access, BlockWrite, BlockErase)
#: Command code (the bits a command starts with) → standard name, for every command here.
COMMAND_PREFIXES: dict[str, str] = {
    "00": "QueryRep", "01": "ACK", "1000": "Query", "1001": "QueryAdjust", "1010": "Select",
    "11000000": "NAK", "11000001": "Req_RN", "11000010": "Read", "11000011": "Write", "11000100": "Kill",
    "11000101": "Lock", "11000110": "Access", "11000111": "BlockWrite", "11001000": "BlockErase",
}
#: Standard name → the CRC a command ends with (5: CRC-5, 16: CRC-16); commands without one absent.
COMMAND_CRC: dict[str, int] = {"Query": 5, **{name: 16 for name in ("Select", "Req_RN", "Read", "Write", "Kill", "Lock",
                                                                    "Access", "BlockWrite", "BlockErase")}}


def encode(cmd: Command) -> np.ndarray:
    """Bits of ``cmd`` as sent after the PIE preamble/frame-sync, CRC included.

    Parameters
    ----------
    cmd : Command
        A Gen2 command object.

    Returns
    -------
    numpy.ndarray
        ``(n,) uint8`` bits.

    Raises
    ------
    TypeError
        If ``cmd`` is not a Gen2 command.
    """
    if not isinstance(cmd, COMMAND_TYPES):
        raise TypeError(f"not a Gen2 command: {cmd!r}")
    return cmd._encode()


def _command_class(cmd) -> type:
    """The command class of ``cmd`` (an instance or a class); TypeError if not a Gen2 command."""
    cls = cmd if isinstance(cmd, type) else type(cmd)
    if cls not in COMMAND_TYPES:
        raise TypeError(f"not a Gen2 command: {cmd!r}")
    return cls


def command_name(cmd) -> str:
    """Standard name of a command: "Query", "Req_RN", ...

    Parameters
    ----------
    cmd : Command or type
        A command instance or class.

    Returns
    -------
    str
        The name.

    Raises
    ------
    TypeError
        If ``cmd`` is not a Gen2 command.
    """
    return _command_class(cmd).NAME


def command_preamble(cmd) -> str:
    """PIE lead-in of a command: ``"query"`` (full preamble with TRcal) or ``"frame-sync"``.

    Parameters
    ----------
    cmd : Command or type
        A command instance or class.

    Returns
    -------
    str
        ``"query"`` or ``"frame-sync"``.

    Raises
    ------
    TypeError
        If ``cmd`` is not a Gen2 command.
    """
    return _command_class(cmd).PREAMBLE


# --------------------------------------------------------------------------- parsing


def _expect_len(name: str, b: np.ndarray, n: int) -> None:
    if b.size != n:
        raise CommandParseError(f"{name} must have {n} bits, got {b.size}")


def _field(b: np.ndarray, start: int, n: int) -> int:
    return bits_to_int(b[start : start + n])


def _lookup(name: str, codes: dict, code: int):
    for key, value in codes.items():
        if value == code:
            return key
    raise CommandParseError(f"{name}: invalid code {code:b}")


def _ebv(name: str, b: np.ndarray, start: int) -> tuple[int, int]:
    try:
        return ebv_decode(b, start)
    except ValueError:
        raise CommandParseError(f"{name}: EBV runs past the end ({b.size} bits)") from None


def _check_crc16(name: str, b: np.ndarray) -> None:
    if not crc16_ok(b):
        raise CommandParseError(f"{name}: CRC-16 check failed")


def parse(bits) -> Command:
    """Parse a reader command from its bits.

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` 0/1, MSB first, CRC included.

    Returns
    -------
    Command
        The command object.

    Raises
    ------
    CommandParseError
        Unknown prefix, wrong length for the prefix, invalid field code (e.g. UpDn 001)
        or CRC-5/CRC-16 failure.
    """
    b = as_bits(bits)
    if b.size < 2:
        raise CommandParseError(f"too short for any command: {b.size} bits")
    if b[0] == 0:
        if b[1] == 0:
            _expect_len("QueryRep", b, 4)
            return QueryRep(session=_field(b, 2, 2))
        _expect_len("ACK", b, 18)
        return ACK(rn16=_field(b, 2, 16))
    p4 = bits_to_str(b[:4])
    if p4 == "1000":
        _expect_len("Query", b, 22)
        if not crc5_ok(b):
            raise CommandParseError("Query: CRC-5 check failed")
        return Query(
            dr="64/3" if b[4] else "8",
            m=_lookup("Query.M", M_CODES, _field(b, 5, 2)),
            trext=bool(b[7]),
            sel=_lookup("Query.Sel", SEL_CODES, _field(b, 8, 2)),
            session=_field(b, 10, 2),
            target="B" if b[12] else "A",
            q=_field(b, 13, 4),
        )
    if p4 == "1001":
        _expect_len("QueryAdjust", b, 9)
        return QueryAdjust(session=_field(b, 4, 2), updn=_lookup("QueryAdjust.UpDn", UPDN_CODES, _field(b, 6, 3)))
    if p4 == "1010":
        return _parse_select(b)
    p8 = bits_to_str(b[:8])
    if p8 == "11000000":
        _expect_len("NAK", b, 8)
        return NAK()
    if p8 == "11000001":
        _expect_len("Req_RN", b, 40)
        _check_crc16("Req_RN", b)
        return ReqRN(rn16=_field(b, 8, 16))
    if p8 == "11000010":
        return _parse_read(b)
    if p8 in _ACCESS_PARSERS:
        return _ACCESS_PARSERS[p8](b)
    raise CommandParseError(f"unknown or unsupported command prefix {p8 or bits_to_str(b)!r}")


def _parse_select(b: np.ndarray) -> Select:
    if b.size < 20:
        raise CommandParseError(f"Select too short: {b.size} bits")
    pointer, n_ptr = _ebv("Select.Pointer", b, 12)
    pos = 12 + n_ptr
    if b.size < pos + 8:
        raise CommandParseError(f"Select too short: {b.size} bits")
    length = _field(b, pos, 8)
    pos += 8
    _expect_len("Select", b, pos + length + 1 + 16)
    _check_crc16("Select", b)
    return Select(
        target=_lookup("Select.Target", {t: t for t in range(5)}, _field(b, 4, 3)),
        action=_field(b, 7, 3),
        membank=_field(b, 10, 2),
        pointer=pointer,
        mask=bits_to_str(b[pos : pos + length]),
        truncate=bool(b[pos + length]),
    )


def _parse_read(b: np.ndarray) -> Read:
    word_ptr, n_ptr = _ebv("Read.WordPtr", b, 10)
    _expect_len("Read", b, 10 + n_ptr + 8 + 16 + 16)
    _check_crc16("Read", b)
    pos = 10 + n_ptr
    return Read(membank=_field(b, 8, 2), word_ptr=word_ptr, word_count=_field(b, pos, 8), rn16=_field(b, pos + 8, 16))


def _parse_write(b: np.ndarray) -> Write:
    word_ptr, n_ptr = _ebv("Write.WordPtr", b, 10)
    pos = 10 + n_ptr
    _expect_len("Write", b, pos + 16 + 16 + 16)
    _check_crc16("Write", b)
    return Write(membank=_field(b, 8, 2), word_ptr=word_ptr, data=_field(b, pos, 16), rn16=_field(b, pos + 16, 16))


def _parse_kill(b: np.ndarray) -> Kill:
    _expect_len("Kill", b, 59)
    _check_crc16("Kill", b)
    return Kill(password=_field(b, 8, 16), recom=_field(b, 24, 3), rn16=_field(b, 27, 16))


def _parse_lock(b: np.ndarray) -> Lock:
    _expect_len("Lock", b, 60)
    _check_crc16("Lock", b)
    return Lock(mask=_field(b, 8, 10), action=_field(b, 18, 10), rn16=_field(b, 28, 16))


def _parse_access(b: np.ndarray) -> Access:
    _expect_len("Access", b, 56)
    _check_crc16("Access", b)
    return Access(password=_field(b, 8, 16), rn16=_field(b, 24, 16))


def _parse_block(name: str, b: np.ndarray) -> tuple[int, int, int, int]:
    """MemBank, WordPtr, WordCount and the position after WordCount of a Block command."""
    word_ptr, n_ptr = _ebv(f"{name}.WordPtr", b, 10)
    pos = 10 + n_ptr
    if b.size < pos + 8:
        raise CommandParseError(f"{name} too short: {b.size} bits")
    return _field(b, 8, 2), word_ptr, _field(b, pos, 8), pos + 8


def _parse_block_write(b: np.ndarray) -> BlockWrite:
    membank, word_ptr, count, pos = _parse_block("BlockWrite", b)
    if count == 0:
        raise CommandParseError("BlockWrite: WordCount 0")
    _expect_len("BlockWrite", b, pos + 16 * count + 16 + 16)
    _check_crc16("BlockWrite", b)
    data = tuple(_field(b, pos + 16 * k, 16) for k in range(count))
    return BlockWrite(membank=membank, word_ptr=word_ptr, data=data, rn16=_field(b, pos + 16 * count, 16))


def _parse_block_erase(b: np.ndarray) -> BlockErase:
    membank, word_ptr, count, pos = _parse_block("BlockErase", b)
    if count == 0:
        raise CommandParseError("BlockErase: WordCount 0")
    _expect_len("BlockErase", b, pos + 16 + 16)
    _check_crc16("BlockErase", b)
    return BlockErase(membank=membank, word_ptr=word_ptr, word_count=count, rn16=_field(b, pos, 16))


_ACCESS_PARSERS = {code: parser for name, parser in (("Write", _parse_write), ("Kill", _parse_kill),
                                                    ("Lock", _parse_lock), ("Access", _parse_access),
                                                    ("BlockWrite", _parse_block_write),
                                                    ("BlockErase", _parse_block_erase))
                   for code, known in COMMAND_PREFIXES.items() if known == name}


def command_fields(cmd: Command) -> dict:
    """Field values of a command as a plain dict (for records and datasets).

    Parameters
    ----------
    cmd : Command
        A command object.

    Returns
    -------
    dict
        Field name → value.
    """
    return {f.name: getattr(cmd, f.name) for f in fields(cmd)}


__all__ = [
    "DR_VALUES",
    "M_CODES",
    "SEL_CODES",
    "TARGET_CODES",
    "UPDN_CODES",
    "MEMBANKS",
    "CommandParseError",
    "normalize_dr",
    "ebv_encode",
    "ebv_decode",
    "Query",
    "QueryRep",
    "QueryAdjust",
    "ACK",
    "NAK",
    "ReqRN",
    "Read",
    "Select",
    "Write",
    "Kill",
    "Lock",
    "Access",
    "BlockWrite",
    "BlockErase",
    "LOCK_FIELDS",
    "cover_code",
    "Command",
    "COMMAND_TYPES",
    "ACCESS_COMMANDS",
    "COMMAND_PREFIXES",
    "COMMAND_CRC",
    "encode",
    "parse",
    "command_name",
    "command_preamble",
    "command_fields",
]

"""What the Gen2 tag state machine (:mod:`rfsim.devices.gen2_tag_state`) deals in: the state
names and their codes, the reply record, the flag persistence times, the PC word, the
slot-counter and RN16 draws, and the clock a population of tags follows at once
(:class:`SharedClock`, moved by :class:`rfsim.devices.gen2_tag_arrays.StateArrays`).
``TagState`` below is :class:`rfsim.devices.gen2_tag_state.TagState`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.memo import PureCache
from rfsim.gen2.bits import as_bits
from rfsim.gen2.tag_draws import _slot_drawer, draw_rn16, slot_draw

STATES = ("ready", "arbitrate", "reply", "acknowledged", "open", "secured", "killed")
REPLY_KINDS = ("RN16", "EPC", "HANDLE", "READ", "ERROR", "DELAYED")
STATE_CODES = {s: k for k, s in enumerate(STATES)}


@dataclass(frozen=True, eq=False)
class Reply:
    """What a tag backscatters in response to one command.

    Attributes
    ----------
    kind : {"RN16", "EPC", "HANDLE", "READ", "ERROR", "DELAYED"}
        What the reply answers (:data:`REPLY_KINDS`): an RN16 (with a CRC-16 when it answers
        a Req_RN in Open/Secured), PC + EPC, the handle (Req_RN in Acknowledged; Access and
        the first Kill), a Read's words, an error (header 1 | code | handle) or a delayed
        reply's success (header 0 | handle).
    bits : ndarray of uint8, shape (n_bits,)
        Payload bits MSB first, CRC-16 included where Gen2 has one (all kinds but the RN16
        of a slot); the line-code preamble and the dummy 1 are not included.
    delay_s : float
        Extra delay of the reply beyond T1 [s] (the chip's programming time of a delayed
        reply, :func:`rfsim.gen2.access.execute`), default 0.
    delayed : bool
        A delayed ("in-process") reply (Write, BlockWrite, BlockErase, Lock, final Kill):
        sent with the extended preamble (TRext = 1 whatever the Query said), default False.
    """

    kind: str
    bits: np.ndarray
    delay_s: float = 0.0
    delayed: bool = False

    def __post_init__(self):
        if self.kind not in REPLY_KINDS:
            raise ValueError(f"reply kind must be one of {REPLY_KINDS}, got {self.kind!r}")
        arr = as_bits(self.bits).copy()
        arr.flags.writeable = False
        object.__setattr__(self, "bits", arr)

    def __eq__(self, other):
        if not isinstance(other, Reply):
            return NotImplemented
        return (self.kind == other.kind and np.array_equal(self.bits, other.bits) and self.delay_s == other.delay_s
                and self.delayed == other.delayed)

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

    Attributes
    ----------
    s1_s : float
        Time after which S1 reverts from B to A, powered or not [s], default 2.0.
    s2_s, s3_s, sl_s : float
        Longest power outage S2, S3 and SL survive [s], default 2.0 each.

    Raises
    ------
    ConfigError
        ``tag.persistence.<name>`` for a negative or non-numeric time.
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
    """Return the protocol-control word of an EPC: L·2¹¹, L = len(epc)/16 ∈ [0, 31] words.

    UMI, XI, T and the numbering-system bits are 0 (EPC Gen2 "Tag memory": L is the 5 MSBs of
    PC). ``pc_word(96 zeros) == 0x3000``.

    Parameters
    ----------
    epc_bits : array_like of {0, 1}, shape (n_bits,)
        The EPC bits.

    Returns
    -------
    int
        The 16-bit PC word.

    Raises
    ------
    ValueError
        When the EPC length is not a multiple of 16 bits or exceeds 496 bits.
    """
    n = as_bits(epc_bits).size
    if n % 16 or n // 16 > 31:
        raise ValueError(f"EPC length must be a multiple of 16 bits, at most 496, got {n}")
    return (n // 16) << 11


def _word_bits() -> np.ndarray:
    """The bits of every 16-bit value, MSB first: ``(2¹⁶, 16)`` uint8, 1 MiB, read-only (row v
    is ``int_to_bits(v, 16)``); a constant, made once per process by :data:`WORD_BITS_CACHE`."""
    table = np.unpackbits(np.arange(1 << 16, dtype=">u2").view(np.uint8).reshape(-1, 2), axis=1)
    table.setflags(write=False)
    return table


#: :func:`_word_bits`, kept (one entry: a pure function of no argument; 1 MiB, made at the
#: first RN16).
WORD_BITS_CACHE = PureCache(_word_bits, 1)


def _bits16(value: int) -> np.ndarray:
    """``int_to_bits(value, 16)`` for 0 ≤ value < 2¹⁶: a read-only row of the table of every
    16-bit value's bits (:data:`WORD_BITS_CACHE`; a view, no copy per call)."""
    return WORD_BITS_CACHE()[value]


def adjusted_q(q, updn):
    """Return Q after a QueryAdjust: :math:`\\min(15, \\max(0, Q + \\mathrm{UpDn}))`.

    EPC Gen2 "QueryAdjust". For one tag or many.

    Parameters
    ----------
    q : int or ndarray of int
        The tag's Q (0–15), or one per tag.
    updn : int
        UpDn ∈ {−1, 0, +1}.

    Returns
    -------
    numpy integer or ndarray of int
        The new Q, the shape of ``q`` (a NumPy integer for an int ``q``).
    """
    return np.minimum(np.maximum(q + updn, 0), 15)


class SharedClock:
    """A time that many tags follow at once, and the arrays that hold the slot counters and
    Q of the tags whose counters count with it.

    Many :class:`TagState` objects follow it (:meth:`TagState.follow`,
    :meth:`TagState.follow_decrements`): the silent steps of a population
    (:class:`StateArrays`) advance every tag that takes one by setting ``t_s``, not each tag's,
    and a counting tag's counter and Q are its rows of ``slots`` and ``qs`` (the population's
    columns), so that a QueryRep's decrements and a QueryAdjust's new counters are written to
    the arrays only, not to each tag.

    Parameters
    ----------
    t_s : float, optional
        Initial time [s], default 0.0.
    slots, qs : ndarray of int, shape (n_tags,), optional
        The columns that hold the counting tags' slot counters and Q (default: none, no tag
        can count with the clock).

    Attributes
    ----------
    t_s : float
        The time of the following tags [s].
    slots : ndarray of int or None
        Slot counter per row (a counting tag reads its row).
    qs : ndarray of int or None
        Q per row (a counting tag reads its row).
    """

    __slots__ = ("t_s", "slots", "qs")

    def __init__(self, t_s: float = 0.0, slots=None, qs=None):
        self.t_s = float(t_s)
        self.slots, self.qs = slots, qs


__all__ = ["STATES", "STATE_CODES", "REPLY_KINDS", "Reply", "FlagPersistence", "SharedClock", "pc_word", "slot_draw",
           "adjusted_q"]

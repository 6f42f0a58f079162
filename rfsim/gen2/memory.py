"""Gen2 tag memory: four word-addressed banks, lock state and password checks.

Memory map (EPC Gen2 v2 / ISO/IEC 18000-63 §6.3.2.1, "Tag memory"), 16-bit words, bit
addresses in hex as the standard writes them (word ``w`` holds bits ``16w`` … ``16w+15``,
MSB first):

=========  ======  ==============================================================
bank       code    words
=========  ======  ==============================================================
Reserved   00      0–1 kill password (00h–1Fh), 2–3 access password (20h–3Fh)
EPC        01      0 StoredCRC (00h–0Fh), 1 StoredPC (10h–1Fh), 2… EPC (20h…),
                   optional XPC_W1 at word 33 (210h–21Fh)
TID        10      0–1 allocation class E2h (00h–07h), MDID (08h–13h), TMN (14h–1Fh);
                   then the chip's XTID header and serial number words, if any
User       11      0… user data (absent on chips without User memory)
=========  ======  ==============================================================

StoredPC (§6.3.2.1.2.2): bits 10h–14h the EPC length L in words, 15h UMI, 16h XI,
17h–1Fh the numbering-system toggle and AFI/attribute bits. StoredCRC (§6.3.2.1.2.1) is the
CRC-16 of the StoredPC and the L EPC words, as transmitted (ones' complement,
:func:`rfsim.gen2.crc.crc16`). The standard has the tag compute it at power-up; this model
recomputes it whenever a write or erase touches the StoredPC or the EPC, which gives the value
the next power-up would compute. Writes to the StoredCRC word itself are refused with
:attr:`TagError.OTHER` (the project's rule: the word is the tag's to compute).

Lock state (§6.3.2.12.3.5, the Lock command's action table), per field of
:data:`rfsim.gen2.commands.LOCK_FIELDS`, as the pair (pwd-lock bit, permalock bit):

======  ====================================================  ==========================
pair    EPC, TID, User bank                                   kill / access password
======  ====================================================  ==========================
0 0     writeable in Open or Secured                          readable and writeable in
                                                              Open or Secured
0 1     permanently writeable (permaunlocked)                 permanently readable and
                                                              writeable
1 0     writeable in Secured only                             read/write in Secured only
1 1     never writeable (permalocked)                         never readable or writeable
======  ====================================================  ==========================

A Lock that would change a field whose permalock bit is set is refused as a whole with
error "memory locked"; one that re-asserts the same pair skips that field (§6.3.2.12.3.5).
A chip without passwords acts as if both passwords were zero and permalocked (§6.3.2.1.1);
its Reserved bank has no words.

Errors are :class:`MemoryAccessError` carrying a Gen2 error code (:class:`TagError`,
Annex I "Error codes").
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.gen2.commands import LOCK_FIELDS
from rfsim.gen2.crc import crc16

RESERVED, EPC, TID, USER = 0, 1, 2, 3
#: Word address of XPC_W1 in the EPC bank (bit address 210h).
XPC_W1_WORD = 0x21
#: Allocation class identifier of EPCglobal TIDs (§6.3.2.1.3).
TID_CLASS_E2 = 0xE2
#: Bank of each lockable field of :data:`rfsim.gen2.commands.LOCK_FIELDS`.
LOCK_FIELD_BANK = {"kill_pwd": RESERVED, "access_pwd": RESERVED, "epc": EPC, "tid": TID, "user": USER}
#: Lock pairs by name (pwd-lock bit, permalock bit).
LOCK_STATES = {"unlocked": (0, 0), "permaunlocked": (0, 1), "locked": (1, 0), "permalocked": (1, 1)}

LockName = Literal["unlocked", "permaunlocked", "locked", "permalocked"]


class TagError(enum.IntEnum):
    """Gen2 tag error codes (EPC Gen2 v2, Annex I "Error codes"; 8 bits in an error reply)."""

    OTHER = 0x00
    NOT_SUPPORTED = 0x01
    INSUFFICIENT_PRIVILEGES = 0x02
    MEMORY_OVERRUN = 0x03
    MEMORY_LOCKED = 0x04
    INSUFFICIENT_POWER = 0x0B
    NON_SPECIFIC = 0x0F


class MemoryAccessError(Exception):
    """A memory operation the tag refuses; the tag answers with an error reply.

    Parameters
    ----------
    code : TagError
        The Gen2 error code.
    message : str
        What was refused.

    Attributes
    ----------
    code : TagError
        As given.
    """

    def __init__(self, code: TagError, message: str):
        self.code = TagError(code)
        super().__init__(f"{self.code.name.lower()}: {message}")


# ----------------------------------------------------------------------------- chip models


@dataclass(frozen=True)
class ChipModel:
    """Memory sizes, TID and write parameters of a tag chip.

    Parameters
    ----------
    name : str
        Model name.
    epc_words : int
        EPC capacity in 16-bit words (the largest EPC length L the chip accepts).
    user_words : int
        User memory in words (0: no User bank).
    passwords : bool
        Whether the chip implements kill and access passwords.
    mdid : int
        12-bit field at TID bits 08h–13h: the mask-designer ID, whose three MSBs are the
        XTID/security/file indicators of the GS1 Tag Data Standard.
    tmn : int
        12-bit tag model number (TID bits 14h–1Fh).
    xtid_header : int or None
        XTID header word (TID word 2) of serialized chips; None: none.
    serial_bits : int
        Length of the TID serial number in bits (a multiple of 16).
    read_sensitivity_dbm : float
        Power at the chip needed to read (inventory), dBm.
    write_sensitivity_dbm : float
        Power at the chip needed to write, dBm.
    write_time_s : float
        Programming time of one 16-bit word (or one lock/kill write), s.
    max_block_write_words : int
        Largest BlockWrite WordCount executed (0: BlockWrite not supported).
    block_erase : bool
        Whether BlockErase is supported.
    source : str
        Where the numbers come from.
    """

    name: str
    epc_words: int
    user_words: int
    passwords: bool
    mdid: int
    tmn: int
    xtid_header: int | None
    serial_bits: int
    read_sensitivity_dbm: float
    write_sensitivity_dbm: float
    write_time_s: float
    max_block_write_words: int = 32
    block_erase: bool = True
    source: str = ""

    @property
    def write_threshold_db(self) -> float:
        """Extra power a write needs over a read, dB (write minus read sensitivity)."""
        return self.write_sensitivity_dbm - self.read_sensitivity_dbm

    def tid_words(self, serial: int = 0) -> tuple[int, ...]:
        """Factory TID of this chip with the given serial number.

        Words 0–1 hold the allocation class E2h, the MDID field and the TMN (§6.3.2.1.3);
        then the XTID header word, if any, and the serial number, MSB word first.

        Parameters
        ----------
        serial : int
            Serial number, ``0 ≤ serial < 2**serial_bits``.

        Returns
        -------
        tuple of int
            TID words.

        Raises
        ------
        ConfigError
            If the serial number does not fit.
        """
        if not 0 <= int(serial) < 1 << self.serial_bits:
            raise ConfigError("tid_serial", serial, f"an integer in [0, 2^{self.serial_bits} - 1] for {self.name}")
        words = [TID_CLASS_E2 << 8 | self.mdid >> 4, (self.mdid & 0xF) << 12 | self.tmn]
        if self.xtid_header is not None:
            words.append(self.xtid_header)
        words += [(int(serial) >> (16 * k)) & 0xFFFF for k in reversed(range(self.serial_bits // 16))]
        return tuple(words)


#: Chip models. Sources: Impinj *Monza R6 Tag Chip Datasheet* (IPJ-W1700, v4.0 2016/v5.0
#: 2017: up to 96-bit EPC, 96-bit TID with 48-bit serial, read −22.1 dBm, write −18.8 dBm,
#: 1.6 ms per 32 bits); Impinj *Monza 4 Tag Chip Datasheet* (IPJ-W1510…, v10.0 2016: read
#: −19.5 dBm single port, write −16.7 dBm, 3.4 ms per 32 bits; Monza 4QT 128-bit EPC,
#: 512-bit User); NXP *UCODE 8/8m product data sheet* SL3S1205_15 (rev. 3.4 2020: read
#: −23 dBm, write −18 dBm, up to 128-bit EPC, 96-bit TID with 48-bit serial, no User memory
#: on UCODE 8, 32-bit kill and access passwords); Alien *Higgs-3 datasheet* (ALN-9662 family):
#: **approximate, from memory** (96–480-bit EPC, 512-bit User, 64-bit TID, read ≈ −18 dBm,
#: write ≈ −15 dBm). Also approximate, from memory: that Monza R6 has no passwords; the TMNs
#: 105h (Monza 4QT), 894h (UCODE 8), 412h (Higgs-3) and the XTID header 2000h; the write times
#: of UCODE 8 and Higgs-3 (the generic 3 ms). Per-word write times are half the datasheets'
#: 32-bit times. The generic chip's numbers are the project's assumptions (a 3 dB write
#: threshold, 3 ms per word, well inside the standard's 20 ms limit of a delayed reply).
CHIP_MODELS: dict[str, ChipModel] = {
    "generic": ChipModel("generic", epc_words=8, user_words=32, passwords=True, mdid=0x000, tmn=0x000,
                         xtid_header=None, serial_bits=32, read_sensitivity_dbm=-18.0,
                         write_sensitivity_dbm=-15.0, write_time_s=3.0e-3,
                         source="project's assumptions"),
    "monza-r6": ChipModel("monza-r6", epc_words=6, user_words=0, passwords=False, mdid=0x801, tmn=0x160,
                          xtid_header=0x2000, serial_bits=48, read_sensitivity_dbm=-22.1,
                          write_sensitivity_dbm=-18.8, write_time_s=0.8e-3,
                          source="Impinj Monza R6 datasheet IPJ-W1700"),
    "monza-4qt": ChipModel("monza-4qt", epc_words=8, user_words=32, passwords=True, mdid=0x801, tmn=0x105,
                           xtid_header=0x2000, serial_bits=48, read_sensitivity_dbm=-19.5,
                           write_sensitivity_dbm=-16.7, write_time_s=1.7e-3,
                           source="Impinj Monza 4 datasheet IPJ-W1510 (TMN approximate)"),
    "ucode-8": ChipModel("ucode-8", epc_words=8, user_words=0, passwords=True, mdid=0x806, tmn=0x894,
                         xtid_header=0x2000, serial_bits=48, read_sensitivity_dbm=-23.0,
                         write_sensitivity_dbm=-18.0, write_time_s=3.0e-3,
                         source="NXP UCODE 8/8m data sheet SL3S1205_15 (TMN, write time approximate)"),
    "higgs-3": ChipModel("higgs-3", epc_words=30, user_words=32, passwords=True, mdid=0x003, tmn=0x412,
                         xtid_header=None, serial_bits=32, read_sensitivity_dbm=-18.0,
                         write_sensitivity_dbm=-15.0, write_time_s=3.0e-3,
                         source="Alien Higgs-3 datasheet (approximate, from memory)"),
}

ChipName = Literal["generic", "monza-r6", "monza-4qt", "ucode-8", "higgs-3"]


def _hex_words(key: str, text: str) -> tuple[int, ...]:
    digits = text.replace(" ", "").replace("_", "")
    if len(digits) % 4 or any(c not in "0123456789abcdefABCDEF" for c in digits):
        raise ConfigError(key, text, "hex digits, a multiple of 4 (whole 16-bit words)")
    return tuple(int(digits[i : i + 4], 16) for i in range(0, len(digits), 4))


@dataclass(frozen=True)
class TagMemoryConfig:
    """Initial memory of a tag (TOML table; errors name ``memory.<key>``).

    Parameters
    ----------
    chip : str
        Chip model of :data:`CHIP_MODELS`; gives the bank sizes and the factory TID.
    epc : str
        EPC as hex digits (whole words); its length sets the StoredPC's L.
    umi, pc_attributes : bool, int
        StoredPC's UMI bit and bits 17h–1Fh (toggle and AFI/attributes).
    xpc_w1 : int or None
        XPC_W1 word (EPC word 33); None: not implemented. Sets XI = (XPC_W1 ≠ 0).
    tid : str
        Whole TID as hex; empty: the chip's factory TID with ``tid_serial``.
    tid_serial : int
        Serial number of the factory TID.
    user_words : int or None
        User memory size in words; None: the chip's.
    user : str
        Initial User memory as hex (the rest is zero).
    kill_password, access_password : int
        32-bit passwords (must be 0 on chips without passwords).
    lock_kill_pwd, lock_access_pwd, lock_epc, lock_tid, lock_user : str
        Lock state of each field: ``unlocked``, ``permaunlocked``, ``locked``, ``permalocked``.
    """

    chip: ChipName = param("generic", doc="chip model (bank sizes, factory TID, write parameters)")
    epc: str = param("300833B2DDD9014000000027", doc="EPC as hex digits, whole 16-bit words")
    umi: bool = param(False, doc="StoredPC UMI bit (User memory indicator)")
    pc_attributes: int = param(0, lo=0, hi=0x1FF, doc="StoredPC bits 17h-1Fh (toggle T, AFI/attributes)")
    xpc_w1: int | None = param(None, lo=0, hi=0xFFFF, doc="XPC_W1 word (EPC word 33); none: no XPC")
    tid: str = param("", doc="whole TID as hex; empty: the chip's factory TID")
    tid_serial: int = param(0, lo=0, hi=2**48 - 1, doc="serial number in the factory TID")
    user_words: int | None = param(None, lo=0, hi=4096, unit="words", doc="User size; none: the chip's")
    user: str = param("", doc="initial User memory as hex (rest zero)")
    kill_password: int = param(0, lo=0, hi=0xFFFFFFFF, doc="32-bit kill password")
    access_password: int = param(0, lo=0, hi=0xFFFFFFFF, doc="32-bit access password")
    lock_kill_pwd: LockName = param("unlocked", doc="kill password lock state")
    lock_access_pwd: LockName = param("unlocked", doc="access password lock state")
    lock_epc: LockName = param("unlocked", doc="EPC bank lock state")
    lock_tid: LockName = param("permalocked", doc="TID bank lock state (factory locked)")
    lock_user: LockName = param("unlocked", doc="User bank lock state")

    def __post_init__(self):
        check_fields(self, "memory")
        chip = self.chip_model
        epc = _hex_words("memory.epc", self.epc)
        if len(epc) > chip.epc_words:
            raise ConfigError("memory.epc", self.epc, f"at most {chip.epc_words} words for chip {chip.name}")
        if self.tid:
            _hex_words("memory.tid", self.tid)
        else:
            try:
                chip.tid_words(self.tid_serial)
            except ConfigError as err:
                raise ConfigError("memory.tid_serial", err.value, err.allowed) from None
        if len(_hex_words("memory.user", self.user)) > self.n_user_words:
            raise ConfigError("memory.user", self.user, f"at most {self.n_user_words} words (memory.user_words)")
        if not chip.passwords:
            for key in ("kill_password", "access_password"):
                if getattr(self, key):
                    raise ConfigError(f"memory.{key}", getattr(self, key), f"0: chip {chip.name} has no passwords")

    @property
    def chip_model(self) -> ChipModel:
        """The :class:`ChipModel` named by ``chip``."""
        return CHIP_MODELS[self.chip]

    @property
    def n_user_words(self) -> int:
        """User memory size in words."""
        return self.chip_model.user_words if self.user_words is None else self.user_words


# ----------------------------------------------------------------------------- memory


def stored_crc(stored_pc: int, epc_words) -> int:
    """StoredCRC of a StoredPC and the EPC words it covers.

    .. math:: \\mathrm{StoredCRC} = \\mathrm{CRC16}(\\mathrm{StoredPC} \\,\\|\\, \\mathrm{EPC}_{0..L-1})

    the CRC-16 as transmitted (preset FFFFh, ones' complement; EPC Gen2 v2 §6.3.2.1.2.1).

    Parameters
    ----------
    stored_pc : int
        16-bit StoredPC.
    epc_words : sequence of int
        The L EPC words, L = StoredPC bits 10h–14h.

    Returns
    -------
    int
        16-bit StoredCRC.
    """
    words = [int(stored_pc)] + [int(w) for w in epc_words]
    return crc16(np.unpackbits(np.array(words, dtype=">u2").view(np.uint8)))  # the words' bits, MSB first


def pc_epc_length(stored_pc: int) -> int:
    """EPC length L in words from a StoredPC (its 5 MSBs, bits 10h–14h).

    Parameters
    ----------
    stored_pc : int
        16-bit StoredPC.

    Returns
    -------
    int
        L, 0–31.
    """
    return (int(stored_pc) >> 11) & 0x1F


class TagMemory:
    """The four memory banks of one tag, their lock state and the password checks.

    Mutable: it is the tag's state. Methods raise :class:`MemoryAccessError` for what the
    tag refuses, leaving memory unchanged (an operation is all or nothing).

    Parameters
    ----------
    config : TagMemoryConfig
        Initial contents, sizes and lock state.

    Attributes
    ----------
    chip : ChipModel
        The chip model.
    banks : list of list of int
        Words of the Reserved, EPC, TID and User banks (index = MemBank code).
    xpc_w1 : int or None
        XPC_W1 (EPC word 33), None if not implemented.
    locks : dict of str to tuple of (int, int)
        Lock pair per field of :data:`rfsim.gen2.commands.LOCK_FIELDS`.
    """

    def __init__(self, config: TagMemoryConfig):
        chip = config.chip_model
        epc = list(_hex_words("memory.epc", config.epc))
        xpc = config.xpc_w1
        pc = len(epc) << 11 | int(config.umi) << 10 | int(bool(xpc)) << 9 | config.pc_attributes
        tid = list(_hex_words("memory.tid", config.tid)) if config.tid else list(chip.tid_words(config.tid_serial))
        user = list(_hex_words("memory.user", config.user))
        user += [0] * (config.n_user_words - len(user))
        self._fill(chip, config.kill_password, config.access_password, pc, epc, tid, user, xpc,
                   {name: LOCK_STATES[getattr(config, "lock_" + name)] for name in LOCK_FIELDS})

    def _fill(self, chip: ChipModel, kill_password: int, access_password: int, pc: int, epc: list, tid: list,
              user: list, xpc, locks: dict) -> None:
        """Set the banks (the EPC padded with zeros to the chip's capacity), XPC_W1 and the locks."""
        self.chip = chip
        reserved = []
        if chip.passwords:
            k, a = int(kill_password), int(access_password)
            reserved = [k >> 16, k & 0xFFFF, a >> 16, a & 0xFFFF]
        epc_bank = [0, pc] + epc + [0] * (chip.epc_words - len(epc))
        self.banks: list[list[int]] = [reserved, epc_bank, tid, user]
        self.xpc_w1 = None if xpc is None else int(xpc)
        self.locks = locks
        if not chip.passwords:
            self.locks["kill_pwd"] = self.locks["access_pwd"] = LOCK_STATES["permalocked"]
        self._update_crc()

    @classmethod
    def from_words(cls, chip: ChipModel, *, epc=(), tid=(), user=(), kill_password: int = 0,
                   access_password: int = 0) -> "TagMemory":
        """Memory of a chip with the given contents, without a :class:`TagMemoryConfig`.

        StoredPC = L·2¹¹ (L = ``len(epc)``; UMI, XI and the attribute bits 0), no XPC_W1, the
        User bank padded with zeros to ``chip.user_words``, the locks of a fresh
        :class:`TagMemoryConfig` (TID permalocked, the rest unlocked). A chip model with
        ``epc_words = len(epc)`` and ``user_words = len(user)`` gives banks of exactly the
        given sizes.

        Parameters
        ----------
        chip : ChipModel
            The chip (sizes, passwords, write parameters).
        epc, tid, user : sequence of int
            16-bit words of the EPC, TID and User memory.
        kill_password, access_password : int
            32-bit passwords (0 on a chip without passwords).

        Returns
        -------
        TagMemory
            The memory.

        Raises
        ------
        ValueError
            When the contents do not fit the chip, a word is not 16-bit or a password not
            32-bit (or non-zero on a chip without passwords).
        """
        epc, tid, user = ([int(w) for w in ws] for ws in (epc, tid, user))
        if any(not 0 <= w <= 0xFFFF for w in epc + tid + user):
            raise ValueError("memory words must be 16-bit values")
        if len(epc) > min(chip.epc_words, 31) or len(user) > chip.user_words:
            raise ValueError(f"{len(epc)} EPC / {len(user)} User words exceed chip {chip.name} "
                             f"({chip.epc_words} / {chip.user_words})")
        for name, pwd in (("kill_password", kill_password), ("access_password", access_password)):
            if not 0 <= int(pwd) < 1 << 32 or (pwd and not chip.passwords):
                raise ValueError(f"{name} must be a 32-bit value (0 on chip {chip.name}), got {pwd}")
        locks = {name: LOCK_STATES[getattr(TagMemoryConfig, "lock_" + name)] for name in LOCK_FIELDS}  # defaults
        out = cls.__new__(cls)
        out._fill(chip, kill_password, access_password, len(epc) << 11, epc, tid,
                  user + [0] * (chip.user_words - len(user)), None, locks)
        return out

    # -- derived values

    @property
    def kill_password(self) -> int:
        """32-bit kill password (0 on chips without passwords)."""
        r = self.banks[RESERVED]
        return r[0] << 16 | r[1] if r else 0

    @property
    def access_password(self) -> int:
        """32-bit access password (0 on chips without passwords)."""
        r = self.banks[RESERVED]
        return r[2] << 16 | r[3] if r else 0

    @property
    def stored_pc(self) -> int:
        """StoredPC (EPC word 1)."""
        return self.banks[EPC][1]

    @property
    def stored_crc(self) -> int:
        """StoredCRC (EPC word 0)."""
        return self.banks[EPC][0]

    @property
    def epc_words(self) -> tuple[int, ...]:
        """The EPC: the L words after the StoredPC."""
        return tuple(self.banks[EPC][2 : 2 + pc_epc_length(self.stored_pc)])

    def bank_size(self, membank: int) -> int:
        """Words in a bank's contiguous memory (XPC_W1 excluded).

        Parameters
        ----------
        membank : int
            0 Reserved, 1 EPC, 2 TID, 3 User.

        Returns
        -------
        int
            Number of words.
        """
        return len(self.banks[membank])

    def _implemented(self, membank: int, word: int) -> bool:
        return word < len(self.banks[membank]) or (membank == EPC and word == XPC_W1_WORD
                                                   and self.xpc_w1 is not None)

    def _check_range(self, membank: int, word_ptr: int, count: int) -> None:
        if count < 1 or not all(self._implemented(membank, w) for w in range(word_ptr, word_ptr + count)):
            raise MemoryAccessError(TagError.MEMORY_OVERRUN,
                                    f"bank {membank} words {word_ptr}..{word_ptr + count - 1} "
                                    f"(bank has {len(self.banks[membank])})")

    def _get(self, membank: int, word: int) -> int:
        return self.xpc_w1 if membank == EPC and word == XPC_W1_WORD else self.banks[membank][word]

    @staticmethod
    def _password_field(word: int) -> str:
        return "kill_pwd" if word < 2 else "access_pwd"

    def _fields(self, membank: int, word_ptr: int, count: int) -> set[str]:
        if membank != RESERVED:
            return {next(f for f, b in LOCK_FIELD_BANK.items() if b == membank)}
        return {self._password_field(w) for w in range(word_ptr, word_ptr + count)}

    def _check_locks(self, membank: int, word_ptr: int, count: int, secured: bool, what: str) -> None:
        """Lock pair 1 1 refuses always, 1 0 outside Secured (the Lock action table)."""
        for name in sorted(self._fields(membank, word_ptr, count)):
            lock, perma = self.locks[name]
            if lock and (perma or not secured):
                raise MemoryAccessError(TagError.MEMORY_LOCKED, f"{name} is {what}-locked")

    # -- operations

    def read(self, membank: int, word_ptr: int, word_count: int, *, secured: bool) -> tuple[int, ...]:
        """Words of a bank, as a Read returns them.

        ``word_count`` 0 reads to the end of the bank's contiguous memory (§6.3.2.12.3.2).
        Passwords locked with pair 1 0 are readable in Secured only, 1 1 never; the other
        banks are always readable.

        Parameters
        ----------
        membank : int
            0 Reserved, 1 EPC, 2 TID, 3 User.
        word_ptr : int
            First word address.
        word_count : int
            Words to read; 0: to the end of the bank.
        secured : bool
            Whether the tag is in the Secured state.

        Returns
        -------
        tuple of int
            The words.

        Raises
        ------
        MemoryAccessError
            Memory overrun (words outside the bank, or an empty read) or memory locked.
        """
        if word_count == 0:
            word_count = max(len(self.banks[membank]) - word_ptr, 0)
        self._check_range(membank, word_ptr, word_count)
        if membank == RESERVED:
            self._check_locks(membank, word_ptr, word_count, secured, "read")
        return tuple(self._get(membank, w) for w in range(word_ptr, word_ptr + word_count))

    def check_write(self, membank: int, word_ptr: int, words, *, secured: bool) -> None:
        """Raise if the words may not be written (or erased) in the current state.

        Parameters
        ----------
        membank : int
            0 Reserved, 1 EPC, 2 TID, 3 User.
        word_ptr : int
            First word address.
        words : sequence of int
            The 16-bit words to write (zeros for an erase), at least one.
        secured : bool
            Whether the tag is in the Secured state.

        Raises
        ------
        MemoryAccessError
            Memory overrun (words outside the bank; also a StoredPC whose L exceeds the
            chip's EPC capacity, the project's rule), memory locked (lock pair 1 1, or 1 0
            in Open), or other error (the StoredCRC word).
        """
        words = list(words)
        self._check_range(membank, word_ptr, len(words))
        self._check_locks(membank, word_ptr, len(words), secured, "write")
        if membank == EPC and word_ptr == 0:
            raise MemoryAccessError(TagError.OTHER, "the StoredCRC is computed by the tag")
        if membank == EPC and word_ptr <= 1 < word_ptr + len(words):
            new_l = pc_epc_length(words[1 - word_ptr])
            if new_l > self.chip.epc_words:
                raise MemoryAccessError(TagError.MEMORY_OVERRUN,
                                        f"StoredPC length {new_l} words > EPC capacity {self.chip.epc_words}")

    def write(self, membank: int, word_ptr: int, words, *, secured: bool) -> None:
        """Write words (Write, BlockWrite) and keep the StoredCRC consistent.

        Parameters
        ----------
        membank : int
            0 Reserved, 1 EPC, 2 TID, 3 User.
        word_ptr : int
            First word address.
        words : sequence of int
            16-bit words to write.
        secured : bool
            Whether the tag is in the Secured state.

        Raises
        ------
        MemoryAccessError
            As :meth:`check_write`; nothing is written then.
        """
        words = [int(w) & 0xFFFF for w in words]
        self.check_write(membank, word_ptr, words, secured=secured)
        for k, w in enumerate(words):
            if membank == EPC and word_ptr + k == XPC_W1_WORD and self.xpc_w1 is not None:
                self.xpc_w1 = w
            else:
                self.banks[membank][word_ptr + k] = w
        if membank == EPC:
            self._update_crc()

    def erase(self, membank: int, word_ptr: int, word_count: int, *, secured: bool) -> None:
        """Set words to zero (BlockErase), keeping the StoredCRC consistent.

        Parameters
        ----------
        membank : int
            0 Reserved, 1 EPC, 2 TID, 3 User.
        word_ptr : int
            First word address.
        word_count : int
            Number of words, ≥ 1.
        secured : bool
            Whether the tag is in the Secured state.

        Raises
        ------
        MemoryAccessError
            As :meth:`check_write`; nothing is erased then.
        """
        self.write(membank, word_ptr, [0] * int(word_count), secured=secured)

    def locks_after(self, mask: int, action: int) -> dict[str, tuple[int, int]]:
        """Lock state a Lock payload would leave (Mask(10) | Action(10), ``LOCK_FIELDS`` order).

        For each field whose two mask bits are set the action pair replaces the lock pair,
        except that a permalocked or permaunlocked field (permalock bit 1) cannot change:
        re-asserting its pair is skipped, changing it refuses the whole Lock
        (§6.3.2.12.3.5). Each mask bit selects its own action bit (mask pair 10 sets only
        the pwd-lock bit, 01 only the permalock bit).

        Parameters
        ----------
        mask : int
            10-bit mask.
        action : int
            10-bit action.

        Returns
        -------
        dict of str to tuple of (int, int)
            Lock pair per field.

        Raises
        ------
        MemoryAccessError
            Memory locked, when a permalock bit would change.
        """
        new = dict(self.locks)
        for k, name in enumerate(LOCK_FIELDS):
            shift = 2 * (len(LOCK_FIELDS) - 1 - k)
            m, a = (int(mask) >> shift) & 0b11, (int(action) >> shift) & 0b11
            if not m:
                continue
            old = self.locks[name]
            pair = (a >> 1 if m & 0b10 else old[0], a & 1 if m & 0b01 else old[1])
            if old[1] and pair != old:
                raise MemoryAccessError(TagError.MEMORY_LOCKED, f"{name} is permanently {self.lock_name(name)}")
            new[name] = pair
        return new

    def lock(self, mask: int, action: int) -> None:
        """Apply a Lock payload (all or nothing; see :meth:`locks_after`).

        Parameters
        ----------
        mask : int
            10-bit mask.
        action : int
            10-bit action.

        Raises
        ------
        MemoryAccessError
            Memory locked, when a permalock bit would change; nothing is applied.
        """
        self.locks = self.locks_after(mask, action)

    def lock_name(self, field: str) -> str:
        """Name of a field's lock state: unlocked, permaunlocked, locked or permalocked.

        Parameters
        ----------
        field : str
            A field of :data:`rfsim.gen2.commands.LOCK_FIELDS`.

        Returns
        -------
        str
            The name.
        """
        return {v: k for k, v in LOCK_STATES.items()}[self.locks[field]]

    def _update_crc(self) -> None:
        bank = self.banks[EPC]
        bank[0] = stored_crc(bank[1], self.epc_words)


__all__ = [
    "RESERVED", "EPC", "TID", "USER", "XPC_W1_WORD", "TID_CLASS_E2", "LOCK_FIELD_BANK", "LOCK_STATES",
    "TagError", "MemoryAccessError", "ChipModel", "CHIP_MODELS", "TagMemoryConfig", "TagMemory",
    "stored_crc", "pc_epc_length",
]

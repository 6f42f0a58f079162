"""Access programs: the steps a reader runs on a tag after singulating it, parsed from a config.

The format (a list of strings or TOML tables) and what each step sends are described in
:mod:`rfsim.protocols.access_sequence`, which runs a program through the engine; this module
holds only the parser and the columns of an ``accesses`` table, so that a scenario's config is
read without importing the engine.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.gen2.access import RN_REPLY_BITS, SUCCESS_REPLY_BITS, read_reply_bits
from rfsim.gen2.commands import LOCK_FIELDS

#: Memory banks by name (MemBank codes, EPC Gen2 §6.3.2.1).
BANKS = {"reserved": 0, "epc": 1, "tid": 2, "user": 3}
#: Lock states by name → (pwd-write/read lock bit, permalock bit) of a Lock's action
#: (§6.3.2.12.3.5; :data:`rfsim.gen2.commands.LOCK_FIELDS` names the fields).
LOCK_STATES = {"unlocked": (False, False), "permaunlocked": (False, True), "locked": (True, False),
               "permalocked": (True, True)}
#: Operations of a program step and their fields, in the order of the string form.
STEP_FIELDS = {"req_rn": (), "read": ("bank", "ptr", "count"), "write": ("bank", "ptr", "data"),
               "blockwrite": ("bank", "ptr", "data"), "blockerase": ("bank", "ptr", "count"),
               "lock": ("field", "state"), "access": ("password",), "kill": ("password",)}
#: Operations of a program step.
OPS = tuple(STEP_FIELDS)
#: Default program: the handle, the TID, four words of User memory, one Write.
DEFAULT_PROGRAM = ("req_rn", "read tid 0 4", "read user 0 4", "write user 2 0xBEEF")
_FORMS = ("'req_rn', 'read <bank> <ptr> <count>', 'write <bank> <ptr> <word>', 'blockwrite <bank> <ptr> "
          "<word>,<word>,...', 'blockerase <bank> <ptr> <count>', 'lock <field> <state>', 'access <password>' "
          "or 'kill <password>'")


@dataclasses.dataclass(frozen=True)
class AccessStep:
    """One step of an access program.

    Attributes
    ----------
    op : str
        The operation, one of :data:`OPS`.
    membank : int
        Memory bank 0–3 (Read, Write, BlockWrite, BlockErase).
    word_ptr : int
        First word address (Read, Write, BlockWrite, BlockErase).
    word_count : int
        Words read or erased (Read, BlockErase), 1–255.
    data : int
        The plain 16-bit word to write (Write).
    words : tuple of int
        The words of a BlockWrite (1–255).
    field : str
        The field a Lock changes (:data:`rfsim.gen2.commands.LOCK_FIELDS`).
    state : str
        The lock state it gives the field (:data:`LOCK_STATES`).
    password : int
        The 32-bit access or kill password (Access, Kill).
    text : str
        The step as given (for records and messages).
    """

    op: str
    membank: int = 0
    word_ptr: int = 0
    word_count: int = 0
    data: int = 0
    words: tuple[int, ...] = ()
    field: str = ""
    state: str = ""
    password: int = 0
    text: str = ""

    @property
    def reply_bits(self) -> int:
        """Bits of the reply of success of the step's last command (:mod:`rfsim.gen2.access`):
        RN16/handle + CRC-16 (Req_RN, Access), 0 | words | handle | CRC-16 (Read), or the
        delayed 0 | handle | CRC-16 (Write, BlockWrite, BlockErase, Lock, the final Kill)."""
        if self.op == "read":
            return read_reply_bits(self.word_count)
        return RN_REPLY_BITS if self.op in ("req_rn", "access") else SUCCESS_REPLY_BITS


def _int(key: str, value, lo: int, hi: int, what: str) -> int:
    try:
        v = int(value, 0) if isinstance(value, str) else value
    except ValueError:
        v = None
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
        raise ConfigError(key, value, f"{what}, an integer in [{lo}, {hi}] (0x… hex allowed)")
    return int(v)


def _bank(key: str, value) -> int:
    if isinstance(value, str) and value.lower() in BANKS:
        return BANKS[value.lower()]
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool) and 0 <= value <= 3:
        return int(value)
    raise ConfigError(key, value, "a memory bank: " + ", ".join(BANKS) + " or 0-3")


def _name(key: str, value, allowed) -> str:
    if isinstance(value, str) and value.lower() in allowed:
        return value.lower()
    raise ConfigError(key, value, "one of " + ", ".join(allowed))


def _words(key: str, value) -> tuple[int, ...]:
    items = value.split(",") if isinstance(value, str) else value
    if isinstance(items, (str, bytes)) or not isinstance(items, Sequence) or not 1 <= len(items) <= 255:
        raise ConfigError(key, value, "1 to 255 16-bit words ('0x1111,0x2222' or a list)")
    return tuple(_int(key, w.strip() if isinstance(w, str) else w, 0, 0xFFFF, "a 16-bit word") for w in items)


def parse_step(step, key: str = "program") -> AccessStep:
    """Parse one program step (module docstring).

    Parameters
    ----------
    step : str or mapping
        A string of :data:`STEP_FIELDS` form (``"read tid 0 4"``, ``"write user 2 0xBEEF"``,
        ``"blockwrite user 0 0x1111,0x2222"``, ``"lock user locked"``, ``"kill 0xCAFEBABE"``…)
        or a table with ``op`` and those fields.
    key : str, default "program"
        Config key named in errors (e.g. ``"access.program[2]"``).

    Returns
    -------
    AccessStep
        The step.

    Raises
    ------
    rfsim.core.errors.ConfigError
        One line naming ``key``, the value and what is allowed: an unknown operation, bank,
        lock field or state, a missing or extra field, an address, count, word or password out
        of range.
    """
    if isinstance(step, str):
        parts = step.split()
        op = parts[0].lower() if parts else ""
        names = STEP_FIELDS.get(op)
        if names is None:
            raise ConfigError(key, step, "a step " + _FORMS)
        if len(parts) != 1 + len(names):
            raise ConfigError(key, step, f"'{op}' with {len(names)} fields" + (f" ({' '.join(names)})" if names else ""))
        fields, text = dict(zip(names, parts[1:])), " ".join([op, *parts[1:]])
    elif isinstance(step, Mapping):
        fields = dict(step)
        op = str(fields.pop("op", "")).lower()
        names = STEP_FIELDS.get(op)
        if names is None:
            raise ConfigError(f"{key}.op", step.get("op"), "one of " + ", ".join(OPS))
        if set(fields) != set(names):
            raise ConfigError(key, dict(step), f"op '{op}' with the fields {sorted(names) or 'none'}")
        text = " ".join([op, *[str(fields[n]) for n in names]])
    else:
        raise ConfigError(key, step, "a string ('read tid 0 4') or a table ({op = 'read', ...})")
    if op == "req_rn":
        return AccessStep("req_rn", text=text)
    if op in ("access", "kill"):
        return AccessStep(op, password=_int(f"{key}.password", fields["password"], 0, 2**32 - 1, "a 32-bit password"),
                          text=text)
    if op == "lock":
        return AccessStep("lock", field=_name(f"{key}.field", fields["field"], LOCK_FIELDS),
                          state=_name(f"{key}.state", fields["state"], LOCK_STATES), text=text)
    bank = _bank(f"{key}.bank", fields["bank"])
    ptr = _int(f"{key}.ptr", fields["ptr"], 0, 2**16 - 1, "word address")
    if op in ("read", "blockerase"):
        return AccessStep(op, bank, ptr, word_count=_int(f"{key}.count", fields["count"], 1, 255, "word count"),
                          text=text)
    if op == "blockwrite":
        return AccessStep(op, bank, ptr, words=_words(f"{key}.data", fields["data"]), text=text)
    return AccessStep("write", bank, ptr, data=_int(f"{key}.data", fields["data"], 0, 0xFFFF, "16-bit word"),
                      text=text)


def parse_program(steps, key: str = "program") -> tuple[AccessStep, ...]:
    """Parse an access program (module docstring).

    Parameters
    ----------
    steps : sequence of str or mapping
        The steps, the first ``"req_rn"`` (the handle).
    key : str, default "program"
        Config key named in errors; step i is ``key[i]``.

    Returns
    -------
    tuple of AccessStep
        The parsed steps.

    Raises
    ------
    rfsim.core.errors.ConfigError
        A bad step (:func:`parse_step`), an empty program or one that does not start with
        ``req_rn``.
    """
    if isinstance(steps, (str, Mapping)) or not isinstance(steps, Sequence) or not steps:
        raise ConfigError(key, steps, "a non-empty list of steps starting with 'req_rn'")
    out = tuple(parse_step(s, f"{key}[{i}]") for i, s in enumerate(steps))
    if out[0].op != "req_rn":
        raise ConfigError(f"{key}[0]", steps[0], "'req_rn' (the handle comes first)")
    return out


#: Columns of an ``accesses`` table: :class:`rfsim.protocols.access_sequence.AccessRecord` field → (units, description).
ACCESS_FIELDS = {
    "step": ("1", "index of the access program step (a Write's Req_RN has its Write's index)"),
    "command": ("", "access command: Req_RN, Read, Write, BlockWrite, BlockErase, Lock, Access or Kill"),
    "result": ("", "ok, error (an error reply), a failure reason (no usable reply) or 'not sent'"),
    "error_code": ("1", "tag error code of an error reply (Gen2 Annex I; 11 = insufficient power), -1 otherwise"),
    "data_hex": ("", "words read (Read) or the RN16/handle (Req_RN, Access, first Kill) as upper-case hex; '' if none"),
    "start_s": ("s", "start of the command's segment (NaN: not sent)"),
    "cmd_end_s": ("s", "end of the command (last rising edge)"),
    "reply_start_s": ("s", "start of the reply the reader detected (NaN: none)"),
    "reply_delay_s": ("s", "reply start minus command end: T1, or T5 for a delayed reply (Write, BlockWrite, "
                      "BlockErase, Lock, the final Kill)"),
    "gap_s": ("s", "from the previous reply's end (T2) or the previous command's end (T4) to this command"),
    "gap_kind": ("", "T2 after a detected reply, T4 after none, '' when not sent"),
    "incident_power_dbm": ("dBm", "ground truth: CW power incident at the tag antenna port during the command"),
    "rssi_dbm": ("dBm", "RSSI of the decoded reply (NaN: none)"),
}



__all__ = ["ACCESS_FIELDS", "AccessStep", "BANKS", "DEFAULT_PROGRAM", "LOCK_STATES", "OPS", "STEP_FIELDS",
           "parse_program", "parse_step"]

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

#: Memory banks by name (MemBank codes, EPC Gen2 §6.3.2.1).
BANKS = {"reserved": 0, "epc": 1, "tid": 2, "user": 3}
#: Operations of a program step.
OPS = ("req_rn", "read", "write")
#: Bits of a Req_RN reply (RN16 or handle + CRC-16) and of a Write's success reply (0 | handle | CRC-16).
REQ_RN_REPLY_BITS, WRITE_REPLY_BITS = 32, 33
#: Default program: the handle, the TID, four words of User memory, one Write (issue's example).
DEFAULT_PROGRAM = ("req_rn", "read tid 0 4", "read user 0 4", "write user 2 0xBEEF")


@dataclasses.dataclass(frozen=True)
class AccessStep:
    """One step of an access program.

    Attributes
    ----------
    op : {"req_rn", "read", "write"}
        The operation.
    membank : int
        Memory bank 0–3 (Read, Write).
    word_ptr : int
        First word address (Read, Write).
    word_count : int
        Words to read (Read), 1–255.
    data : int
        The plain 16-bit word to write (Write).
    text : str
        The step as given (for records and messages).
    """

    op: str
    membank: int = 0
    word_ptr: int = 0
    word_count: int = 0
    data: int = 0
    text: str = ""

    @property
    def reply_bits(self) -> int:
        """Bits of the reply of success: RN16 + CRC-16, 0 | words | handle | CRC-16, or 0 |
        handle | CRC-16 (:mod:`rfsim.gen2.access`)."""
        if self.op == "read":
            return 33 + 16 * self.word_count
        return WRITE_REPLY_BITS if self.op == "write" else REQ_RN_REPLY_BITS


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


def parse_step(step, key: str = "program") -> AccessStep:
    """Parse one program step (module docstring).

    Parameters
    ----------
    step : str or mapping
        ``"req_rn"``, ``"read <bank> <ptr> <count>"``, ``"write <bank> <ptr> <word>"``, or a
        table with ``op`` and ``bank``, ``ptr``, ``count`` / ``data``.
    key : str, default "program"
        Config key named in errors (e.g. ``"access.program[2]"``).

    Returns
    -------
    AccessStep
        The step.

    Raises
    ------
    rfsim.core.errors.ConfigError
        One line naming ``key``, the value and what is allowed: an unknown operation or bank,
        a missing or extra field, an address, count or word out of range.
    """
    if isinstance(step, str):
        parts = step.split()
        op = parts[0].lower() if parts else ""
        names = {"req_rn": (), "read": ("bank", "ptr", "count"), "write": ("bank", "ptr", "data")}.get(op)
        if names is None:
            raise ConfigError(key, step, "a step 'req_rn', 'read <bank> <ptr> <count>' or 'write <bank> <ptr> <word>'")
        if len(parts) != 1 + len(names):
            raise ConfigError(key, step, f"'{op}' with {len(names)} fields" + (f" ({' '.join(names)})" if names else ""))
        fields, text = dict(zip(names, parts[1:])), " ".join([op, *parts[1:]])
    elif isinstance(step, Mapping):
        fields = dict(step)
        op = str(fields.pop("op", "")).lower()
        allowed = {"req_rn": set(), "read": {"bank", "ptr", "count"}, "write": {"bank", "ptr", "data"}}.get(op)
        if allowed is None:
            raise ConfigError(f"{key}.op", step.get("op"), "one of " + ", ".join(OPS))
        if set(fields) != allowed:
            raise ConfigError(key, dict(step), f"op '{op}' with the fields {sorted(allowed) or 'none'}")
        text = " ".join([op, *[str(fields[n]) for n in ("bank", "ptr", "count", "data") if n in fields]])
    else:
        raise ConfigError(key, step, "a string ('read tid 0 4') or a table ({op = 'read', ...})")
    if op == "req_rn":
        return AccessStep("req_rn", text=text)
    bank = _bank(f"{key}.bank", fields["bank"])
    ptr = _int(f"{key}.ptr", fields["ptr"], 0, 2**16 - 1, "word address")
    if op == "read":
        return AccessStep("read", bank, ptr, word_count=_int(f"{key}.count", fields["count"], 1, 255, "word count"),
                          text=text)
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
    "command": ("", "access command: Req_RN, Read or Write"),
    "result": ("", "ok, error (an error reply), a failure reason (no usable reply) or 'not sent'"),
    "error_code": ("1", "tag error code of an error reply (Gen2 Annex I; 11 = insufficient power), -1 otherwise"),
    "data_hex": ("", "words read (Read) or the RN16/handle (Req_RN) as upper-case hex; '' if none"),
    "start_s": ("s", "start of the command's segment (NaN: not sent)"),
    "cmd_end_s": ("s", "end of the command (last rising edge)"),
    "reply_start_s": ("s", "start of the reply the reader detected (NaN: none)"),
    "reply_delay_s": ("s", "reply start minus command end: T1, or T5 for a delayed reply (Write)"),
    "gap_s": ("s", "from the previous reply's end (T2) or the previous command's end (T4) to this command"),
    "gap_kind": ("", "T2 after a detected reply, T4 after none, '' when not sent"),
    "incident_power_dbm": ("dBm", "ground truth: CW power incident at the tag antenna port during the command"),
    "rssi_dbm": ("dBm", "RSSI of the decoded reply (NaN: none)"),
}



__all__ = ["ACCESS_FIELDS", "AccessStep", "BANKS", "DEFAULT_PROGRAM", "OPS", "REQ_RN_REPLY_BITS", "WRITE_REPLY_BITS",
           "parse_program", "parse_step"]

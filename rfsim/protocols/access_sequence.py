"""Access sequences: what a reader does with a tag after singulating it.

After a successful singulation (Query → RN16 → ACK → PC+EPC+CRC-16, the EPC reply decoded with
its CRC right: :func:`rfsim.protocols.engine.singulate_batch`) a reader runs a per-tag *access
program*: Req_RN with the tag's RN16 (the tag answers with its handle), then each step with the
handle — Read, another Req_RN, Write (EPC Gen2 v2 / ISO 18000-63 §6.3.2.12.3; command and reply
formats gen2-and-validation-anchors.md §4.4, :mod:`rfsim.gen2.commands`,
:mod:`rfsim.gen2.access`). Every command is one sample-level exchange of the engine
(:func:`rfsim.protocols.engine.run_exchanges`, a batch of independent trials), over the channel
draw of the trial's Query (``draw_channel=False``: quasi-static within the round; each trial
needs a channel object of its own, which holds that draw).

A program is a list of steps, each a string or a table (TOML friendly, :func:`rfsim.protocols.access_program.parse_program`):

=====================================  =================================================
step                                   what the reader sends
=====================================  =================================================
``"req_rn"``                           Req_RN; the first one (with the RN16 of the
                                       singulation) gets the handle, a later one (with
                                       the handle) a new RN16
``"read <bank> <ptr> <n>"``            Read of ``n`` words (1–255) of ``bank``
                                       (``reserved``, ``epc``, ``tid``, ``user`` or 0–3)
                                       from word ``ptr``
``"write <bank> <ptr> <w>"``           Req_RN for a fresh RN16, then Write of the word
                                       ``w`` (``0xBEEF`` or decimal) cover-coded with it
``"blockwrite <bank> <ptr> <w>,<w>"``  BlockWrite of the words (not cover-coded)
``"blockerase <bank> <ptr> <n>"``      BlockErase of ``n`` words
``"lock <field> <state>"``             Lock of one field (``kill_pwd``, ``access_pwd``,
                                       ``epc``, ``tid``, ``user``) to ``unlocked``,
                                       ``locked``, ``permaunlocked`` or ``permalocked``
``"access <password>"``                Req_RN, Access (upper half), Req_RN, Access
                                       (lower half), each half cover-coded
``"kill <password>"``                  Req_RN, Kill (upper half), Req_RN, Kill (lower
                                       half): the tag answers the last with a delayed
                                       reply and is killed
=====================================  =================================================

or a table of the same fields, e.g. ``{op = "read", bank = "tid", ptr = 0, count = 4}`` /
``{op = "write", bank = "user", ptr = 2, data = 0xBEEF}`` (:data:`rfsim.protocols.access_program.STEP_FIELDS`).
A program starts with ``"req_rn"`` (the handle).

Cover coding (§6.3.2.12.3.3 Write, §6.3.2.12.3.4 Kill, §6.3.2.12.3.6 Access): the Write's data
field, and each password half, is the plain value XOR the RN16 of the tag's reply to the
Req_RN just before it (:func:`rfsim.gen2.commands.cover_code`); those Req_RNs are recorded as
commands of the same step. A trial goes on to the next command of a step only while its replies
are decoded; the rest of the step is "not sent".

Timing (gen2-and-validation-anchors.md §4.3, :mod:`rfsim.gen2.link`): a command that follows a
reply the reader detected starts T2 after the reply's end (``t2_tpri`` Tpri, default 10, inside
the standard's 3–20 Tpri; the reply's end is its detected start plus its nominal duration,
:func:`rfsim.gen2.link.backscatter_duration_s`); a command that follows one without a reply
starts when the reader's reply window ends (T1max + the reply + 3 Tpri after the command,
:func:`rfsim.gen2.link.reply_window_s`: T3 ≥ 0 after T1) and at least T4 = 2 RTcal after the
previous command. The replies of Write, BlockWrite, BlockErase, Lock and the final Kill are
delayed (``delayed_reply``, the engine's window T5 ≤ 20 ms after the command, sent with the
extended preamble; their nominal duration is taken with TRext = 1). Replies with a header bit
(Read and the delayed ones) may be error replies ``1 | code(8) |
handle | CRC-16`` (41 bits), which the engine's reader decodes at that length
(``header_bit``); the error code is recorded (Annex I, :class:`rfsim.gen2.memory.TagError`).

Results of an access (:data:`ACCESS_RESULTS`): ``"ok"`` (the reply decoded, CRC right, header
0), ``"error"`` (an error reply decoded, CRC right: ``error_code`` holds its code), the
engine's failure reasons where the reader got no usable reply (``"not powered"``, ``"no
reply"``, ``"crc error"``, … :data:`rfsim.protocols.engine.FAILURE_REASONS`), and ``"not
sent"`` for the steps a reader cannot send (no handle: the first Req_RN failed, or the
singulation did; a Write whose Req_RN failed has no cover code).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.gen2.access import ERROR_REPLY_BITS, RN_REPLY_BITS, SUCCESS_REPLY_BITS
from rfsim.protocols.access_program import (ACCESS_FIELDS, BANKS, DEFAULT_PROGRAM, LOCK_STATES, OPS, AccessStep,
                                            parse_program, parse_step)
from rfsim.gen2.bits import bits_to_int
from rfsim.gen2.commands import Access, BlockErase, BlockWrite, Kill, Lock, Read, ReqRN, Write
from rfsim.gen2.link import backscatter_duration_s, t2, t4
from rfsim.protocols.engine import FAILURE_REASONS, run_exchanges, singulate_batch

#: Results of an access: decoded replies, the engine's failure reasons, and steps not sent.
ACCESS_RESULTS = ("ok", "error", *[r for r in FAILURE_REASONS if r], "not sent")


@dataclasses.dataclass(frozen=True)
class AccessRecord:
    """One access command and what came back (the columns of an ``accesses`` table).

    Attributes
    ----------
    step : int
        Index of the program step (a Write's Req_RN has its Write's index).
    command : str
        ``"Req_RN"``, ``"Read"`` or ``"Write"``.
    result : str
        One of :data:`ACCESS_RESULTS`.
    error_code : int
        The tag's error code of an ``"error"`` result (Annex I), −1 otherwise.
    data_hex : str
        Words read (Read), the RN16 or handle (Req_RN), as upper-case hex; ``""`` if none.
    start_s : float
        Start of the command's segment [s] (NaN: not sent).
    cmd_end_s : float
        End of the command (last rising edge) [s].
    reply_start_s : float
        Start of the reply the reader detected [s] (NaN: none).
    reply_delay_s : float
        ``reply_start_s − cmd_end_s`` [s]: T1, or T5 for a delayed reply.
    gap_s : float
        From the end of the previous reply (``gap_kind`` "T2") or the previous command
        (``"T4"``) to this command's start [s].
    gap_kind : str
        ``"T2"`` after a detected reply, ``"T4"`` after none, ``""`` when not sent.
    incident_power_dbm : float
        CW power incident at the tag's antenna port during the command [dBm] (ground truth).
    rssi_dbm : float
        RSSI of the decoded reply [dBm] (NaN: none).
    """

    step: int
    command: str
    result: str
    error_code: int = -1
    data_hex: str = ""
    start_s: float = math.nan
    cmd_end_s: float = math.nan
    reply_start_s: float = math.nan
    reply_delay_s: float = math.nan
    gap_s: float = math.nan
    gap_kind: str = ""
    incident_power_dbm: float = math.nan
    rssi_dbm: float = math.nan


@dataclasses.dataclass
class AccessRun:
    """One trial: its singulation and its access records.

    Attributes
    ----------
    singulation : list of rfsim.protocols.engine.Exchange
        The Query's exchange and, when the reader accepted an RN16, the ACK's.
    records : list of AccessRecord
        One per access command (a record ``"not sent"`` per step the reader could not send).
    """

    singulation: list
    records: list

    @property
    def epc_ok(self) -> bool:
        """The EPC reply was decoded with its CRC right (the access program ran)."""
        return len(self.singulation) == 2 and self.singulation[1].success


@dataclasses.dataclass
class _Trial:
    """A trial's state while its program runs."""

    b: int
    tag: int  # index of the singulated tag among the trial's tags
    rn16: int
    handle: int | None
    t_s: float  # start of the next command
    prev_end_s: float  # end of the previous reply (T2) or command (T4)
    gap_kind: str
    records: list


def _reply_end_s(link, read, n_bits: int, delayed: bool) -> float:
    """End of a detected reply [s]: its start + its nominal duration (TRext = 1 when delayed)."""
    return read.start_s + backscatter_duration_s(n_bits, blf_hz=link.blf_hz, m=link.m, trext=link.trext or delayed)


def _verdict(ex, tag: int) -> tuple[str, int, np.ndarray | None]:
    """``(result, error code, payload bits)`` of an exchange (module docstring "Results")."""
    read = ex.read
    if ex.failure_reason in ("not powered", "decode error", "no reply") or read is None or not read.success:
        return ex.failure_reason or (read.failure_reason if read is not None else "no reply"), -1, None
    if ex.failure_reason == "bit error" or (ex.decoded_tag is not None and ex.decoded_tag != tag):
        return "bit error", -1, None
    bits = read.bits
    return ("error", bits_to_int(bits[1:9]), None) if bits.size == ERROR_REPLY_BITS and bits[0] == 1 else \
        ("ok", -1, bits)


def _hex(bits: np.ndarray) -> str:
    return "".join(f"{bits_to_int(bits[i:i + 16]):04X}" for i in range(0, bits.size - bits.size % 16, 16))


def _exchange(trials: list, step: int, name: str, cmds: list, reply_bits: int, devices: dict, *, t2_s: float,
              t4_s: float, header_bit: bool = False, delayed: bool = False) -> list:
    """One command for each of ``trials`` (one batch), their records appended; returns, per
    trial, the reply's payload bits (None unless ``"ok"``)."""
    if not trials:
        return []
    bs = [t.b for t in trials]
    exs = run_exchanges([devices["reader"][b] for b in bs], [devices["tags"][b] for b in bs],
                        [devices["channel"][b] for b in bs], cmds, t_s=[t.t_s for t in trials],
                        rngs=[devices["rng"][b] for b in bs], reply_bits=reply_bits, expect_crc=True,
                        round_index=[devices["round"][b] for b in bs], draw_channel=False, header_bit=header_bit,
                        delayed_reply=delayed)
    out = []
    for t, ex in zip(trials, exs):
        link = devices["reader"][t.b].link
        result, code, bits = _verdict(ex, t.tag)
        read = ex.read
        seen = read is not None and read.bits is not None  # the reader's own view: it detected a reply
        start = read.start_s if seen else math.nan
        data = "" if bits is None else _hex(bits[:16]) if bits.size == RN_REPLY_BITS else _hex(bits[1:-32])
        t.records.append(AccessRecord(step=step, command=name, result=result, error_code=code, data_hex=data,
                                      start_s=t.t_s, cmd_end_s=ex.cmd_end_s, reply_start_s=start,
                                      reply_delay_s=start - ex.cmd_end_s, gap_s=t.t_s - t.prev_end_s,
                                      gap_kind=t.gap_kind, incident_power_dbm=float(ex.incident_power_dbm[t.tag]),
                                      rssi_dbm=float(read.rssi_dbm) if bits is not None or result == "error"
                                      else math.nan))
        if seen:
            t.prev_end_s, t.gap_kind = _reply_end_s(link, read, read.bits.size, delayed), "T2"
            t.t_s = t.prev_end_s + t2_s
        else:
            t.prev_end_s, t.gap_kind = ex.cmd_end_s, "T4"
            t.t_s = max(ex.end_s, ex.cmd_end_s + t4_s)
        out.append(bits)
    return out


def _not_sent(trials: list, step: int, name: str) -> None:
    for t in trials:
        t.records.append(AccessRecord(step=step, command=name, result="not sent"))


def run_access_batch(reader, tags: Sequence[Sequence], channel, *, t_s, rngs: Sequence[np.random.Generator], query,
                     program: Sequence[AccessStep], round_index=0, epc_bits: int = 128,
                     t2_tpri: float = 10.0) -> list[AccessRun]:
    """Singulate a tag in each of B independent trials, then run the access program on it.

    The singulation is :func:`rfsim.protocols.engine.singulate_batch`; the program runs on the
    trials whose EPC reply was decoded with its CRC right, one batch of exchanges per command
    (timing, cover coding and results: module docstring).

    Parameters
    ----------
    reader : object or list
        Reader device; one value or one per trial.
    tags : sequence of sequence
        B sequences of tags, trial b's tags.
    channel : list
        One channel per trial (each holds its trial's draw for the access commands).
    t_s : float or list of float
        Start time of the Query [s]; one value or one per trial.
    rngs : sequence of numpy.random.Generator
        B generators, trial b's channel draw and receiver noise (every command of the trial).
    query : object
        The Query command (Q = 0).
    program : sequence of AccessStep
        The access program (:func:`parse_program`), starting with a Req_RN.
    round_index : int or list of int, default 0
        Inventory round (selects the antenna); one value or one per trial.
    epc_bits : int, default 128
        Bits of the PC+EPC+CRC reply to the ACK.
    t2_tpri : float, default 10.0
        T2, from a reply's end to the next command [Tpri], in [3, 20] (§4.3).

    Returns
    -------
    list of AccessRun
        Per trial its singulation and its access records (one per command, and ``"not sent"``
        records for the steps not sent: a Write not sent gets one for its Req_RN and one for it).

    Raises
    ------
    rfsim.core.errors.ConfigError
        ``t2_tpri`` outside [3, 20], or a program that does not start with a Req_RN.
    ValueError
        A ``channel`` that is not one object per trial.
    """
    if not 3.0 <= t2_tpri <= 20.0:
        raise ConfigError("t2_tpri", t2_tpri, "a number in [3, 20] (Gen2 T2 in Tpri)")
    if not program or program[0].op != "req_rn":
        raise ConfigError("program", [s.text for s in program], "a program starting with 'req_rn'")
    n = len(rngs)
    if not isinstance(channel, (list, tuple)) or len(channel) != n or len({id(c) for c in channel}) < n:
        raise ValueError("channel: one channel object per trial (each holds its trial's draw)")
    readers = list(reader) if isinstance(reader, (list, tuple)) else [reader] * n
    rounds = list(round_index) if isinstance(round_index, (list, tuple)) else [round_index] * n
    singles = singulate_batch(readers, tags, list(channel), t_s=t_s, rngs=rngs, query=query, round_index=rounds,
                              epc_bits=epc_bits)
    devices = dict(reader=readers, tags=list(tags), channel=list(channel), rng=list(rngs), round=rounds)
    runs = [AccessRun(singulation=ex, records=[]) for ex in singles]
    active = []
    for b, run in enumerate(runs):
        if run.epc_ok:
            query_ex, ack = run.singulation
            link = readers[b].link
            end = _reply_end_s(link, ack.read, epc_bits, False)
            active.append(_Trial(b=b, tag=ack.decoded_tag, rn16=bits_to_int(query_ex.read.bits), handle=None,
                                 t_s=end + t2_tpri * link.tpri_s, prev_end_s=end, gap_kind="T2", records=run.records))
        else:  # never singulated: no step is sent
            run.records.extend(AccessRecord(step=k, command=name, result="not sent") for k, name in _commands(program))
    lk = readers[0].link
    timing = dict(t2_s=t2_tpri * lk.tpri_s, t4_s=t4(lk).min_s)
    if not t2(lk).min_s <= timing["t2_s"] <= t2(lk).max_s * (1 + 1e-12):
        raise ConfigError("t2_tpri", t2_tpri, "a T2 inside the link's 3-20 Tpri")
    for k, step in enumerate(program):
        _run_step(active, k, step, devices, timing)
    return runs


@dataclasses.dataclass(frozen=True)
class _Action:
    """One command of a step: its name, how it is built from the trial and the cover RN16, its
    reply (bits, header bit, delayed) and whether its reply's RN16 covers the next command."""

    name: str
    build: Callable
    reply_bits: int
    header_bit: bool = False
    delayed: bool = False
    cover: bool = False


def _cover() -> _Action:
    """A Req_RN with the handle whose reply's RN16 is the next command's cover code."""
    return _Action("Req_RN", lambda t, rn: ReqRN(t.handle), RN_REPLY_BITS, cover=True)


def _actions(k: int, step: AccessStep) -> list[_Action]:
    """The commands of step ``k`` (module docstring table)."""
    op = step.op
    if op == "req_rn":
        return [_Action("Req_RN", (lambda t, rn: ReqRN(t.rn16)) if k == 0 else (lambda t, rn: ReqRN(t.handle)),
                        RN_REPLY_BITS)]
    if op == "read":
        return [_Action("Read", lambda t, rn: Read(step.membank, step.word_ptr, step.word_count, t.handle),
                        step.reply_bits, header_bit=True)]
    delayed = dict(reply_bits=SUCCESS_REPLY_BITS, header_bit=True, delayed=True)
    if op == "write":
        return [_cover(), _Action("Write", lambda t, rn: Write.cover_coded(step.membank, step.word_ptr, step.data, rn,
                                                                          t.handle), **delayed)]
    if op == "blockwrite":
        return [_Action("BlockWrite", lambda t, rn: BlockWrite(step.membank, step.word_ptr, step.words, t.handle),
                        **delayed)]
    if op == "blockerase":
        return [_Action("BlockErase", lambda t, rn: BlockErase(step.membank, step.word_ptr, step.word_count,
                                                               t.handle), **delayed)]
    if op == "lock":
        return [_Action("Lock", lambda t, rn: Lock.of(t.handle, **{step.field: LOCK_STATES[step.state]}), **delayed)]
    upper, lower = step.password >> 16, step.password & 0xFFFF
    if op == "access":
        return [_cover(), _Action("Access", lambda t, rn: Access.cover_coded(upper, rn, t.handle), RN_REPLY_BITS),
                _cover(), _Action("Access", lambda t, rn: Access.cover_coded(lower, rn, t.handle), RN_REPLY_BITS)]
    return [_cover(), _Action("Kill", lambda t, rn: Kill.cover_coded(upper, rn, t.handle), RN_REPLY_BITS),
            _cover(), _Action("Kill", lambda t, rn: Kill.cover_coded(lower, rn, t.handle), **delayed)]


def _commands(program: Sequence[AccessStep]) -> list[tuple[int, str]]:
    """``(step index, command name)`` of every command of a program (a Write is two, an Access
    or Kill four)."""
    return [(k, a.name) for k, step in enumerate(program) for a in _actions(k, step)]


def _run_step(active: list, k: int, step: AccessStep, devices: dict, timing: dict) -> None:
    """Step ``k`` of the program for the singulated trials (records appended to each).

    Its commands run in order, one batch each; a trial goes on to the next command of the step
    only while its replies are decoded ("ok"), the others get "not sent" records for the rest.
    The first step's Req_RN (with the singulation's RN16) gives the handle; every later command
    needs it."""
    go = [t for t in active if t.handle is not None] if k else list(active)
    covers = [0] * len(go)  # per trial of go: the RN16 of its last reply (the next command's cover code)
    for action in _actions(k, step):
        going = {t.b for t in go}
        _not_sent([t for t in active if t.b not in going], k, action.name)
        bits = _exchange(go, k, action.name, [action.build(t, rn) for t, rn in zip(go, covers)], action.reply_bits,
                         devices, header_bit=action.header_bit, delayed=action.delayed, **timing)
        if k == 0 and step.op == "req_rn":
            for t, b in zip(go, bits):
                t.handle = None if b is None else bits_to_int(b[:16])
        go, covers = [t for t, b in zip(go, bits) if b is not None], [bits_to_int(b[:16]) for b in bits if b is not None]


def access_columns(runs: Sequence[AccessRun]) -> dict[str, np.ndarray]:
    """The records of ``runs`` as columns (:data:`ACCESS_FIELDS`) plus ``trial`` (the run's index).

    Parameters
    ----------
    runs : sequence of AccessRun
        Trials' runs.

    Returns
    -------
    dict of str to numpy.ndarray
        ``trial`` and one column per :class:`AccessRecord` field, one row per record.
    """
    rows = [(i, r) for i, run in enumerate(runs) for r in run.records]
    out = {"trial": np.array([i for i, _ in rows], dtype=np.int64)}
    for f in dataclasses.fields(AccessRecord):
        values = [getattr(r, f.name) for _, r in rows]
        out[f.name] = np.array(values, dtype=str if f.type == "str" else np.int64 if f.type == "int" else float)
    return out


__all__ = ["ACCESS_FIELDS", "ACCESS_RESULTS", "AccessRecord", "AccessRun", "AccessStep", "BANKS", "DEFAULT_PROGRAM",
           "OPS", "access_columns", "parse_program", "parse_step", "run_access_batch"]

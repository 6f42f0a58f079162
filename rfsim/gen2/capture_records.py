"""Decoded captures as tables: the commands and the tag replies of ``rfsim decode``.

The replies table is a per-read table in the schema every simulated reader writes
(:mod:`rfsim.core.reads`: EPC, antenna port, channel, carrier, time stamps, seen count, RSSI,
phase, Doppler, their reader-quantized variants and the ground truth) plus the capture's own
columns, so a measured session and a simulated one can be put side by side
(``rfsim.core.dataset.read_table(path, "reads")`` → pandas; ``rfsim export``). What a capture
cannot know is written as the schema's "unknown" value: antenna port and channel 0; carrier,
Doppler and the ground truth NaN. A reply is a tag report (``tag_seen_count`` 1) when it is an
EPC reply with a correct CRC-16. The same rows serve ``--format json|csv``.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from rfsim.core.dataset import Dataset, column
from rfsim.core.reads import READ_SCHEMA, read_columns
from rfsim.core.records import time_stamp_us

#: The capture's own columns of the replies table (beside the per-read schema).
CAPTURE_FIELDS: dict[str, tuple[str, str]] = {
    "time_s": ("s", "start of the tag reply (pilot or preamble) in the capture"),
    "end_s": ("s", "end of the reply, or where the next command cut it"),
    "command_index": ("1", "row of the preceding reader command in the commands table"),
    "command": ("", "reader command the reply answers (Query, ACK, Req_RN, Read, ...)"),
    "kind": ("", "reply type: RN16, EPC (PC+EPC+CRC-16), handle (RN16+CRC-16), read (header 0+words+handle+CRC-16), "
                 "success (delayed: header 0+handle+CRC-16) or error (header 1+code+handle+CRC-16)"),
    "rn16": ("1", "RN16 (RN16 reply) or handle (handle/read/success/error reply); -1 if none"),
    "pc": ("1", "protocol-control word of an EPC reply; -1 if none"),
    "data_hex": ("", "words of a read reply as upper-case hex ('' if none)"),
    "delayed": ("1", "searched as a delayed (in-process) reply, up to 20 ms after the command (extended preamble)"),
    "error_code": ("1", "error code of an error reply (EPC Gen2 Annex I); -1 if none"),
    "error_name": ("", "name of the error code ('' if none)"),
    "latency_s": ("s", "from the command's last rising edge to the reply's start (T1, or T5 if delayed)"),
    "crc_checked": ("1", "the reply carries a CRC-16 and was decoded complete"),
    "crc_ok": ("1", "CRC-16 over the reply correct (False where crc_checked is False)"),
    "truncated": ("1", "the next command or the capture's end cut the reply"),
    "bits": ("", "decoded data bits (dummy 1 removed) as a 0/1 string"),
    "n_bits_expected": ("1", "data bits of the complete reply (-1 unknown)"),
    "m": ("1", "line code: 1 = FM0, 2/4/8 = Miller-M"),
    "trext": ("1", "pilot tone (TRext) present"),
    "blf_hz": ("Hz", "mean backscatter link frequency measured on the reply"),
    "blf_drift": ("1", "relative BLF change from the reply's start to its end (tracked)"),
    "corr": ("1", "normalised preamble correlation at the decoded start and BLF (0..1)"),
    "snr_db": ("dB", "|h|^2 over the residual noise power per sample at the capture's sample rate"),
}
#: What a capture's values of the per-read schema mean (added to the schema's descriptions).
SCHEMA_NOTES = {
    "first_seen_timestamp_us": "start of the reply in the capture",
    "tag_seen_count": "1 for an EPC reply with a correct CRC-16",
    "peak_rssi_dbm": "10*log10|h|^2 + 30 of the reply's complex amplitude h: dBm if the capture is in sqrt(W), "
                     "else dB relative to the capture's unit",
    "doppler_frequency_hz": "not measured by the capture decoder",
}
#: Columns of the replies table: the capture's own, then the per-read schema (name → (units, description)).
READ_FIELDS: dict[str, tuple[str, str]] = {
    **CAPTURE_FIELDS,
    **{k: (f.units, f.text(SCHEMA_NOTES.get(k, ""))) for k, f in READ_SCHEMA.items()},
}
COMMAND_FIELDS: dict[str, tuple[str, str]] = {
    "time_s": ("s", "falling edge of the command's delimiter"),
    "end_s": ("s", "last rising edge of the command"),
    "command": ("", "command name (Query, ACK, ... or 'unknown')"),
    "bits": ("", "decoded command bits as a 0/1 string"),
    "fields_json": ("", "parsed fields as a JSON object ('{}' when parsing failed)"),
    "crc_checked": ("1", "the command carries a CRC (Query: CRC-5; Select, Req_RN, Read: CRC-16)"),
    "crc_ok": ("1", "its CRC is correct (False where crc_checked is False)"),
    "error": ("", "parse error ('' if parsed)"),
    "tari_s": ("s", "data-0 duration measured on the command"),
    "rtcal_s": ("s", "RTcal measured on the command"),
    "trcal_s": ("s", "TRcal measured on the command (NaN without a Query preamble)"),
    "delimiter_s": ("s", "delimiter measured on the command"),
}


def _int_or(value, default: int = -1) -> int:
    return default if value is None else int(value)


def _schema_inputs(reps) -> dict[str, Any]:
    """The arguments of :func:`rfsim.core.reads.read_columns` for decoded replies ``reps``."""
    n = len(reps)
    return dict(epc=np.array([r.epc_hex or "" for r in reps], dtype=str).reshape(n),
                antenna_port=np.zeros(n, np.int64), channel_index=np.zeros(n, np.int64),
                frequency_hz=np.full(n, math.nan), first_seen_timestamp_us=time_stamp_us([r.start_s for r in reps]),
                tag_seen_count=np.array([r.kind == "EPC" and bool(r.crc_ok) for r in reps], dtype=bool).reshape(n),
                peak_rssi_dbm=np.array([r.rssi_dbm for r in reps], float).reshape(n),
                phase_angle_rad=np.array([r.phase_rad for r in reps], float).reshape(n),
                doppler_frequency_hz=np.full(n, math.nan), notes=SCHEMA_NOTES)


def _capture_row(rep) -> dict[str, Any]:
    return {
        "time_s": rep.start_s, "end_s": rep.end_s, "command_index": rep.command_index, "command": rep.command,
        "kind": rep.kind, "rn16": _int_or(rep.rn16), "pc": _int_or(rep.pc),
        "data_hex": rep.data_hex or "", "delayed": bool(rep.delayed), "error_code": _int_or(rep.error_code),
        "error_name": rep.error_name or "", "latency_s": rep.latency_s,
        "crc_checked": rep.crc_ok is not None, "crc_ok": bool(rep.crc_ok),
        "truncated": bool(rep.truncated), "bits": rep.bits, "n_bits_expected": rep.n_bits_expected,
        "m": rep.m, "trext": bool(rep.trext), "blf_hz": rep.blf_hz, "blf_drift": rep.blf_drift, "corr": rep.corr,
        "snr_db": rep.snr_db,
    }


def reply_row(rep) -> dict[str, Any]:
    """One replies-table row (:data:`READ_FIELDS`) of a tag reply record: the capture's
    columns and the per-read schema's (:mod:`rfsim.core.reads`), as Python scalars.

    Parameters
    ----------
    rep : rfsim.gen2.replies.TagReplyRecord
        The decoded reply.

    Returns
    -------
    dict of str to object
        Column name → value (unknown integers −1, unknown numbers NaN), units as in
        :data:`READ_FIELDS`.
    """
    schema = read_columns(**_schema_inputs([rep]))
    return {**_capture_row(rep), **{k: c.data[0].item() for k, c in schema.items()}}


def command_row(rec) -> dict[str, Any]:
    """One commands-table row (:data:`COMMAND_FIELDS`) of a reader command record.

    Parameters
    ----------
    rec : rfsim.gen2.capture.ReaderCommandRecord
        The decoded command.

    Returns
    -------
    dict of str to object
        Column name → value, units as in :data:`COMMAND_FIELDS`.
    """
    return {
        "time_s": rec.start_s, "end_s": rec.end_s, "command": rec.name, "bits": rec.bits,
        "fields_json": json.dumps(rec.fields, sort_keys=True), "crc_checked": rec.crc_ok is not None,
        "crc_ok": bool(rec.crc_ok), "error": rec.error or "", "tari_s": rec.tari_s, "rtcal_s": rec.rtcal_s,
        "trcal_s": rec.trcal_s, "delimiter_s": rec.delimiter_s,
    }


def _columns(rows: list[dict], fields: dict[str, tuple[str, str]]):
    out = {}
    for name, (units, description) in fields.items():
        values = [row[name] for row in rows]
        if not values:  # an empty table keeps its columns: text where units are "", else numbers
            values = np.array([], dtype=str) if units == "" else np.zeros(0)
        out[name] = column(values, units, description)
    return out


def capture_dataset(records, replies, *, capture: str, fs_hz: float, timing) -> Dataset:
    """A dataset of a decoded capture.

    The tables ``commands`` and ``reads`` (one row per tag reply) and the capture's sample
    rate, median timings and warnings as attributes.

    Parameters
    ----------
    records : sequence of rfsim.gen2.capture.ReaderCommandRecord
        Decoded reader commands.
    replies : sequence of rfsim.gen2.replies.TagReplyRecord
        Decoded tag replies.
    capture : str
        Name of the capture (the title and the ``capture`` attribute).
    fs_hz : float
        Sample rate of the capture [Hz].
    timing : rfsim.gen2.capture.ReaderTiming
        Command count, median Tari/RTcal/TRcal/delimiter [s] (NaN: not measured) and warnings.

    Returns
    -------
    rfsim.core.dataset.Dataset
        The dataset.
    """
    ds = Dataset(title=f"rfsim decode of {capture}", scenario="decode")
    ds.add_table("commands", _columns([command_row(r) for r in records], COMMAND_FIELDS))
    ds.add_table("reads", {**_columns([_capture_row(r) for r in replies], CAPTURE_FIELDS),
                           **read_columns(**_schema_inputs(replies))})
    ds.attrs.update(capture=str(capture), fs_hz=float(fs_hz), n_commands=int(timing.n_commands),
                    warnings="\n".join(timing.warnings))
    for key in ("tari_s", "rtcal_s", "trcal_s", "delimiter_s"):
        value = getattr(timing, key)
        if not math.isnan(value):  # a NaN attribute would state nothing
            ds.attrs[f"median_{key}"] = float(value)
    return ds


__all__ = ["CAPTURE_FIELDS", "SCHEMA_NOTES", "READ_FIELDS", "COMMAND_FIELDS", "reply_row", "command_row",
           "capture_dataset"]

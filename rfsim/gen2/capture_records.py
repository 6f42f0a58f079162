"""Decoded captures as tables: the commands and the tag replies of ``rfsim decode``.

The replies table is the per-read layout every simulated reader writes
(:data:`rfsim.core.records.READ_MEASUREMENT_FIELDS`: antenna, channel, carrier, RSSI, phase,
Doppler, SNR) plus the capture's own columns, so a measured session and a simulated one
can be put side by side (``rfsim.core.dataset.read_table(path, "reads")`` → pandas). What a
capture cannot know is written as its "unknown" value: antenna and channel 0, carrier and
Doppler NaN. The same rows serve ``--format json|csv``.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from rfsim.core.dataset import Dataset, column
from rfsim.core.records import READ_MEASUREMENT_FIELDS

READ_FIELDS: dict[str, tuple[str, str]] = {
    "time_s": ("s", "start of the tag reply (pilot or preamble) in the capture"),
    "end_s": ("s", "end of the reply, or where the next command cut it"),
    "command_index": ("1", "row of the preceding reader command in the commands table"),
    "command": ("", "reader command the reply answers (Query, ACK, Req_RN, Read, ...)"),
    "kind": ("", "reply type the command implies: RN16, EPC (PC+EPC+CRC-16), handle, read"),
    "rn16": ("1", "RN16 (RN16 reply) or handle (handle/read reply); -1 if none"),
    "pc": ("1", "protocol-control word of an EPC reply; -1 if none"),
    "epc_hex": ("", "EPC of an EPC reply as upper-case hex ('' if none)"),
    "data_hex": ("", "words of a read reply as upper-case hex ('' if none)"),
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
    **READ_MEASUREMENT_FIELDS,
}
READ_FIELDS["rssi_dbm"] = ("dBm", "10*log10|h|^2 + 30 of the reply's complex amplitude h: dBm if the capture is "
                                  "in sqrt(W), else dB relative to the capture's unit")
READ_FIELDS["snr_db"] = ("dB", "|h|^2 over the residual noise power per sample at the capture's sample rate")
READ_FIELDS["antenna"] = ("1", "reader antenna port (0: not known from a capture)")
READ_FIELDS["channel_index"] = ("1", "hop-table channel (0: not known from a capture)")
READ_FIELDS["frequency_hz"] = ("Hz", "carrier frequency (NaN: not known from a baseband capture)")
READ_FIELDS["doppler_hz"] = ("Hz", "Doppler (NaN: not measured by the capture decoder)")

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


def reply_row(rep) -> dict[str, Any]:
    """One replies-table row (:data:`READ_FIELDS`) of a tag reply record.

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
    return {
        "time_s": rep.start_s, "end_s": rep.end_s, "command_index": rep.command_index, "command": rep.command,
        "kind": rep.kind, "rn16": _int_or(rep.rn16), "pc": _int_or(rep.pc), "epc_hex": rep.epc_hex or "",
        "data_hex": rep.data_hex or "", "crc_checked": rep.crc_ok is not None, "crc_ok": bool(rep.crc_ok),
        "truncated": bool(rep.truncated), "bits": rep.bits, "n_bits_expected": rep.n_bits_expected,
        "m": rep.m, "trext": bool(rep.trext), "blf_hz": rep.blf_hz, "blf_drift": rep.blf_drift, "corr": rep.corr,
        "antenna": 0, "channel_index": 0, "frequency_hz": math.nan, "rssi_dbm": rep.rssi_dbm,
        "phase_rad": rep.phase_rad, "doppler_hz": math.nan, "snr_db": rep.snr_db,
    }


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
    ds.add_table("reads", _columns([reply_row(r) for r in replies], READ_FIELDS))
    ds.attrs.update(capture=str(capture), fs_hz=float(fs_hz), n_commands=int(timing.n_commands),
                    warnings="\n".join(timing.warnings))
    for key in ("tari_s", "rtcal_s", "trcal_s", "delimiter_s"):
        value = getattr(timing, key)
        if not math.isnan(value):  # a NaN attribute would state nothing
            ds.attrs[f"median_{key}"] = float(value)
    return ds


__all__ = ["READ_FIELDS", "COMMAND_FIELDS", "reply_row", "command_row", "capture_dataset"]

"""Recorded baseband captures: loading and decoding the reader commands they contain.

A capture is a complex baseband recording (GNU Radio file sink: raw interleaved
complex64, or a NumPy ``.npy`` array) of unknown amplitude scale. Reader commands are
found in its envelope |x| (or in a real envelope given directly, which may also carry an
unknown offset), normalised to 0…1 by the two level clusters, and decoded with the PIE
decoder of :mod:`rfsim.gen2.pie`; the bits are parsed with :mod:`rfsim.gen2.commands`.
Timings are the medians over all commands (anchors §3.7: gr-rfid reader waveform).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rfsim.errors import UserError
from rfsim.gen2.bits import bits_to_str
from rfsim.gen2.commands import CommandParseError, command_fields, command_name, parse
from rfsim.gen2.crc import crc5_ok, crc16_ok
from rfsim.gen2.pie import pie_decode, two_level_threshold

#: File name endings read as raw interleaved complex64 (GNU Radio file sink).
RAW_SUFFIXES = (".cf32", ".fc32", ".cfile", ".c64", ".bin", ".raw", ".dat")
SUFFIXES = RAW_SUFFIXES + (".npy",)

#: Command names by bit prefix (longest prefix wins), to name commands that fail parsing.
_PREFIXES = {
    "00": "QueryRep", "01": "ACK", "1000": "Query", "1001": "QueryAdjust", "1010": "Select",
    "11000000": "NAK", "11000001": "Req_RN", "11000010": "Read",
}
#: Commands that carry a CRC (and which one).
_CRC = {"Query": 5, "Select": 16, "Req_RN": 16, "Read": 16}


def load_capture(path) -> np.ndarray:
    """Read a capture file as ``(n,) complex64``.

    ``.npy`` (1-D, real or complex) or raw interleaved float32 I/Q with one of
    :data:`RAW_SUFFIXES`. Raises :class:`rfsim.errors.UserError` (one line) when the file is
    missing, has another ending, is empty or malformed.
    """
    p = Path(path)
    if not p.is_file():
        raise UserError(f"capture '{p}' not found")
    if p.suffix.lower() not in SUFFIXES:
        raise UserError(f"capture '{p}': unsupported file type '{p.suffix}'; use one of {', '.join(SUFFIXES)}")
    if p.suffix.lower() == ".npy":
        try:
            arr = np.load(p, allow_pickle=False)
        except (ValueError, OSError) as err:
            raise UserError(f"capture '{p}' is not a readable .npy file ({err})") from None
        if arr.ndim != 1 or not (np.issubdtype(arr.dtype, np.number) and arr.dtype != bool):
            raise UserError(f"capture '{p}' must hold a 1-D numeric array, got {arr.dtype} {arr.shape}")
        x = arr.astype(np.complex64)
    else:
        size = p.stat().st_size
        if size % 8:
            raise UserError(f"capture '{p}': {size} bytes is not a whole number of complex64 samples")
        x = np.fromfile(p, dtype=np.complex64)
    if x.size == 0:
        raise UserError(f"capture '{p}' is empty")
    return x


@dataclass(frozen=True)
class ReaderCommandRecord:
    """One reader command found in a capture.

    ``name`` is the command name ("Query", "ACK", … or "unknown"), ``fields`` the parsed
    fields (empty when parsing failed), ``crc_ok`` True/False for commands with a CRC and
    None otherwise, ``error`` the parse error message or None. Times in seconds;
    ``trcal_s`` is NaN for commands sent with frame-sync.
    """

    start_s: float
    name: str
    bits: str
    fields: dict = field(default_factory=dict)
    crc_ok: bool | None = None
    error: str | None = None
    delimiter_s: float = math.nan
    tari_s: float = math.nan
    rtcal_s: float = math.nan
    trcal_s: float = math.nan


@dataclass(frozen=True)
class ReaderTiming:
    """Median PIE timings over the commands of a capture [s] (NaN when none)."""

    n_commands: int
    tari_s: float
    rtcal_s: float
    trcal_s: float
    delimiter_s: float


def _name_from_prefix(bits: str) -> str:
    for n in (8, 4, 2):
        if bits[:n] in _PREFIXES and len(bits) >= n:
            return _PREFIXES[bits[:n]]
    return "unknown"


def _crc_ok(name: str, bits: np.ndarray) -> bool | None:
    kind = _CRC.get(name)
    if kind == 5:
        return crc5_ok(bits)
    if kind == 16:
        return crc16_ok(bits)
    return None


def parse_record(bits: np.ndarray, **timing) -> ReaderCommandRecord:
    """Parse decoded command bits into a :class:`ReaderCommandRecord` (never raises)."""
    text = bits_to_str(bits)
    try:
        cmd = parse(bits)
    except CommandParseError as err:
        name = _name_from_prefix(text)
        return ReaderCommandRecord(bits=text, name=name, crc_ok=_crc_ok(name, bits), error=str(err), **timing)
    name = command_name(cmd)
    return ReaderCommandRecord(bits=text, name=name, fields=command_fields(cmd), crc_ok=_crc_ok(name, bits), **timing)


def normalized_envelope(samples) -> np.ndarray:
    """Envelope scaled so that the low level cluster is 0 and the high one 1.

    ``samples``: complex baseband (→ |x|) or a real envelope of any scale and offset.
    """
    x = np.asarray(samples)
    env = np.abs(x).astype(np.float64) if np.iscomplexobj(x) else x.astype(np.float64)
    _, lo, hi = two_level_threshold(env)
    return (env - lo) / (hi - lo) if hi > lo else env - lo


def decode_reader_commands(samples, fs_hz: float) -> tuple[list[ReaderCommandRecord], ReaderTiming]:
    """Find, decode and parse every reader PIE command in a capture.

    Parameters
    ----------
    samples : (n,) complex baseband or real envelope, arbitrary scale (and offset, if real)
    fs_hz : sample rate [Hz]

    Returns
    -------
    records : list of :class:`ReaderCommandRecord` in time order
    timing : :class:`ReaderTiming`, medians over the commands
    """
    fs_hz = float(fs_hz)
    if not fs_hz > 0:
        raise ValueError(f"fs_hz must be > 0, got {fs_hz}")
    frames = pie_decode(normalized_envelope(samples))
    records = [
        parse_record(
            f.bits, start_s=f.start / fs_hz, delimiter_s=f.delimiter / fs_hz, tari_s=f.tari / fs_hz,
            rtcal_s=f.rtcal / fs_hz, trcal_s=f.trcal / fs_hz,
        )
        for f in frames
    ]

    def med(values):
        v = np.array([x for x in values if not math.isnan(x)])
        return float(np.median(v)) if v.size else math.nan

    timing = ReaderTiming(
        n_commands=len(records),
        tari_s=med(r.tari_s for r in records),
        rtcal_s=med(r.rtcal_s for r in records),
        trcal_s=med(r.trcal_s for r in records),
        delimiter_s=med(r.delimiter_s for r in records),
    )
    return records, timing


__all__ = [
    "RAW_SUFFIXES",
    "SUFFIXES",
    "ReaderCommandRecord",
    "ReaderTiming",
    "load_capture",
    "normalized_envelope",
    "parse_record",
    "decode_reader_commands",
]

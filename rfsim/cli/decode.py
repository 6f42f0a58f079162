"""``rfsim decode CAPTURE --fs HZ``: list the reader commands in a baseband capture."""

from __future__ import annotations

import argparse
import math

from rfsim.errors import UserError
from rfsim.gen2.capture import SUFFIXES, decode_reader_commands, load_capture


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "decode",
        help="decode the reader (PIE) commands in a baseband capture",
        description=(
            "Find every reader command in a complex baseband capture (raw interleaved complex64 "
            "as written by a GNU Radio file sink, or .npy), parse it and check its CRC; print one "
            "line per command (start time, name, fields, CRC) and the median Tari, RTcal and TRcal."
        ),
    )
    p.add_argument("capture", help=f"capture file ({', '.join(SUFFIXES)})")
    p.add_argument("--fs", dest="fs_hz", type=float, required=True, metavar="HZ",
                   help="sample rate of the capture in Hz, e.g. 250e3")
    p.set_defaults(func=run)


def _format_value(key: str, value) -> str:
    if key == "rn16" and isinstance(value, int):
        return f"0x{value:04X}"
    return str(value)


def _us(value_s: float) -> str:
    return "n/a" if math.isnan(value_s) else f"{value_s * 1e6:.2f} µs"


def run(args: argparse.Namespace) -> int:
    """Print the decoded commands of ``args.capture`` sampled at ``args.fs_hz``; exit code 0."""
    fs_hz = float(args.fs_hz)
    if not (math.isfinite(fs_hz) and fs_hz > 0):
        raise UserError(f"--fs must be a positive sample rate in Hz, got {args.fs_hz!r}")
    samples = load_capture(args.capture)
    records, timing = decode_reader_commands(samples, fs_hz)
    for rec in records:
        fields = " ".join(f"{k}={_format_value(k, v)}" for k, v in rec.fields.items())
        crc = {True: "CRC ok", False: "CRC bad", None: "no CRC"}[rec.crc_ok]
        detail = fields if not rec.error else f"bits={rec.bits} ({rec.error})"
        print(f"{rec.start_s:12.6f} s  {rec.name:<11} {detail}  {crc}")
    print(
        f"{timing.n_commands} commands; Tari {_us(timing.tari_s)}, RTcal {_us(timing.rtcal_s)}, "
        f"TRcal {_us(timing.trcal_s)} (medians)"
    )
    return 0


__all__ = ["add_parser", "run"]

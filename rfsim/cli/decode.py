"""``rfsim decode CAPTURE --fs HZ``: list the reader commands and tag replies in a baseband capture."""

from __future__ import annotations

import argparse
import math

from rfsim.errors import UserError
from rfsim.gen2.capture import SUFFIXES, decode_reader_commands, load_capture
from rfsim.gen2.replies import decode_tag_replies


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "decode",
        help="decode the reader (PIE) commands and tag replies in a baseband capture",
        description=(
            "Find every reader command in a complex baseband capture (raw interleaved complex64 "
            "as written by a GNU Radio file sink, or .npy), parse it and check its CRC; print one "
            "line per command (start time, name, fields, CRC) and the median Tari, RTcal and TRcal. "
            "After every Query/QueryRep/QueryAdjust and ACK the tag reply is searched in the T1 "
            "window (FM0/Miller with M and TRext of the last Query, BLF = DR/TRcal measured in the "
            "capture unless given) and printed with its RN16, or PC + EPC and CRC-16 status, the "
            "BLF it was decoded with and its preamble correlation."
        ),
    )
    p.add_argument("capture", help=f"capture file ({', '.join(SUFFIXES)})")
    p.add_argument("--fs", dest="fs_hz", type=float, required=True, metavar="HZ",
                   help="sample rate of the capture in Hz, e.g. 250e3")
    p.add_argument("--blf", dest="blf_hz", type=float, default=None, metavar="HZ",
                   help="tag backscatter link frequency in Hz (default: DR/TRcal of the last Query)")
    p.add_argument("--trcal", dest="trcal_s", type=float, default=None, metavar="S",
                   help="TRcal in seconds (default: measured on the last Query)")
    p.add_argument("--dr", default=None, choices=("8", "64/3"), help="divide ratio (default: from the Query)")
    p.add_argument("--m", dest="m", type=int, default=None, choices=(1, 2, 4, 8),
                   help="tag encoding: 1 = FM0, 2/4/8 = Miller-M (default: from the Query)")
    p.add_argument("--trext", type=int, default=None, choices=(0, 1),
                   help="pilot tone (TRext) of the replies (default: from the Query)")
    p.set_defaults(func=run)


def _format_value(key: str, value) -> str:
    if key == "rn16" and isinstance(value, int):
        return f"0x{value:04X}"
    return str(value)


def _us(value_s: float) -> str:
    return "n/a" if math.isnan(value_s) else f"{value_s * 1e6:.2f} µs"


def _reply_line(rep) -> str:
    if rep.kind == "RN16":
        what = f"RN16=0x{rep.rn16:04X}"
    else:
        what = f"PC=0x{rep.pc:04X} EPC={rep.epc_hex or '-'}  {'CRC ok' if rep.crc_ok else 'CRC bad'}"
    return (f"{rep.start_s:12.6f} s    tag reply  {what}  BLF {rep.blf_hz / 1e3:.2f} kHz  "
            f"corr {rep.corr:.3f}")


def _positive(value, flag: str):
    if value is not None and not (math.isfinite(value) and value > 0):
        raise UserError(f"{flag} must be positive, got {value!r}")
    return value


def run(args: argparse.Namespace) -> int:
    """Print the decoded commands and tag replies of ``args.capture`` sampled at ``args.fs_hz``;
    exit code 0."""
    fs_hz = float(args.fs_hz)
    if not (math.isfinite(fs_hz) and fs_hz > 0):
        raise UserError(f"--fs must be a positive sample rate in Hz, got {args.fs_hz!r}")
    blf_hz = _positive(getattr(args, "blf_hz", None), "--blf")
    trcal_s = _positive(getattr(args, "trcal_s", None), "--trcal")
    trext = getattr(args, "trext", None)
    samples = load_capture(args.capture)
    records, timing = decode_reader_commands(samples, fs_hz)
    replies = decode_tag_replies(samples, fs_hz, records, blf_hz=blf_hz, trcal_s=trcal_s,
                                 dr=getattr(args, "dr", None), m=getattr(args, "m", None),
                                 trext=None if trext is None else bool(trext))
    by_command = {rep.command_index: rep for rep in replies}
    for k, rec in enumerate(records):
        fields = " ".join(f"{key}={_format_value(key, v)}" for key, v in rec.fields.items())
        crc = {True: "CRC ok", False: "CRC bad", None: "no CRC"}[rec.crc_ok]
        detail = fields if not rec.error else f"bits={rec.bits} ({rec.error})"
        print(f"{rec.start_s:12.6f} s  {rec.name:<11} {detail}  {crc}")
        if k in by_command:
            print(_reply_line(by_command[k]))
    print(
        f"{timing.n_commands} commands; Tari {_us(timing.tari_s)}, RTcal {_us(timing.rtcal_s)}, "
        f"TRcal {_us(timing.trcal_s)} (medians)"
    )
    if replies:
        n_rn16 = sum(rep.kind == "RN16" for rep in replies)
        n_epc = len(replies) - n_rn16
        n_ok = sum(bool(rep.crc_ok) for rep in replies)
        print(f"{len(replies)} tag replies: {n_rn16} RN16, {n_epc} EPC ({n_ok} with CRC ok)")
    else:
        print("no tag replies found")
    return 0


__all__ = ["add_parser", "run"]

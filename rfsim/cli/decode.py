"""``rfsim decode CAPTURE --fs HZ``: list the reader commands and tag replies in a baseband
capture as text, JSON or CSV, and optionally write them as an HDF5 dataset."""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import tempfile
from pathlib import Path

from rfsim.core.errors import UserError, write_failure

FORMATS = ("text", "json", "csv")
#: Capture file endings (rfsim.gen2.capture.SUFFIXES, spelled out here so that building the
#: parser does not import the decoders: ``rfsim --help`` stays fast; a test checks they agree).
SUFFIXES = (".cf32", ".fc32", ".cfile", ".c64", ".bin", ".raw", ".dat", ".npy")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the ``decode`` subcommand.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the ``rfsim`` parser; ``decode`` is added to it with ``func=run``.
    """
    p = sub.add_parser(
        "decode",
        help="decode the reader (PIE) commands and tag replies in a baseband capture",
        description=(
            "Find every reader command in a baseband capture (raw interleaved complex64 as written "
            "by a GNU Radio file sink, or .npy, complex IQ or a real |IQ| envelope), parse it and "
            "check its CRC. After every command that elicits a reply (Query family: RN16, ACK: "
            "PC+EPC+CRC-16, Req_RN/Access/first Kill: handle, Read: data+handle or an error reply) the tag "
            "reply is searched in the T1 window, and after Write/BlockWrite/BlockErase/Lock/final Kill the "
            "delayed success or error reply (extended preamble) up to 20 ms later: line code from the last Query, BLF = DR/TRcal measured in the capture (or given), "
            "searched blind over the Gen2 ranges when there is no Query; BLF and timing are measured "
            "on the reply itself. Replies cut by the next command are reported as truncated. Prints one "
            "line per command and reply and a summary (--format text), or the same fields as JSON or "
            "CSV; --output writes the commands and replies tables as HDF5 (the per-read layout of the "
            "simulated readers)."
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
    p.add_argument("--format", dest="output_format", default="text", choices=FORMATS,
                   help="stdout format: text lines with a summary (default), one JSON document, or CSV rows")
    p.add_argument("-o", "--output", default=None, metavar="X.h5",
                   help="also write the commands and tag replies as an HDF5 dataset")
    p.set_defaults(func=run)


def _format_value(key: str, value) -> str:
    if key == "rn16" and isinstance(value, int):
        return f"0x{value:04X}"
    return str(value)


def _us(value_s: float) -> str:
    return "n/a" if math.isnan(value_s) else f"{value_s * 1e6:.2f} µs"


def _reply_line(rep) -> str:
    if rep.kind == "RN16":
        what = f"RN16=0x{rep.rn16:04X}" if rep.rn16 is not None else "RN16=?"
    elif rep.kind == "EPC":
        what = f"PC=0x{(rep.pc or 0):04X} EPC={rep.epc_hex or '-'}"
    elif rep.kind in ("handle", "success"):
        what = f"handle=0x{(rep.rn16 or 0):04X}"
    elif rep.kind == "error":
        code = "?" if rep.error_code is None else f"0x{rep.error_code:02X} {rep.error_name}"
        what = f"code={code} handle=0x{(rep.rn16 or 0):04X}"
    else:
        what = f"data={rep.data_hex or '-'} handle=0x{(rep.rn16 or 0):04X}"
    if rep.delayed:
        what += f" (delayed, {rep.latency_s * 1e6:.1f} µs after the command)"
    if rep.truncated:
        state = f"TRUNCATED at {rep.end_s:.6f} s ({len(rep.bits)} of {rep.n_bits_expected} bits)"
    else:
        state = {True: "CRC ok", False: "CRC bad", None: "no CRC"}[rep.crc_ok]
    return (f"{rep.start_s:12.6f} s    tag reply  {rep.kind} {what}  {state}  BLF {rep.blf_hz / 1e3:.2f} kHz  "
            f"{'FM0' if rep.m == 1 else f'Miller-{rep.m}'}{' TRext' if rep.trext else ''}  corr {rep.corr:.3f}  "
            f"SNR {rep.snr_db:.1f} dB")


def _summary(timing, replies) -> str:
    n_rn16 = sum(rep.kind == "RN16" for rep in replies)
    n_ok = sum(bool(rep.crc_ok) for rep in replies)
    n_cut = sum(rep.truncated for rep in replies)
    return (f"{timing.n_commands} commands (Tari {_us(timing.tari_s)}, RTcal {_us(timing.rtcal_s)}, "
            f"TRcal {_us(timing.trcal_s)}, medians); {len(replies)} tag replies ({n_rn16} RN16, "
            f"{len(replies) - n_rn16} with CRC-16, {n_ok} CRC ok, {n_cut} truncated)")


def _positive(value, flag: str):
    if value is not None and not (math.isfinite(value) and value > 0):
        raise UserError(f"{flag} must be positive, got {value!r}")
    return value


#: Gen2 ranges (EPC UHF Gen2 v2.0.1, Tables 6.9 and 6.10): TRcal 17.2–225 µs; BLF 40–640 kHz,
#: with the largest frequency tolerance of Table 6.9 (±22 %) on either side.
TRCAL_RANGE_S = (17.2e-6, 225e-6)
BLF_RANGE_HZ = (40e3 * (1 - 0.22), 640e3 * (1 + 0.22))


def _in_range(value, flag: str, bounds: tuple[float, float], unit: str, scale: float):
    if value is not None and not bounds[0] <= value <= bounds[1]:
        raise UserError(f"{flag} {value:g}: outside the Gen2 range {bounds[0] * scale:g}–{bounds[1] * scale:g} "
                        f"{unit} (is the unit right? {flag} takes {'Hz' if unit == 'kHz' else 'seconds'})")
    return value


def _check_output(path: str | None, capture: str | None = None) -> Path | None:
    """The dataset path, checked before any decoding: an HDF5 name (``.h5``/``.hdf5``), not
    the capture itself, not a directory, its folder created if missing and writable (a probe
    file is created and removed there)."""
    if path is None:
        return None
    p = Path(path)
    if p.is_dir():
        raise UserError(f"--output '{p}' is a directory; give a file name such as {p / 'capture.h5'}")
    if capture is not None and p.exists() and Path(capture).exists() and os.path.samefile(p, capture):
        raise UserError(f"--output '{p}' is the capture being decoded; give another file name")
    if p.suffix not in (".h5", ".hdf5"):
        raise UserError(f"--output '{p}': the file name must end in .h5 or .hdf5 (it is an HDF5 dataset)")
    parent = p.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=parent, prefix=".rfsim-probe-"):
            pass
    except (FileExistsError, NotADirectoryError):
        raise UserError(f"--output '{p}': '{parent}' is not a folder") from None
    except OSError as err:
        raise UserError(f"--output '{p}': cannot write in '{parent}' ({err.strerror or err})") from None
    return p


def _json_value(v):
    return None if isinstance(v, float) and not math.isfinite(v) else v


def _write(args, records, replies, timing) -> None:
    from rfsim.gen2.capture_records import COMMAND_FIELDS, READ_FIELDS, command_row, reply_row

    fmt = getattr(args, "output_format", "text")
    out = sys.stdout
    if fmt == "json":
        doc = {"commands": [{k: _json_value(v) for k, v in command_row(r).items()} for r in records],
               "replies": [{k: _json_value(v) for k, v in reply_row(r).items()} for r in replies],
               "summary": _summary(timing, replies), "warnings": list(timing.warnings)}
        json.dump(doc, out, ensure_ascii=False)
        out.write("\n")
        return
    if fmt == "csv":
        names = ["record"] + list(dict.fromkeys([*READ_FIELDS, *COMMAND_FIELDS]))
        w = csv.DictWriter(out, fieldnames=names, restval="", lineterminator="\n")
        w.writeheader()
        by_command = {}
        for rep in replies:
            by_command.setdefault(rep.command_index, []).append(rep)
        for k, rec in enumerate(records):
            w.writerow({"record": "command", **command_row(rec)})
            for rep in by_command.get(k, ()):
                w.writerow({"record": "reply", **reply_row(rep)})
        print(_summary(timing, replies), file=sys.stderr)
        return
    by_command = {rep.command_index: rep for rep in replies}
    for k, rec in enumerate(records):
        fields = " ".join(f"{key}={_format_value(key, v)}" for key, v in rec.fields.items())
        crc = {True: "CRC ok", False: "CRC bad", None: "no CRC"}[rec.crc_ok]
        detail = fields if not rec.error else f"bits={rec.bits} ({rec.error})"
        print(f"{rec.start_s:12.6f} s  {rec.name:<11} {detail}  {crc}", file=out)
        if k in by_command:
            print(_reply_line(by_command[k]), file=out)
    print(_summary(timing, replies), file=out)


def run(args: argparse.Namespace) -> int:
    """Run ``rfsim decode``: decode a capture, print what it holds and optionally write a dataset.

    The reader commands are decoded (:func:`rfsim.gen2.capture.decode_reader_commands`), then
    the tag replies after them (:func:`rfsim.gen2.replies.decode_tag_replies`); the timing
    warnings go to stderr, the listing to stdout in ``args.output_format``, and with
    ``--output`` the commands and replies tables are written as HDF5 under the output's lock.
    A reader that closes stdout early (``| head``) is not an error.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments: ``capture`` (path), ``fs_hz`` (sample rate [Hz]), optional
        ``blf_hz`` [Hz], ``trcal_s`` [s], ``dr``, ``m``, ``trext`` (None: from the Query),
        ``output_format`` (one of :data:`FORMATS`) and ``output`` (HDF5 path or None).

    Returns
    -------
    int
        Exit status 0.

    Raises
    ------
    rfsim.core.errors.UserError
        For a sample rate that is not positive, a BLF or TRcal that is not positive or outside
        the Gen2 range, an unusable output path or an unreadable capture.
    rfsim.core.errors.ResourceError
        If the system refuses a write to the standard output.
    """
    from rfsim.gen2.capture_records import capture_dataset
    from rfsim.gen2.capture import decode_reader_commands, load_capture
    from rfsim.gen2.replies import decode_tag_replies

    fs_hz = float(args.fs_hz)
    if not (math.isfinite(fs_hz) and fs_hz > 0):
        raise UserError(f"--fs must be a positive sample rate in Hz, got {args.fs_hz!r}")
    blf_hz = _positive(getattr(args, "blf_hz", None), "--blf")
    trcal_s = _positive(getattr(args, "trcal_s", None), "--trcal")
    _in_range(blf_hz, "--blf", BLF_RANGE_HZ, "kHz", 1e-3)
    _in_range(trcal_s, "--trcal", TRCAL_RANGE_S, "µs", 1e6)
    trext = getattr(args, "trext", None)
    output = _check_output(getattr(args, "output", None), args.capture)
    samples = load_capture(args.capture)
    records, timing = decode_reader_commands(samples, fs_hz)
    for warning in timing.warnings:
        print(f"rfsim: warning: {warning}", file=sys.stderr)
    replies = decode_tag_replies(samples, fs_hz, records, blf_hz=blf_hz, trcal_s=trcal_s,
                                 dr=getattr(args, "dr", None), m=getattr(args, "m", None),
                                 trext=None if trext is None else bool(trext))
    if output is not None:
        from rfsim.core.dataset import make_provenance, utc_now, write_dataset
        from rfsim.core.outputs import remove_stale_partials
        from rfsim.core.locks import output_lock
        prov = make_provenance(config_toml="", seed=0, scenario="decode", start_time_utc=utc_now(),
                               extra={"capture": str(args.capture), "fs_hz": fs_hz})
        with output_lock(output, what="--output", kind="decode"):
            remove_stale_partials(output)
            write_dataset(output, capture_dataset(records, replies, capture=str(args.capture), fs_hz=fs_hz,
                                                  timing=timing), prov)
    try:
        _write(args, records, replies, timing)
        sys.stdout.flush()
    except BrokenPipeError:
        # the reader of our stdout has gone (``| head``): not an error; keep Python's exit
        # flush from raising again
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except OSError as err:
        failure = write_failure(err, "the standard output", hint=False)
        if failure is None:
            raise
        raise failure from None
    return 0


__all__ = ["add_parser", "run", "FORMATS"]

"""``rfsim export DATASET --table reads --format csv|jsonl [-o OUT]``: a table as text.

A table that holds the per-read schema (:mod:`rfsim.core.reads`) is written as the tag
reports a reader hands over: one report per CSV row or JSON line, the schema's keys in its
order (``epc`` as hex, ``antenna_port``, ``peak_rssi_dbm``, ``phase_angle_rad``,
``first_seen_timestamp_us``, …, the quantized variants and the ground truth), only the reads the
reader reports (``tag_seen_count`` ≥ 1) — what a sllurp user's tag-report analysis reads. Any
other table is written whole, every column (in the file's order) and every row.

Numbers are written so that they read back to the same bits (``repr`` of a float); NaN is an
empty CSV field and a JSON ``null``; booleans are ``true``/``false``. Without ``-o`` the
text goes to the standard output; with it, the file is written atomically.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from collections.abc import Iterator
from pathlib import Path

from rfsim.core.errors import UserError
from rfsim.core.lazy import lazy_import
from rfsim.core.outputs import atomic_path, check_output_file

# Loaded when a command runs, not when 'rfsim --help' builds the parser.
np = lazy_import("numpy")
h5py = lazy_import("h5py")
_dataset = lazy_import("rfsim.core.dataset")
_reads = lazy_import("rfsim.core.reads")

FORMATS = ("csv", "jsonl")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the ``export`` subcommand.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the ``rfsim`` parser; ``export`` is added to it with ``func=run``.
    """
    p = sub.add_parser("export", help="write a dataset table as CSV or JSON lines (reads as tag reports)",
                       description="Write one table of an HDF5 dataset as CSV or JSON lines. A reads table "
                                   "(the per-read schema) is written as tag reports: one reported read per "
                                   "row/line with the schema's keys (epc as hex, antenna_port, peak_rssi_dbm, "
                                   "phase_angle_rad, first_seen_timestamp_us, ...).")
    p.add_argument("dataset", type=Path, help="dataset file (HDF5)")
    p.add_argument("--table", default="reads", help="table to write (default: reads)")
    p.add_argument("--format", default="csv", choices=FORMATS, help="csv (a header row) or jsonl (one JSON "
                                                                    "object a line); default csv")
    p.add_argument("-o", "--output", type=Path, default=None, help="file to write (default: standard output)")
    p.set_defaults(func=run)


def load_table(path: Path, table: str) -> dict:
    """Read the columns to export of a table of a dataset.

    A table with the per-read schema (:func:`rfsim.core.reads.has_read_schema`) gives the
    columns of :data:`rfsim.core.reads.READ_SCHEMA`, in its order, and only the reads the
    reader reports (``tag_seen_count`` ≥ 1); any other table gives every column and row.

    Parameters
    ----------
    path : pathlib.Path
        The HDF5 dataset.
    table : str
        Name of the table (a group with a ``row`` dimension).

    Returns
    -------
    dict of str to ndarray
        Column name → values, shape (n_rows,), in the order described above.

    Raises
    ------
    rfsim.core.errors.UserError
        If the file is missing, is a folder or is not HDF5, or has no such table.
    """
    if not path.is_file():
        raise UserError(f"dataset {str(path)!r}: no such file" if not path.exists()
                        else f"dataset {str(path)!r} is a directory, not an HDF5 file")
    try:
        with h5py.File(path, "r") as f:
            tables = sorted(k for k, g in f.items() if isinstance(g, h5py.Group) and "row" in g)
    except OSError:
        raise UserError(f"dataset {str(path)!r} is not an HDF5 file") from None
    if table not in tables:
        raise UserError(f"--table {table!r}: {str(path)!r} has no such table (tables: {', '.join(tables) or 'none'})")
    cols = _dataset.read_table(path, table)
    if _reads.has_read_schema(cols):
        keep = cols["tag_seen_count"] >= 1
        return {k: cols[k][keep] for k in _reads.READ_SCHEMA}
    return cols


def _value(v):
    """A column value as a JSON value: int, float (None for NaN, ±inf kept), bool or str."""
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.floating):
        return None if math.isnan(v) else float(v)
    return str(v)


def _csv_field(v) -> str:
    v = _value(v)
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    return repr(v) if isinstance(v, float) else str(v)


def rows(cols: dict) -> Iterator[dict]:
    """Iterate over a table's rows as dicts of JSON values.

    Parameters
    ----------
    cols : dict of str to ndarray
        Columns of equal length (the first gives the row count).

    Yields
    ------
    dict
        Column name → value of one row: bool, int, float (None for NaN, ±inf kept) or str.
    """
    names = list(cols)
    n = len(cols[names[0]]) if names else 0
    for i in range(n):
        yield {k: _value(cols[k][i]) for k in names}


def write_text(cols: dict, fmt: str, out) -> None:
    """Write a table to a text stream as CSV or JSON lines.

    CSV has a header row; floats are written with ``repr`` (they read back to the same bits),
    NaN as an empty field, booleans as ``true``/``false``. JSON lines hold one object per
    row (:func:`rows`).

    Parameters
    ----------
    cols : dict of str to ndarray
        Columns of equal length, written in the dict's order.
    fmt : {"csv", "jsonl"}
        The format (anything but ``"csv"`` writes JSON lines).
    out : file-like
        A text stream open for writing.
    """
    names = list(cols)
    if fmt == "csv":
        w = csv.writer(out, lineterminator="\n")
        w.writerow(names)
        n = len(cols[names[0]]) if names else 0
        for i in range(n):
            w.writerow([_csv_field(cols[k][i]) for k in names])
    else:
        for row in rows(cols):
            out.write(json.dumps(row, allow_nan=True) + "\n")


def run(args: argparse.Namespace) -> int:
    """Run ``rfsim export``: write a dataset table to stdout or, atomically, to a file.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments: ``dataset`` (pathlib.Path), ``table`` (str), ``format`` (one of
        :data:`FORMATS`) and ``output`` (pathlib.Path or None: standard output).

    Returns
    -------
    int
        Exit status 0.

    Raises
    ------
    rfsim.core.errors.UserError
        For an unusable output path, or a dataset or table that cannot be read
        (:func:`load_table`).
    """
    if args.output is not None:
        check_output_file(args.output, "-o")
    cols = load_table(args.dataset, args.table)
    if args.output is None:
        write_text(cols, args.format, sys.stdout)
        return 0
    with atomic_path(args.output, f"-o {str(args.output)!r}") as tmp:
        with open(tmp, "w", encoding="utf-8", newline="") as out:
            write_text(cols, args.format, out)
    return 0


__all__ = ["FORMATS", "load_table", "rows", "write_text", "run"]

"""The point store of a sweep: crash-safe append-only segments with an index of finished runs.

Every finished run (point ``i``, repetition ``k``) is appended, as soon as it finishes, to
the segment of the process that ran it, in the point store beside the output::

    <output>.points/seg-<UTC time>-<host>-<pid>-<tag>.log    records, append-only
    <output>.points/seg-<UTC time>-<host>-<pid>-<tag>.idx    8-byte header, one 64-byte entry per record

so a sweep creates one pair of files per worker process (or per shard task), not one file
per run. A record is ``"RFSP" | version u8 | header length u32 | payload length u64 |
header (JSON) | payload (raw arrays) | CRC-32 u32`` of header and payload, written with one
``write`` on a file opened for appending; its index entry (point, repetition, seed,
offset, length, first 16 bytes of the SHA-256 of the run's resolved config TOML, CRC-32 of
these 56 bytes) is appended after it. An index file starts with :data:`INDEX_MAGIC`
(format 2); an index without it is one of format 1 (56-byte entries without a checksum,
still read). Files are fsync'ed at most :data:`SYNC_INTERVAL_S` apart and when the
writer closes.

Crash safety: a killed writer (even SIGKILL) leaves at worst a truncated last record, or a
record without its index entry. Readers keep only index entries whose record lies wholly
inside the log, and scan the log past the last indexed record for complete records whose
CRC holds (so a record written just before the kill is not lost). Nothing is ever
rewritten in place, and no file is left under a temporary name.

Every index entry is checked when the store is read (:func:`check_index`: its checksum,
point, repetition and length in bounds, records back to back from offset 0); a damaged index
file (bad disk, stray write) is a one-line :class:`DamagedIndexError` naming it and the
command that rebuilds it from its log (``rfsim sweep repair SPEC``, :func:`repair_store`).

A record stands for a run of the current spec when its point, repetition, seed and config
digest all match — a changed spec recomputes exactly the points it changed, as with
``--resume``. When a run has several matching records (a sweep run again without
``--resume``), the one in the most recently created segment is used; they hold the same
bits anyway, since a run's result depends only on its seed and config.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import functools
import hashlib
import json
import math
import os
import re
import resource
import secrets
import struct
import sys
import time
import zlib
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

import rfsim
from rfsim.runs.registry import load_scenario
from rfsim.core.config import to_toml
from rfsim.core.dataset import Column, Dataset, git_revision, utc_now
from rfsim.core.errors import ResourceError, UserError, write_failure
from rfsim.core.outputs import atomic_path

MAGIC, VERSION = b"RFSP", 1
_PREFIX = struct.Struct("<4sBIQ")  # magic, version, header length, payload length
_CRC = struct.Struct("<I")
#: One index entry per record (64 bytes, little-endian): the fields of a run, then the
#: CRC-32 of the 56 bytes before it (zero-extended to 8 bytes).
INDEX_DTYPE = np.dtype([("point", "<i8"), ("repetition", "<i8"), ("seed", "<i8"), ("offset", "<i8"),
                        ("length", "<i8"), ("digest", "V16"), ("crc32", "<u8")])
#: The first 8 bytes of an index file of format 2 (entries with a checksum). Read as the
#: point of a format-1 entry it is above :data:`MAX_POINT`, so no format-1 index starts so.
INDEX_MAGIC = b"RFSIDX\x02\n"
#: An index entry of format 1 (56 bytes, no checksum), written by rfsim before 2026-12.
_INDEX_V1_DTYPE = np.dtype(INDEX_DTYPE.descr[:-1])
_CHECKED_BYTES = _INDEX_V1_DTYPE.itemsize  # the bytes of an entry its CRC-32 covers
#: Longest time between two fsyncs of a segment that is being written [s].
SYNC_INTERVAL_S = 1.0


@dataclasses.dataclass(frozen=True)
class PointTask:
    """Everything a worker needs to run one (point, repetition) and persist it.

    ``scenario_module`` is the importable name of the scenario's module; the worker loads it
    through the scenario registry (:func:`rfsim.runs.registry.load_scenario`), the one place
    that imports scenarios by name."""

    scenario_module: str
    config: Any
    point: int
    repetition: int
    seed: int
    store: Path


@dataclasses.dataclass(frozen=True)
class PointResult:
    """What a worker reports back: which segment holds the run, how long it took, who ran it."""

    point: int
    repetition: int
    path: Path
    wall_time_s: float
    pid: int
    host: str
    peak_rss_mb: float


def points_dir(output: Path) -> Path:
    """The point store of the sweep writing ``output``.

    Parameters
    ----------
    output : Path
        The sweep's merged dataset (``.h5``).

    Returns
    -------
    Path
        ``<output>.points`` beside it.
    """
    return output.with_name(output.name + ".points")


def config_digest(config: Any) -> bytes:
    """First 16 bytes of the SHA-256 of the resolved config's TOML text.

    Parameters
    ----------
    config : dataclass
        A scenario's resolved config (:func:`rfsim.core.config.to_toml` writes it).

    Returns
    -------
    bytes
        16 bytes that stand for the config in the index entries of its runs.
    """
    return hashlib.sha256(to_toml(config).encode("utf-8")).digest()[:16]


def _peak_rss_mb() -> float:
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 1024.0 if sys.platform != "darwin" else rss / 2**20


# ----------------------------------------------------------------------------- encoding


def _array_meta(arr: np.ndarray, offset: int) -> dict[str, Any]:
    if arr.dtype.kind == "O":
        raise TypeError("object arrays cannot be stored; use numbers, booleans or str")
    return {"dtype": arr.dtype.str, "shape": list(arr.shape), "offset": offset, "nbytes": arr.nbytes,
            "sha1": hashlib.sha1(arr.tobytes()).hexdigest()}


def _fixed_width_text(name: str, data: np.ndarray) -> np.ndarray:
    """A text column held as an object array of ``str`` (one shared object per distinct value,
    :func:`rfsim.core.dataset.is_text`) as fixed-width ``U``: the store keeps raw array bytes only."""
    if data.dtype.kind != "O":
        return data
    if not all(isinstance(v, str) for v in set(data.ravel().tolist())):
        raise TypeError(f"column {name!r}: object arrays cannot be stored unless every element is a str")
    return data.astype(str)


def encode_dataset(ds: Dataset) -> tuple[dict[str, Any], list[bytes]]:
    """JSON-able description of ``ds`` and the raw bytes of its arrays, in order.

    Parameters
    ----------
    ds : Dataset
        The dataset of one run (tables, grids, attributes; text as ``str`` or ``U`` arrays).

    Returns
    -------
    desc : dict
        Title, scenario, descriptions and, per attribute and column, its units, description,
        dims and array metadata (dtype, shape, byte offset in the payload, SHA-1).
    buffers : list of bytes
        The arrays' bytes in payload order.

    Raises
    ------
    TypeError
        A column is an object array of anything but ``str``.
    """
    buffers: list[bytes] = []
    offset = 0

    def add(data: Any) -> dict[str, Any]:
        nonlocal offset
        arr = np.asarray(data)
        meta = _array_meta(arr, offset)
        buffers.append(arr.tobytes())
        offset += arr.nbytes
        return meta

    def col(name: str, c: Column) -> dict[str, Any]:
        return {"name": name, "units": c.units, "description": c.description, "dims": list(c.dims),
                "array": add(_fixed_width_text(name, c.data))}

    desc = {
        "title": ds.title, "scenario": ds.scenario, "descriptions": dict(ds.descriptions),
        "attrs": [{"name": k, "array": add(v)} for k, v in ds.attrs.items()],
        "tables": [{"name": t, "columns": [col(c, v) for c, v in cols.items()]}
                   for t, cols in ds.tables.items()],
        "grids": [{"name": g, "coords": [col(c, v) for c, v in coords.items()],
                   "variables": [col(c, v) for c, v in variables.items()]}
                  for g, (coords, variables) in ds.grids.items()],
    }
    return desc, buffers


def decode_array(payload: bytes | memoryview, meta: Mapping[str, Any]) -> np.ndarray:
    """One array of a record's payload (read-only view).

    Parameters
    ----------
    payload : bytes or memoryview
        The record's payload.
    meta : mapping
        The array's entry of the record's description (``dtype``, ``shape``, ``offset``).

    Returns
    -------
    ndarray
        A read-only view of the payload's bytes with that dtype and shape.
    """
    dtype = np.dtype(meta["dtype"])
    count = math.prod(meta["shape"])
    return np.frombuffer(payload, dtype=dtype, count=count, offset=meta["offset"]).reshape(meta["shape"])


def decode_dataset(desc: Mapping[str, Any], payload: bytes | memoryview) -> Dataset:
    """The :class:`Dataset` of a record (inverse of :func:`encode_dataset`).

    Parameters
    ----------
    desc : mapping
        The record's description (:func:`encode_dataset`).
    payload : bytes or memoryview
        The record's payload.

    Returns
    -------
    Dataset
        Its columns and attributes are read-only views of ``payload``.
    """
    def col(c: Mapping[str, Any]) -> Column:
        return Column(decode_array(payload, c["array"]), c["units"], c["description"], tuple(c["dims"]))

    ds = Dataset(title=desc["title"], scenario=desc["scenario"], descriptions=dict(desc.get("descriptions", {})))
    ds.attrs = {a["name"]: decode_array(payload, a["array"])[()] for a in desc["attrs"]}
    ds.tables = {t["name"]: {c["name"]: col(c) for c in t["columns"]} for t in desc["tables"]}
    ds.grids = {g["name"]: ({c["name"]: col(c) for c in g["coords"]},
                            {v["name"]: col(v) for v in g["variables"]}) for g in desc["grids"]}
    return ds


def encode_record(header: Mapping[str, Any], buffers: Iterable[bytes]) -> bytes:
    """One point record: prefix, JSON header, payload and the CRC-32 of header and payload.

    Parameters
    ----------
    header : mapping
        JSON-able header (the run's point, repetition, seed, provenance and dataset description).
    buffers : iterable of bytes
        The payload's parts, in order.

    Returns
    -------
    bytes
        ``"RFSP" | version u8 | header length u32 | payload length u64 | header | payload | CRC-32 u32``.
    """
    head = json.dumps(header, separators=(",", ":")).encode("utf-8")
    payload = b"".join(buffers)
    crc = zlib.crc32(payload, zlib.crc32(head))
    return _PREFIX.pack(MAGIC, VERSION, len(head), len(payload)) + head + payload + _CRC.pack(crc)


class CorruptRecordError(UserError, ValueError):
    """A point record is torn or fails its CRC (a damaged file; rerun with ``--resume``)."""


def decode_record(raw: bytes) -> tuple[dict[str, Any], memoryview]:
    """The header and payload of a whole record.

    Parameters
    ----------
    raw : bytes
        Exactly one record's bytes.

    Returns
    -------
    header : dict
        The record's JSON header.
    payload : memoryview
        Its payload.

    Raises
    ------
    CorruptRecordError
        The bytes are torn, not a record of this version, or fail the CRC.
    """
    if len(raw) < _PREFIX.size + _CRC.size:
        raise CorruptRecordError("point record too short")
    magic, version, n_head, n_payload = _PREFIX.unpack_from(raw)
    if magic != MAGIC or version != VERSION or len(raw) != _PREFIX.size + n_head + n_payload + _CRC.size:
        raise CorruptRecordError("not a complete point record")
    view = memoryview(raw)
    head = view[_PREFIX.size:_PREFIX.size + n_head]
    payload = view[_PREFIX.size + n_head:_PREFIX.size + n_head + n_payload]
    (crc,) = _CRC.unpack_from(raw, len(raw) - _CRC.size)
    if zlib.crc32(payload, zlib.crc32(head)) != crc:
        raise CorruptRecordError("point record fails its CRC")
    return json.loads(bytes(head)), payload


# ----------------------------------------------------------------------------- writing


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        n = os.write(fd, view)
        view = view[n:]


class SegmentWriter:
    """The append-only segment (log + index) of one process in one point store.

    Parameters
    ----------
    store : Path
        The point store (created if missing); the segment's files get a new unique name.

    Attributes
    ----------
    log_path, index_path : Path
        The segment's log and index.
    pid : int
        The writing process.
    offset : int
        Bytes written to the log [B].
    records : int
        Records appended.
    """

    def __init__(self, store: Path):
        store.mkdir(parents=True, exist_ok=True)
        stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%dT%H%M%S.%fZ")
        host = re.sub(r"[^A-Za-z0-9.-]", "_", os.uname().nodename)[:40] or "host"
        stem = f"seg-{stamp}-{host}-{os.getpid()}-{secrets.token_hex(3)}"
        self.log_path, self.index_path = store / f"{stem}.log", store / f"{stem}.idx"
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND
        self._log = os.open(self.log_path, flags, 0o644)
        self._index = os.open(self.index_path, flags, 0o644)
        self.pid, self.offset, self.records = os.getpid(), 0, 0
        try:
            _write_all(self._index, INDEX_MAGIC)
        except OSError as err:
            self._refused(err)
        self._synced = time.monotonic()

    def append(self, point: int, repetition: int, seed: int, digest: bytes, header: Mapping[str, Any],
               buffers: Iterable[bytes]) -> int:
        """Append one record and its index entry.

        Parameters
        ----------
        point, repetition, seed : int
            The run's point, repetition and seed.
        digest : bytes
            16 bytes of its config (:func:`config_digest`).
        header : mapping
            The record's JSON header.
        buffers : iterable of bytes
            The payload's parts.

        Returns
        -------
        int
            The record's offset in the log [B].

        Raises
        ------
        ResourceError
            The disk is full or failed (one line naming the segment).
        """
        record = encode_record(header, buffers)
        entry = index_entries([(point, repetition, seed, self.offset, len(record), digest)])
        try:
            _write_all(self._log, record)
            _write_all(self._index, entry.tobytes())
        except OSError as err:
            self._refused(err)
        offset = self.offset
        self.offset += len(record)
        self.records += 1
        if time.monotonic() - self._synced >= SYNC_INTERVAL_S:
            self.sync()
        return offset

    def _refused(self, err: OSError) -> None:
        """Disk full, I/O error: one line naming the segment (other errors as they are)."""
        failure = write_failure(err, f"the point store segment {str(self.log_path)!r}")
        if failure is None:
            raise err
        raise ResourceError(f"{failure}; the runs finished before are kept (continue with --resume)") from None

    def sync(self) -> None:
        """Flush the log and the index to the disk (fsync)."""
        os.fsync(self._log)
        os.fsync(self._index)
        self._synced = time.monotonic()

    def close(self) -> None:
        """Sync and close both files (again: nothing)."""
        if self._log < 0:
            return
        try:
            self.sync()
        finally:
            os.close(self._log)
            os.close(self._index)
            self._log = self._index = -1


_WRITERS: dict[tuple[int, str], SegmentWriter] = {}


def writer_for(store: Path) -> SegmentWriter:
    """This process's writer of ``store`` (created on first use; a forked child gets its own).

    Parameters
    ----------
    store : Path
        The point store.

    Returns
    -------
    SegmentWriter
        Closed when the process exits (:func:`close_writers`).
    """
    key = (os.getpid(), str(store))
    writer = _WRITERS.get(key)
    if writer is None:
        if not _WRITERS:
            _register_exit_hook()
        writer = _WRITERS[key] = SegmentWriter(store)
    return writer


def close_writers() -> None:
    """Close (fsync) every segment this process is writing."""
    pid = os.getpid()
    for key in [k for k in _WRITERS if k[0] == pid]:
        _WRITERS.pop(key).close()


def _register_exit_hook() -> None:
    import atexit
    from multiprocessing import util

    atexit.register(close_writers)
    util.Finalize(None, close_writers, exitpriority=10)  # pool workers leave through os._exit


@functools.lru_cache(maxsize=1)
def _static_provenance() -> dict[str, str]:
    return {"rfsim_version": rfsim.__version__, "git_revision": git_revision()}


def run_point(task: PointTask) -> PointResult:
    """Run one point in this process and append it to this process's segment.

    Parameters
    ----------
    task : PointTask
        The scenario, config, point, repetition, seed and store of the run.

    Returns
    -------
    PointResult
        The segment that holds the run, its wall time [s], the process and its peak RSS [MB].
    """
    module = load_scenario(task.scenario_module)
    start_utc, t0 = utc_now(), time.perf_counter()
    from rfsim.core.procs import few_collections

    with few_collections():
        dataset = module.run(task.config, seed=task.seed)
    dataset.scenario = module.NAME
    desc, buffers = encode_dataset(dataset)
    wall = time.perf_counter() - t0
    digest = config_digest(task.config)
    header = {"point": task.point, "repetition": task.repetition, "seed": task.seed, "scenario": module.NAME,
              "config_sha256_16": digest.hex(), "start_time_utc": start_utc,
              "end_time_utc": utc_now(), "wall_time_s": wall, "pid": os.getpid(),
              "host": os.uname().nodename, **_static_provenance(), "dataset": desc}
    writer = writer_for(task.store)
    writer.append(task.point, task.repetition, task.seed, digest, header, buffers)
    return PointResult(task.point, task.repetition, writer.log_path, wall, os.getpid(), os.uname().nodename,
                       _peak_rss_mb())


def run_points(tasks: list[PointTask]) -> list[PointResult]:
    """Run a batch of points one after another (one task of a pool or Dask worker).

    Parameters
    ----------
    tasks : list of PointTask
        The runs of the batch.

    Returns
    -------
    list of PointResult
        One per task, in order.
    """
    return [run_point(t) for t in tasks]


# ----------------------------------------------------------------------------- reading


@dataclasses.dataclass(frozen=True)
class RecordRef:
    """Where one finished run is: segment log, offset and length of its record."""

    log: Path
    offset: int
    length: int


def _scan_log(log: Path, start: int, size: int) -> list[tuple]:
    """Index entries of the complete, CRC-valid records of ``log`` from byte ``start``."""
    found = []
    with open(log, "rb") as f:
        pos = start
        while pos + _PREFIX.size <= size:
            f.seek(pos)
            prefix = f.read(_PREFIX.size)
            magic, version, n_head, n_payload = _PREFIX.unpack(prefix)
            length = _PREFIX.size + n_head + n_payload + _CRC.size
            if magic != MAGIC or version != VERSION or pos + length > size:
                break
            f.seek(pos)
            try:
                header, _ = decode_record(f.read(length))
            except ValueError:
                break
            digest = bytes.fromhex(header["config_sha256_16"])
            found.append((header["point"], header["repetition"], header["seed"], pos, length, digest))
            pos += length
    return found


def segments(store: Path) -> list[Path]:
    """The segment logs of ``store``, oldest first (their names start with the UTC time).

    Parameters
    ----------
    store : Path
        The point store.

    Returns
    -------
    list of Path
        The ``seg-*.log`` files (empty if the store does not exist).
    """
    return sorted(store.glob("seg-*.log")) if store.is_dir() else []


#: Shortest record: prefix, empty header and payload, CRC [bytes].
MIN_RECORD_BYTES = _PREFIX.size + _CRC.size
#: Bounds of a valid index entry: far above any sweep (10¹² points, 4·10⁶ repetitions,
#: 1 TB records) and low enough that ``point * (max repetition + 1)`` fits in int64.
MAX_POINT, MAX_REPETITION, MAX_RECORD_BYTES = 2**40, 2**22, 2**40


class DamagedIndexError(UserError):
    """An index file of the point store is not what its writer appended: it names the file
    and the command that rebuilds it from its log (``rfsim sweep repair SPEC``)."""

    def __init__(self, index: Path, why: str, spec: str = "SPEC.toml"):
        self.index, self.why, self.spec = Path(index), why, spec
        super().__init__(str(self))

    def __str__(self) -> str:
        return (f"point store index {str(self.index)!r} is damaged ({self.why}); rebuild it from its "
                f"log with: rfsim sweep repair {self.spec} (then continue with --resume)")

    def __reduce__(self):
        return (type(self), (self.index, self.why, self.spec))


def _entry_crcs(entries: np.ndarray) -> np.ndarray:
    """CRC-32 of the first 56 bytes (all fields but the checksum) of each index entry."""
    raw = memoryview(np.ascontiguousarray(entries, INDEX_DTYPE).tobytes())
    size = INDEX_DTYPE.itemsize
    return np.array([zlib.crc32(raw[k * size:k * size + _CHECKED_BYTES]) for k in range(len(entries))],
                    np.uint64)


def index_entries(rows: Iterable[tuple]) -> np.ndarray:
    """Index entries of ``(point, repetition, seed, offset, length, digest)`` rows.

    Parameters
    ----------
    rows : iterable of tuple
        Point, repetition, seed, record offset [B], record length [B] and 16-byte config digest.

    Returns
    -------
    ndarray of INDEX_DTYPE, shape (n_rows,)
        The entries, each with the CRC-32 of its first 56 bytes in ``crc32``.
    """
    entries = np.array([(*row, 0) for row in rows], INDEX_DTYPE)
    entries["crc32"] = _entry_crcs(entries)
    return entries


def parse_index(raw: bytes, index: Path) -> np.ndarray:
    """The entries of an index file, each one checked (:func:`check_index`).

    An index of format 2 starts with :data:`INDEX_MAGIC`; one without it is of format 1
    (56-byte entries without a checksum: only their bounds and offsets are checked). A torn
    last entry (a writer killed while appending it) is left out.

    Parameters
    ----------
    raw : bytes
        The file's bytes.
    index : Path
        The file (named in the error).

    Returns
    -------
    ndarray of INDEX_DTYPE, shape (n_entries,)
        Its whole entries (format 1: with their checksums computed).

    Raises
    ------
    DamagedIndexError
        The header or an entry is damaged (checksum, bounds, offsets).
    """
    size = INDEX_DTYPE.itemsize
    if raw.startswith(INDEX_MAGIC):
        body = raw[len(INDEX_MAGIC):]
        return check_index(np.frombuffer(body[:len(body) // size * size], INDEX_DTYPE), index)
    if INDEX_MAGIC.startswith(raw):  # empty, or its writer was killed while writing the header
        return np.zeros(0, INDEX_DTYPE)
    if raw[:4] == INDEX_MAGIC[:4] or raw[4:8] == INDEX_MAGIC[4:8]:
        raise DamagedIndexError(index, "its header is damaged")
    old = np.frombuffer(raw[:len(raw) // _CHECKED_BYTES * _CHECKED_BYTES], _INDEX_V1_DTYPE)
    entries = np.zeros(len(old), INDEX_DTYPE)
    for name in _INDEX_V1_DTYPE.names:
        entries[name] = old[name]
    entries["crc32"] = _entry_crcs(entries)
    return check_index(entries, index)


def check_index(entries: np.ndarray, index: Path) -> np.ndarray:
    """Check that every entry of an index is one its writer appended.

    Its checksum holds, point, repetition and length are in bounds and each record starts
    where the one before ended (the writer appends records back to back from offset 0).

    Parameters
    ----------
    entries : ndarray of INDEX_DTYPE, shape (n_entries,)
        The index's entries.
    index : Path
        The index file (named in the error).

    Returns
    -------
    ndarray of INDEX_DTYPE
        ``entries``.

    Raises
    ------
    DamagedIndexError
        Naming the first damaged entry.
    """
    if not len(entries):
        return entries
    point, rep = entries["point"], entries["repetition"]
    offset, length = entries["offset"], entries["length"]
    checks = [(entries["crc32"] != _entry_crcs(entries), "a checksum that fails"),
              ((point < 0) | (point >= MAX_POINT), f"a point outside [0, {MAX_POINT})"),
              ((rep < 0) | (rep >= MAX_REPETITION), f"a repetition outside [0, {MAX_REPETITION})"),
              ((length < MIN_RECORD_BYTES) | (length > MAX_RECORD_BYTES), "a record length out of bounds"),
              ((offset < 0) | (offset > MAX_RECORD_BYTES * MAX_POINT), "an offset out of bounds")]
    first = [(int(np.argmax(bad)), what) for bad, what in checks if bad.any()]
    if first:  # the first damaged entry is named
        k, what = min(first, key=lambda hit: hit[0])
        raise DamagedIndexError(index, f"entry {k} of {len(entries)} has {what}")
    expected = np.concatenate([[0], np.cumsum(length[:-1])])  # no overflow: bounded above
    gaps = offset != expected
    if gaps.any():
        k = int(np.argmax(gaps))
        raise DamagedIndexError(index, f"entry {k} of {len(entries)} points at byte {int(offset[k])}, "
                                       f"where the records before it end at byte {int(expected[k])}")
    return entries


def read_index(store: Path) -> Iterator[tuple[Path, np.ndarray]]:
    """The index entries of the complete records of every segment, oldest first.

    Every index entry is checked (:func:`parse_index`); entries whose record lies beyond the
    end of the log (a crash) are left out, and complete records after the last indexed one
    (a writer killed in between) are found by scanning the log.

    Parameters
    ----------
    store : Path
        The point store.

    Yields
    ------
    log : Path
        A segment's log.
    entries : ndarray of INDEX_DTYPE
        The entries of its complete records.

    Raises
    ------
    DamagedIndexError
        An index file is damaged (naming it).
    """
    for log in segments(store):
        index = log.with_suffix(".idx")
        try:
            size = log.stat().st_size
            raw = index.read_bytes() if index.exists() else b""
        except OSError:
            continue
        entries = parse_index(raw, index)
        entries = entries[entries["offset"] + entries["length"] <= size]  # a log cut short (crash)
        end = int((entries["offset"] + entries["length"]).max()) if len(entries) else 0
        if end < size:  # records written after the last index entry (killed in between)
            extra = _scan_log(log, end, size)
            if extra:
                entries = np.concatenate([entries, index_entries(extra)])
        yield log, entries


def rebuild_index(log: Path) -> int:
    """Rewrite the index of segment ``log`` from the log itself.

    The new index (format 2) lists the log's complete, CRC-valid records from the start up to
    the first damaged one, and replaces the old one atomically. Only while no sweep writes
    the store.

    Parameters
    ----------
    log : Path
        The segment's log.

    Returns
    -------
    int
        The number of entries written.
    """
    index = log.with_suffix(".idx")
    entries = index_entries(_scan_log(log, 0, log.stat().st_size))
    with atomic_path(index, f"the point store index {str(index)!r}") as tmp:
        tmp.write_bytes(INDEX_MAGIC + entries.tobytes())
    return len(entries)


def repair_store(store: Path) -> list[tuple[Path, int]]:
    """Rebuild every damaged index of ``store`` from its log (:func:`rebuild_index`).

    Parameters
    ----------
    store : Path
        The point store.

    Returns
    -------
    list of (Path, int)
        Each rebuilt index and its number of entries (empty: the store is sound).
    """
    repaired = []
    for log in segments(store):
        index = log.with_suffix(".idx")
        raw = index.read_bytes() if index.exists() else b""
        try:
            parse_index(raw, index)
        except DamagedIndexError:
            repaired.append((index, rebuild_index(log)))
    return repaired


class StoreIndex:
    """Lookup of finished runs: (point, repetition, seed, config digest) → :class:`RecordRef`.

    All index entries of the store in NumPy arrays sorted by (point, repetition, segment
    age, offset) — about 70 bytes per record, no Python object per run.

    Parameters
    ----------
    store : Path
        The point store (read with :func:`read_index`).

    Attributes
    ----------
    store : Path
        The point store.
    logs : list of Path
        Its segment logs, oldest first (segment numbers index it).
    """

    def __init__(self, store: Path):
        self.store = store
        self.logs: list[Path] = []
        parts, segs = [], []
        for seg_id, (log, entries) in enumerate(read_index(store)):
            self.logs.append(log)
            parts.append(entries)
            segs.append(np.full(len(entries), seg_id, np.int32))
        e = np.concatenate(parts) if parts else np.zeros(0, INDEX_DTYPE)
        seg = np.concatenate(segs) if segs else np.zeros(0, np.int32)
        order = np.lexsort((e["offset"], seg, e["repetition"], e["point"]))
        self._e, self._seg = e[order], seg[order]
        self._base = int(self._e["repetition"].max()) + 1 if len(e) else 1
        self._keys = self._e["point"] * self._base + self._e["repetition"]

    @property
    def n_segments(self) -> int:
        """Number of segments in the store."""
        return len(self.logs)

    def __len__(self) -> int:
        """Distinct runs (point, repetition, seed, config) in the store."""
        e = self._e
        return len(set(zip(e["point"].tolist(), e["repetition"].tolist(), e["seed"].tolist(),
                           e["digest"].tolist())))

    def locate(self, point: int, repetition: int, seed: int, digest: bytes) -> tuple[int, int, int] | None:
        """Where the newest record of a run is.

        Parameters
        ----------
        point, repetition, seed : int
            The run.
        digest : bytes
            16 bytes of its config (:func:`config_digest`).

        Returns
        -------
        tuple of int or None
            (segment number, offset [B], length [B]) of the newest record with that point,
            repetition, seed and digest; None if there is none.
        """
        if repetition >= self._base:
            return None
        key = point * self._base + repetition
        lo, hi = np.searchsorted(self._keys, key, "left"), np.searchsorted(self._keys, key, "right")
        for j in range(hi - 1, lo - 1, -1):  # newest segment first
            row = self._e[j]
            if int(row["seed"]) == seed and bytes(row["digest"]) == digest:
                return int(self._seg[j]), int(row["offset"]), int(row["length"])
        return None

    def find(self, point: int, repetition: int, seed: int, digest: bytes) -> RecordRef | None:
        """The newest record of a run (:meth:`locate`) as a reference.

        Parameters
        ----------
        point, repetition, seed : int
            The run.
        digest : bytes
            16 bytes of its config.

        Returns
        -------
        RecordRef or None
            Its log, offset and length; None if the store has no such run.
        """
        hit = self.locate(point, repetition, seed, digest)
        return None if hit is None else RecordRef(self.logs[hit[0]], hit[1], hit[2])


class RecordReader:
    """Reads records by reference, keeping at most one segment file open."""

    def __init__(self):
        self._path: Path | None = None
        self._file = None

    def _seek(self, ref: RecordRef):
        if ref.log != self._path:
            self.close()
            self._file, self._path = open(ref.log, "rb"), ref.log
        self._file.seek(ref.offset)
        return self._file

    def read(self, ref: RecordRef) -> tuple[dict[str, Any], memoryview]:
        """Header and payload of a record, its CRC checked.

        Parameters
        ----------
        ref : RecordRef
            Where the record is.

        Returns
        -------
        header : dict
            The record's JSON header.
        payload : memoryview
            Its payload.

        Raises
        ------
        CorruptRecordError
            One line naming the segment and the byte where the damaged record starts.
        """
        try:
            return decode_record(self._seek(ref).read(ref.length))
        except CorruptRecordError as err:
            raise self._damaged(ref, str(err)) from None

    def header(self, ref: RecordRef) -> dict[str, Any]:
        """The JSON header of a record alone (the payload is not read, nor its CRC checked).

        Parameters
        ----------
        ref : RecordRef
            Where the record is.

        Returns
        -------
        dict
            The record's header.

        Raises
        ------
        CorruptRecordError
            The header is unreadable.
        """
        f = self._seek(ref)
        try:
            magic, version, n_head, _ = _PREFIX.unpack(f.read(_PREFIX.size))
            if magic != MAGIC or version != VERSION:
                raise ValueError("no point record")
            return json.loads(f.read(n_head))
        except (ValueError, struct.error) as err:  # a damaged header: bad JSON or UTF-8
            raise self._damaged(ref, f"point record header unreadable ({type(err).__name__})") from None

    @staticmethod
    def _damaged(ref: RecordRef, what: str) -> CorruptRecordError:
        return CorruptRecordError(f"{what} in {str(ref.log)!r} at byte {ref.offset}: the file is damaged; "
                                  "move that segment (.log and .idx) away and rerun with --resume")

    def close(self) -> None:
        """Close the open segment file, if any."""
        if self._file is not None:
            self._file.close()
        self._file, self._path = None, None

    def __enter__(self) -> RecordReader:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


__all__ = [
    "PointTask",
    "PointResult",
    "RecordRef",
    "StoreIndex",
    "RecordReader",
    "CorruptRecordError",
    "DamagedIndexError",
    "check_index",
    "parse_index",
    "index_entries",
    "INDEX_MAGIC",
    "rebuild_index",
    "repair_store",
    "SegmentWriter",
    "INDEX_DTYPE",
    "SYNC_INTERVAL_S",
    "points_dir",
    "config_digest",
    "encode_dataset",
    "decode_dataset",
    "decode_array",
    "encode_record",
    "decode_record",
    "run_point",
    "run_points",
    "writer_for",
    "close_writers",
    "segments",
    "read_index",
]

"""Streaming merge of a sweep's point store into one HDF5 dataset.

Layout of the merged file (runs in (point, repetition) order):

* ``sweep_runs`` — one row per run: ``sweep_point``, ``sweep_repetition``, ``seed``, the
  swept values under their dotted keys (units from the config field metadata) and the
  scalar root attributes every run has.
* every table of the runs, concatenated, with the added columns ``sweep_point``,
  ``sweep_repetition`` and ``sweep.<key>`` for *every* swept key. The prefix keeps them
  apart from the scenario's own columns. The point index has the one name
  ``sweep_point`` (and the repetition ``sweep_repetition``) in every table and grid.
* a grid that every run has with identical coordinates and variable shapes is stacked
  along two new leading dimensions ``sweep_point`` and ``sweep_repetition`` (with the
  variables ``sweep.<key>`` over ``sweep_point``); otherwise each run's copy is stored as
  its own grid ``<grid>__point-000123-rep-00``.

Swept values that are numbers (or all booleans) keep their type; any other swept value —
a string such as a link profile name, a list, a table, ``none`` — is text: an HDF5
variable-length UTF-8 string (``h5py.string_dtype("utf-8")``, as every text column of
:mod:`rfsim.core.dataset`), lists and ``none`` as their TOML text, tables as their Python
text. The text of a value is the same in ``sweep_runs`` and on the rows (:func:`value_text`).

Columns of 4096 values or more are chunked and gzip-compressed. The merge makes two
passes over the store: the first reads only the records' headers (names, dtypes,
lengths, coordinate checksums), the second one record at a time, writing its rows and
grid slices straight into the output (tables through a bounded row buffer), so its
memory is one run's data plus the buffer and the per-run scalars of ``sweep_runs`` — not
the whole sweep. The output is written under a temporary name and renamed at the end.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from rfsim.core.config import field_at, field_meta, toml_value
from rfsim.core.dataset import (Column, Dataset, atomic_h5file, column, create_array, create_row_scale, stored_values,
                           write_group_descriptions, write_provenance, write_root_attrs)
from rfsim.sweep.store import RecordReader, RecordRef, decode_array, decode_dataset

RUNS_TABLE = "sweep_runs"
RUNS_DESCRIPTION = ("one row per run of the sweep (point, repetition): its seed, its swept config values "
                    "and the scalar results (root attributes) of its dataset")
#: names of the columns/dimensions the merge adds to the scenario's own tables and grids
POINT, REPETITION, KEY_PREFIX = "sweep_point", "sweep_repetition", "sweep."
#: rows of one table buffered before they are written (bounds the merge's memory)
BUFFER_ROWS = 1 << 16
#: bytes of a stacked grid buffered before they are written
BUFFER_BYTES = 8 << 20


def _is_scalar_number(v: Any) -> bool:
    return isinstance(v, (bool, int, float, np.integer, np.floating, np.bool_))


def _as_stored(v: Any) -> Any:
    if isinstance(v, dict):  # a whole sub-table swept at once
        return repr(v)
    if isinstance(v, (list, tuple)) or v is None:
        return toml_value(tuple(v) if isinstance(v, list) else v)
    return v


def value_text(v: Any) -> str:
    """The text a non-numeric swept value is stored as.

    Parameters
    ----------
    v : object
        A swept value.

    Returns
    -------
    str
        Strings as they are; lists, tuples and None as their TOML text; tables (dicts) as
        their Python text; anything else (e.g. a number swept together with text) as ``str``.
    """
    return v if isinstance(v, str) else str(_as_stored(v))


def value_column(key: str, values: Sequence[Any], config_cls: type, *, text: bool | None = None) -> Column:
    """One column of the swept values of ``key``.

    Numbers and booleans are stored as such, anything else as text (:func:`value_text`). The
    column's units and description come from the config field's metadata
    (:func:`rfsim.core.config.field_meta`).

    Parameters
    ----------
    key : str
        Dotted config key of the swept value (e.g. ``"reader.ptx_dbm"``).
    values : sequence
        The swept values, one per row.
    config_cls : type
        The scenario's config dataclass, for the key's units and doc.
    text : bool, optional
        Force text (True) or values as they are (False); None (default): text unless every
        value is a number, or every one a boolean.

    Returns
    -------
    rfsim.core.dataset.Column
        The column, described as ``"swept config value <key>: <doc>"``.
    """
    found = field_at(config_cls, key)
    meta = field_meta(found[0]) if found is not None else {"unit": "", "doc": ""}
    if text is None:
        text = not (all(isinstance(v, (bool, np.bool_)) for v in values)
                    or all(_is_scalar_number(v) and not isinstance(v, (bool, np.bool_)) for v in values))
    data = [value_text(v) for v in values] if text else list(values)
    desc = f"swept config value {key}" + (f": {meta['doc']}" if meta["doc"] else "")
    return column(data, meta["unit"], desc)


# ----------------------------------------------------------------------------- pass 1


@dataclasses.dataclass
class _TableSchema:
    columns: list[tuple[str, str, str, np.dtype]]  # name, units, description, dtype
    lengths: np.ndarray  # rows per run, -1 where the run has no such table


@dataclasses.dataclass
class _GridSchema:
    coords: list[tuple[str, str]]  # name, sha1
    variables: list[tuple[str, tuple[int, ...], tuple[str, ...], str]]  # name, shape, dims, dtype
    present: int = 0
    stackable: bool = True


def _promote(a: np.dtype, b: np.dtype) -> np.dtype:
    if a == b:
        return a
    if a.kind == "U" and b.kind == "U":
        return a if a.itemsize >= b.itemsize else b
    return np.result_type(a, b)


def _scan(refs: Sequence[RecordRef], reader: RecordReader):
    tables: dict[str, _TableSchema] = {}
    grids: dict[str, _GridSchema] = {}
    attr_counts: dict[str, int] = {}
    attr_order: list[str] = []
    descriptions: dict[str, str] = {}
    for j, ref in enumerate(refs):
        desc = reader.header(ref)["dataset"]
        for name, text in desc.get("descriptions", {}).items():
            descriptions.setdefault(name, text)
        for a in desc["attrs"]:
            if not a["array"]["shape"]:
                if a["name"] not in attr_counts:
                    attr_order.append(a["name"])
                attr_counts[a["name"]] = attr_counts.get(a["name"], 0) + 1
        for t in desc["tables"]:
            cols = [(c["name"], c["units"], c["description"], np.dtype(c["array"]["dtype"]))
                    for c in t["columns"]]
            schema = tables.get(t["name"])
            if schema is None:
                schema = tables[t["name"]] = _TableSchema(cols, np.full(len(refs), -1, np.int64))
            else:
                if [c[0] for c in cols] != [c[0] for c in schema.columns]:
                    raise ValueError(f"table {t['name']!r}: run {j} has columns {[c[0] for c in cols]}, "
                                     f"the first has {[c[0] for c in schema.columns]}")
                schema.columns = [(c0[0], c0[1], c0[2], _promote(c0[3], c[3]))
                                  for c0, c in zip(schema.columns, cols)]
            schema.lengths[j] = desc_len(t)
        for g in desc["grids"]:
            coords = [(c["name"], c["array"]["sha1"]) for c in g["coords"]]
            variables = [(v["name"], tuple(v["array"]["shape"]), tuple(v["dims"]), v["array"]["dtype"])
                         for v in g["variables"]]
            schema = grids.setdefault(g["name"], _GridSchema(coords, variables))
            schema.present += 1
            if schema.coords != coords or [v[:3] for v in schema.variables] != [v[:3] for v in variables]:
                schema.stackable = False
            elif schema.variables != variables:  # same shapes, other dtypes: promote
                schema.variables = [(v0[0], v0[1], v0[2], _promote(np.dtype(v0[3]), np.dtype(v[3])).str)
                                    for v0, v in zip(schema.variables, variables)]
    for schema in grids.values():
        schema.stackable = schema.stackable and schema.present == len(refs)
    attrs = [a for a in attr_order if attr_counts[a] == len(refs)]
    return tables, grids, attrs, descriptions


def desc_len(table: Mapping[str, Any]) -> int:
    """Rows of a table described in a record header.

    Parameters
    ----------
    table : mapping
        One entry of a record header's ``"tables"`` list (:mod:`rfsim.sweep.store`).

    Returns
    -------
    int
        The length of the table's first column.
    """
    return int(table["columns"][0]["array"]["shape"][0])


# ----------------------------------------------------------------------------- pass 2


class _TableWriter:
    """Writes one merged table part by part through a bounded buffer."""

    def __init__(self, group: h5py.Group, columns: Mapping[str, Column], n_rows: int):
        self.datasets = {}
        row = create_row_scale(group, n_rows)
        for name, like in columns.items():
            ds = create_array(group, name, like, (n_rows,))
            ds.dims[0].attach_scale(row)
            self.datasets[name] = ds
        self.pos, self.rows, self.parts = 0, 0, {name: [] for name in columns}

    def add(self, part: Mapping[str, np.ndarray]) -> None:
        n = len(next(iter(part.values())))
        for name, data in part.items():
            self.parts[name].append(np.array(data))  # a copy: a view would keep the whole record alive
        self.rows += n
        if self.rows >= BUFFER_ROWS:
            self.flush()

    def flush(self) -> None:
        if not self.rows:
            return
        for name, parts in self.parts.items():
            data = np.concatenate(parts) if len(parts) > 1 else parts[0]
            self.datasets[name][self.pos:self.pos + self.rows] = stored_values(data)
            parts.clear()
        self.pos += self.rows
        self.rows = 0


def _check_reserved(kind: str, name: str, names: Sequence[str], keys: Sequence[str]) -> None:
    for reserved in [POINT, REPETITION, *(KEY_PREFIX + k for k in keys)]:
        if reserved in names:
            raise ValueError(f"{kind} {name!r} already has a column {reserved!r}; cannot merge")


def merge_store(output: Path, refs: Sequence[RecordRef], runs: tuple[np.ndarray, np.ndarray, np.ndarray],
                point_value, n_points: int, n_repetitions: int, keys: Sequence[str], config_cls: type,
                provenance: Mapping[str, Any], numeric_keys: Mapping[str, np.dtype]) -> Path:
    """Merge the stored records of a sweep's runs into one HDF5 file.

    Two passes over the store: headers first (schemas), then one record at a time (see the
    module docstring for the layout). Every swept key is repeated on every row of the
    tables as ``sweep.<key>``. The file is written under a temporary name and renamed.

    Parameters
    ----------
    output : pathlib.Path
        The merged file to write.
    refs : sequence of rfsim.sweep.store.RecordRef
        The record of each run, in (point, repetition) order, ``n_points × n_repetitions``
        of them.
    runs : tuple of three ndarray, each shape (n_runs,)
        ``(points, repetitions, seeds)`` of the runs, in the order of ``refs``.
    point_value : callable
        ``point_value(i)`` → dict of dotted key to swept value of point ``i``.
    n_points : int
        Points of the sweep.
    n_repetitions : int
        Repetitions per point.
    keys : sequence of str
        The swept dotted keys.
    config_cls : type
        The scenario's config dataclass (units and docs of the swept keys).
    provenance : mapping
        Provenance attributes written to the merged file.
    numeric_keys : mapping of str to numpy.dtype
        The swept keys whose every value is a number or boolean, with their column dtype;
        every other swept key is a text column.

    Returns
    -------
    pathlib.Path
        ``output``.

    Raises
    ------
    ValueError
        The runs' tables disagree on their columns, or a table or grid already has a
        column the merge adds (``sweep_point``, ``sweep_repetition``, ``sweep.<key>``).
    """
    with RecordReader() as reader:
        tables, grids, attr_names, descriptions = _scan(refs, reader)
        pts, reps, seeds = (np.asarray(a, dtype=np.int64) for a in runs)
        scenario = ""
        with atomic_h5file(output) as f:
            title = ""
            writers: dict[str, _TableWriter] = {}
            for name, schema in tables.items():
                names = [c[0] for c in schema.columns]
                _check_reserved("table", name, names, keys)
                like = {POINT: column(np.zeros(0, np.int64), "1", "sweep point index"),
                        REPETITION: column(np.zeros(0, np.int64), "1", "repetition of the point")}
                for key in keys:
                    like[KEY_PREFIX + key] = _key_column(key, [point_value(0)[key]], config_cls, numeric_keys)
                for cname, units, desc, dtype in schema.columns:
                    like[cname] = Column(np.zeros(0, dtype), units, desc)
                n_rows = int(schema.lengths[schema.lengths > 0].sum())
                writers[name] = _TableWriter(f.create_group(name), like, n_rows)
            stacked = {name: None for name, g in grids.items() if g.stackable}
            attr_values: dict[str, list | np.ndarray] = {}
            for j, ref in enumerate(refs):
                header, payload = reader.read(ref)
                desc = header["dataset"]
                if j == 0:
                    title = desc["title"] + " (sweep)"
                    scenario = desc["scenario"]
                attrs = {a["name"]: a for a in desc["attrs"]}
                for a in attr_names:  # per-run scalars: one NumPy array per attribute
                    value = decode_array(payload, attrs[a]["array"])[()]
                    if a not in attr_values:
                        kind = np.asarray(value).dtype
                        attr_values[a] = np.zeros(len(refs), kind) if kind.kind in "biuf" else [None] * len(refs)
                    store = attr_values[a]
                    if isinstance(store, np.ndarray) and not np.can_cast(np.asarray(value).dtype, store.dtype):
                        kind = np.result_type(store.dtype, np.asarray(value).dtype)  # as np.asarray would
                        store = attr_values[a] = store.astype(kind) if kind.kind in "biuf" else list(store)
                    store[j] = value
                run = decode_dataset(desc, payload)
                p, k = int(pts[j]), int(reps[j])
                values = point_value(p)
                for name, cols in run.tables.items():
                    n = len(next(iter(cols.values())).data)
                    part = {POINT: np.full(n, p, np.int64), REPETITION: np.full(n, k, np.int64)}
                    for key in keys:
                        if key in numeric_keys:
                            part[KEY_PREFIX + key] = np.full(n, values[key], dtype=numeric_keys[key])
                        else:  # one shared str object per row, not a fixed-width copy
                            part[KEY_PREFIX + key] = np.full(n, value_text(values[key]), dtype=object)
                    part.update({c: col.data for c, col in cols.items()})
                    writers[name].add(part)
                for name, (coords, variables) in run.grids.items():
                    if name in stacked:
                        if stacked[name] is None:
                            stacked[name] = _create_stacked(f, name, coords, variables, grids[name], n_points,
                                                            n_repetitions, keys, point_value, config_cls,
                                                            numeric_keys)
                        stacked[name].add(p, k, {vname: v.data for vname, v in variables.items()})
                    else:
                        _write_grid_copy(f, f"{name}__point-{p:06d}-rep-{k:02d}", coords, variables)
                del run, header, payload
            for w in [*writers.values(), *(g for g in stacked.values() if g is not None)]:
                w.flush()
            runs_cols: dict[str, Column] = {
                POINT: column(pts, "1", "sweep point index"),
                REPETITION: column(reps, "1", "repetition of the point"),
                "seed": column(seeds, "1",
                               "seed the scenario ran with (SeedSequence(seed, spawn_key=(point, repetition)))"),
            }
            for key in keys:
                runs_cols[key] = _key_column(key, [point_value(int(p))[key] for p in pts], config_cls,
                                             numeric_keys)
            for name in attr_names:
                if name not in runs_cols:
                    runs_cols[name] = column(attr_values[name], "", f"root attribute {name!r} of the run")
            w = _TableWriter(f.create_group(RUNS_TABLE), runs_cols, len(pts))
            w.add({c: col.data for c, col in runs_cols.items()})
            w.flush()
            copies = {f"{g}__point-{int(p):06d}-rep-{int(k):02d}": descriptions[g] for g in grids
                      if g not in stacked and g in descriptions for p, k in zip(pts, reps)}
            write_group_descriptions(f, {**descriptions, **copies, RUNS_TABLE: RUNS_DESCRIPTION})
            write_root_attrs(f, Dataset(title=title or "sweep", scenario=scenario))
            write_provenance(f, provenance)
    return output


def _key_column(key: str, values: Sequence[Any], config_cls: type,
                numeric_keys: Mapping[str, np.dtype]) -> Column:
    """Column of swept values of ``key``: the key's dtype if it is numeric, else text."""
    if key in numeric_keys:
        v = value_column(key, values, config_cls, text=False)
        return dataclasses.replace(v, data=v.data.astype(numeric_keys[key]))
    return value_column(key, values, config_cls, text=True)


def _create_stacked(f, name, coords, variables, schema: _GridSchema, n_points, n_reps, keys, point_value,
                    config_cls, numeric_keys) -> _GridWriter:
    _check_reserved("grid", name, [*coords, *variables], keys)
    g = f.create_group(name)
    all_coords = {POINT: column(np.arange(n_points, dtype=np.int64), "1", "sweep point index"),
                  REPETITION: column(np.arange(n_reps, dtype=np.int64), "1", "repetition of the point"),
                  **coords}
    scales = _write_scales(g, all_coords)
    for key in keys:
        vals = _key_column(key, [point_value(i)[key] for i in range(n_points)], config_cls, numeric_keys)
        _write_full(g, KEY_PREFIX + key, vals).dims[0].attach_scale(scales[POINT])
    out = {}
    dtypes = {v[0]: np.dtype(v[3]) for v in schema.variables}
    for vname, v in variables.items():
        like = Column(np.zeros(0, dtypes[vname]), v.units, v.description)
        ds = create_array(g, vname, like, (n_points, n_reps) + v.data.shape)
        for axis, dim in enumerate((POINT, REPETITION, *v.dims)):
            ds.dims[axis].attach_scale(scales[dim])
        out[vname] = ds
    return _GridWriter(out, n_reps)


class _GridWriter:
    """Writes a stacked grid in blocks of whole points (bounded buffer, few HDF5 calls)."""

    def __init__(self, datasets: Mapping[str, h5py.Dataset], n_reps: int):
        self.datasets, self.n_reps = dict(datasets), n_reps
        run_bytes = sum(int(np.prod(ds.shape[2:])) * ds.dtype.itemsize for ds in self.datasets.values())
        per_point = (run_bytes + 128 * len(self.datasets)) * n_reps  # data + array object overhead
        self.block_points = max(1, BUFFER_BYTES // per_point)
        self.first, self.parts = None, {name: [] for name in self.datasets}

    def add(self, point: int, repetition: int, data: Mapping[str, np.ndarray]) -> None:
        if self.first is None:
            self.first = point
        for name, arr in data.items():
            self.parts[name].append(np.array(arr))  # a copy: a view would keep the whole record alive
        if repetition == self.n_reps - 1 and point + 1 - self.first >= self.block_points:
            self.flush()

    def flush(self) -> None:
        if self.first is None:
            return
        for name, parts in self.parts.items():
            block = np.stack(parts)
            n = len(parts) // self.n_reps
            self.datasets[name][self.first:self.first + n] = stored_values(
                block.reshape((n, self.n_reps) + block.shape[1:]))
            parts.clear()
        self.first = None


def _write_full(g: h5py.Group, name: str, col: Column) -> h5py.Dataset:
    ds = create_array(g, name, col, col.data.shape)
    ds[...] = stored_values(col.data)
    return ds


def _write_scales(g: h5py.Group, coords: Mapping[str, Column]) -> dict[str, h5py.Dataset]:
    scales = {}
    for cname, c in coords.items():
        scales[cname] = _write_full(g, cname, c)
        scales[cname].make_scale(cname)
    return scales


def _write_grid_copy(f, name, coords, variables) -> None:
    g = f.create_group(name)
    scales = _write_scales(g, coords)
    for vname, v in variables.items():
        ds = _write_full(g, vname, v)
        for axis, dim in enumerate(v.dims):
            ds.dims[axis].attach_scale(scales[dim])


__all__ = ["RUNS_TABLE", "POINT", "REPETITION", "KEY_PREFIX", "value_text", "value_column", "merge_store"]

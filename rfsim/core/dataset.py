"""HDF5 datasets: columnar tables, gridded data with dimension scales, provenance.

Layout of a file written by :func:`write_dataset` (one HDF5 group per table or grid)::

    /                     attrs: title, scenario, rfsim_version, Conventions, source, history,
                          the run's scalar results
    /<table>              attr description (what one row is)
    /<table>/row          dimension scale 0..n-1
    /<table>/<column>     1-D, one per field, attrs units, long_name, description
    /<grid>               attr description
    /<grid>/<coord>       1-D dimension scales (attrs units, long_name, description)
    /<grid>/<variable>    N-D over named coords (attrs units, long_name, description)
    /provenance           attrs: config_toml, seed, rfsim_version, git_revision, command_line,
                          start_time_utc, end_time_utc, platform, python, numpy, numba, h5py,
                          scipy, matplotlib

Every group is also a valid netCDF-4 group: ``xarray.open_dataset(path,
engine="h5netcdf", group="<name>")`` opens it without custom code and shows ``units`` and
``long_name`` (CF conventions) on every variable. Booleans are stored as ``uint8`` with the
CF attributes ``flag_values = [0, 1]``, ``flag_meanings = "false true"`` and
``rfsim_dtype = "bool"`` (netCDF has no bool type; :func:`read_table` gives them back as
bool); strings as UTF-8 variable-length strings, with ``units = ""`` (text is not a quantity;
every variable still has the attribute). A ``long_name`` is short (a label for an axis or a
legend, :func:`long_name`); the sentence is in ``description``.

The root attributes ``Conventions`` (:data:`CONVENTIONS`), ``source`` (rfsim version and
scenario) and ``history`` (ISO time and the command line that wrote the file) say where a file
comes from; ``Conventions`` does not claim CF compliance (units such as dBm are not UDUNITS
units), it names this layout.

Root attributes that are not finite numbers (NaN, ±inf) must say what they mean: a text
attribute ``<name>_meaning`` beside them (e.g. "inf: no nulls along this track"), else
:func:`write_dataset` refuses the dataset.

Any table into pandas, in one line (``read_table`` returns plain NumPy columns)::

    frame = pandas.DataFrame(rfsim.core.dataset.read_table("results/link.h5", "reads"))

and any group, grids included, through xarray::

    frame = xarray.open_dataset(path, engine="h5netcdf", group="tracks").to_dataframe()

Files are written to a hidden temporary name beside the target, flushed, fsync'ed and
renamed over the final name, so a killed run never leaves a truncated file under the
final name.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import gc
import importlib.metadata
import io
import os
import platform
import subprocess
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

import rfsim
from rfsim.core.command_line import command_line
from rfsim.core.errors import ResourceError, write_failure
from rfsim.core.lazy import lazy_import
from rfsim.core.outputs import partial_path

h5py = lazy_import("h5py")

_ROW_DIM = "row"
#: Root attributes :func:`write_root_attrs` writes itself (not copied from ``Dataset.attrs``).
_ROOT_OWN = ("title", "scenario", "rfsim_version", "Conventions", "source", "history")
_BOOL_ATTR = "rfsim_dtype"
#: Description attribute of every file's provenance group.
PROVENANCE_DESCRIPTION = ("how this file was made: the resolved config (TOML), the seed, the rfsim version "
                          "and git revision, the command line, start and end time (UTC) and the software platform")
#: The root ``Conventions`` attribute: this layout (groups of aligned columns with a ``row``
#: dimension scale, ``units``/``long_name``/``description`` on every variable, CF flag attributes on
#: booleans, ``<name>_meaning`` beside non-finite attributes), documented on the datasets page.
#: Not "CF-1.x": some units (dBm, dBi) are not UDUNITS units.
CONVENTIONS = "rfsim-dataset-1"
#: Longest ``long_name`` [characters] derived from a description (:func:`long_name`).
LONG_NAME_MAX = 60


@dataclasses.dataclass(frozen=True)
class Column:
    """One named array with its unit and description.

    The CF ``long_name`` written with it is the description's first clause, kept short
    (:func:`long_name`).

    Parameters
    ----------
    data : ndarray
        The values: shape (n_rows,) in a table, the shape over ``dims`` in a grid.
    units : str
        Unit, e.g. ``"m"``, ``"dBm"``, ``"1"`` for dimensionless; a text column's units are
        always ``""`` (set so whatever is given).
    description : str
        What the values are, one sentence.
    dims : tuple of str, default ()
        The grid coordinates a gridded variable spans, in axis order; table columns leave it
        empty.
    """

    data: np.ndarray
    units: str
    description: str
    dims: tuple[str, ...] = ()

    def __post_init__(self):
        if is_text(np.asarray(self.data)) and self.units:  # text is not a quantity: one spelling, ""
            object.__setattr__(self, "units", "")


def column(data: Any, units: str, description: str, dims: tuple[str, ...] = ()) -> Column:
    """Build a :class:`Column`, converting ``data`` to an array (strings to ``str``).

    Parameters
    ----------
    data : array_like
        The values; object and ``str`` arrays become fixed-width ``str`` arrays.
    units : str
        Unit (``""`` for text).
    description : str
        What the values are, one sentence.
    dims : tuple of str, default ()
        Grid coordinates the values span, in axis order (empty for a table column).

    Returns
    -------
    Column
        The column.
    """
    arr = np.asarray(data)
    if arr.dtype.kind in "OU":
        arr = arr.astype(str)
    return Column(arr, units, description, tuple(dims))


@dataclasses.dataclass
class Dataset:
    """In-memory content of one dataset file: tables, grids and root attributes.

    Parameters
    ----------
    title : str, default ""
        Root ``title`` attribute.
    scenario : str, default ""
        Name of the scenario that made it (root ``scenario`` attribute).
    tables : dict of str to dict of str to Column, default {}
        Table name → its aligned 1-D columns.
    grids : dict of str to (dict of str to Column, dict of str to Column), default {}
        Grid name → (coordinates, variables over them).
    attrs : dict of str to object, default {}
        Further root attributes (e.g. the run's scalar results).
    descriptions : dict of str to str, default {}
        Group name → what the group holds (what one row of a table is).
    """

    title: str = ""
    scenario: str = ""
    tables: dict[str, dict[str, Column]] = dataclasses.field(default_factory=dict)
    grids: dict[str, tuple[dict[str, Column], dict[str, Column]]] = dataclasses.field(
        default_factory=dict)
    attrs: dict[str, Any] = dataclasses.field(default_factory=dict)
    #: group name → what the group holds (what one row of a table is)
    descriptions: dict[str, str] = dataclasses.field(default_factory=dict)

    def add_table(self, name: str, columns: Mapping[str, Column], description: str = "") -> None:
        """Add a columnar table of aligned 1-D columns of equal length.

        Parameters
        ----------
        name : str
            Group name of the table (not empty, not ``"provenance"``, not used yet).
        columns : mapping of str to Column
            Column name → column, each of shape (n_rows,); ``"row"`` is reserved.
        description : str, default ""
            What one row is.

        Raises
        ------
        ValueError
            If the name is empty, reserved or used, there are no columns, a column is not 1-D,
            the lengths differ, or a column is named ``"row"``.
        """
        self._check_new(name)
        lengths = {k: c.data.shape for k, c in columns.items()}
        if not columns:
            raise ValueError(f"table {name!r} has no columns")
        if any(len(s) != 1 for s in lengths.values()):
            raise ValueError(f"table {name!r}: columns must be 1-D, got shapes {lengths}")
        if len({s[0] for s in lengths.values()}) != 1:
            raise ValueError(f"table {name!r}: columns differ in length: {lengths}")
        if _ROW_DIM in columns:
            raise ValueError(f"table {name!r}: {_ROW_DIM!r} is reserved for the row index")
        self.tables[name] = dict(columns)
        if description:
            self.descriptions[name] = description

    def add_grid(self, name: str, coords: Mapping[str, Column],
                 variables: Mapping[str, Column], description: str = "") -> None:
        """Add gridded data: 1-D coordinates and variables over (a subset of) them.

        Parameters
        ----------
        name : str
            Group name of the grid (not empty, not ``"provenance"``, not used yet).
        coords : mapping of str to Column
            Coordinate name → 1-D column (a dimension scale).
        variables : mapping of str to Column
            Variable name → column whose shape is the coordinates' lengths over its ``dims``
            (empty ``dims``: every coordinate, in the order of ``coords``).
        description : str, default ""
            What the grid holds.

        Raises
        ------
        ValueError
            If the name is empty, reserved or used, a coordinate is not 1-D, a variable names an
            unknown coordinate or has the wrong shape.
        """
        self._check_new(name)
        for cname, c in coords.items():
            if c.data.ndim != 1:
                raise ValueError(f"grid {name!r}: coordinate {cname!r} must be 1-D")
        for vname, v in variables.items():
            dims = v.dims or tuple(coords)
            if any(d not in coords for d in dims):
                raise ValueError(f"grid {name!r}: variable {vname!r} names unknown dims {dims}")
            expected = tuple(len(coords[d].data) for d in dims)
            if v.data.shape != expected:
                raise ValueError(f"grid {name!r}: variable {vname!r} has shape "
                                 f"{v.data.shape}, expected {expected} over {dims}")
        self.grids[name] = (dict(coords), {k: dataclasses.replace(v, dims=v.dims or tuple(coords))
                                           for k, v in variables.items()})
        if description:
            self.descriptions[name] = description

    def _check_new(self, name: str) -> None:
        if name in self.tables or name in self.grids or name == "provenance" or not name:
            raise ValueError(f"dataset group name {name!r} is empty, reserved or already used")


# ----------------------------------------------------------------------------- provenance


def git_revision() -> str:
    """Git commit of the rfsim source tree.

    Returns
    -------
    str
        The 40-hex commit, with ``-dirty`` appended when tracked files have changes; ``""``
        when not in a git checkout (or git is not available).
    """
    src = Path(rfsim.__file__).resolve().parent.parent
    try:
        out = subprocess.run(["git", "-C", str(src), "rev-parse", "HEAD"], capture_output=True,
                             text=True, timeout=5, check=False)
    except (OSError, subprocess.SubprocessError):
        return ""
    rev = out.stdout.strip()
    if out.returncode != 0 or len(rev) != 40:
        return ""
    dirty = subprocess.run(["git", "-C", str(src), "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True, timeout=5, check=False).stdout.strip()
    return rev + ("-dirty" if dirty else "")


def utc_now() -> str:
    """Current UTC time, ISO 8601 with seconds (for provenance only, never for seeding).

    Returns
    -------
    str
        E.g. ``"2026-01-31T12:00:00+00:00"``.
    """
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def package_version(name: str) -> str:
    """Installed version of a distribution, read from its metadata without importing it.

    Parameters
    ----------
    name : str
        Distribution name, e.g. ``"scipy"``.

    Returns
    -------
    str
        The version, or ``""`` if it is not installed.
    """
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return ""


def make_provenance(*, config_toml: str, seed: int, scenario: str, start_time_utc: str,
                    extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Provenance attributes of a run.

    The end time is stamped when the file is written (:func:`write_provenance`).

    Parameters
    ----------
    config_toml : str
        The resolved config as TOML.
    seed : int
        Root seed of the run.
    scenario : str
        Scenario name.
    start_time_utc : str
        Start time, ISO 8601 (:func:`utc_now`).
    extra : mapping of str to object or None, default None
        Further attributes; they override those above of the same name.

    Returns
    -------
    dict of str to object
        ``config_toml``, ``seed``, ``scenario``, ``rfsim_version``, ``git_revision``,
        ``command_line`` (:func:`command_line`), ``start_time_utc``, ``platform`` and the
        versions of ``python``, ``numpy``, ``numba``, ``h5py``, ``scipy`` and ``matplotlib``
        (the libraries the numbers depend on), then ``extra``.
    """
    import numba

    prov = {
        "config_toml": config_toml,
        "seed": int(seed),
        "scenario": scenario,
        "rfsim_version": rfsim.__version__,
        "git_revision": git_revision(),
        "command_line": command_line(),
        "start_time_utc": start_time_utc,
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "numba": numba.__version__,
        "h5py": h5py.__version__,
        "scipy": package_version("scipy"),
        "matplotlib": package_version("matplotlib"),
    }
    prov.update(extra or {})
    return prov


# ----------------------------------------------------------------------------- writing


#: Words a shortened ``long_name`` does not end on.
_DANGLING = frozenset("a an and as at by for from in into of on or over per the to with without".split())


def _outside_brackets(text: str) -> str:
    """``text`` without its parenthesised parts (nested ones too; an unclosed "(" ends it)."""
    out, depth = [], 0
    for ch in text:
        if ch == "(":
            depth += 1
        elif ch == ")" and depth:
            depth -= 1
        elif not depth:
            out.append(ch)
    return "".join(out)


def _first_clause(text: str) -> str:
    """``text`` up to its first ";" or ": " outside parentheses."""
    depth = 0
    for i, ch in enumerate(text):
        depth += (ch == "(") - (ch == ")" and depth > 0)
        if not depth and (ch == ";" or text.startswith(": ", i)):
            return text[:i]
    return text


def long_name(description: str) -> str:
    """CF ``long_name`` of a column: a short label derived from its description.

    The description's first clause (up to the first ";" or ": " outside parentheses); if it is
    longer than :data:`LONG_NAME_MAX` characters, without its parenthesised parts; if still
    longer, cut after its last whole word that fits (at a comma if one is in the second half),
    without a dangling "of", "at", …. The full sentence stays in ``description``.

    Parameters
    ----------
    description : str
        The column's description; ``"<label>: <sentence>"`` gives exactly ``<label>``.

    Returns
    -------
    str
        The label, whitespace collapsed, without trailing spaces, commas or periods.
    """
    clause = _first_clause(description)
    text = " ".join(clause.split()).strip(" ,.")
    if len(text) <= LONG_NAME_MAX:
        return text
    text = " ".join(_outside_brackets(clause).split()).strip(" ,.") or text
    if len(text) <= LONG_NAME_MAX:
        return text
    cut = text.rfind(", ", 0, LONG_NAME_MAX + 1)
    words = text[:cut].split() if cut > LONG_NAME_MAX // 2 else text[:LONG_NAME_MAX + 1].split()[:-1]
    while len(words) > 1 and words[-1].lower().strip(",") in _DANGLING:
        words.pop()
    return " ".join(words).rstrip(",") or text[:LONG_NAME_MAX]


def _array_attrs(col: Column, name: str) -> dict[str, Any]:
    attrs: dict[str, Any] = {"units": col.units, "long_name": long_name(col.description) or name,
                             "description": col.description}
    if col.data.dtype == bool:
        attrs[_BOOL_ATTR] = "bool"
        attrs["flag_values"] = np.array([0, 1], dtype=np.uint8)
        attrs["flag_meanings"] = "false true"
    return attrs


def is_text(data: np.ndarray) -> bool:
    """Whether an array is a text column.

    Parameters
    ----------
    data : ndarray
        The column's values.

    Returns
    -------
    bool
        True for fixed-width ``str`` (``U``) and object arrays (of ``str``, which a column of
        few distinct values can use to hold one shared object per value instead of a copy per
        row).
    """
    return data.dtype.kind in "OU"


def stored_values(data: np.ndarray) -> np.ndarray:
    """Values of an array as they are written to HDF5.

    Parameters
    ----------
    data : ndarray
        The column's values.

    Returns
    -------
    ndarray
        Booleans as uint8, fixed-width text as an object array of ``str`` (UTF-8 in the file),
        anything else unchanged (not copied).
    """
    if data.dtype == bool:
        return data.astype(np.uint8)
    if data.dtype.kind == "U":
        return data.astype(object)
    return data


def _h5_dtype(data: np.ndarray) -> Any:
    if is_text(data):
        return h5py.string_dtype("utf-8")
    return stored_values(data[:0]).dtype


#: Rows of a text column converted to Python strings at a time when it is written (the
#: conversion costs ~100 bytes a row; written whole, a long column's copy would be the peak).
TEXT_SLICE_ROWS = 1 << 16


def _write_array(group: h5py.Group, name: str, col: Column) -> h5py.Dataset:
    if is_text(col.data):
        ds = group.create_dataset(name, shape=col.data.shape, dtype=_h5_dtype(col.data))
        if col.data.ndim != 1:   # text over a grid: rare and small, written whole
            ds[...] = stored_values(col.data)
        for start in range(0, len(col.data) if col.data.ndim == 1 else 0, TEXT_SLICE_ROWS):
            ds[start:start + TEXT_SLICE_ROWS] = stored_values(col.data[start:start + TEXT_SLICE_ROWS])
    else:
        data = stored_values(col.data)
        opts = {"compression": "gzip", "compression_opts": 4} if data.size >= 4096 else {}
        ds = group.create_dataset(name, data=data, **opts)
    for k, v in _array_attrs(col, name).items():
        ds.attrs[k] = v
    return ds


def create_array(group: h5py.Group, name: str, like: Column, shape: tuple[int, ...]) -> h5py.Dataset:
    """Create an empty HDF5 dataset typed and described like a column, to be filled in parts.

    Same dtype conventions and attributes as :func:`write_dataset`; chunked with gzip (and
    byte shuffle) when it holds at least 4096 non-text values, so large merged columns are
    compressed. Write parts with ``ds[i:j] = stored_values(data)``.

    Parameters
    ----------
    group : h5py.Group
        The group to create it in.
    name : str
        Its name.
    like : Column
        The dtype (of ``like.data``), units and description to use.
    shape : tuple of int
        Its shape.

    Returns
    -------
    h5py.Dataset
        The new dataset, with its ``units``, ``long_name`` and ``description`` attributes (and
        the flag attributes of a boolean).
    """
    size = int(np.prod(shape, dtype=np.int64))
    opts: dict[str, Any] = {}
    if size >= 4096 and not is_text(like.data):
        opts = {"compression": "gzip", "compression_opts": 4, "shuffle": True, "chunks": True}
    ds = group.create_dataset(name, shape=shape, dtype=_h5_dtype(like.data), **opts)
    for k, v in _array_attrs(like, name).items():
        ds.attrs[k] = v
    return ds


def create_row_scale(group: h5py.Group, n_rows: int) -> h5py.Dataset:
    """Create the ``row`` dimension scale (0 … n_rows − 1) of a table group.

    Parameters
    ----------
    group : h5py.Group
        The table's group.
    n_rows : int
        Number of rows.

    Returns
    -------
    h5py.Dataset
        The int64 ``row`` dataset, made a dimension scale.
    """
    like = Column(np.zeros(0, np.int64), "1", "row index of the table, 0-based")
    row = create_array(group, _ROW_DIM, like, (n_rows,))
    row.attrs["long_name"] = "row index"
    step = 1 << 20
    for start in range(0, n_rows, step):
        row[start:min(start + step, n_rows)] = np.arange(start, min(start + step, n_rows), dtype=np.int64)
    row.make_scale(_ROW_DIM)
    return row


def _write_table(f: h5py.File, name: str, columns: Mapping[str, Column]) -> None:
    g = f.create_group(name)
    row = create_row_scale(g, len(next(iter(columns.values())).data))
    for cname, col in columns.items():
        ds = _write_array(g, cname, col)
        ds.dims[0].attach_scale(row)


def _write_grid(f: h5py.File, name: str, coords: Mapping[str, Column],
                variables: Mapping[str, Column]) -> None:
    g = f.create_group(name)
    scales = {}
    for cname, c in coords.items():
        ds = _write_array(g, cname, c)
        ds.make_scale(cname)
        scales[cname] = ds
    for vname, v in variables.items():
        ds = _write_array(g, vname, v)
        for axis, dim in enumerate(v.dims):
            ds.dims[axis].attach_scale(scales[dim])


def check_attributes(attrs: Mapping[str, Any]) -> None:
    """Check that every non-finite numeric attribute says what it means.

    Parameters
    ----------
    attrs : mapping of str to object
        Root attributes; a float or complex value (or array) with a NaN or ±inf needs a
        non-empty text attribute ``<name>_meaning``.

    Raises
    ------
    ValueError
        Naming the first non-finite attribute without a meaning.
    """
    for k, v in attrs.items():
        arr = np.asarray(v)
        if arr.dtype.kind in "fc" and not np.all(np.isfinite(arr)) and not str(attrs.get(f"{k}_meaning", "")):
            raise ValueError(f"dataset attribute {k!r} = {v!r} is not finite; add a text attribute "
                             f"'{k}_meaning' that says what the value means")


@contextlib.contextmanager
def atomic_h5file(path: str | Path) -> Iterator[h5py.File]:
    """Open an HDF5 file for writing under a hidden temporary name beside ``path``.

    On leaving the block the file is closed, fsync'ed and renamed over ``path`` (with the
    folder fsync'ed); on an exception (including Ctrl-C and SIGTERM) the temporary file is
    removed, so ``path`` is either the old file or the complete new one. The folder is
    created if missing.

    Parameters
    ----------
    path : str or pathlib.Path
        The final file.

    Yields
    ------
    h5py.File
        The temporary file, open for writing.

    Raises
    ------
    rfsim.core.errors.ResourceError
        If the operating system refuses a write (disk full, I/O error, quota), in one line
        naming ``path``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = partial_path(path)
    try:
        with _h5py_reports_held() as held:
            f = h5py.File(tmp, "w")
            try:
                yield f
                f.flush()
                f.close()
            except BaseException as failed:
                if write_failure(failed, "") is not None:
                    held.drop()
                _abandon(f, tmp)
                raise
        _fsync_file(tmp)
        os.replace(tmp, path)
        _fsync_dir(path.parent)
    except BaseException as err:
        tmp.unlink(missing_ok=True)
        failure = write_failure(err, f"{str(path)!r}")
        if failure is not None:
            raise ResourceError(f"{failure}; the previous file, if any, is unchanged") from None
        raise


class _HeldText(io.StringIO):
    """What was written to ``sys.stderr`` while an HDF5 file was written (see below)."""

    dropped = False

    def drop(self) -> None:
        self.dropped = True


@contextlib.contextmanager
def _h5py_reports_held() -> Iterator[_HeldText]:
    """Hold back what is printed on ``sys.stderr`` while an HDF5 file is written.

    After a refused write (disk full), HDF5 fails again for every object freed or flushed
    until the file is closed, and h5py prints a traceback for each (hundreds of lines)
    before the error reaches the writer, where the one-line error says what happened. The
    held text (and the reports to ``sys.unraisablehook``) are passed on when the write
    succeeds and dropped when it fails (``drop()``).
    Progress reporters keep their own reference to the stream and are not held back."""
    held, saved, saved_hook = _HeldText(), sys.stderr, sys.unraisablehook
    reports: list = []
    sys.stderr = held
    sys.unraisablehook = reports.append  # h5py's reports of objects it could not free
    try:
        yield held
    finally:
        sys.stderr, sys.unraisablehook = saved, saved_hook
        if not held.dropped:
            if held.getvalue():
                saved.write(held.getvalue())
            for report in reports:
                saved_hook(report)


def _abandon(f: h5py.File, tmp: Path) -> None:
    """Close the HDF5 file ``f`` (at ``tmp``) after a failure: truncated first, which gives
    its space back, so that HDF5's last writes as it closes do not fail again."""
    with contextlib.suppress(OSError):
        os.truncate(tmp, 0)
    with contextlib.suppress(Exception):
        f.close()
    gc.collect()


def history_line(command: str | None = None, time_utc: str | None = None) -> str:
    """One line of the root ``history`` attribute: ``"<ISO time UTC> <command line>"``.

    Parameters
    ----------
    command : str or None, default None
        The command line (None: the running one, :func:`command_line`).
    time_utc : str or None, default None
        ISO 8601 time (None or empty: now, :func:`utc_now`).

    Returns
    -------
    str
        The line.
    """
    return f"{time_utc or utc_now()} {command if command is not None else command_line()}"


def write_root_attrs(f: h5py.File, dataset: Dataset, provenance: Mapping[str, Any] | None = None) -> None:
    """Write the root attributes of a dataset file.

    They are ``title``, ``scenario``, ``rfsim_version``, ``Conventions``
    (:data:`CONVENTIONS`), ``source`` (``"rfsim <version>, scenario <name>"``), ``history`` and
    the other entries of ``dataset.attrs``. ``history`` is one :func:`history_line` with the
    provenance's command line (the running one without provenance), after the history the
    dataset already had (a file read back and written again keeps its past lines).

    Parameters
    ----------
    f : h5py.File
        The file, open for writing.
    dataset : Dataset
        Its content (title, scenario, attrs).
    provenance : mapping of str to object or None, default None
        Provenance attributes; only ``command_line`` is used here.
    """
    f.attrs["title"] = dataset.title
    f.attrs["scenario"] = dataset.scenario
    f.attrs["rfsim_version"] = rfsim.__version__
    f.attrs["Conventions"] = CONVENTIONS
    f.attrs["source"] = f"rfsim {rfsim.__version__}, scenario {dataset.scenario or 'none'}"
    past = str(dataset.attrs.get("history", ""))
    line = history_line((provenance or {}).get("command_line"))
    f.attrs["history"] = f"{past}\n{line}" if past else line
    for k, v in dataset.attrs.items():
        if k not in _ROOT_OWN:
            f.attrs[k] = v


def write_provenance(f: h5py.File, provenance: Mapping[str, Any]) -> None:
    """Write the ``/provenance`` group, with ``end_time_utc`` stamped now.

    Parameters
    ----------
    f : h5py.File
        The file, open for writing.
    provenance : mapping of str to object
        The attributes (:func:`make_provenance`); the group also gets its ``description``.
    """
    prov = f.create_group("provenance")
    prov.attrs["description"] = PROVENANCE_DESCRIPTION
    for k, v in {**provenance, "end_time_utc": utc_now()}.items():
        prov.attrs[k] = v


def write_dataset(path: str | Path, dataset: Dataset, provenance: Mapping[str, Any]) -> Path:
    """Write a dataset atomically to a file (temporary name, fsync, rename).

    See the module docstring for the layout; the provenance gets ``end_time_utc`` stamped now.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write (replaced if it exists).
    dataset : Dataset
        Tables, grids, descriptions and root attributes.
    provenance : mapping of str to object
        Provenance attributes (:func:`make_provenance`).

    Returns
    -------
    pathlib.Path
        The final path.

    Raises
    ------
    ValueError
        If a root attribute is not finite and has no ``<name>_meaning``
        (:func:`check_attributes`); checked before anything is written.
    rfsim.core.errors.ResourceError
        If the system refuses the write (:func:`atomic_h5file`).
    """
    check_attributes(dataset.attrs)
    path = Path(path)
    with atomic_h5file(path) as f:
        write_root_attrs(f, dataset, provenance)
        for name, cols in dataset.tables.items():
            _write_table(f, name, cols)
        for name, (coords, variables) in dataset.grids.items():
            _write_grid(f, name, coords, variables)
        write_group_descriptions(f, dataset.descriptions)
        write_provenance(f, provenance)
    return path


def write_group_descriptions(f: h5py.File, descriptions: Mapping[str, str]) -> None:
    """Set the ``description`` attribute of each named group that is in the file.

    Parameters
    ----------
    f : h5py.File
        The file, open for writing.
    descriptions : mapping of str to str
        Group name → description; names not in the file are skipped.
    """
    for name, text in descriptions.items():
        if name in f:
            f[name].attrs["description"] = text


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


# ----------------------------------------------------------------------------- reading


def _read_array(ds: h5py.Dataset) -> np.ndarray:
    if h5py.check_string_dtype(ds.dtype) is not None:
        return ds.asstr()[()].astype(str)
    data = ds[()]
    if ds.attrs.get(_BOOL_ATTR) == "bool":
        data = data.astype(bool)
    return np.asarray(data)


def read_table(path: str | Path, name: str) -> dict[str, np.ndarray]:
    """Read the columns of a table as plain arrays (without the row index).

    ``pandas.DataFrame(read_table(path, name))`` is the table as a data frame.

    Parameters
    ----------
    path : str or pathlib.Path
        The HDF5 file.
    name : str
        The table's group.

    Returns
    -------
    dict of str to ndarray
        Column name → values, shape (n_rows,), in the file's order; booleans as bool, text as
        ``str`` arrays.
    """
    with h5py.File(path, "r") as f:
        g = f[name]
        return {k: _read_array(ds) for k, ds in g.items() if k != _ROW_DIM}


def read_provenance(path: str | Path) -> dict[str, Any]:
    """Read the provenance attributes of a dataset file.

    Parameters
    ----------
    path : str or pathlib.Path
        The HDF5 file.

    Returns
    -------
    dict of str to object
        The attributes of its ``provenance`` group, without ``description``; bytes decoded to
        ``str``.
    """
    with h5py.File(path, "r") as f:
        return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f["provenance"].attrs.items()
            if k != "description"}


def read_dataset(path: str | Path) -> Dataset:
    """Read a whole file written by :func:`write_dataset` back into a :class:`Dataset`.

    A group with a ``row`` dimension scale is a table; any other group but ``provenance`` is a
    grid (its dimension scales the coordinates).

    Parameters
    ----------
    path : str or pathlib.Path
        The HDF5 file.

    Returns
    -------
    Dataset
        Its title, scenario, root attributes (``history`` included), group descriptions,
        tables and grids.
    """
    out = Dataset()
    with h5py.File(path, "r") as f:
        out.title = str(f.attrs.get("title", ""))
        out.scenario = str(f.attrs.get("scenario", ""))
        out.attrs = {k: v for k, v in f.attrs.items() if k not in _ROOT_OWN or k == "history"}
        for gname, g in f.items():
            if gname == "provenance":
                continue
            if g.attrs.get("description"):
                out.descriptions[gname] = str(g.attrs["description"])

            def col(ds: h5py.Dataset, dims: tuple[str, ...] = ()) -> Column:
                return Column(_read_array(ds), str(ds.attrs.get("units", "")),
                              str(ds.attrs.get("description", "")), dims)

            if _ROW_DIM in g and g[_ROW_DIM].is_scale:
                out.tables[gname] = {k: col(ds) for k, ds in g.items() if k != _ROW_DIM}
            else:
                coords = {k: col(ds) for k, ds in g.items() if ds.is_scale}
                variables = {}
                for k, ds in g.items():
                    if ds.is_scale:
                        continue
                    dims = tuple(ds.dims[i][0].name.rsplit("/", 1)[-1] for i in range(ds.ndim))
                    variables[k] = col(ds, dims)
                out.grids[gname] = (coords, variables)
    return out


__all__ = [
    "Column",
    "column",
    "Dataset",
    "make_provenance",
    "git_revision",
    "utc_now",
    "write_dataset",
    "atomic_h5file",
    "create_array",
    "create_row_scale",
    "stored_values",
    "is_text",
    "TEXT_SLICE_ROWS",
    "write_root_attrs",
    "history_line",
    "command_line",
    "package_version",
    "CONVENTIONS",
    "LONG_NAME_MAX",
    "write_provenance",
    "write_group_descriptions",
    "check_attributes",
    "long_name",
    "PROVENANCE_DESCRIPTION",
    "read_dataset",
    "read_table",
    "read_provenance",
]

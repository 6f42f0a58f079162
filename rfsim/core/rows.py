"""Tables built block by block: rows appended per case (or per trial) and joined into columns
once, when the dataset is written; and the reading back of one contiguous block of rows.

A scalar appended to a block is kept as a read-only broadcast view (no memory until the column is
joined); text comes back as an object array whose rows share one ``str`` per distinct value
(8 bytes a row instead of 4 bytes a character); a text column given by an index into a list of
names (:class:`IndexedText`) is expanded only when written.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from rfsim.core.dataset import Column, Dataset, column
from rfsim.core.lazy import lazy_import

h5py = lazy_import("h5py")


class IndexedText:
    """A text column held as integer indices, expanded to strings only when written.

    Row r is ``name(index[r])``, one ``str`` object per distinct index (e.g. a tag's EPC from
    its number).

    Parameters
    ----------
    index : array_like of int, shape (n_rows,)
        Non-negative index of each row.
    name : callable
        ``name(k) -> str``, the text of index ``k``.

    Attributes
    ----------
    index : ndarray
        The indices.
    size : int
        Number of rows.
    name : callable
        As given.
    """

    def __init__(self, index: np.ndarray, name: Callable[[int], str]):
        self.index = np.asarray(index)
        self.size = self.index.size
        self.name = name

    def strings(self) -> np.ndarray:
        """Expand the rows to an object array of strings.

        ``name`` is called once for each k in 0 … ``index.max()``.

        Returns
        -------
        ndarray of object, shape (n_rows,)
            One ``str`` per index, shared by that index's rows.
        """
        names = np.array([self.name(k) for k in range(int(self.index.max(initial=-1)) + 1)], dtype=object)
        return names[self.index] if self.size else np.zeros(0, dtype=object)


def _shared_text(part: np.ndarray) -> np.ndarray:
    """A text part as an object array with one ``str`` object per distinct value."""
    if part.size and part.strides == (0,):   # a broadcast scalar (the usual case)
        shared = np.empty(part.size, dtype=object)
        shared.fill(str(part[0]))   # one object in every row (np.full would copy it per row)
        return shared
    values, index = np.unique(part, return_inverse=True)
    return np.array([str(v) for v in values], dtype=object)[index.reshape(-1)]


def join_parts(parts) -> np.ndarray:
    """Join one column from its parts.

    If any part is text (``U`` dtype or :class:`IndexedText`), the column is an object array
    with one ``str`` object per distinct value in each part; else the parts are concatenated.

    Parameters
    ----------
    parts : sequence of ndarray or IndexedText
        1-D arrays (possibly read-only broadcast scalars) and text columns, in row order.

    Returns
    -------
    ndarray, shape (n_rows,)
        The column.
    """
    if any(isinstance(p, IndexedText) or p.dtype.kind == "U" for p in parts):
        return np.concatenate([p.strings() if isinstance(p, IndexedText) else _shared_text(p) for p in parts])
    return np.concatenate(parts)


class RowTables:
    """Columns of several tables accumulated block by block (see the module docstring).

    Attributes
    ----------
    rows : dict of str to dict of str to list
        Table name → column name → the parts appended so far.
    """

    def __init__(self):
        self.rows = defaultdict(lambda: defaultdict(list))

    def extend(self, table: str, **cols) -> None:
        """Append one block of rows to a table.

        Parameters
        ----------
        table : str
            Name of the table.
        **cols : array_like or IndexedText
            Column name → values of the block: arrays (raveled), :class:`IndexedText`, or
            scalars, broadcast (as read-only views) to the block's length, that of the longest
            array.
        """
        n = max(v.size if isinstance(v, IndexedText) else np.size(v) for v in cols.values())
        for k, v in cols.items():
            if isinstance(v, IndexedText):
                self.rows[table][k].append(v)
            else:
                self.rows[table][k].append(np.broadcast_to(np.asarray(v), (n,)) if np.ndim(v) == 0 else np.ravel(v))

    def write(self, ds: Dataset, units: Mapping[str, tuple[str, str]], descriptions: Mapping[str, str]) -> None:
        """Join every column and add the tables to a dataset.

        The columns are joined one at a time, each one's parts freed as it is joined, and the
        accumulated rows are emptied.

        Parameters
        ----------
        ds : rfsim.core.dataset.Dataset
            The dataset the tables are added to.
        units : mapping of str to (str, str)
            Column name → (unit, description); a column not in it gets unit ``""`` and its name
            as description.
        descriptions : mapping of str to str
            Table name → what one row is; every table needs an entry.
        """
        for name in list(self.rows):
            cols = self.rows.pop(name)
            out = {}
            for k in list(cols):
                parts = cols.pop(k)
                joined = join_parts(parts)
                out[k] = (Column(joined, *units.get(k, ("", k))) if joined.dtype == object
                          else column(joined, *units.get(k, ("", k))))
                del parts
            ds.add_table(name, out, description=descriptions[name])


def read_block(path: str | Path, table: str, key: str, value, names) -> dict[str, np.ndarray]:
    """Read the rows of a table whose key column equals a value, without loading the whole table.

    Those rows must be contiguous (a table written block by block): the rows from the first
    to the last match are read.

    Parameters
    ----------
    path : str or pathlib.Path
        The HDF5 dataset.
    table : str
        The table's group.
    key : str
        Column to match.
    value : object
        The value of ``key`` the rows have.
    names : iterable of str
        Columns to read.

    Returns
    -------
    dict of str to ndarray
        Column name → values of the block (text as ``str`` arrays, booleans as bool); empty
        float arrays when no row matches.
    """
    with h5py.File(path, "r") as f:
        g = f[table]
        rows = np.flatnonzero(g[key][()] == value)
        if rows.size == 0:
            return {k: np.zeros(0) for k in names}
        sl = slice(int(rows[0]), int(rows[-1]) + 1)
        out = {}
        for k in names:
            ds = g[k]
            if h5py.check_string_dtype(ds.dtype) is not None:
                out[k] = ds.asstr()[sl].astype(str)
            else:
                v = ds[sl]
                out[k] = v.astype(bool) if ds.attrs.get("rfsim_dtype") == "bool" else v
        return out


__all__ = ["IndexedText", "join_parts", "RowTables", "read_block"]

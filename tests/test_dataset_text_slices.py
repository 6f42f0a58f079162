"""Text columns are written in slices: the file must equal one written whole by h5py."""

import h5py
import numpy as np
import pytest

import rfsim.core.dataset as dsmod
from rfsim.core.dataset import Column, Dataset, write_dataset

#: non-ASCII, empty and long strings, 10 rows: more than 3 slices of 3 rows
TEXT = np.array(["", "µ", "Özkaya", "", "a" * 40, "ß€😀", "fixed", "", "mobile", "x"])


def _write(tmp_path, name, data, monkeypatch, rows):
    monkeypatch.setattr(dsmod, "TEXT_SLICE_ROWS", rows)
    ds = Dataset(title="t")
    ds.add_table("tab", {"s": Column(data, "", "a text column")})
    return write_dataset(tmp_path / name, ds, {"seed": 1})


def _whole(tmp_path):
    """The reference: the column written whole, straight through h5py."""
    path = tmp_path / "whole.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("s", data=TEXT.astype(object), dtype=h5py.string_dtype("utf-8"))
    return path


@pytest.mark.parametrize("data", [TEXT, TEXT.astype(object)], ids=["U", "object"])
@pytest.mark.parametrize("rows", [3, 1 << 16])
def test_text_column_written_in_slices_equals_whole_write(tmp_path, monkeypatch, data, rows):
    path = _write(tmp_path, "sliced.h5", data, monkeypatch, rows)
    with h5py.File(path, "r") as f, h5py.File(_whole(tmp_path), "r") as g:
        a, b = f["tab/s"], g["s"]
        assert a.dtype == b.dtype and h5py.check_string_dtype(a.dtype).encoding == "utf-8"
        assert a.shape == b.shape == (10,)
        assert (a.chunks, a.compression) == (b.chunks, b.compression) == (None, None)
        assert a.id.get_create_plist().get_layout() == b.id.get_create_plist().get_layout()
        assert list(a.asstr()[()]) == list(b.asstr()[()]) == list(TEXT)
        assert a[()].tolist() == b[()].tolist()   # the raw UTF-8 bytes


def test_empty_text_column(tmp_path, monkeypatch):
    path = _write(tmp_path, "empty.h5", np.zeros(0, dtype="<U1"), monkeypatch, 3)
    with h5py.File(path, "r") as f:
        assert f["tab/s"].shape == (0,) and h5py.check_string_dtype(f["tab/s"].dtype) is not None

"""The append-only point store: exact round trip, torn records, lost index entries, newest
segment wins; a toy sweep of 1,000 runs: few files, exact resume and bit-identical merges."""

from __future__ import annotations

import os

import numpy as np
import pytest

import rfsim.bench.sweep_scale as toy
from rfsim.core.dataset import Column, Dataset, column, read_dataset
from rfsim.sweep import PoolExecutor, SerialExecutor, StoreIndex, parse_spec, points_dir, run_sweep
from rfsim.sweep.store import (INDEX_DTYPE, INDEX_MAGIC, DamagedIndexError, RecordReader, SegmentWriter, decode_dataset,
                               encode_dataset, read_index, repair_store)
from test_sweep_run import assert_identical


def sample_dataset(value: float) -> Dataset:
    ds = Dataset(title="t", scenario="s")
    ds.add_table("t", {"x": column([value, 2.0], "m", "x"), "ok": column([True, False], "1", "flag"),
                       "name": column(["a", "bcd"], "", "label"), "n": column(np.array([1, 2], np.int32), "1", "n")})
    ds.add_grid("g", {"f": column([1.0, 2.0, 3.0], "Hz", "f")},
                {"p": column([0.5, 0.25, value], "W", "p")})
    ds.attrs.update({"a": 1.5, "b": 7, "c": "text", "d": np.float32(2.5)})
    return ds


def append(writer: SegmentWriter, point: int, value: float, digest: bytes = b"\x01" * 16) -> None:
    desc, buffers = encode_dataset(sample_dataset(value))
    header = {"point": point, "repetition": 0, "seed": 9, "config_sha256_16": digest.hex(), "dataset": desc}
    writer.append(point, 0, 9, digest, header, buffers)


def test_encode_decode_round_trip_is_exact():
    ds = sample_dataset(3.25)
    desc, buffers = encode_dataset(ds)
    back = decode_dataset(desc, b"".join(buffers))
    for name, col in ds.tables["t"].items():
        got = back.tables["t"][name]
        assert got.data.dtype == col.data.dtype and np.array_equal(got.data, col.data)
        assert (got.units, got.description) == (col.units, col.description)
    assert np.array_equal(back.grids["g"][1]["p"].data, ds.grids["g"][1]["p"].data)
    assert back.grids["g"][1]["p"].dims == ("f",)
    assert back.attrs == {"a": 1.5, "b": 7, "c": "text", "d": np.float32(2.5)}
    assert type(back.attrs["d"]) is np.float32


def test_a_text_column_of_shared_str_objects_is_stored_as_fixed_width_text():
    """rss-localization holds its text columns as object arrays of str (one shared object per
    value); the store keeps them as U text, equal element by element; other objects are refused."""
    labels = np.empty(5, dtype=object)
    labels[:3] = "nn"
    labels[3:] = "grid-map"
    ds = Dataset(title="t", scenario="s")
    ds.add_table("t", {"estimator": Column(labels, "", "label")})
    desc, buffers = encode_dataset(ds)
    got = decode_dataset(desc, b"".join(buffers)).tables["t"]["estimator"].data
    assert got.dtype.kind == "U" and got.tolist() == ["nn", "nn", "nn", "grid-map", "grid-map"]
    bad = Dataset(title="t", scenario="s")
    bad.add_table("t", {"x": Column(np.array([1, "a"], dtype=object), "", "mixed")})
    with pytest.raises(TypeError, match="'x'"):
        encode_dataset(bad)


def test_a_torn_last_record_is_ignored(tmp_path):
    w = SegmentWriter(tmp_path)
    for p in range(3):
        append(w, p, float(p))
    w.close()
    size = w.log_path.stat().st_size
    with open(w.log_path, "r+b") as f:  # a writer killed in the middle of its last record
        f.truncate(size - 100)
    [(log, entries)] = list(read_index(tmp_path))
    assert list(entries["point"]) == [0, 1]
    assert len(StoreIndex(tmp_path)) == 2


def test_a_record_without_its_index_entry_is_recovered_if_complete(tmp_path):
    w = SegmentWriter(tmp_path)
    for p in range(3):
        append(w, p, float(p))
    w.close()
    raw = w.index_path.read_bytes()
    w.index_path.write_bytes(raw[:len(INDEX_MAGIC) + 2 * INDEX_DTYPE.itemsize + 10])  # killed while writing entry 3
    [(log, entries)] = list(read_index(tmp_path))
    assert list(entries["point"]) == [0, 1, 2]
    ref = StoreIndex(tmp_path).find(2, 0, 9, b"\x01" * 16)
    with RecordReader() as reader:
        header, payload = reader.read(ref)
    assert decode_dataset(header["dataset"], payload).tables["t"]["x"].data[0] == 2.0


def test_a_corrupt_unindexed_record_is_not_used(tmp_path):
    w = SegmentWriter(tmp_path)
    for p in range(2):
        append(w, p, float(p))
    w.close()
    w.index_path.write_bytes(w.index_path.read_bytes()[:len(INDEX_MAGIC) + INDEX_DTYPE.itemsize])
    data = bytearray(w.log_path.read_bytes())
    data[-20] ^= 0xFF  # a flipped bit in the second record's payload: its CRC fails
    w.log_path.write_bytes(bytes(data))
    assert [int(p) for _, e in read_index(tmp_path) for p in e["point"]] == [0]


def test_every_flipped_bit_of_an_index_is_named(tmp_path):
    """Each of the bits of the header and of an entry, flipped alone, makes the index
    damaged, naming the file (and the entry); the repair restores the appended bytes."""
    w = SegmentWriter(tmp_path)
    for p in range(3):
        append(w, p, float(p))
    w.close()
    sound = w.index_path.read_bytes()
    assert len(sound) == len(INDEX_MAGIC) + 3 * INDEX_DTYPE.itemsize == 8 + 3 * 64
    entry_1 = len(INDEX_MAGIC) + INDEX_DTYPE.itemsize
    for at in [*range(len(INDEX_MAGIC)), *range(entry_1, entry_1 + INDEX_DTYPE.itemsize)]:
        for bit in range(8):
            raw = bytearray(sound)
            raw[at] ^= 1 << bit
            w.index_path.write_bytes(bytes(raw))
            with pytest.raises(DamagedIndexError) as info:
                list(read_index(tmp_path))
            message = str(info.value)
            assert str(w.index_path) in message and "rfsim sweep repair" in message, (at, bit)
            assert ("entry 1 of 3 has" in message) if at >= entry_1 else ("entry 1 " not in message), (at, bit)
    assert repair_store(tmp_path) == [(w.index_path, 3)]
    assert w.index_path.read_bytes() == sound


def test_an_index_without_checksums_is_still_read(tmp_path):
    """An index of format 1 (56-byte entries, no header, no checksum) finds the same runs."""
    w = SegmentWriter(tmp_path)
    for p in range(3):
        append(w, p, float(p))
    w.close()
    [(_, entries)] = list(read_index(tmp_path))
    old = np.zeros(3, [(name, INDEX_DTYPE[name]) for name in INDEX_DTYPE.names if name != "crc32"])
    for name in old.dtype.names:
        old[name] = entries[name]
    assert old.dtype.itemsize == 56
    w.index_path.write_bytes(old.tobytes())
    [(_, back)] = list(read_index(tmp_path))
    assert back.tobytes() == entries.tobytes()
    assert repair_store(tmp_path) == []
    w.index_path.write_bytes(old.tobytes()[:56 + 8] + (2**50).to_bytes(8, "little") + old.tobytes()[56 + 16:])
    with pytest.raises(DamagedIndexError, match="entry 1 of 3 has a repetition outside"):
        list(read_index(tmp_path))


def test_an_index_torn_in_its_header_has_no_entries(tmp_path):
    w = SegmentWriter(tmp_path)
    append(w, 0, 1.0)
    w.close()
    w.index_path.write_bytes(INDEX_MAGIC[:5])  # the writer killed while writing the header
    [(_, entries)] = list(read_index(tmp_path))
    assert list(entries["point"]) == [0]  # its record is found in the log


def test_the_newest_segment_wins_and_other_digests_do_not_match(tmp_path):
    old = SegmentWriter(tmp_path)
    append(old, 0, 1.0)
    old.close()
    new = SegmentWriter(tmp_path)
    append(new, 0, 2.0)
    append(new, 1, 5.0, digest=b"\x02" * 16)
    new.close()
    index = StoreIndex(tmp_path)
    assert index.find(0, 0, 9, b"\x01" * 16).log == new.log_path
    assert index.find(1, 0, 9, b"\x01" * 16) is None  # point 1 was run with another config
    assert index.find(0, 0, 8, b"\x01" * 16) is None  # ... and no run with another seed


def toy_spec(folder, n_points=100, reps=10):
    return parse_spec({"scenario": toy.NAME, "seed": 4, "repetitions": reps, "output": str(folder / "toy.h5"),
                       "base": {"rows": 8},
                       "axes": [{"kind": "grid", "key": "gain_db",
                                 "values": [float(v) for v in np.linspace(-10, 10, n_points)]}]})


def test_a_1000_run_toy_sweep_writes_few_files_and_resumes_exactly(tmp_path):
    (tmp_path / "serial").mkdir()
    (tmp_path / "pool").mkdir()
    serial = run_sweep(toy_spec(tmp_path / "serial"), SerialExecutor(), module=toy)
    spec = toy_spec(tmp_path / "pool")
    first = run_sweep(spec, PoolExecutor(2), merge=False, module=toy)
    assert first.computed == 1000
    store = points_dir(spec.output)
    assert len(list(store.iterdir())) == 4  # one log + one index per worker, not 1000 files
    # lose the second half of one segment (a crash before the data reached the disk)
    log = sorted(store.glob("seg-*.log"))[0]
    with open(log, "r+b") as f:
        f.truncate(log.stat().st_size // 2)
    left = len(StoreIndex(store))
    assert 500 <= left < 1000
    again = run_sweep(spec, PoolExecutor(2), resume=True, module=toy)
    assert (again.computed, again.reused) == (1000 - left, left)
    assert assert_identical(serial.output, again.output) > 10
    merged = read_dataset(again.output)
    assert len(merged.tables["reads"]["power_w"].data) == 1000 * 8
    assert merged.grids["spectrum"][1]["p_w"].data.shape == (100, 10, 16)
    # each stacked slice is exactly that run's own grid, computed afresh
    from rfsim.sweep import point_seed
    alone = toy.run(toy.Config(gain_db=float(np.linspace(-10, 10, 100)[73]), rows=8), seed=point_seed(4, 73, 7))
    assert np.array_equal(merged.grids["spectrum"][1]["p_w"].data[73, 7], alone.grids["spectrum"][1]["p_w"].data)
    assert os.path.getsize(again.output) <= 1.5 * sum(p.stat().st_size for p in store.iterdir())


@pytest.mark.parametrize("where,message", [("header", "header unreadable"), ("payload", "fails its CRC")])
def test_a_corrupt_indexed_record_stops_the_merge_with_one_line(where, message, tmp_path):
    from rfsim.core.errors import UserError
    from rfsim.sweep import merge_sweep

    spec = toy_spec(tmp_path, n_points=3, reps=1)
    run_sweep(spec, SerialExecutor(), merge=False, module=toy)
    [(log, entries)] = list(read_index(points_dir(spec.output)))
    start, length = int(entries["offset"][1]), int(entries["length"][1])
    data = bytearray(log.read_bytes())
    data[start + 30 if where == "header" else start + length - 20] ^= 0xFF  # one damaged byte in record 1
    log.write_bytes(bytes(data))
    with pytest.raises(UserError, match=message + r".* move that segment") as info:
        merge_sweep(spec, module=toy)
    assert "\n" not in str(info.value)
    assert not spec.output.exists()

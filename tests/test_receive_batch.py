"""The reader's reads of a batch of windows in one call (``Reader.receive_batch``, the decoder's
"known" search on a ``(B, n)`` batch, ``receive_batch_kernel``) equal its reads window by window,
record for record."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.core.rng import trial_rng
from rfsim.gen2.reply_decoder import decode
from test_batch import DISTANCES, SEED, assert_same_exchange, devices, query_of
from test_reader import T0_S, epc_bits, make_reader, synth_rx


def _same_read(a, b):
    """Two ReadResults equal field for field (NaN equal to NaN, bits by value)."""
    for k in a.__dataclass_fields__ if hasattr(a, "__dataclass_fields__") else a._fields:
        va, vb = getattr(a, k), getattr(b, k)
        if isinstance(va, np.ndarray) or isinstance(vb, np.ndarray):
            assert va is not None and vb is not None and np.array_equal(va, vb), k
            assert va.dtype == vb.dtype, k
        elif isinstance(va, float) and math.isnan(va):
            assert isinstance(vb, float) and math.isnan(vb), k
        else:
            assert va == vb and type(va) is type(vb), k


def _windows(reader, n_bits, seed):
    """Five windows of equal length: replies at several SNRs and phases, one of noise only."""
    rows = []
    for trial, snr_db in enumerate((30.0, 8.0, 3.0, None, 15.0)):
        rng = trial_rng(seed, n_bits, trial)
        bits = epc_bits(rng) if n_bits == 128 else rng.integers(0, 2, 16).astype(np.uint8)
        h = 0j if snr_db is None else 10 ** (-65 / 20) * np.exp(1j * (0.3 + trial))
        rx, _ = synth_rx(reader, bits, h=h, snr_db=0.0 if snr_db is None else snr_db, rng=rng)
        if snr_db is None:
            rx = rx + 1e-6 * (rng.standard_normal(rx.size) + 1j * rng.standard_normal(rx.size))
        rows.append(rx)
    return np.stack(rows)


@pytest.mark.parametrize("profile, n_bits, decoder", [("miller4-320k", 128, "viterbi"), ("miller4-320k", 16, "viterbi"),
                                                      ("fm0-640k", 128, "viterbi"), ("fm0-40k", 16, "bitwise")])
def test_receive_batch_equals_receive_window_by_window(profile, n_bits, decoder):
    reader = make_reader(profile=profile, decoder=decoder)
    rx = _windows(reader, n_bits, 81)
    kw = dict(t0_s=T0_S, n_bits=n_bits, expect_crc=n_bits == 128, cmd_end_s=T0_S, carrier=0.3 - 0.8j)
    batch = reader.receive_batch(rx, **kw)
    single = [reader.receive(row, **kw) for row in rx]
    assert len(batch) == len(single) == rx.shape[0]
    reasons = {r.failure_reason for r in single}
    assert "" in reasons and "preamble not found" in reasons  # reads and a window without a reply
    for a, b in zip(batch, single):
        _same_read(a, b)


def test_batch_windows_keep_their_own_lags():
    """Each window is searched over its own lo…hi: window 1's reply starts 300 samples later
    and is searched there; with window 0's lags it is missed (the test can fail)."""
    reader = make_reader(profile="miller4-320k")
    rng = trial_rng(82)
    shift = 300
    rx0, start = synth_rx(reader, epc_bits(rng), h=10 ** (-65 / 20) * np.exp(0.4j), snr_db=20.0, rng=rng)
    rx1, _ = synth_rx(reader, epc_bits(rng), h=10 ** (-65 / 20) * np.exp(2.1j), snr_db=20.0, rng=rng)
    rx0 = np.concatenate([rx0, np.full(shift, rx0[-1])])  # windows of equal length,
    rx1 = np.concatenate([np.full(shift, rx1[0]), rx1])  # window 1's reply later
    lk = reader.link
    n_reply = int(math.ceil(lk.reply_duration_s(128) * reader.fs_hz))
    plan = reader._receive_memo().known
    lo0, hi0 = int(start) - 20, int(start) + 20
    lo, hi = np.array([lo0, lo0 + shift]), np.array([hi0, hi0 + shift])
    kw = dict(n_bits=128, n_reply=n_reply, crc=True)
    out = decode(np.stack([rx0, rx1]), plan, lo=lo, hi=hi, **kw)
    own = [decode(rx0, plan, lo=lo0, hi=hi0, **kw), decode(rx1, plan, lo=lo0 + shift, hi=hi0 + shift, **kw)]
    for b, o in enumerate(own):
        assert o.found and o.crc_ok
        assert (bool(out.found[b]), float(out.start[b]), float(out.corr[b]), out.crc_ok[b]) == (
            o.found, o.start, o.corr, o.crc_ok)
        assert np.array_equal(out.bits[b], o.bits)
        assert (complex(out.gain[b]), float(out.sigma2[b]), float(out.slope[b])) == (o.gain, o.sigma2, o.slope)
    assert abs(out.start[1] - out.start[0] - shift) < 1
    swapped = decode(rx1, plan, lo=lo0, hi=hi0, **kw)  # window 1 with window 0's lags
    assert not (swapped.found and swapped.start == out.start[1])


def test_run_exchanges_reads_a_command_s_replies_in_one_call(monkeypatch):
    """The trials that reply to one command are read by one ``receive_batch`` (no read window by
    window), and the records equal the separate runs'."""
    from rfsim.devices.reader import Reader
    from rfsim.protocols.batch import run_exchanges
    from rfsim.protocols.engine import run_exchange

    near = (1.0, 2.0, 3.0, 2.5)
    reader, tags, channel = devices(near)
    calls = []
    single_receive = Reader.receive
    monkeypatch.setattr(Reader, "receive", lambda self, *a, **k: calls.append(1) or single_receive(self, *a, **k))
    batch = run_exchanges(reader, tags, channel, query_of(reader), t_s=0.25,
                          rngs=[trial_rng(SEED, 2, b) for b in range(len(near))], reply_bits=16, expect_crc=False)
    assert calls == []
    reader2, tags2, channel2 = devices(near)
    single = [run_exchange(reader2, tags2[b], channel2, query_of(reader2), t_s=0.25, rng=trial_rng(SEED, 2, b),
                           reply_bits=16, expect_crc=False) for b in range(len(near))]
    assert len(calls) == len(near)
    assert any(ex.success for ex in single)
    for a, b in zip(batch, single):
        assert_same_exchange(a, b)


def _shifted_windows(reader, seed):
    """Windows of different starts and lengths, as the EPC reads of an ACK batch: window b begins
    ``lead`` samples before its own command's end (at its own absolute time), ends ``tail`` samples
    after the reply's window; the reply of window 3 is noise only, window 4 is too short for a
    reply. Returns (windows, t0_s, cmd_end_s, carrier, true start [samples of each window])."""
    fs = reader.fs_hz
    rng = trial_rng(seed)
    rows, t0s, ends, carriers, starts = [], [], [], [], []
    for b, (lead, tail, snr_db) in enumerate(((0, 0, 25.0), (137, 41, 12.0), (290, 3, 30.0), (55, 200, None),
                                              (411, 0, 20.0), (23, 7, 18.0))):
        h = 10 ** (-65 / 20) * np.exp(1j * (0.5 + 1.1 * b))
        rx, start = synth_rx(reader, epc_bits(rng), h=0j if snr_db is None else h,
                             snr_db=0.0 if snr_db is None else snr_db, rng=rng)
        if snr_db is None:
            rx = rx + 1e-6 * (rng.standard_normal(rx.size) + 1j * rng.standard_normal(rx.size))
        rx = np.concatenate([np.full(lead, rx[0]), rx, np.full(tail, rx[-1])])
        if b == 4:
            rx = rx[:lead + int(start) // 2]  # no room for a reply after the command's end
        t0 = 3.0 + 0.0125 * b + 0.37 / fs * b  # each window its own time base, off the sample grid
        rows.append(rx)
        t0s.append(t0)
        ends.append(t0 + lead / fs)
        carriers.append(np.exp(1j * (0.2 - 0.7 * b)))
        starts.append(lead + start)
    return rows, t0s, ends, carriers, starts


@pytest.mark.parametrize("profile, decoder", [("miller4-320k", "viterbi"), ("fm0-640k", "bitwise")])
def test_receive_batch_of_windows_with_their_own_starts(profile, decoder):
    """EPC reads of windows that differ in length, first sample time, command end and carrier
    (each its own lags and time base) in one call equal the reads window by window, record for
    record; each read is found where its own window's reply is (a window read with another's
    offset or time base is not: the test can fail)."""
    reader = make_reader(profile=profile, decoder=decoder)
    rows, t0s, ends, carriers, starts = _shifted_windows(reader, 83)
    kw = dict(n_bits=128, expect_crc=True)
    batch = reader.receive_batch(rows, t0_s=t0s, cmd_end_s=ends, carrier=carriers, **kw)
    single = [reader.receive(row, t0_s=t, cmd_end_s=e, carrier=c, **kw)
              for row, t, e, c in zip(rows, t0s, ends, carriers)]
    assert [r.failure_reason for r in single] == ["", "", "", "preamble not found", "preamble not found", ""]
    for a, b in zip(batch, single):
        _same_read(a, b)
    fs = reader.fs_hz
    for b in (0, 1, 2, 5):  # the reply found at its own window's start, on its own time base
        assert abs((batch[b].start_s - t0s[b]) * fs - starts[b]) < 0.2
    # another window's time base moves the reply by the difference of the leads (hundreds of samples)
    other = reader.receive(rows[2], t0_s=t0s[1], cmd_end_s=ends[1], carrier=carriers[2], **kw)
    assert not (other.success and other.start_s == batch[2].start_s)


def test_batch_kernel_reads_each_window_at_its_own_offset():
    """``receive_batch_kernel`` on windows one after the other (flat array, starts and ends) equals
    ``receive_kernel`` on each window alone; with the offsets of windows of another length it
    does not (the test can fail)."""
    from rfsim.gen2 import _receive_kernels as rxk

    reader = make_reader(profile="miller4-320k")
    rows, t0s, ends, _, _ = _shifted_windows(reader, 84)
    rows = [rows[b] for b in (0, 1, 2, 5)]
    plan = reader._receive_memo().known
    n_reply = int(math.ceil(reader.link.reply_duration_s(128) * reader.fs_hz))
    lags = [reader.reply_start_lags(row.size, n_reply, t0_s=t, cmd_end_s=e)
            for row, t, e in zip(rows, [t0s[b] for b in (0, 1, 2, 5)], [ends[b] for b in (0, 1, 2, 5)])]
    lo, hi = (np.array(v, dtype=np.int64) for v in zip(*lags))
    threshold = np.array([plan.detection(int(b - a + 1), plan.blf_hz).threshold for a, b in lags])
    args = plan.known_arguments(plan.blf_hz)

    def batch(offsets):
        n = len(rows)
        det, bits = np.zeros((2, n, 129), dtype=np.uint8)
        out_f, out_c, status = np.zeros((n, 4)), np.zeros((n, 1), dtype=np.complex128), np.zeros(n, dtype=np.int64)
        rxk.receive_batch_kernel(np.concatenate(rows), offsets[:-1], offsets[1:], lo, hi, n_reply, threshold, *args,
                                 det, bits, out_f, out_c, status)
        return status, bits, out_f, out_c

    offsets = np.concatenate([[0], np.cumsum([row.size for row in rows])]).astype(np.int64)
    status, bits, out_f, out_c = batch(offsets)
    for b, row in enumerate(rows):
        det1, bits1 = np.zeros((2, 129), dtype=np.uint8)
        f1, c1 = np.zeros(4), np.zeros(1, dtype=np.complex128)
        s1 = rxk.receive_kernel(row, lo[b], hi[b], n_reply, threshold[b], *args, det1, bits1, f1, c1)
        assert (status[b], s1) == (rxk.RECEIVED, rxk.RECEIVED)
        assert np.array_equal(bits[b], bits1) and np.array_equal(out_f[b], f1) and np.array_equal(out_c[b], c1)
    equal = np.concatenate([[0], np.cumsum([rows[0].size] * len(rows))]).astype(np.int64)  # all as long as window 0
    status2, bits2, out_f2, _ = batch(equal)
    assert not all(s == rxk.RECEIVED and np.array_equal(b2, b1) and np.array_equal(f2, f1)
                   for s, b2, b1, f2, f1 in zip(status2[1:], bits2[1:], bits[1:], out_f2[1:], out_f[1:]))


def test_singulate_batch_reads_the_epc_replies_in_one_call(monkeypatch):
    """The EPC replies to the ACKs of a batch (each trial its own ACK, command end and listen
    start) are read by the batch's calls (no read window by window), and every record equals
    the separate singulations'."""
    from rfsim.devices.reader import Reader
    from rfsim.protocols.batch import singulate_batch
    from rfsim.protocols.engine import singulate

    near = (1.0, 2.0, 3.0, 2.5, 1.5)
    reader, tags, channel = devices(near)
    calls, batches = [], []
    single_receive, batch_receive = Reader.receive, Reader.receive_batch
    monkeypatch.setattr(Reader, "receive", lambda self, *a, **k: calls.append(1) or single_receive(self, *a, **k))
    monkeypatch.setattr(Reader, "receive_batch", lambda self, rx, **k: batches.append((len(rx), k["n_bits"])) or
                        batch_receive(self, rx, **k))
    batch = singulate_batch(reader, tags, channel, t_s=0.0, rngs=[trial_rng(SEED, 4, b) for b in range(len(near))],
                            query=query_of(reader), round_index=1)
    assert calls == []
    epc = [e for e in batches if e[1] == 128]
    assert len(epc) == 1 and epc[0][0] == sum(len(s) == 2 for s in batch) >= 3
    reader2, tags2, channel2 = devices(near)
    single = [singulate(reader2, tags2[b], channel2, t_s=0.0, rng=trial_rng(SEED, 4, b), query=query_of(reader2),
                        round_index=1) for b in range(len(near))]
    assert sum(len(s) == 2 and s[1].success for s in single) >= 3
    for a, b in zip(batch, single):
        assert [e.command for e in a] == [e.command for e in b]
        for ea, eb in zip(a, b):
            assert_same_exchange(ea, eb)


def test_receive_batch_reads_windows_where_they_lie():
    """Windows left in one array with gaps and out of order (``Windows``: each its own start and
    end, as the engine's block of reader inputs) read in one call equal the reads window by window,
    record for record; the same call with two windows' places swapped does not (the test can fail)."""
    from rfsim.gen2.reply_decoder import Windows

    reader = make_reader(profile="miller4-320k")
    rows, t0s, ends, carriers, _ = _shifted_windows(reader, 85)
    order = [3, 0, 5, 1, 4, 2]  # the windows' places in the array, with a gap before each
    gap = 17
    buffer = np.zeros(sum(r.size + gap for r in rows), dtype=np.complex128)
    first = np.zeros(len(rows), dtype=np.int64)
    at = 0
    for b in order:
        at += gap
        buffer[at:at + rows[b].size] = rows[b]
        first[b] = at
        at += rows[b].size
    last = first + np.array([r.size for r in rows])
    kw = dict(n_bits=128, expect_crc=True, t0_s=t0s, cmd_end_s=ends, carrier=carriers)
    laid = reader.receive_batch(Windows(buffer, first, last), **kw)
    single = [reader.receive(row, t0_s=t, cmd_end_s=e, carrier=c, n_bits=128, expect_crc=True)
              for row, t, e, c in zip(rows, t0s, ends, carriers)]
    assert sum(r.success for r in single) == 4
    for a, b in zip(laid, single):
        _same_read(a, b)
    first[[0, 2]], last[[0, 2]] = first[[2, 0]].copy(), last[[2, 0]].copy()  # windows 0 and 2 swapped
    swapped = reader.receive_batch(Windows(buffer, first, last), **kw)
    assert not (swapped[0].success and swapped[0].start_s == single[0].start_s
                and swapped[2].success and swapped[2].start_s == single[2].start_s)


def test_measurement_rule_of_a_batch_is_each_read_s():
    """The measurement rule (gain, slope, residual -> RSSI, phase, Doppler, SNR, Eb/N0) over B reads
    equals the rule on each read alone (B = 1), bit for bit, including |h| = 0 and σ² = 0; the values
    are those of the formulas written here; a batch read out of order does not match (the test can fail)."""
    from rfsim.devices.reader_measure import measurements

    rng = trial_rng(86)
    n = 400
    gain = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * 10 ** rng.uniform(-6, -2, n)
    gain[3] = 0
    sigma2 = 10 ** rng.uniform(-16, -9, n)
    sigma2[5] = 0
    slope = rng.uniform(-50, 50, n)
    kw = dict(blf_hz=320e3, fs_hz=4e6, m=4)
    batch = measurements(gain, slope, sigma2, **kw)
    for b in range(n):
        one = measurements([gain[b]], [slope[b]], [sigma2[b]], **kw)
        for k, v in batch.items():
            assert v[b] == one[k][0] or (math.isnan(v[b]) and math.isnan(one[k][0])), (k, b)
    batch = {k: np.array(v) for k, v in batch.items()}
    p = np.abs(gain) ** 2
    with np.errstate(divide="ignore"):
        assert np.allclose(batch["rssi_dbm"][p > 0], 10 * np.log10(p[p > 0]) + 30, rtol=0, atol=1e-9)
        snr = 10 * np.log10(p / sigma2)
    assert batch["rssi_dbm"][3] == -math.inf and batch["snr_db"][3] == math.inf and batch["snr_db"][5] == math.inf
    ok = (p > 0) & (sigma2 > 0)
    assert np.allclose(batch["snr_db"][ok], snr[ok], rtol=0, atol=1e-9)
    assert np.allclose(batch["ebn0_db"][ok], snr[ok] + 10 * math.log10(4e6 * 4 / 320e3), rtol=0, atol=1e-9)
    assert np.allclose(batch["phase_rad"], np.mod(-np.angle(gain), 2 * math.pi), rtol=0, atol=1e-12)
    assert np.array_equal(batch["doppler_hz"], slope / (2 * math.pi))
    rolled = measurements(np.roll(gain, 1), slope, sigma2, **kw)
    assert not np.array_equal(np.array(rolled["rssi_dbm"]), batch["rssi_dbm"])


def test_start_lags_of_a_batch_are_each_window_s():
    """The reply start lags of B windows at once equal :meth:`Reader.reply_start_lags` of each
    (the public rule, a batch of one), with a command end or none; the lags of another window's
    time base differ (the test can fail)."""
    reader = make_reader(profile="miller4-320k")
    rows, t0s, ends, _, _ = _shifted_windows(reader, 87)
    n = [r.size for r in rows]
    lo, hi = reader._start_lags(n, 900, t0s, ends)
    for b in range(len(rows)):
        assert (lo[b], hi[b]) == reader.reply_start_lags(n[b], 900, t0_s=t0s[b], cmd_end_s=ends[b])
        # the rule written here: [end + T1min, end + T1max] in samples, one wider each side, clipped
        t1min, t1max = reader.reply_search_window_s()
        fs = reader.fs_hz
        assert lo[b] == max(0, math.floor((ends[b] + t1min - t0s[b]) * fs) - 1)
        assert hi[b] == min(n[b] - 900, math.ceil((ends[b] + t1max - t0s[b]) * fs) + 1)
    lo0, hi0 = reader._start_lags(n, 900, t0s, [None] * len(rows))
    assert lo0 == [0] * len(rows) and hi0 == [k - 900 for k in n]
    lo2, _ = reader._start_lags(n, 900, t0s[1:] + t0s[:1], ends)
    assert lo2 != lo


def test_run_exchanges_reads_a_block_where_the_air_step_formed_it(monkeypatch):
    """In a batch the air step forms the reader inputs of a block in one array and the reads take
    them there (``Windows``, no copy of the windows); the records equal the separate runs'."""
    from rfsim.devices.reader import Reader
    from rfsim.gen2.reply_decoder import Windows
    from rfsim.protocols.batch import run_exchanges
    from rfsim.protocols.engine import run_exchange

    near = (1.0, 2.0, 3.0, 2.5)
    reader, tags, channel = devices(near)
    seen = []
    batch_read = Reader.receive_batch
    monkeypatch.setattr(Reader, "receive_batch",
                        lambda self, rx, **k: seen.append(type(rx)) or batch_read(self, rx, **k))
    batch = run_exchanges(reader, tags, channel, query_of(reader), t_s=0.25,
                          rngs=[trial_rng(SEED, 2, b) for b in range(len(near))], reply_bits=16, expect_crc=False)
    assert seen == [Windows]
    reader2, tags2, channel2 = devices(near)
    single = [run_exchange(reader2, tags2[b], channel2, query_of(reader2), t_s=0.25, rng=trial_rng(SEED, 2, b),
                           reply_bits=16, expect_crc=False) for b in range(len(near))]
    assert any(ex.success for ex in single)
    for a, b in zip(batch, single):
        assert_same_exchange(a, b)

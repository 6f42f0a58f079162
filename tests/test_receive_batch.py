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

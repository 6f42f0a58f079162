"""The reader's batched receive (``Reader.receive_batch``, ``ReaderPort.receive_all``): B reply
windows read by one kernel call equal B calls of ``Reader.receive``, bit for bit.

The reference is the single-window receive itself (its own tests hold it against the NumPy
twin and the physics); the batch must give every field of every ``ReadResult`` exactly
(``np.array_equal`` on the bits, ``==`` on every float, NaN where NaN). The batch mixes windows
of different lengths and times, successful reads, CRC errors, noise only (preamble not found),
a window too short for a reply and carriers of either polarity.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rfsim.core.rng import trial_rng
from test_reader import T0_S, epc_bits, make_reader, synth_rx


def assert_same_read(a, b):
    fa, fb = dataclasses.asdict(a), dataclasses.asdict(b)
    assert fa.keys() == fb.keys()
    for k in fa:
        va, vb = fa[k], fb[k]
        if isinstance(va, np.ndarray) or isinstance(vb, np.ndarray):
            assert isinstance(va, np.ndarray) and isinstance(vb, np.ndarray), k
            assert va.dtype == vb.dtype and np.array_equal(va, vb), k
        elif isinstance(va, float) and math.isnan(va):
            assert isinstance(vb, float) and math.isnan(vb), k
        else:
            assert va == vb, k


def windows(reader, n_bits):
    """Reply windows of several kinds: ``(rx, t0_s, cmd_end_s, carrier)`` each."""
    out = []
    for k in range(7):
        rng = trial_rng(81, n_bits, k)
        bits = epc_bits(rng) if n_bits == 128 else rng.integers(0, 2, 16).astype(np.uint8)
        if k == 2:
            bits = bits.copy()
            bits[5] ^= 1  # a CRC error for the EPC
        h = 10 ** (-60 / 20) * np.exp(1j * (0.4 + k))
        rx, _ = synth_rx(reader, bits, h=h, snr_db=(25.0, 12.0, 30.0, 0.0, 8.0, 18.0, 40.0)[k], rng=rng,
                         tail_s=(20 + 13 * k) / reader.link.blf_hz)
        if k == 3:  # noise only
            rx, _ = synth_rx(reader, bits, h=0j, snr_db=0.0, rng=rng)
            rx = rx + 1e-6 * (rng.standard_normal(rx.size) + 1j * rng.standard_normal(rx.size)) + 0.03
        t0 = T0_S + 1e-3 * k
        out.append((rx, t0, t0, (None, 1.0 + 0j, -0.7 + 0.2j)[k % 3]))
    short = out[0][0][:40]  # no room for a reply in the search window
    out.insert(4, (short, T0_S, T0_S, None))
    return out


def read_batch(reader, ws, n_bits, expect_crc):
    return reader.receive_batch([w[0] for w in ws], t0_s=[w[1] for w in ws], n_bits=n_bits, expect_crc=expect_crc,
                                cmd_end_s=[w[2] for w in ws], carrier=[w[3] for w in ws])


@pytest.mark.parametrize("profile, n_bits, decoder", [("miller4-320k", 128, "viterbi"), ("miller4-320k", 16, "viterbi"),
                                                      ("fm0-640k", 128, "bitwise")])
def test_receive_batch_equals_receive_per_window(profile, n_bits, decoder, monkeypatch):
    import rfsim.devices.reader as reader_module

    reader = make_reader(profile=profile, decoder=decoder)
    ws = windows(reader, n_bits)
    calls = []
    kernels = reader_module._rbk

    class Counting:
        def receive_batch_kernel(self, *args):
            calls.append(len(args[0]))
            return kernels.receive_batch_kernel(*args)

    monkeypatch.setattr(reader_module, "_rbk", Counting())
    batch = read_batch(reader, ws, n_bits, n_bits == 128)
    assert calls == [len(ws) - 1]  # one kernel call for every window with room for a reply
    single = [reader.receive(rx, t0_s=t0, n_bits=n_bits, expect_crc=n_bits == 128, cmd_end_s=end, carrier=c)
              for rx, t0, end, c in ws]
    reasons = [r.failure_reason for r in single]
    assert "" in reasons and "preamble not found" in reasons
    if n_bits == 128:
        assert "crc error" in reasons
    for a, b in zip(batch, single):
        assert_same_read(a, b)


def test_receive_batch_of_other_receivers_reads_one_by_one():
    # the BLF search keeps state from one read to the next (the RN16's BLF): the batch reads
    # its windows in order through receive, as separate calls do
    ws = windows(make_reader(profile="miller4-320k"), 16)[:3]
    reader = make_reader(profile="miller4-320k", blf_search="preamble")
    batch = read_batch(reader, ws, 16, False)
    reader2 = make_reader(profile="miller4-320k", blf_search="preamble")
    single = [reader2.receive(rx, t0_s=t0, n_bits=16, expect_crc=False, cmd_end_s=end, carrier=c)
              for rx, t0, end, c in ws]
    for a, b in zip(batch, single):
        assert_same_read(a, b)


def test_receive_batch_refuses_a_window_that_is_not_1d():
    reader = make_reader(profile="miller4-320k")
    rx = windows(reader, 16)[0][0]
    with pytest.raises(ValueError, match="rx must be 1-D"):
        reader.receive_batch([rx, rx.reshape(2, -1)], t0_s=[T0_S] * 2, n_bits=16, expect_crc=False,
                             cmd_end_s=[T0_S] * 2, carrier=[None] * 2)


def test_receive_batch_of_a_replaced_receive_reads_through_it():
    reader = make_reader(profile="miller4-320k")
    ws = windows(reader, 16)[:3]
    seen = []
    original = reader.receive

    def receive(rx, **kwargs):
        seen.append(rx.size)
        return original(rx, **kwargs)

    reader.receive = receive
    batch = read_batch(reader, ws, 16, False)
    assert seen == [w[0].size for w in ws]
    for a, (rx, t0, end, c) in zip(batch, ws):
        assert_same_read(a, original(rx, t0_s=t0, n_bits=16, expect_crc=False, cmd_end_s=end, carrier=c))

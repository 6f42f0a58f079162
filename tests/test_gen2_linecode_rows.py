"""decode_reply_rows: rfsim.gen2.linecode.decode_reply on many rows with one setup — the
same detections row by row (bits, start, gain, offset, correlation), None exactly where
decode_reply raises (a zero row: zero gain)."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.gen2.linecode import decode_reply, decode_reply_rows, reply_waveform

FS_HZ, BLF_HZ = 1e6, 48e3


@pytest.mark.parametrize("m, trext", [(2, True), (1, False), (4, False)])
def test_decode_reply_rows_equals_decode_reply_row_by_row(m, trext):
    rng = np.random.default_rng(m)
    n = 3000
    rows = []
    for k in range(6):
        bits = rng.integers(0, 2, 16).astype(np.uint8)
        s = reply_waveform(bits, m=m, trext=trext, blf_hz=BLF_HZ, fs_hz=FS_HZ, t0_s=(40 + 17 * k) / FS_HZ,
                           n_samples=n)
        noise = (0.2 * k) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
        rows.append((0.7 - 0.3j) * s + (0.1 + 0.05j) + noise)
    rows.append(np.zeros(n, complex))  # zero gain: decode_reply raises
    r = np.array(rows)
    kw = dict(n_bits=16, m=m, trext=trext, blf_hz=BLF_HZ, fs_hz=FS_HZ, search_samples=300)
    pick = np.array([6, 0, 3, 5, 1])
    got = decode_reply_rows(r, pick, **kw)
    assert len(got) == pick.size
    for i, det in zip(pick, got):
        try:
            want = decode_reply(r[i], **kw)
        except ValueError:
            assert det is None
            continue
        assert det is not None
        np.testing.assert_array_equal(det.bits, want.bits)
        assert (det.start_sample, det.gain, det.dc, det.corr) == (want.start_sample, want.gain, want.dc, want.corr)
    assert got[0] is None and got[1] is not None and got[1].corr > 0.9  # the zero row, the clean reply

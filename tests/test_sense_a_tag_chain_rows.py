"""The many-positions ST receive chain (:func:`rfsim.devices.sense_a_tag.chain_rows`): its numba
kernel for the diode law against the NumPy/SciPy twin (``lfilter``, ``sosfilt``, the
comparator row by row) within a derived ULP/absolute bound (the kernel's ``math.log`` and NumPy's
``np.log`` may differ by 1 ULP), and against :meth:`STReceiver.chain` row by row (to
rounding: its RC runs in another operation order).

Inputs: a CW of 0.02-1 V peak at 50 Ω (diode argument x = G_v·V/(n·V_T) from ≈ 0.7 to
≈ 37, both series of the I0 kernel) plus an ASK backscatter square wave at BLF and white
noise, drawn from a fixed seed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.devices import st_receiver as sr
from rfsim.devices.sense_a_tag import chain_rows
from reference.devices_sense_a_tag import chain_rows_reference, diode_chain_bounds
from reference.ulp import assert_close_ulp

FS_HZ, BLF_HZ = 1e6, 48e3


def _inputs(n_rows: int = 40, n: int = 1500, seed: int = 7) -> np.ndarray:
    rng = np.random.default_rng(seed)
    v_cw = np.exp(rng.uniform(math.log(0.02), math.log(1.0), n_rows))  # peak volts at 50 Ω
    c = v_cw / math.sqrt(2.0 * 50.0) * np.exp(1j * rng.uniform(-np.pi, np.pi, n_rows))  # √W
    b = 0.1 * c * np.exp(1j * rng.uniform(-np.pi, np.pi, n_rows))
    square = np.where(np.floor(np.arange(n) * 2 * BLF_HZ / FS_HZ) % 2 == 0, 1.0, -1.0)
    noise = 1e-5 * (rng.standard_normal((n_rows, n)) + 1j * rng.standard_normal((n_rows, n)))
    return c[:, None] + b[:, None] * square[None, :] + noise


def _receiver(order: int = 1) -> sr.STReceiver:
    det = sr.EnvelopeDetector(tau_s=1.0 / (2.0 * math.pi * 4.0 * BLF_HZ), law="diode")
    return sr.STReceiver(fs_hz=FS_HZ, blf_hz=BLF_HZ, m=2, trext=True, detector=det, bpf_order=order)


@pytest.mark.parametrize("order", [1, 2])
def test_diode_chain_kernel_meets_the_scipy_twin_contract(order):
    """Envelopes within the ULP bound and band-passed signals within the absolute bound of
    :func:`reference.devices_sense_a_tag.diode_chain_bounds` (derived there: one faithfully rounded
    ``ln`` per sample, amplified by the cancellation in ``ln i0e(X) + X`` and re-rounded in the
    filters); the comparator and its toggles identical, because no band-passed sample of the
    reference lies within that bound of a switching level (asserted)."""
    x = _inputs()
    rx = _receiver(order)
    got, want = chain_rows(rx, x), chain_rows_reference(rx, x)
    max_ulp, atol_bp = diode_chain_bounds(rx, x)
    assert got[0].shape == got[1].shape == got[2].shape == x.shape
    assert_close_ulp(got[0], want[0], max_ulp)
    np.testing.assert_allclose(got[1], want[1], rtol=0.0, atol=atol_bp)
    assert np.abs(np.abs(want[1]) - 0.5 * rx.threshold_v).min() > atol_bp
    np.testing.assert_array_equal(got[2], want[2])
    np.testing.assert_array_equal(got[3], want[3])
    assert (got[3] > 0).any() and (got[3] == 0).any()  # rows above and below the threshold


def test_chain_rows_follows_the_single_chain_row_by_row():
    """The single chain's RC is ``y += a·(u − y)``, the rows' ``y = (1 − a)·y + a·u``
    (lfilter's order): the same filter, equal to rounding."""
    x = _inputs(n_rows=12)
    rx = _receiver()
    env, bp, cmp, tog = chain_rows(rx, x)
    for i in range(x.shape[0]):
        ch = rx.chain(x[i])
        np.testing.assert_allclose(env[i], ch.envelope_v, rtol=1e-13, atol=0.0)
        np.testing.assert_allclose(bp[i], ch.bandpassed_v, rtol=0.0, atol=1e-13 * np.abs(ch.envelope_v).max())
        np.testing.assert_array_equal(cmp[i], ch.comparator)
        assert tog[i] == ch.toggles


@pytest.mark.parametrize("n", [0, 1, 255, 256, 257, 2467])
def test_i0e_kernel_blocks_equal_scipy_bit_for_bit(n):
    """The block-wise I0 kernel of the diode law against scipy.special.i0e with both series
    mixed in every block (shuffled), at block-boundary sizes."""
    from scipy.special import i0e

    rng = np.random.default_rng(n)
    x = np.where(rng.random(n) < 0.2, rng.uniform(-8.0, 8.0, n), rng.uniform(8.0, 60.0, n))
    if n > 3:
        x[:4] = [8.0, np.nextafter(8.0, 9.0), -8.0, 0.0]
        rng.shuffle(x)
    np.testing.assert_array_equal(sr.i0e(x).view(np.int64), i0e(x).view(np.int64))


def test_chain_rows_of_an_odd_count_equal_each_row_alone():
    """The kernel takes rows two at a time (the last of an odd count paired with itself): every
    row's outputs are those of the row run alone, bit for bit, whatever its partner, with one
    and two band-pass sections."""
    x = _inputs(n_rows=7, n=900, seed=11)
    for order in (1, 2):
        rx = _receiver(order)
        env, bp, cmp, tog = chain_rows(rx, x)
        for i in range(x.shape[0]):
            e1, b1, c1, t1 = chain_rows(rx, x[i:i + 1])
            np.testing.assert_array_equal(env[i], e1[0])
            np.testing.assert_array_equal(bp[i], b1[0])
            np.testing.assert_array_equal(cmp[i], c1[0])
            assert tog[i] == t1[0]


def _reply_comparators(rx: sr.STReceiver, bits, n_rows: int, seed: int) -> np.ndarray:
    """Comparator-like rows (±1): the reply's line-code levels after a few samples of −1, with
    some rows flipped in random samples (noise) and some rows repeated."""
    from rfsim.gen2.linecode import reply_waveform

    lv = reply_waveform(bits, m=rx.m, trext=rx.trext, blf_hz=rx.blf_hz, fs_hz=rx.fs_hz, t0_s=30 / rx.fs_hz,
                        n_samples=int(30 + 1.2 * rx.fs_hz * (len(bits) + 30) * rx.m / rx.blf_hz))
    base = np.where(lv > 0, 1.0, -1.0)
    rng = np.random.default_rng(seed)
    rows = np.repeat(base[None, :], n_rows, axis=0)
    for i in range(0, n_rows, 3):  # every third row: flipped samples, a few or (from row 6) beyond repair
        flip = rng.choice(base.size, size=int(rng.integers(1, 20)) if i < 6 else base.size // 3, replace=False)
        rows[i, flip] *= -1.0
    rows[1] = rows[0]  # a noisy row repeated
    return rows


def test_decode_rows_decodes_each_distinct_comparator_output_once(monkeypatch):
    """Rows with equal comparator outputs are decoded once (a memo shared between calls holds
    them), and every row's outcome is that of the row decoded alone
    (:meth:`STReceiver.decode_comparator`: correlation ≥ min_corr and the expected bits)."""
    from rfsim.devices import sense_a_tag as sat

    rx = _receiver()
    bits = np.random.default_rng(3).integers(0, 2, 16).astype(np.uint8)
    cmp = _reply_comparators(rx, bits, 12, seed=5)
    calls = []
    real = sat.decode_reply_rows
    monkeypatch.setattr(sat, "decode_reply_rows", lambda part, idx, **kw: calls.append(len(idx)) or real(part, idx, **kw))
    n = cmp.shape[0]
    env, tog = np.zeros_like(cmp), np.full(n, 10**6)
    memo = {}
    got = sat.decode_rows(rx, env, env, cmp, tog, rows=np.ones(n, bool), expected_bits=bits, start_sample=0,
                          search_samples=None, memo=memo)
    distinct = len({r.tobytes() for r in cmp})
    assert calls == [distinct] and distinct < n
    want = []
    for r in cmp:
        det = rx.decode_comparator(r, n_bits=bits.size)
        want.append(det is not None and det.corr >= rx.min_corr and np.array_equal(det.bits, bits))
    np.testing.assert_array_equal(got, want)
    assert any(want) and not all(want)  # both outcomes occur
    again = sat.decode_rows(rx, env, env, cmp[::-1].copy(), tog, rows=np.ones(n, bool), expected_bits=bits,
                            start_sample=0, search_samples=None, memo=memo)
    assert calls == [distinct, 0]
    np.testing.assert_array_equal(again, want[::-1])

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

"""The reader's receive in one compiled call against its NumPy twin (steps 1–5 of
``Reader.receive`` with NumPy's reductions, ``reference.devices_reader.receive_reference``).

Decisions (found or not, start, bits, CRC) must be identical; the measurements differ only by
the order of the sums (the kernel sums sample by sample, NumPy pairwise
or by BLAS), within the bound derived in :func:`_bounds`.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.core.rng import trial_rng
from reference.devices_reader import receive_reference
from reference.ulp import assert_close_ulp
from test_reader import T0_S, epc_bits, make_reader, synth_rx

U = 2.0 ** -53  # unit round-off of float64


def _bounds(rx, h_abs, sigma_abs, t_reply_s):
    """Largest differences of the measurements between two summation orders.

    Every sum of n terms x_i, in any order, is within (n − 1)·u·Σ|x_i| of the exact sum (Higham,
    Accuracy and Stability of Numerical Algorithms, 2nd ed., eq. 4.4), so two orders differ by at
    most 2n·u·Σ|x_i|/n per term. The receiver's sums run over at most N = rx.size samples whose
    magnitudes are at most A = max|rx| (the leakage dominates; the offset removals r = rx − m and
    r − c add ≤ 2u·A per sample): the gain h = Σ z·s·e^{−jωt}/Σs² differs by at most
    δh = 2N·u·A + 2u·A·2 ≤ 4N·u·A (also each block gain g_k, whose n/K terms are divided by n/K).
    Hence, to first order in δ = δh/|h|: RSSI = 20·log10|h| + 30 by (20/ln 10)·δ dB, the phase
    arg h by δ rad, σ² (mean |e|², |e| ≈ σ) by 2(δh + 2u·A)/σ + 2N·u relative, SNR by
    (10/ln 10)·(2δ + δσ²) dB, the Doppler slope (a weighted line through arg g_k at K = 8 block
    centres spaced T/8: Σ|t_k − t̄| / Σ(t_k − t̄)² = 3.05/T) by 4·δ/(2π·T) Hz. Each result then
    carries a few ULP of its own rounding (log10, atan2, the wrap): + 8 ULP."""
    n, a = rx.size, float(np.max(np.abs(rx)))
    dh = 4 * n * U * a
    rel_h = dh / h_abs
    rel_s2 = 2 * (dh + 2 * U * a) / sigma_abs + 2 * n * U
    return {"rssi_dbm": 20 / math.log(10) * rel_h, "phase_rad": rel_h,
            "snr_db": 10 / math.log(10) * (2 * rel_h + rel_s2), "doppler_hz": 4 * rel_h / (2 * math.pi * t_reply_s)}


def _assert_within(actual, desired, bound, name):
    """``actual`` within ``bound`` of ``desired``, as a ULP count of ``desired`` (+ 8 ULP, see
    :func:`_bounds`)."""
    max_ulp = int(math.ceil(bound / np.spacing(abs(desired)))) + 8
    assert_close_ulp(np.float64(actual), np.float64(desired), max_ulp, err_msg=name)


@pytest.mark.parametrize("profile, n_bits, snr_db, doppler_hz, decoder", [
    ("miller4-320k", 128, 30.0, 0.0, "viterbi"),
    ("miller4-320k", 16, 8.0, 0.0, "viterbi"),
    ("miller4-320k", 128, 4.0, 30.5, "viterbi"),
    ("fm0-640k", 128, 12.0, -6.1, "viterbi"),
    ("fm0-40k", 16, 20.0, 0.0, "bitwise"),
    ("pass-miller2-48k", 128, 10.0, 0.0, "bitwise"),
])
def test_receive_kernel_equals_reference(profile, n_bits, snr_db, doppler_hz, decoder):
    reader = make_reader(profile=profile, decoder=decoder)
    lk = reader.link
    for trial in range(3):
        rng = trial_rng(71, n_bits, int(snr_db), trial)
        bits = epc_bits(rng) if n_bits == 128 else rng.integers(0, 2, 16).astype(np.uint8)
        h = 10 ** (-65 / 20) * np.exp(1j * (0.3 + trial))
        rx, _ = synth_rx(reader, bits, h=h, snr_db=snr_db, rng=rng, doppler_hz=doppler_hz)
        res = reader.receive(rx, t0_s=T0_S, n_bits=n_bits, expect_crc=n_bits == 128, cmd_end_s=T0_S)
        ok, ref_bits, reason, start_s, corr, h_m, slope, sigma2 = receive_reference(
            reader, rx, t0_s=T0_S, n_bits=n_bits, expect_crc=n_bits == 128, cmd_end_s=T0_S)
        # decisions: identical
        assert (res.success, res.failure_reason, res.start_s) == (ok, reason, start_s)
        np.testing.assert_array_equal(res.bits, ref_bits)
        # the preamble correlation: its sums (and the offset removal before them) over at most
        # N samples, each term ≤ A, against a peak of ≈ corr·n_pre·|h|: ≤ 6N·u·A/|h| apart
        _assert_within(res.corr, corr, 6 * rx.size * U * float(np.max(np.abs(rx))) / abs(h), "corr")
        bound = _bounds(rx, abs(h_m), math.sqrt(sigma2), lk.reply_duration_s(n_bits))
        meas = reader._measurements(h_m, slope, sigma2, lk.blf_hz)
        for name, b in bound.items():
            _assert_within(getattr(res, name), meas[name], b, name)
        assert res.ebn0_db - res.snr_db == pytest.approx(meas["ebn0_db"] - meas["snr_db"])


def test_receive_kernel_not_found_equals_reference():
    """Noise only: "preamble not found" at the same start, the correlation within its bound."""
    reader = make_reader(profile="miller4-320k")
    for trial in range(3):
        rng = trial_rng(72, trial)
        rx, _ = synth_rx(reader, epc_bits(rng), h=0j, snr_db=0.0, rng=rng)
        rx = rx + 1e-6 * (rng.standard_normal(rx.size) + 1j * rng.standard_normal(rx.size)) + 0.03
        res = reader.receive(rx, t0_s=T0_S, n_bits=128, expect_crc=True, cmd_end_s=T0_S)
        ok, bits, reason, start_s, corr, *_ = receive_reference(reader, rx, t0_s=T0_S, n_bits=128, expect_crc=True,
                                                                 cmd_end_s=T0_S)
        assert (res.success, res.bits, res.failure_reason, res.start_s) == (ok, bits, reason, start_s)
        assert reason == "preamble not found"
        # as above, with the noise amplitude 1e-6 in place of |h|
        _assert_within(res.corr, corr, 6 * rx.size * U * float(np.max(np.abs(rx))) / 1e-6, "corr")

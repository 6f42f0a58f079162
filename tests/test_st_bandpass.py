"""The ST band-pass designed with NumPy equals SciPy's design bit for bit (the reference is
``scipy.signal.butter`` / ``sosfilt_zi`` themselves), and the ST chain of many rows in one
numba pass equals its SciPy twin (lfilter, sosfilt, comparator): bit for bit where both do the
same exactly rounded steps, within a derived bound for the diode law (its ``ln``)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss

from rfsim.devices import st_receiver as sr
from rfsim.devices.sense_a_tag import chain_rows
from reference.devices_sense_a_tag import chain_rows_reference, diode_chain_bounds
from reference.ulp import assert_close_ulp
from rfsim.devices.st_bandpass import butter_bandpass_sos, sos_steady_state


def _edges(n, seed):
    rng = np.random.default_rng(seed)
    fs = rng.choice([1e6, 2e6, 4e6, 8e6]) * rng.uniform(0.5, 2.0, n)
    lo = rng.uniform(1e-4, 0.45, n) * fs
    hi = lo + rng.uniform(1e-4, 1.0, n) * (0.4999 * fs - lo)
    return fs, lo, hi


def test_order_one_design_equals_scipy_bit_for_bit():
    fs, lo, hi = _edges(3000, 4)
    n_complex = 0
    cases = [(1e6, 6e3, 192e3), (4e6, 40e3, 1.28e6)] + list(zip(fs, lo, hi))  # the ST defaults first
    for f, a, b in cases:
        ours = butter_bandpass_sos(1, a, b, f)
        ref = ss.butter(1, [a, b], btype="bandpass", fs=f, output="sos")
        assert ours.dtype == ref.dtype and ours.shape == ref.shape == (1, 6)
        # exact: the design calls the same NumPy ufuncs (tan, exp, complex sqrt) on the same arrays
        # in SciPy's order, and the steady state solves the same 2×2 system with np.linalg.solve
        assert np.array_equal(ours, ref), (f, a, b)
        assert np.array_equal(sos_steady_state(ours), ss.sosfilt_zi(ref)), (f, a, b)
        n_complex += np.iscomplex(np.roots(ref[0, 3:])).any()
    assert 0 < n_complex < len(cases)  # both kinds of pole pair were met


@pytest.mark.parametrize("order", [2, 3])
def test_higher_orders_are_scipys(order):
    ours = butter_bandpass_sos(order, 5e3, 150e3, 1e6)
    ref = ss.butter(order, [5e3, 150e3], btype="bandpass", fs=1e6, output="sos")
    assert np.array_equal(ours, ref)
    assert np.array_equal(sos_steady_state(ours), ss.sosfilt_zi(ref))


def test_bad_edges_rejected():
    with pytest.raises(ValueError):
        butter_bandpass_sos(1, 100e3, 600e3, 1e6)


@pytest.mark.parametrize("law", ["linear", "diode", "square"])
@pytest.mark.parametrize("fs_hz, blf_hz, order", [(1e6, 48e3, 1), (4e6, 320e3, 1), (2e6, 40e3, 2)])
def test_chain_rows_equals_its_scipy_twin(law, fs_hz, blf_hz, order):
    rng = np.random.default_rng(7)
    det = sr.EnvelopeDetector(tau_s=1.0 / (2.0 * np.pi * 4.0 * blf_hz), law=law)
    rx = sr.STReceiver(fs_hz=fs_hz, blf_hz=blf_hz, m=2, trext=False, detector=det, bpf_order=order)
    n = 2500
    square = np.sign(np.sin(2.0 * np.pi * blf_hz * np.arange(n) / fs_hz))
    x = (0.05 + 0.004 * square) * np.exp(0.3j) + 1e-4 * (rng.standard_normal((4, n)) + 1j * rng.standard_normal((4, n)))
    ours, ref = chain_rows(rx, x), chain_rows_reference(rx, x)
    for a, b in zip(ours, ref):
        assert a.dtype == b.dtype and a.shape == b.shape
    if law == "diode":  # ln in the kernel (C library) and in NumPy (maybe SIMD): the derived contract
        max_ulp, atol_bp = diode_chain_bounds(rx, x)
        assert_close_ulp(ours[0], ref[0], max_ulp)
        np.testing.assert_allclose(ours[1], ref[1], rtol=0.0, atol=atol_bp)
        assert np.abs(np.abs(ref[1]) - 0.5 * rx.threshold_v).min() > atol_bp  # so the comparator cannot differ
        ours, ref = ours[2:], ref[2:]
    for a, b in zip(ours, ref):  # the other laws: the same detector output (NumPy) and exactly the same filter steps
        assert np.array_equal(a, b)
    if law == "linear":
        assert np.all(ref[3] > 10)  # the comparator toggles: the test covers its switching

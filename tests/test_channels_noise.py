"""Noise: PASS golden variances, kTB·F, density × bandwidth, complex AWGN statistics."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.io import loadmat

from rfsim.channels.noise import (
    complex_awgn,
    noise_power_from_density_w,
    pass_noise_variance_w,
    thermal_noise_power_w,
)
from rfsim.core.errors import ConfigError
from rfsim.core.rng import trial_rng


def test_pass_channel_noise_golden(reference_data):
    """results_channel_noise.mat: var = 10^{n0/10−3}/bw·fs/frxs per receiver (100 'wgn' cases)
    and exactly 0 for the 10 'off' cases."""
    m = loadmat(reference_data / "pass-selftest" / "results_channel_noise.mat",
                squeeze_me=True, struct_as_record=False)
    n_wgn = n_off = n_rx = 0
    for s, r in zip(m["settings"], m["results"]):
        n_rx_case = int(np.atleast_1d(s.size)[1])          # size = [length, n_rx]
        n0 = np.atleast_2d(s.n0)                            # (n_rx or 1, 2): [dBm, per Hz]
        frxs = np.atleast_1d(s.frxs)                        # (n_rx or 1,) [Hz]
        ref = np.atleast_1d(r.var).astype(float)
        assert ref.size == n_rx_case and n0.shape[0] in (1, n_rx_case)
        if s.type == "off":
            assert np.all(ref == 0.0)
            n_off += 1
            continue
        assert s.type == "wgn"
        got = np.broadcast_to(pass_noise_variance_w(n0[:, 0], n0[:, 1], s.fs, frxs), ref.shape)
        np.testing.assert_allclose(got, ref, rtol=1e-12)
        n_wgn += 1
        n_rx += ref.size
    assert (n_wgn, n_off) == (100, 10)
    assert n_rx > 100


def test_pass_default_noise_level():
    """pass-paris-simulator.md §2.4: −47 dBm per 3000 Hz = −81.8 dBm/Hz."""
    assert 10 * np.log10(pass_noise_variance_w(-47.0, 3000.0, 1.0, 1.0)) + 30 == pytest.approx(
        -81.77, abs=0.01)


def test_thermal_noise_ktb():
    # k·T0 = 1.380649e-23 J/K · 290 K = 4.0039e-21 W/Hz = −173.975 dBm/Hz (SI-exact k)
    assert thermal_noise_power_w(1.0) == pytest.approx(1.380649e-23 * 290.0, rel=1e-12)
    p = thermal_noise_power_w(1e6, nf_db=6.0)
    assert 10 * np.log10(p) + 30 == pytest.approx(-173.975 + 60.0 + 6.0, abs=1e-3)
    assert thermal_noise_power_w(2e6, 0.0, 100.0) == pytest.approx(1.380649e-23 * 100 * 2e6)
    np.testing.assert_allclose(thermal_noise_power_w([1.0, 2.0], [0.0, 3.0]),
                               1.380649e-23 * 290 * np.array([1.0, 2.0 * 10**0.3]))
    with pytest.raises(ConfigError):
        thermal_noise_power_w(-1.0)


def test_noise_power_from_density():
    assert noise_power_from_density_w(-174.0, 1e6) == pytest.approx(10 ** (-11.4 - 3), rel=1e-12)
    np.testing.assert_allclose(noise_power_from_density_w([-100.0, -90.0], 1e3),
                               [1e-13 * 1e3, 1e-12 * 1e3])


def test_complex_awgn_power_and_circularity():
    """N = 400000 samples of power P.

    |n|² is exponential with mean P and std P → the mean's relative s.e. is 1/√N = 0.16 %;
    tolerance 5/√N. E[n²] = 0 (circular): |mean(n²)|/P has s.e. ≈ 1/√N; tolerance 5/√N. Re and
    Im each carry P/2 (s.e. of each variance √(2/N) relative): tolerance 5·√(2/N). Gaussianity:
    KS test of Re/√(P/2) against N(0, 1) at a fixed seed, p > 1e-3.
    """
    n_samples, power = 400_000, 3.2e-9
    n = complex_awgn(n_samples, power, rng=trial_rng(21, 0))
    assert n.shape == (n_samples,) and n.dtype == np.complex128
    tol = 5 / np.sqrt(n_samples)
    assert np.mean(np.abs(n) ** 2) == pytest.approx(power, rel=tol)
    assert abs(np.mean(n * n)) / power < tol
    assert np.var(n.real) == pytest.approx(power / 2, rel=5 * np.sqrt(2 / n_samples))
    assert np.var(n.imag) == pytest.approx(power / 2, rel=5 * np.sqrt(2 / n_samples))
    assert abs(np.mean(n.real * n.imag)) / (power / 2) < tol
    assert stats.kstest(n.real / np.sqrt(power / 2), "norm").pvalue > 1e-3


def test_complex_awgn_shapes_seeds_and_per_receiver_power():
    powers = np.array([1.0, 4.0, 0.0])
    n = complex_awgn((100_000, 3), powers, rng=trial_rng(22, 0))
    assert n.shape == (100_000, 3)
    np.testing.assert_allclose(np.mean(np.abs(n) ** 2, axis=0), powers, rtol=5 / np.sqrt(1e5))
    assert np.all(n[:, 2] == 0)
    np.testing.assert_array_equal(complex_awgn(8, 1.0, rng=trial_rng(22, 1)),
                                  complex_awgn(8, 1.0, rng=trial_rng(22, 1)))
    assert complex_awgn((2, 5), 1.0, rng=trial_rng(22, 2)).shape == (2, 5)
    with pytest.raises(ConfigError):
        complex_awgn(4, -1.0, rng=trial_rng(22, 3))
